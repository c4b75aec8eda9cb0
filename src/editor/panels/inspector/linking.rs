//! Hover linking between the viewport and the inspector: a viewport pixel's plane and ray come
//! from the frame's [`GridMapping`](crate::epipolar::GridMapping); an inspector cell's view
//! direction from [`EpipolarFrame::dir`](crate::epipolar::EpipolarFrame::dir), projected into
//! the viewport.

use crate::render::{FrameSetup, Method};
use crate::scene::Camera;

/// The (plane, ray) of a viewport pixel (continuous coordinates), when it lies inside the grid.
pub fn cell_of_pixel(setup: &FrameSetup, camera: &Camera, px: f64, py: f64) -> Option<(f64, f64)> {
    if setup.method == Method::Cartesian {
        return None; // its grid is screen-aligned, not epipolar
    }
    let dir = camera.pixel_dir_f64(px, py, setup.width, setup.height);
    let m = &setup.mapping;
    let x = m.plane_coord(setup.frame.phi_of_dir(dir));
    let y = m.ray_coord(crate::epipolar::angle_between(setup.frame.axis, dir));
    let (p, r) = (m.grid.planes as f64, m.grid.rays as f64);
    (x >= 0.0 && x < p && y >= 0.0 && y < r).then_some((x, y))
}

/// The viewport pixel (continuous, in the frame's pixels) the view ray of `(plane, ray)` passes
/// through; `None` when it points away from the camera.
pub fn pixel_of_cell(setup: &FrameSetup, camera: &Camera, plane: f64, ray: f64) -> Option<(f64, f64)> {
    let m = &setup.mapping;
    let dir = setup.frame.dir(m.phi_of_plane(plane), m.gamma_of_ray(ray));
    camera.pixel_of_dir_f64(dir, setup.width, setup.height)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_and_cell_round_trip() {
        let scene = crate::scene::builtin_scene();
        let setup = FrameSetup::new(&scene, 320, 200, Method::Vsv).unwrap();
        for (px, py) in [(10.0, 20.0), (160.0, 100.0), (300.0, 180.0)] {
            let (x, y) = cell_of_pixel(&setup, &scene.camera, px, py).expect("inside the grid");
            // The centre of a cell is within a cell of the pixel's ray; back to the pixel from the
            // exact coordinates.
            let (qx, qy) = pixel_of_cell(&setup, &scene.camera, x, y).unwrap();
            assert!((qx - px).abs() < 1e-3 && (qy - py).abs() < 1e-3, "{px},{py} -> {x},{y} -> {qx},{qy}");
        }
    }
}

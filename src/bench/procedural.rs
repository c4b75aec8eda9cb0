//! Procedural scenes of a chosen size, for the time-against-triangles sweep.
//!
//! A closed room (floor, ceiling, four walls) with a point light under the ceiling and an 8 x 8 grid
//! of UV spheres at desk height: every sphere casts a shaft-shaped shadow volume toward the floor
//! and the walls, and the triangle count is set by the spheres' tessellation, so the screen-space
//! content stays the same while the triangle count grows.

use crate::params::{Grid, Light, Medium};
use crate::scene::{build, Camera, Mesh, Scene};
use glam::Vec3;

/// Spheres per side of the grid.
const SIDE: usize = 8;

/// A UV sphere with `lon` segments around and `lat` rings (2 * lon * (lat - 1) triangles).
fn sphere(name: String, c: Vec3, r: f32, lon: usize, lat: usize) -> Mesh {
    Mesh { albedo: Vec3::new(0.6, 0.55, 0.5), ..build::sphere(&name, c, r, lat as u32, lon as u32) }
}

fn quad(name: &str, c: Vec3, u: Vec3, v: Vec3) -> Mesh {
    Mesh { albedo: Vec3::splat(0.7), ..build::quad(name, c, u, v) }
}

/// A room with 64 spheres and at least `target` triangles in all (and at least 64 * 24 + 12),
/// within 10% above it for targets of 10 000 and more.
pub fn procedural_scene(target: usize) -> Scene {
    let (hx, hy, hz) = (8.0f32, 3.0f32, 8.0f32);
    let mut meshes = vec![
        quad("floor", Vec3::ZERO, Vec3::X * hx, Vec3::Z * hz),
        quad("ceiling", Vec3::Y * 2.0 * hy, Vec3::X * hx, Vec3::Z * hz),
        quad("wall -x", Vec3::new(-hx, hy, 0.0), Vec3::Y * hy, Vec3::Z * hz),
        quad("wall +x", Vec3::new(hx, hy, 0.0), Vec3::Y * hy, Vec3::Z * hz),
        quad("wall -z", Vec3::new(0.0, hy, -hz), Vec3::X * hx, Vec3::Y * hy),
        quad("wall +z", Vec3::new(0.0, hy, hz), Vec3::X * hx, Vec3::Y * hy),
    ];
    let per_sphere = target.saturating_sub(12).div_ceil(SIDE * SIDE);
    // 2 * lon * (lat - 1) with lon = 2 lat: 4 lat^2 - 4 lat triangles; the smallest lat that
    // reaches the target, so a sweep "up to a million" does reach a million.
    let mut lat = 3;
    while 4 * lat * lat - 4 * lat < per_sphere {
        lat += 1;
    }
    let lon = 2 * lat;
    let pitch = 1.6f32;
    for i in 0..SIDE {
        for k in 0..SIDE {
            let c = Vec3::new((i as f32 - 3.5) * pitch, 1.2 + 0.3 * ((i + k) % 3) as f32, (k as f32 - 3.5) * pitch);
            meshes.push(sphere(format!("sphere {i},{k}"), c, 0.45, lon, lat));
        }
    }
    let mut scene = Scene {
        name: String::new(),
        source: None,
        meshes,
        camera: Camera {
            eye: Vec3::new(7.2, 4.6, 7.2),
            target: Vec3::new(-1.0, 1.0, -1.0),
            up: Vec3::Y,
            fov_y_deg: 65.0,
            near: 0.02,
            far: 60.0,
        },
        light: Light::Point { position: Vec3::new(-1.3, 5.2, -0.7), intensity: Vec3::splat(60.0), radius: 0.0 },
        medium: Medium::default(),
        grid: Grid::default(),
    };
    scene.name = format!("procedural room, {} triangles", scene.triangle_count());
    scene
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_counts_follow_the_target_and_the_scene_is_valid() {
        for target in [10_000usize, 100_000, 1_000_000] {
            let s = procedural_scene(target);
            s.validate().unwrap();
            let n = s.triangle_count() as f64;
            assert!(n >= target as f64 && n / (target as f64) < 1.1, "{target}: {n}");
        }
    }
}

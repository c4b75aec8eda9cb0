//! The built-in default scene: a closed room lit only through a barred window by a point light
//! outside, with a trefoil knot on a pedestal standing in the light shafts.
//!
//! Procedural and deterministic (no files, no randomness), about 9k triangles.
//!
//! Layout (scene units are metres, Y up): the room's interior is `[-4, 4] x [0, 4] x [-4, 4]`; every
//! wall, the floor and the ceiling are 0.2 thick boxes that overlap at the edges, so the room is
//! light-tight except for the window. The window is an opening of `z in [-1.5, 1.5]`,
//! `y in [1.6, 3.4]` in the `+X` wall, crossed by five vertical bars and one horizontal bar. The light
//! sits outside, up and to the right of the window, so the shafts fall steeply across the room onto
//! the floor; the knot stands in the middle shaft and casts a shadow volume through the fog. The camera
//! stands in the opposite corner and sees the window, the shafts, the knot and the lit floor.

use super::load::primitives;
use super::{Camera, Mesh, Scene};
use crate::params::{Grid, Light, Medium, Phase};
use glam::{Mat4, Vec3};

/// Half-size of the room's interior in x and z; the interior height is `ROOM_HEIGHT`.
const ROOM_HALF: f32 = 4.0;
const ROOM_HEIGHT: f32 = 4.0;
const WALL: f32 = 0.2;

/// The window opening in the `+X` wall.
const WINDOW_Z: (f32, f32) = (-1.5, 1.5);
const WINDOW_Y: (f32, f32) = (1.6, 3.4);

/// Position of the point light (outside the room).
const LIGHT_POSITION: Vec3 = Vec3::new(9.0, 7.0, 0.8);

fn boxed(name: &str, min: Vec3, max: Vec3, albedo: Vec3) -> Mesh {
    let mut m = primitives::cube(name, 0.5, albedo);
    m.transform(Mat4::from_translation((min + max) * 0.5) * Mat4::from_scale(max - min));
    m
}

/// A closed tube of radius `tube` around the (2, 3) torus knot (trefoil) with radii `big`, `small`,
/// in the XY plane, centred at the origin: 360 rings of 12 sides. Frames are parallel-transported
/// and the residual twist is spread over the loop, so the tube closes without a seam.
fn torus_knot(name: &str, big: f32, small: f32, tube: f32, albedo: Vec3) -> Mesh {
    let (p, q, segments, sides) = (2.0f32, 3.0f32, 360u32, 12u32);
    let curve = |t: f32| {
        let r = big + small * (q * t).cos();
        Vec3::new(r * (p * t).cos(), r * (p * t).sin(), small * (q * t).sin())
    };
    let tau = std::f32::consts::TAU;
    let n = segments as usize;
    let centers: Vec<Vec3> = (0..n).map(|i| curve(i as f32 / n as f32 * tau)).collect();
    let tangents: Vec<Vec3> = (0..n).map(|i| (centers[(i + 1) % n] - centers[(i + n - 1) % n]).normalize()).collect();
    // Parallel transport of a normal around the loop.
    let mut normals = Vec::with_capacity(n);
    let mut nrm = tangents[0].any_orthonormal_vector();
    for t in &tangents {
        nrm = (nrm - *t * nrm.dot(*t)).normalize();
        normals.push(nrm);
    }
    // Twist between the transported and the initial normal after one loop, removed gradually.
    let last = (normals[n - 1] - tangents[0] * normals[n - 1].dot(tangents[0])).normalize();
    let twist = last.cross(normals[0]).dot(tangents[0]).atan2(last.dot(normals[0]));
    let mut positions = Vec::with_capacity(n * sides as usize);
    for i in 0..n {
        let t = tangents[i];
        let a = twist * (i as f32 / n as f32);
        let nn = Mat4::from_axis_angle(t, a).transform_vector3(normals[i]);
        let bb = t.cross(nn);
        for s in 0..sides {
            let phi = s as f32 / sides as f32 * tau;
            positions.push(centers[i] + tube * (nn * phi.cos() + bb * phi.sin()));
        }
    }
    let idx = |i: usize, s: u32| (i % n) as u32 * sides + s % sides;
    let mut triangles = Vec::with_capacity(n * sides as usize * 2);
    for i in 0..n {
        for s in 0..sides {
            let (a, b, c, d) = (idx(i, s), idx(i + 1, s), idx(i + 1, s + 1), idx(i, s + 1));
            triangles.push([a, b, c]);
            triangles.push([a, c, d]);
        }
    }
    Mesh { name: name.to_string(), positions, triangles, albedo }
}

/// The built-in scene (see the module documentation).
pub fn builtin_scene() -> Scene {
    let (h, y, w) = (ROOM_HALF, ROOM_HEIGHT, WALL);
    let wall = Vec3::new(0.62, 0.6, 0.56);
    let floor = Vec3::new(0.55, 0.53, 0.5);
    let ceiling = Vec3::splat(0.7);
    let bars = Vec3::splat(0.25);
    let mut meshes = vec![
        boxed("floor", Vec3::new(-h - w, -w, -h - w), Vec3::new(h + w, 0.0, h + w), floor),
        boxed("ceiling", Vec3::new(-h - w, y, -h - w), Vec3::new(h + w, y + w, h + w), ceiling),
        boxed("wall -x", Vec3::new(-h - w, -w, -h - w), Vec3::new(-h, y + w, h + w), wall),
        boxed("wall -z", Vec3::new(-h - w, -w, -h - w), Vec3::new(h + w, y + w, -h), wall),
        boxed("wall +z", Vec3::new(-h - w, -w, h), Vec3::new(h + w, y + w, h + w), wall),
        // The +X wall, in four pieces around the window.
        boxed("wall +x below", Vec3::new(h, -w, -h - w), Vec3::new(h + w, WINDOW_Y.0, h + w), wall),
        boxed("wall +x above", Vec3::new(h, WINDOW_Y.1, -h - w), Vec3::new(h + w, y + w, h + w), wall),
        boxed("wall +x left", Vec3::new(h, -w, -h - w), Vec3::new(h + w, y + w, WINDOW_Z.0), wall),
        boxed("wall +x right", Vec3::new(h, -w, WINDOW_Z.1), Vec3::new(h + w, y + w, h + w), wall),
    ];
    // The grating: five vertical bars and one horizontal bar, as deep as the wall.
    let bar = 0.09;
    let span = WINDOW_Z.1 - WINDOW_Z.0;
    for i in 1..=5 {
        let z = WINDOW_Z.0 + span * i as f32 / 6.0;
        meshes.push(boxed(
            &format!("bar {i}"),
            Vec3::new(h, WINDOW_Y.0, z - bar * 0.5),
            Vec3::new(h + w, WINDOW_Y.1, z + bar * 0.5),
            bars,
        ));
    }
    let ymid = 0.5 * (WINDOW_Y.0 + WINDOW_Y.1);
    meshes.push(boxed(
        "crossbar",
        Vec3::new(h, ymid - bar * 0.5, WINDOW_Z.0),
        Vec3::new(h + w, ymid + bar * 0.5, WINDOW_Z.1),
        bars,
    ));
    // The caster: a trefoil knot on a pedestal, in the middle shaft.
    let knot_center = Vec3::new(2.0, 1.33, -0.67);
    meshes.push(boxed(
        "pedestal",
        Vec3::new(knot_center.x - 0.2, 0.0, knot_center.z - 0.2),
        Vec3::new(knot_center.x + 0.2, knot_center.y - 0.6, knot_center.z + 0.2),
        Vec3::splat(0.45),
    ));
    let mut knot = torus_knot("knot", 0.42, 0.2, 0.1, Vec3::new(0.8, 0.42, 0.18));
    // Its plane faces halfway between the camera and the light, so that both see its loops open.
    let facing = glam::Quat::from_rotation_arc(Vec3::Z, Vec3::new(0.36, 0.5, 0.8).normalize());
    knot.transform(Mat4::from_rotation_translation(facing, knot_center));
    meshes.push(knot);

    Scene {
        name: "built-in".into(),
        source: None,
        meshes,
        camera: Camera {
            eye: Vec3::new(0.0, 1.9, 3.8),
            target: Vec3::new(2.0, 1.4, -1.0),
            up: Vec3::Y,
            fov_y_deg: 60.0,
            near: 0.01,
            far: 100.0,
        },
        light: Light::Point { position: LIGHT_POSITION, intensity: Vec3::splat(900.0), radius: 0.0 },
        medium: Medium {
            scattering: Vec3::splat(0.08),
            absorption: Vec3::splat(0.01),
            density: 1.0,
            phase: Phase::HenyeyGreenstein { g: 0.4 },
        },
        grid: Grid::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_is_valid_and_deterministic() {
        let a = builtin_scene();
        a.validate().unwrap();
        assert_eq!(a, builtin_scene());
        assert!(a.triangle_count() < 20_000, "{}", a.triangle_count());
    }
}

//! Building blocks of small procedural scenes, shared by the `check` cases (`crate::check::cases`)
//! and the integration tests (`tests/common`), so that both measure the same geometry.

use super::{Camera, Mesh};
use crate::params::{Light, Medium, Phase};
use glam::Vec3;

/// A quad with centre `c` and half-axes `u`, `v` (albedo 0.6), wound `c - u - v`, `c + u - v`,
/// `c + u + v`, `c - u + v`.
pub fn quad(name: &str, c: Vec3, u: Vec3, v: Vec3) -> Mesh {
    Mesh {
        name: name.into(),
        positions: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        albedo: Vec3::splat(0.6),
    }
}

/// An axis-aligned box with centre `c` and half-extent `h` (albedo 0.5); `open_top` leaves out the
/// +y face.
pub fn cuboid(name: &str, c: Vec3, h: Vec3, open_top: bool) -> Mesh {
    let positions = (0..8)
        .map(|i| {
            let s = |bit: u32| if i & bit == 0 { -1.0 } else { 1.0 };
            c + h * Vec3::new(s(1), s(2), s(4))
        })
        .collect();
    // faces: -z, +z, -y, +y, -x, +x (corner bits: 1 = x, 2 = y, 4 = z)
    let faces: [(u32, [u32; 4]); 6] = [
        (0, [0, 1, 3, 2]),
        (1, [4, 6, 7, 5]),
        (2, [0, 4, 5, 1]),
        (3, [2, 3, 7, 6]),
        (4, [0, 2, 6, 4]),
        (5, [1, 5, 7, 3]),
    ];
    let triangles = faces
        .iter()
        .filter(|(k, _)| !(open_top && *k == 3))
        .flat_map(|(_, f)| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    Mesh { name: name.into(), positions, triangles, albedo: Vec3::splat(0.5) }
}

/// A light haze, mildly forward scattering: sigma_s (0.1, 0.08, 0.06), sigma_a 0.02, HG g = 0.3.
pub fn haze() -> Medium {
    Medium {
        scattering: Vec3::new(0.1, 0.08, 0.06),
        absorption: Vec3::splat(0.02),
        density: 1.0,
        phase: Phase::HenyeyGreenstein { g: 0.3 },
    }
}

/// An ideal point light of `intensity` W/sr in every channel.
pub fn point(position: Vec3, intensity: f32) -> Light {
    Light::Point { position, intensity: Vec3::splat(intensity), radius: 0.0 }
}

/// A directional light toward `direction` (normalised here) with an irradiance of 2 W/m^2.
pub fn directional(direction: Vec3) -> Light {
    Light::Directional { direction: direction.normalize(), irradiance: Vec3::splat(2.0) }
}

/// The eye 6 units in front of the origin at height 1.5, looking slightly down at (0, 1, 0);
/// 50 degrees vertical field of view.
pub fn side_camera() -> Camera {
    Camera {
        eye: Vec3::new(0.0, 1.5, 6.0),
        target: Vec3::new(0.0, 1.0, 0.0),
        up: Vec3::Y,
        fov_y_deg: 50.0,
        near: 0.01,
        far: 100.0,
    }
}

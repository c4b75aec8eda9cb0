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
    let positions = crate::scene::Aabb { min: c - h, max: c + h }.corners().to_vec();
    // faces: -z, +z, -y, +y, -x, +x (corner bits as Aabb::corners: 1 = x, 2 = y, 4 = z)
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

/// A closed UV sphere with centre `c` and radius `r`: `rings` latitude bands of `segments`
/// quads each, the poles as single shared vertices, every edge shared by exactly two triangles
/// (albedo 0.5).
pub fn sphere(name: &str, c: Vec3, r: f32, rings: u32, segments: u32) -> Mesh {
    let (rings, segments) = (rings.max(2), segments.max(3));
    let mut positions = vec![c + Vec3::Y * r];
    for i in 1..rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            positions.push(c + r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    positions.push(c - Vec3::Y * r);
    let bottom = positions.len() as u32 - 1;
    let at = |ring: u32, j: u32| 1 + (ring - 1) * segments + j % segments;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, at(1, j + 1), at(1, j)]);
        triangles.push([bottom, at(rings - 1, j), at(rings - 1, j + 1)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            let (a, b, c2, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            triangles.push([a, b, c2]);
            triangles.push([a, c2, d]);
        }
    }
    Mesh { name: name.into(), positions, triangles, albedo: Vec3::splat(0.5) }
}

/// A closed axis-aligned box with centre `c` and half-extent `h` whose faces are each split into
/// `n x n` quads, with the vertices along shared edges shared (albedo 0.5): many more edges and
/// vertices for a light ray to slip through than [`cuboid`]'s 12 triangles.
pub fn tessellated_cuboid(name: &str, c: Vec3, h: Vec3, n: u32) -> Mesh {
    let n = n.max(1);
    // Lattice points on the surface of the (n+1)^3 grid, indexed once each.
    let mut index = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut vertex = |i: u32, j: u32, k: u32| -> u32 {
        *index.entry((i, j, k)).or_insert_with(|| {
            let s = |v: u32| v as f32 / n as f32 * 2.0 - 1.0;
            positions.push(c + h * Vec3::new(s(i), s(j), s(k)));
            positions.len() as u32 - 1
        })
    };
    let mut triangles = Vec::new();
    for axis in 0..3 {
        for side in [0, n] {
            for a in 0..n {
                for b in 0..n {
                    let p = |da: u32, db: u32| {
                        let mut q = [0u32; 3];
                        q[axis] = side;
                        q[(axis + 1) % 3] = a + da;
                        q[(axis + 2) % 3] = b + db;
                        (q[0], q[1], q[2])
                    };
                    let v: Vec<u32> =
                        [p(0, 0), p(1, 0), p(1, 1), p(0, 1)].into_iter().map(|(i, j, k)| vertex(i, j, k)).collect();
                    // Winding does not matter to the shadows; alternate the diagonal so that both
                    // directions of shared diagonal edges occur.
                    if (a + b) % 2 == 0 {
                        triangles.push([v[0], v[1], v[2]]);
                        triangles.push([v[0], v[2], v[3]]);
                    } else {
                        triangles.push([v[0], v[1], v[3]]);
                        triangles.push([v[1], v[2], v[3]]);
                    }
                }
            }
        }
    }
    Mesh { name: name.into(), positions, triangles, albedo: Vec3::splat(0.5) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// Every edge of the closed meshes is shared by exactly two triangles.
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2), "{}: an edge is not shared by exactly two triangles", m.name);
    }

    #[test]
    fn spheres_and_tessellated_boxes_are_closed() {
        assert_closed(&sphere("s", Vec3::ZERO, 1.0, 7, 11));
        assert_closed(&tessellated_cuboid("b", Vec3::ZERO, Vec3::splat(0.5), 3));
        assert_closed(&cuboid("c", Vec3::ZERO, Vec3::splat(0.5), false));
        assert_eq!(tessellated_cuboid("b", Vec3::ZERO, Vec3::ONE, 3).triangles.len(), 6 * 9 * 2);
    }
}

//! Procedural primitives shared by the Mitsuba loader and the scene file's `builtin = "..."` meshes.
//! All are closed or flat triangle meshes with outward (or +Z) counter-clockwise winding.

use crate::scene::Mesh;
use glam::Vec3;

fn mesh(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, albedo: Vec3) -> Mesh {
    Mesh { name: name.to_string(), positions, triangles, albedo }
}

/// The square `[-1, 1]^2` at `z = 0`, facing +Z (Mitsuba's `rectangle`).
pub(crate) fn rectangle(name: &str, albedo: Vec3) -> Mesh {
    let p = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    mesh(name, p, vec![[0, 1, 2], [0, 2, 3]], albedo)
}

/// The unit disk at `z = 0`, facing +Z (Mitsuba's `disk`).
pub(crate) fn disk(name: &str, segments: u32, albedo: Vec3) -> Mesh {
    let segments = segments.max(3);
    let mut p = vec![Vec3::ZERO];
    let mut t = Vec::new();
    for i in 0..segments {
        let a = i as f32 / segments as f32 * std::f32::consts::TAU;
        p.push(Vec3::new(a.cos(), a.sin(), 0.0));
        t.push([0, 1 + i, 1 + (i + 1) % segments]);
    }
    mesh(name, p, t, albedo)
}

/// The cube `[-h, h]^3` (Mitsuba's `cube` has `h = 1`).
pub(crate) fn cube(name: &str, h: f32, albedo: Vec3) -> Mesh {
    let mut p = Vec::with_capacity(8);
    for i in 0..8u32 {
        let s = |bit: u32| if i & bit != 0 { h } else { -h };
        p.push(Vec3::new(s(1), s(2), s(4)));
    }
    // Quads (outward CCW) by corner index: bit 0 = +x, bit 1 = +y, bit 2 = +z.
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let mut t = Vec::with_capacity(12);
    for q in quads {
        t.push([q[0], q[1], q[2]]);
        t.push([q[0], q[2], q[3]]);
    }
    mesh(name, p, t, albedo)
}

/// A UV sphere.
pub(crate) fn sphere(name: &str, center: Vec3, radius: f32, rings: u32, segments: u32, albedo: Vec3) -> Mesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let mut p = vec![center + Vec3::Y * radius];
    for r in 1..rings {
        let theta = r as f32 / rings as f32 * std::f32::consts::PI;
        for s in 0..segments {
            let phi = s as f32 / segments as f32 * std::f32::consts::TAU;
            p.push(center + radius * Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()));
        }
    }
    p.push(center - Vec3::Y * radius);
    let south = p.len() as u32 - 1;
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let mut t = Vec::new();
    for s in 0..segments {
        t.push([0, ring(1, s), ring(1, s + 1)]);
        t.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            t.push([a, c, d]);
            t.push([a, d, b]);
        }
    }
    mesh(name, p, t, albedo)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Closed meshes have zero total area vector and outward winding (positive signed volume).
    fn signed_volume(m: &Mesh) -> f32 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn primitives_are_closed_and_outward() {
        let c = cube("c", 1.0, Vec3::ONE);
        assert!((signed_volume(&c) - 8.0).abs() < 1e-5);
        let s = sphere("s", Vec3::ZERO, 1.0, 32, 64, Vec3::ONE);
        let v = signed_volume(&s);
        assert!((v - 4.0 / 3.0 * std::f32::consts::PI).abs() < 0.05, "{v}");
        let r = rectangle("r", Vec3::ONE);
        let [a, b, c] = r.triangles[0].map(|i| r.positions[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0);
        let d = disk("d", 16, Vec3::ONE);
        let [a, b, c] = d.triangles[0].map(|i| d.positions[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0);
    }
}

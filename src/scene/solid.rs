//! Which meshes bound a solid, so that their back faces can be skipped.
//!
//! A mesh is *closed* when, after welding vertices at equal positions and ignoring zero-area
//! triangles, every directed edge `a -> b` occurs exactly once and so does its reverse `b -> a`:
//! the surface has no border, no edge shared by more than two triangles, and one consistent
//! winding. Its signed volume `V = 1/6 sum a . (b x c)` then says which way the winding's normals
//! `(b - a) x (c - a)` point: outward when `V > 0`, inward when `V < 0`.
//!
//! Why it matters: seen from a point outside a closed mesh (winding number 0 there), a ray that
//! reaches a triangle facing away from that point (by its outward normal) must have entered the
//! solid earlier through one facing toward it. So for the nearest surface along rays from the eye
//! (Surface), from the light (the shadow map) or the first light-ray hit after the scan (Voxelize),
//! the faces turned away add nothing. A mesh's bounding box holds the solid: a viewpoint outside
//! the box, with a margin for near-plane clipping, is outside the solid. Every other mesh (open,
//! non-manifold, inconsistently wound) is drawn and voxelized from both sides, as before.

use super::{Aabb, Mesh};
use glam::Vec3;

/// Whether a mesh bounds a solid, and which way its winding's normals point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Closure {
    /// Not closed (a border, a non-manifold edge, inconsistent winding, or no volume): both
    /// sides of every triangle can be seen.
    #[default]
    Open,
    /// Closed, with `(b - a) x (c - a)` pointing out of the solid.
    Outward,
    /// Closed, with `(b - a) x (c - a)` pointing into the solid.
    Inward,
}

impl Closure {
    /// `+1` outward, `-1` inward, `0` open: the sign that turns a triangle's winding normal into
    /// its outward normal.
    pub fn sign(self) -> f32 {
        match self {
            Closure::Open => 0.0,
            Closure::Outward => 1.0,
            Closure::Inward => -1.0,
        }
    }
}

/// [`Closure`] of `mesh` (two sorts of its edges: ~0.1 s for a million triangles).
pub fn closure(mesh: &Mesh) -> Closure {
    // Weld by exact position (+0.0 and -0.0 as one): loaders often split vertices along UV or
    // normal seams. Sorting, not hashing: a million-vertex mesh welds several times faster.
    let keys: Vec<[u32; 3]> = mesh.positions.iter().map(|p| (*p + Vec3::ZERO).to_array().map(f32::to_bits)).collect();
    let mut order: Vec<u32> = (0..keys.len() as u32).collect();
    order.sort_unstable_by_key(|&i| keys[i as usize]);
    let mut ids = vec![0u32; keys.len()];
    let mut id = 0u32;
    for (k, &i) in order.iter().enumerate() {
        if k > 0 && keys[i as usize] != keys[order[k - 1] as usize] {
            id += 1;
        }
        ids[i as usize] = id;
    }
    let mut edges: Vec<u64> = Vec::with_capacity(mesh.triangles.len() * 3);
    let mut reversed: Vec<u64> = Vec::with_capacity(mesh.triangles.len() * 3);
    let mut volume = 0.0f64;
    for t in &mesh.triangles {
        let (Some(&a), Some(&b), Some(&c)) = (ids.get(t[0] as usize), ids.get(t[1] as usize), ids.get(t[2] as usize))
        else {
            return Closure::Open;
        };
        let [pa, pb, pc] = t.map(|i| mesh.positions[i as usize].as_dvec3());
        if a == b || b == c || c == a || (pb - pa).cross(pc - pa) == glam::DVec3::ZERO {
            continue;
        }
        volume += pa.dot(pb.cross(pc));
        for (from, to) in [(a, b), (b, c), (c, a)] {
            edges.push(u64::from(from) << 32 | u64::from(to));
            reversed.push(u64::from(to) << 32 | u64::from(from));
        }
    }
    // Closed and consistently wound: no directed edge twice, and the edges are their reverses.
    edges.sort_unstable();
    reversed.sort_unstable();
    if edges.is_empty() || edges.windows(2).any(|w| w[0] == w[1]) || edges != reversed {
        return Closure::Open;
    }
    // A closed surface of (nearly) no volume, e.g. a sheet folded onto itself, has no inside.
    let b = mesh.bounds();
    let scale = f64::from(b.extent().max_element()).max(f64::MIN_POSITIVE);
    if volume.abs() <= 1e-9 * scale * scale * scale {
        return Closure::Open;
    }
    if volume > 0.0 {
        Closure::Outward
    } else {
        Closure::Inward
    }
}

/// Whether `p` lies outside `bounds` grown by `margin` on every side (then outside the solid, and
/// no near plane within `margin` of `p` can clip it).
pub fn outside(bounds: &Aabb, p: Vec3, margin: f32) -> bool {
    let m = Vec3::splat(margin.max(0.0));
    !Aabb { min: bounds.min - m, max: bounds.max + m }.contains(p)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::build;

    #[test]
    fn closed_meshes_and_their_orientation() {
        // The builder's boxes are wound with their normals inside (the built-in room is one).
        let cube = build::cuboid("c", Vec3::ZERO, Vec3::ONE, false);
        assert_eq!(closure(&cube), Closure::Inward);
        let mut flipped = cube.clone();
        for t in &mut flipped.triangles {
            t.swap(1, 2);
        }
        assert_eq!(closure(&flipped), Closure::Outward);
        assert_eq!(closure(&build::sphere("s", Vec3::new(1.0, 2.0, 3.0), 0.5, 6, 12)), Closure::Outward);
        // Closed, but wound alike on opposite sides (its winding is left arbitrary): not a solid
        // this test can orient, so both sides stay drawn.
        assert_eq!(closure(&build::tessellated_cuboid("t", Vec3::ZERO, Vec3::ONE, 3)), Closure::Open);
    }

    #[test]
    fn borders_folds_and_split_vertices() {
        assert_eq!(closure(&build::quad("q", Vec3::ZERO, Vec3::X, Vec3::Z)), Closure::Open);
        assert_eq!(closure(&build::cuboid("c", Vec3::ZERO, Vec3::ONE, true)), Closure::Open);
        // One triangle wound the other way: inconsistent.
        let mut cube = build::cuboid("c", Vec3::ZERO, Vec3::ONE, false);
        cube.triangles[0].swap(1, 2);
        assert_eq!(closure(&cube), Closure::Open);
        // A missing triangle leaves a border.
        let mut holed = build::cuboid("c", Vec3::ZERO, Vec3::ONE, false);
        holed.triangles.pop();
        assert_eq!(closure(&holed), Closure::Open);
        // Every triangle with its own three vertices (flat-shaded export): welded, still closed.
        let cube = build::cuboid("c", Vec3::ZERO, Vec3::ONE, false);
        let mut split = Mesh { positions: Vec::new(), triangles: Vec::new(), ..cube.clone() };
        for t in &cube.triangles {
            let base = split.positions.len() as u32;
            split.positions.extend(t.iter().map(|&i| cube.positions[i as usize]));
            split.triangles.push([base, base + 1, base + 2]);
        }
        assert_eq!(closure(&split), Closure::Inward);
        // Two copies of a cube in one mesh: every edge twice.
        let mut twice = cube.clone();
        twice.triangles.extend(cube.triangles.iter().copied());
        assert_eq!(closure(&twice), Closure::Open);
        // A quad and its reverse: closed but with no volume.
        let q = build::quad("q", Vec3::ZERO, Vec3::X, Vec3::Z);
        let mut sheet = q.clone();
        sheet.triangles.extend(q.triangles.iter().map(|t| [t[0], t[2], t[1]]));
        assert_eq!(closure(&sheet), Closure::Open);
        // Indices past the vertices: not judged.
        let mut bad = build::cuboid("c", Vec3::ZERO, Vec3::ONE, false);
        bad.triangles[0][0] = 999;
        assert_eq!(closure(&bad), Closure::Open);
    }

    #[test]
    fn outside_the_grown_box() {
        let b = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
        assert!(!outside(&b, Vec3::splat(0.5), 0.0));
        assert!(outside(&b, Vec3::new(1.5, 0.5, 0.5), 0.1));
        assert!(!outside(&b, Vec3::new(1.05, 0.5, 0.5), 0.1));
    }
}

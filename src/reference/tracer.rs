//! Ray queries against every triangle of a [`Scene`] in `f64`: closest hit for view rays and
//! any-hit (early exit) for shadow rays.
//!
//! The hierarchy is built by the `bvh` crate (binned SAH, parallel build) over the triangles' `f64`
//! bounding boxes and flattened with [`bvh::bvh::Bvh::flatten_custom`] into a stackless array; the
//! traversal loop and the triangle test live here because the crate's iterators cannot shorten the
//! ray as hits are found, cannot stop at `tmax`, and its triangle test culls back faces (every
//! triangle here is two-sided). The crate's stack-based iterators also hold at most 32 pending
//! nodes, which a deep SAH tree over a scanned mesh can exceed; the flat layout has no stack.

use crate::scene::Scene;
use bvh::aabb::{Aabb as BAabb, Bounded};
use bvh::bounding_hierarchy::{BHShape, BoundingHierarchy};
use bvh::bvh::Bvh as CrateBvh;
use glam::DVec3;
use nalgebra::Point3;

/// A closest-hit result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance along the (unit) ray direction.
    pub t: f64,
    /// Index of the triangle in the order of [`Scene::world_triangles`].
    pub tri: usize,
    /// Index of the triangle's mesh in `scene.meshes`.
    pub mesh: usize,
    /// Unit geometric normal `(b - a) x (c - a)` normalised, *not* flipped toward the ray.
    pub normal: DVec3,
}

/// Counters of the work done by queries (for tests and statistics).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TraceStats {
    /// Closest-hit queries ([`Tracer::first_hit`]).
    pub closest_queries: u64,
    /// Any-hit queries ([`Tracer::occluded`]).
    pub any_queries: u64,
    /// Ray-triangle tests performed.
    pub tri_tests: u64,
    /// Inner-node box tests performed.
    pub box_tests: u64,
}

impl TraceStats {
    pub fn add(&mut self, o: &TraceStats) {
        self.closest_queries += o.closest_queries;
        self.any_queries += o.any_queries;
        self.tri_tests += o.tri_tests;
        self.box_tests += o.box_tests;
    }
}

#[derive(Debug, Clone, Copy)]
struct Tri {
    a: DVec3,
    e1: DVec3,
    e2: DVec3,
    mesh: u32,
    /// Index in `Scene::world_triangles` order.
    index: u32,
}

/// Shape handed to the `bvh` crate's builder.
struct Shape {
    aabb: BAabb<f64, 3>,
    node: usize,
}

impl Bounded<f64, 3> for Shape {
    fn aabb(&self) -> BAabb<f64, 3> {
        self.aabb
    }
}

impl BHShape<f64, 3> for Shape {
    fn set_bh_node_index(&mut self, i: usize) {
        self.node = i;
    }
    fn bh_node_index(&self) -> usize {
        self.node
    }
}

/// One flat node: an inner node (box test; `entry` on success, `exit` on failure) or a leaf
/// (`entry == LEAF`, one triangle, then `exit`).
#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f64; 3],
    max: [f64; 3],
    entry: u32,
    exit: u32,
    shape: u32,
}

const LEAF: u32 = u32::MAX;

/// Relative barycentric slack of the triangle test: rays through a shared edge hit at least one
/// of the two triangles (shadows do not leak through a closed mesh's edges).
const BARY_EPS: f64 = 1e-12;

/// A bounding volume hierarchy over the scene's triangles with `f64` ray queries.
#[derive(Debug, Clone)]
pub struct Tracer {
    tris: Vec<Tri>,
    nodes: Vec<Node>,
    /// Bounds of every triangle (padded), tested first by every query.
    bounds: ([f64; 3], [f64; 3]),
    diagonal: f64,
}

/// A prepared ray: origin, direction and per-axis reciprocals.
struct Ray {
    o: [f64; 3],
    d: [f64; 3],
    inv: [f64; 3],
    od: DVec3,
    dd: DVec3,
}

impl Ray {
    fn new(o: DVec3, d: DVec3) -> Ray {
        let inv = [1.0 / d.x, 1.0 / d.y, 1.0 / d.z];
        Ray { o: o.to_array(), d: d.to_array(), inv, od: o, dd: d }
    }

    /// Slab test of the segment `[0, tmax]` against a box; conservative for axis-parallel rays
    /// (a zero direction component only checks that the origin lies inside that slab).
    #[inline]
    fn hits_box(&self, min: &[f64; 3], max: &[f64; 3], tmax: f64) -> bool {
        let mut t0 = 0.0f64;
        let mut t1 = tmax;
        for k in 0..3 {
            if self.d[k] == 0.0 {
                if self.o[k] < min[k] || self.o[k] > max[k] {
                    return false;
                }
                continue;
            }
            let a = (min[k] - self.o[k]) * self.inv[k];
            let b = (max[k] - self.o[k]) * self.inv[k];
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            if lo > t0 {
                t0 = lo;
            }
            if hi < t1 {
                t1 = hi;
            }
            if t0 > t1 {
                return false;
            }
        }
        true
    }
}

impl Tri {
    /// Two-sided Möller–Trumbore: the distance in `(0, tmax)` or `None`.
    #[inline]
    fn intersect(&self, r: &Ray, tmax: f64) -> Option<f64> {
        let p = r.dd.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = r.od - self.a;
        let u = s.dot(p) * inv;
        if !(-BARY_EPS..=1.0 + BARY_EPS).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = r.dd.dot(q) * inv;
        if v < -BARY_EPS || u + v > 1.0 + BARY_EPS {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        (t > 0.0 && t < tmax).then_some(t)
    }
}

impl Tracer {
    /// Builds the hierarchy over every non-degenerate triangle of the scene (zero-area triangles
    /// can never be hit and are left out).
    pub fn new(scene: &Scene) -> Tracer {
        let mut tris = Vec::with_capacity(scene.triangle_count());
        for (index, (v, mesh)) in scene.world_triangles().enumerate() {
            let a = v[0].as_dvec3();
            let e1 = v[1].as_dvec3() - a;
            let e2 = v[2].as_dvec3() - a;
            let n = e1.cross(e2);
            if !(n.length_squared() > 0.0) || !n.is_finite() {
                continue;
            }
            tris.push(Tri { a, e1, e2, mesh: mesh as u32, index: index as u32 });
        }
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &tris {
            for p in [t.a, t.a + t.e1, t.a + t.e2] {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        let diagonal = if tris.is_empty() { 0.0 } else { (hi - lo).length() };
        // Pad every box by a tiny absolute amount so rounding in the slab test never culls a
        // triangle the exact test would hit.
        let pad = diagonal * 1e-12 + 1e-300;
        let mut shapes: Vec<Shape> = tris
            .iter()
            .map(|t| {
                let (b, c) = (t.a + t.e1, t.a + t.e2);
                let mn = t.a.min(b).min(c) - DVec3::splat(pad);
                let mx = t.a.max(b).max(c) + DVec3::splat(pad);
                Shape {
                    aabb: BAabb::with_bounds(Point3::new(mn.x, mn.y, mn.z), Point3::new(mx.x, mx.y, mx.z)),
                    node: 0,
                }
            })
            .collect();
        let nodes = if shapes.is_empty() {
            Vec::new()
        } else {
            let bvh: CrateBvh<f64, 3> = CrateBvh::build_par(&mut shapes);
            bvh.flatten_custom(&|aabb: &BAabb<f64, 3>, entry, exit, shape| Node {
                min: [aabb.min.x, aabb.min.y, aabb.min.z],
                max: [aabb.max.x, aabb.max.y, aabb.max.z],
                entry,
                exit,
                shape,
            })
        };
        let bounds = ((lo - DVec3::splat(pad)).to_array(), (hi + DVec3::splat(pad)).to_array());
        Tracer { tris, nodes, bounds, diagonal }
    }

    /// Number of triangles in the hierarchy (degenerate ones excluded).
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Length of the diagonal of the triangles' bounding box.
    pub fn diagonal(&self) -> f64 {
        self.diagonal
    }

    /// The closest triangle hit by the ray `origin + t dir`, `0 < t < tmax` (`dir` need not be
    /// unit; `t` is then in units of `|dir|`).
    pub fn first_hit(&self, origin: DVec3, dir: DVec3, tmax: f64) -> Option<Hit> {
        self.first_hit_stats(origin, dir, tmax, &mut TraceStats::default())
    }

    /// Whether any triangle lies on the ray `origin + t dir`, `0 < t < tmax`; stops at the first
    /// triangle found (any-hit).
    pub fn occluded(&self, origin: DVec3, dir: DVec3, tmax: f64) -> bool {
        self.occluded_stats(origin, dir, tmax, &mut TraceStats::default())
    }

    /// [`Tracer::first_hit`], counting the work in `stats`.
    pub fn first_hit_stats(&self, origin: DVec3, dir: DVec3, tmax: f64, stats: &mut TraceStats) -> Option<Hit> {
        stats.closest_queries += 1;
        let r = Ray::new(origin, dir);
        let mut best: Option<(f64, usize)> = None;
        let mut tbest = tmax;
        self.traverse(&r, &mut tbest, stats, |i, t| {
            best = Some((t, i));
            false
        });
        best.map(|(t, i)| {
            let tri = &self.tris[i];
            Hit { t, tri: tri.index as usize, mesh: tri.mesh as usize, normal: tri.e1.cross(tri.e2).normalize() }
        })
    }

    /// [`Tracer::occluded`], counting the work in `stats`.
    pub fn occluded_stats(&self, origin: DVec3, dir: DVec3, tmax: f64, stats: &mut TraceStats) -> bool {
        stats.any_queries += 1;
        let r = Ray::new(origin, dir);
        let mut found = false;
        let mut t = tmax;
        self.traverse(&r, &mut t, stats, |_, _| {
            found = true;
            true
        });
        found
    }

    /// Stackless traversal of the flat hierarchy. `on_hit(triangle, t)` is called for every hit
    /// closer than the current `tmax` (which then shrinks to `t`); returning `true` stops.
    fn traverse(&self, r: &Ray, tmax: &mut f64, stats: &mut TraceStats, mut on_hit: impl FnMut(usize, f64) -> bool) {
        if self.nodes.is_empty() || !(*tmax > 0.0) {
            return;
        }
        stats.box_tests += 1;
        if !r.hits_box(&self.bounds.0, &self.bounds.1, *tmax) {
            return;
        }
        let n = self.nodes.len();
        let mut i = 0usize;
        while i < n {
            let node = &self.nodes[i];
            if node.entry == LEAF {
                stats.tri_tests += 1;
                let s = node.shape as usize;
                if let Some(t) = self.tris[s].intersect(r, *tmax) {
                    *tmax = t;
                    if on_hit(s, t) {
                        return;
                    }
                }
                i = node.exit as usize;
            } else {
                stats.box_tests += 1;
                i = if r.hits_box(&node.min, &node.max, *tmax) { node.entry as usize } else { node.exit as usize };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{Grid, Light, Medium};
    use crate::scene::{Camera, Mesh};
    use glam::Vec3;

    /// Deterministic pseudo-random numbers in [-1, 1).
    fn rng(seed: u64) -> impl FnMut() -> f64 {
        let mut s = seed;
        move || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    fn soup(n: usize) -> Scene {
        let mut r = rng(0x1234_5678_9abc_def1);
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for i in 0..n {
            let c = Vec3::new(r() as f32, r() as f32, r() as f32) * 3.0;
            for _ in 0..3 {
                positions.push(c + Vec3::new(r() as f32, r() as f32, r() as f32) * 0.4);
            }
            triangles.push([3 * i as u32, 3 * i as u32 + 1, 3 * i as u32 + 2]);
        }
        // One degenerate triangle, which must be skipped without shifting indices.
        positions.push(Vec3::ZERO);
        triangles.insert(5, [(positions.len() - 1) as u32; 3]);
        Scene {
            name: "soup".into(),
            source: None,
            meshes: vec![Mesh { name: "soup".into(), positions, triangles, albedo: Vec3::ONE }],
            camera: Camera::default(),
            light: Light::default(),
            medium: Medium::default(),
            grid: Grid::default(),
        }
    }

    /// Brute force over every triangle with the same test.
    fn brute(s: &Scene, o: DVec3, d: DVec3, tmax: f64) -> Option<(f64, usize)> {
        let r = Ray::new(o, d);
        let mut best: Option<(f64, usize)> = None;
        for (i, (v, mesh)) in s.world_triangles().enumerate() {
            let a = v[0].as_dvec3();
            let t = Tri { a, e1: v[1].as_dvec3() - a, e2: v[2].as_dvec3() - a, mesh: mesh as u32, index: i as u32 };
            if t.e1.cross(t.e2).length_squared() == 0.0 {
                continue;
            }
            if let Some(th) = t.intersect(&r, best.map_or(tmax, |b| b.0)) {
                best = Some((th, i));
            }
        }
        best
    }

    #[test]
    fn matches_brute_force() {
        let s = soup(3000);
        let tracer = Tracer::new(&s);
        assert_eq!(tracer.triangle_count(), 3000);
        let mut r = rng(99);
        let mut hits = 0;
        for k in 0..2000 {
            let o = DVec3::new(r(), r(), r()) * 5.0;
            let d = DVec3::new(r(), r(), r()).normalize();
            let tmax = if k % 3 == 0 { f64::INFINITY } else { 2.0 + 4.0 * r().abs() };
            let want = brute(&s, o, d, tmax);
            let got = tracer.first_hit(o, d, tmax);
            assert_eq!(got.map(|h| h.tri), want.map(|w| w.1), "ray {k}");
            if let (Some(g), Some(w)) = (got, want) {
                assert_eq!(g.t, w.0);
                hits += 1;
                let n = g.normal;
                assert!((n.length() - 1.0).abs() < 1e-12);
            }
            assert_eq!(tracer.occluded(o, d, tmax), want.is_some(), "ray {k}");
        }
        assert!(hits > 200, "only {hits} hits: the test is too weak");
    }

    #[test]
    fn two_sided_and_edge_tight() {
        // A quad split along its diagonal: rays through the diagonal must hit from both sides.
        let q = Mesh {
            name: "q".into(),
            positions: vec![
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            albedo: Vec3::ONE,
        };
        let mut s = soup(10);
        s.meshes = vec![q];
        let t = Tracer::new(&s);
        for k in 0..101 {
            let x = -0.99 + 1.98 * k as f64 / 100.0;
            for dz in [1.0, -1.0] {
                let o = DVec3::new(x, x, -dz);
                assert!(t.occluded(o, DVec3::new(0.0, 0.0, dz), 10.0), "leak at {x}");
                let h = t.first_hit(o, DVec3::new(0.0, 0.0, dz), 10.0).unwrap();
                assert!((h.t - 1.0).abs() < 1e-15);
            }
        }
        // tmax is exclusive and the origin is excluded.
        assert!(!t.occluded(DVec3::new(0.2, 0.1, -1.0), DVec3::Z, 1.0 - 1e-12));
        assert!(!t.occluded(DVec3::new(0.2, 0.1, 0.0), DVec3::Z, 1.0));
        // Axis-parallel rays with zero direction components.
        assert!(t.occluded(DVec3::new(0.5, 0.5, 2.0), -DVec3::Z, 5.0));
        assert!(!t.occluded(DVec3::new(0.5, 0.5, 2.0), DVec3::X, 5.0));
    }
}

//! Meshes of any size that fits the adapter render (issue 12): past the adapter's largest storage
//! binding the triangles are culled and voxelized in chunks; coincident triangles cost what
//! distinct ones cost; triangles of zero area cost nothing.

mod common;

use common::{occluder_scene, point_light, renderer};
use epivox::metrics;
use epivox::params::Grid;
use epivox::render::{Method, SceneGpu};
use epivox::scene::Mesh;
use glam::Vec3;

/// The occluder of `occluder_scene` (a 1 x 1 square at height 1.5) split into `n x n` quads.
fn tessellated_occluder(n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            let (u, v) = (i as f32 / n as f32 - 0.5, j as f32 / n as f32 - 0.5);
            positions.push(Vec3::new(u, 1.5, v));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh { name: "tessellated occluder".into(), positions, triangles, albedo: Vec3::splat(0.6) }
}

/// An occluder of ~2.9 million triangles (139 MB of triangle data, past llvmpipe's 128 MiB
/// storage binding, so it is voxelized in two chunks) shadows the medium as its two-triangle
/// original does: the same scattered light within the grid's sampling noise.
#[test]
fn a_mesh_past_the_binding_limit_renders_in_chunks() {
    let Some(mut r) = renderer() else { return };
    let mut simple = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    simple.grid = Grid { planes: 256, rays: 256, bins: 64, ..Grid::default() };
    let mut big = simple.clone();
    // 1204^2 quads: 2 899 232 triangles.
    big.meshes[1] = tessellated_occluder(1204);
    let triangles = big.triangle_count() as u64;
    let limit = {
        let l = r.ctx.device.limits();
        l.max_storage_buffer_binding_size.min(l.max_buffer_size)
    };
    if triangles * SceneGpu::TRIANGLE_BYTES <= limit {
        eprintln!("NOTE: this adapter binds {limit} bytes: the big mesh fits in one chunk here");
    }
    let a = r.render(&simple, 64, 64, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let b = r.render(&big, 64, 64, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let counts = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
    let dropped = counts.culled_depth as u64 + counts.culled_view as u64 + counts.culled_back as u64;
    assert_eq!(counts.kept as u64 + dropped, triangles);
    // Sampled light rays meet the tessellated square where they meet the plain one; the
    // tessellation only moves the f32 roundings of its edges.
    let stats = metrics::compare(&b.scatter, &a.scatter).unwrap_or_else(|e| panic!("{e}"));
    assert!(stats.rel_rmse < 1e-3, "the chunked big mesh shadows differently: {stats}");
}

/// 100 000 copies of one triangle are as much work per copy as one: the work list holds exactly
/// 100 000 times the single triangle's items, and the frame renders (the old rasterizing voxelizer
/// took over a minute here). Triangles of zero area are dropped by Cull without work.
#[test]
fn coincident_triangles_cost_what_distinct_ones_cost() {
    let Some(mut r) = renderer() else { return };
    let mut s = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    s.grid = Grid { planes: 64, rays: 64, bins: 32, ..Grid::default() };
    let tri = Mesh {
        name: "one".into(),
        positions: vec![Vec3::new(-0.3, 1.5, -0.2), Vec3::new(0.4, 1.5, -0.1), Vec3::new(0.0, 1.6, 0.4)],
        triangles: vec![[0, 1, 2]],
        albedo: Vec3::splat(0.5),
    };
    s.meshes = vec![tri.clone()];
    r.render(&s, 32, 32, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let one = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(one.kept, 1);
    let copies = 100_000u32;
    s.meshes = vec![Mesh { triangles: vec![[0, 1, 2]; copies as usize], ..tri.clone() }];
    r.render(&s, 32, 32, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let many = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((many.kept, many.items), (copies, one.items * copies as u64));

    let flat = Mesh {
        // Collinear in exact binary fractions: the cross product is exactly zero in f32 too.
        positions: vec![Vec3::new(-0.25, 1.5, -0.25), Vec3::new(0.5, 1.5, 0.0), Vec3::new(0.125, 1.5, -0.125)],
        ..tri
    };
    s.meshes = vec![Mesh { triangles: vec![[0, 1, 2]; 10_000], ..flat }];
    r.render(&s, 32, 32, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let degenerate = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((degenerate.kept, degenerate.items), (0, 0), "zero-area triangles got work: {degenerate:?}");
}

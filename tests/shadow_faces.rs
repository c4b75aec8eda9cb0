//! The point light's cube shadow map with face culling (each face draws only the triangles that
//! can reach its 90-degree pyramid, `shaders/shadow_cull.wgsl`) is the map without it: the same
//! surfaces shadowed, bit for bit, for scenes whose triangles straddle faces, lie behind the
//! light, surround it, or touch a face's edge planes exactly.

mod common;

use common::{point_light, renderer};
use epivox::params::Grid;
use epivox::render::Method;
use epivox::scene::Scene;
use glam::Vec3;

/// Renders `scene` with face culling on and off and returns how many pixels of the final image
/// differ, and the largest difference.
fn difference(scene: &Scene, method: Method) -> (usize, f32) {
    let Some(mut r) = renderer() else { return (0, 0.0) };
    let mut images = Vec::new();
    for culling in [true, false] {
        r.shadow_face_culling = culling;
        let out = r.render(scene, 96, 80, method).unwrap_or_else(|e| panic!("{e}"));
        // The comparison means something only if the culled path ran.
        assert!(r.shadow_face_lists(), "no face lists were made for {}", scene.name);
        images.push(out.hdr);
    }
    let (a, b) = (&images[0], &images[1]);
    let mut differ = 0;
    let mut max = 0.0f32;
    for (x, y) in a.pixels.iter().zip(&b.pixels) {
        let d = (0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0f32, f32::max);
        if x != y {
            differ += 1;
        }
        max = max.max(d);
    }
    (differ, max)
}

#[test]
fn culled_faces_shadow_what_every_face_drawing_everything_shadows() {
    // Procedural rooms: 64 tessellated spheres around a point light in a walled room (every face
    // sees triangles, many straddle two or three faces).
    let mut room = epivox::bench::procedural_scene(20_000);
    room.grid = Grid { planes: 64, rays: 64, bins: 32, ..Grid::default() };
    for method in [Method::Vsv, Method::Raymarch { steps: 32, jitter: false }] {
        let (differ, max) = difference(&room, method);
        assert_eq!(differ, 0, "{method:?}: {differ} pixels differ (max {max})");
    }
    // The light exactly on a vertex and on the planes of the faces' edges: the built-in scene
    // with the light moved to the corner of its box and to the middle of an edge.
    let mut s = epivox::scene::builtin_scene();
    s.grid = Grid { planes: 64, rays: 64, bins: 32, ..Grid::default() };
    let b = s.bounds();
    let (lo, hi) = (b.min, b.max);
    for light in
        [Vec3::new(lo.x, lo.y, lo.z) + 1e-3, Vec3::new(0.0, hi.y * 0.5, 0.0), Vec3::new(lo.x * 0.5, hi.y * 0.9, 0.0)]
    {
        s.light = point_light(light);
        let (differ, max) = difference(&s, Method::Vsv);
        assert_eq!(differ, 0, "light at {light}: {differ} pixels differ (max {max})");
    }
}

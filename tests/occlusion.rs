//! Under a directional light, Cull drops the triangles the shadow map shows behind nearer surfaces
//! at every texel around them (`epivox::render::ShadowPyramid`): their bits would change nothing
//! after the scan, so the shadow volume must come out the same, bit for bit, where no occluder
//! has a gap narrower than a shadow-map texel (the scene below has none). The map itself leaves
//! them out too (they cannot win its depth test), for every method: the same map, bit for bit. Cull reads the pyramid an
//! earlier frame with the same casters and light left (`ShadowPyramid::built_from`), also after a
//! camera move, which fits the sun's map to another rectangle (`ShadowFit`): the first frame after
//! the light or the geometry changed culls nothing.

mod common;

use common::renderer;
use epivox::params::{Grid, Light};
use epivox::render::{Method, Pass, SurfaceShadows};
use epivox::scene::build::quad;
use glam::Vec3;

/// The procedural room of 64 closed spheres with a roof over half of it instead of its ceiling,
/// the sun high above: the spheres under the roof are hidden from it.
fn half_roofed_room() -> epivox::scene::Scene {
    let mut room = epivox::bench::procedural_scene(20_000);
    let Some(ceiling) = room.meshes.iter().position(|m| m.name == "ceiling") else {
        panic!("the procedural room has no ceiling")
    };
    let b = room.meshes[ceiling].bounds();
    let h = (b.max - b.min) * 0.5;
    room.meshes[ceiling] =
        quad("roof", Vec3::new(b.min.x + 0.5 * h.x, b.max.y, b.center().z), Vec3::X * 0.5 * h.x, Vec3::Z * h.z);
    room.light = Light::Directional { direction: Vec3::new(0.15, 1.0, 0.1).normalize(), irradiance: Vec3::splat(3.0) };
    room.grid = Grid { planes: 256, rays: 256, bins: 128, ..Grid::default() };
    room
}

#[test]
fn hidden_triangles_are_culled_and_the_shadow_volume_is_the_same() {
    let Some(mut r) = renderer() else { return };
    let room = half_roofed_room();
    let spheres: usize = room.meshes.iter().filter(|m| m.name.starts_with("sphere")).map(|m| m.triangles.len()).sum();
    let frame = |r: &mut epivox::render::Renderer, scene: &epivox::scene::Scene| {
        let out = r.render(scene, 160, 120, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        let counts = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
        let grid = r.read_grid().unwrap_or_else(|e| panic!("{e}"));
        let entries = r.read_exact_stats().unwrap_or_else(|e| panic!("{e}")).map(|s| s.entries);
        (out, counts, grid, entries)
    };
    // The first frame has no pyramid yet: it culls nothing and makes one at its end.
    let first = frame(&mut r, &room);
    assert_eq!(first.1.culled_hidden, 0, "the first frame culled with no pyramid");
    assert!(first.0.passes.contains(&Pass::ShadowPyramid), "the first frame made no pyramid: {:?}", first.0.passes);
    let on = frame(&mut r, &room);
    assert!(!on.0.passes.contains(&Pass::ShadowPyramid), "the same map's pyramid was made again");
    r.occlusion_culling = false;
    let off = frame(&mut r, &room);
    eprintln!("with the test: {:?}; without: {:?}; {spheres} sphere triangles", on.1, off.1);
    assert_eq!(off.1.culled_hidden, 0);
    assert!(!off.0.passes.contains(&Pass::ShadowPyramid), "the pyramid was made with the test off");
    // About half the spheres lie under the roof; an eighth of all sphere triangles at least (the
    // faces of those under it that face the light: the rest are culled as back faces first).
    assert!(
        on.1.culled_hidden as usize > spheres / 8,
        "only {} of {spheres} sphere triangles were culled as hidden",
        on.1.culled_hidden
    );
    assert!(on.1.items < off.1.items, "culling removed no work: {} against {} items", on.1.items, off.1.items);
    // Exact surface shadows (the default) leave the hidden triangles out of their lists too: the
    // images below are the same.
    let (Some(listed_on), Some(listed_off)) = (on.3, off.3) else { panic!("no exact shadows' counts") };
    assert!(listed_on < listed_off, "the exact shadows listed {listed_on} entries with the test, {listed_off} without");
    for other in [&first, &off] {
        let differing = on.2.iter().zip(&other.2).filter(|(a, b)| a != b).count();
        assert_eq!(differing, 0, "{differing} words of the shadow volume differ");
        assert!(on.0.scatter.pixels == other.0.scatter.pixels, "the scattered light differs");
        // The shadow map drawn without the hidden triangles is the same map: the lit surfaces too.
        assert!(on.0.hdr.pixels == other.0.hdr.pixels, "the final image differs");
    }
    // A camera move fits the map to another rectangle: Cull still reads the pyramid of the map
    // fitted to the old view (with that map's matrix); its shadow volume and images are those of
    // a renderer that culls no hidden triangle. Under exact surface shadows (the default) the
    // frame draws no map to make a pyramid of its own (an orbit's next frame moves again): the
    // first frame of the still view does.
    r.occlusion_culling = true;
    frame(&mut r, &room);
    let mut moved = room.clone();
    moved.camera.eye += Vec3::new(0.4, -0.1, 0.3);
    let after = frame(&mut r, &moved);
    assert!(after.1.culled_hidden > 0, "the camera move dropped the test");
    assert!(after.0.passes.contains(&Pass::ShadowFit), "the map was not fitted anew: {:?}", after.0.passes);
    assert!(!after.0.passes.contains(&Pass::ShadowMap), "the moving view's frame drew a map: {:?}", after.0.passes);
    let still = frame(&mut r, &moved);
    assert!(still.0.passes.contains(&Pass::ShadowPyramid), "no pyramid of the new fit: {:?}", still.0.passes);
    assert!(still.0.hdr.pixels == after.0.hdr.pixels, "the still view's frame differs");
    let Some(mut plain) = renderer() else { return };
    plain.occlusion_culling = false;
    let expected = frame(&mut plain, &moved);
    let differing = after.2.iter().zip(&expected.2).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "after the camera move {differing} words of the shadow volume differ");
    assert!(after.0.scatter.pixels == expected.0.scatter.pixels, "after the camera move the scattered light differs");
    assert!(after.0.hdr.pixels == expected.0.hdr.pixels, "after the camera move the final image differs");
    // A new light direction: the frame culls without the test (the old light's pyramid is not
    // this light's). Where the surfaces take the map's shadows that frame draws the new map and
    // makes its pyramid, and the next frame culls with it. Under exact surface shadows (the
    // default) the map is drawn only for the pyramid, and not in a frame whose sun moved since
    // the last (a light drag would draw one per frame for nothing): the first frame of the still
    // sun makes it, and the one after it culls with it.
    let mut turned = room.clone();
    turned.light =
        Light::Directional { direction: Vec3::new(-0.1, 1.0, 0.15).normalize(), irradiance: Vec3::splat(3.0) };
    assert_eq!(r.surface_shadows, SurfaceShadows::Exact);
    let moved_sun = frame(&mut r, &turned);
    assert_eq!(moved_sun.1.culled_hidden, 0, "the old light's pyramid was used for the new light");
    assert!(!moved_sun.0.passes.contains(&Pass::ShadowMap), "the moving sun's frame drew a map");
    let still = frame(&mut r, &turned);
    assert_eq!(still.1.culled_hidden, 0, "a pyramid was used before one was made in this light");
    assert!(still.0.passes.contains(&Pass::ShadowPyramid), "the still sun's frame made no pyramid");
    assert!(frame(&mut r, &turned).1.culled_hidden > 0, "the new light's pyramid culled nothing");
    r.surface_shadows = SurfaceShadows::Map;
    frame(&mut r, &room);
    assert_eq!(frame(&mut r, &turned).1.culled_hidden, 0, "the old light's pyramid was used for the new light");
    assert!(frame(&mut r, &turned).1.culled_hidden > 0, "the map's pyramid of the new light culled nothing");
}

#[test]
fn point_lights_and_no_pruning_skip_the_test() {
    let Some(mut r) = renderer() else { return };
    let mut room = half_roofed_room();
    r.prune = false;
    for _ in 0..2 {
        let out = r.render(&room, 64, 48, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        assert!(!out.passes.contains(&Pass::ShadowPyramid));
        assert_eq!(r.cull_counts().unwrap_or_else(|e| panic!("{e}")).culled_hidden, 0, "culled with pruning off");
    }
    r.prune = true;
    room.light = common::point_light(Vec3::new(0.5, 3.0, 0.2));
    for _ in 0..2 {
        let out = r.render(&room, 64, 48, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        assert!(!out.passes.contains(&Pass::ShadowPyramid));
        assert_eq!(r.cull_counts().unwrap_or_else(|e| panic!("{e}")).culled_hidden, 0, "culled under a point light");
    }
}

#[test]
fn the_march_sees_the_same_map_without_the_hidden_triangles() {
    let Some(mut r) = renderer() else { return };
    let room = half_roofed_room();
    let march = Method::Raymarch { steps: 32, jitter: false };
    // The first frame makes the pyramid; the second draws the map without the hidden triangles.
    let first = r.render(&room, 96, 72, march).unwrap_or_else(|e| panic!("{e}"));
    assert!(first.passes.contains(&Pass::ShadowPyramid), "no pyramid after the march's first frame");
    let second = r.render(&room, 96, 72, march).unwrap_or_else(|e| panic!("{e}"));
    assert!(!second.passes.contains(&Pass::ShadowPyramid));
    assert!(first.hdr.pixels == second.hdr.pixels, "the final image differs");
    assert!(first.scatter.pixels == second.scatter.pixels, "the marched light differs");
}

/// On the classroom under its sun, Cull also tests each large triangle's planes in blocks of 64
/// (`Renderer::hidden_blocks`, cull.wgsl `hidden_blocks`): the hidden blocks at the ends of a
/// triangle's range leave its work and Voxelize skips the others. Their bits would change nothing
/// after the scan, so the shadow volume must be the same, word for word, with the blocks tested
/// and without (both with the whole triangles' test; this view has no occluder's gap that the
/// pyramid could miss: measured word for word at 512x512 and 128x96), and there must be less work.
#[test]
fn hidden_blocks_of_large_triangles_are_skipped_and_the_shadow_volume_is_the_same() {
    let Some(mut r) = renderer() else { return };
    let classroom = common::shared_scene("japanese_classroom");
    let frame = |r: &mut epivox::render::Renderer| {
        let out = r.render(&classroom, 128, 96, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        let counts = r.cull_counts().unwrap_or_else(|e| panic!("{e}"));
        let grid = r.read_grid().unwrap_or_else(|e| panic!("{e}"));
        (out, counts, grid)
    };
    // The first frame makes the pyramid; the second tests with it.
    frame(&mut r);
    let on = frame(&mut r);
    r.hidden_blocks = false;
    let off = frame(&mut r);
    eprintln!("blocks tested: {:?}; not: {:?}", on.1, off.1);
    assert!(off.1.culled_hidden > 0 && off.1.culled_hidden == on.1.culled_hidden, "{:?} {:?}", on.1, off.1);
    // A sixth of the items at 512x512; at least a tenth here.
    assert!(
        (on.1.items as f64) < 0.9 * off.1.items as f64,
        "the blocks removed little work: {} against {} items",
        on.1.items,
        off.1.items
    );
    let differing = on.2.iter().zip(&off.2).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} words of the shadow volume differ");
    assert!(on.0.scatter.pixels == off.0.scatter.pixels, "the scattered light differs");
}

//! Surface's culling (`shaders/surface_cull.wgsl`) leaves out the triangles whose bounding box holds
//! no pixel centre, and the solids' faces clearly turned away from the eye, before the rasterizer
//! sees them, and draws the others in their order. They would have drawn nothing, so every target,
//! and with them the final image and the scattered light, must be the same as when every triangle
//! is drawn: bit for bit, for a finely tessellated scene (most triangles emptied), at image sizes
//! whose edges cut triangles, and with triangles across the near plane and behind the eye.

mod common;

use common::{point_light, renderer};
use epivox::render::{Method, Renderer};
use epivox::scene::{build, Scene};
use epivox::Image;
use glam::Vec3;

/// Renders `scene` with the culling on and off; panics where the images differ or the culled
/// frame's list is not the scene's triangles in order. Returns how many triangles the culled frame
/// left out, and how many the scene has.
fn same_with_and_without(r: &mut Renderer, scene: &Scene, (w, h): (u32, u32), method: Method) -> (usize, usize) {
    let mut images: Vec<(Image, Image)> = Vec::new();
    let mut emptied = (0, 0);
    // Every frame draws its surfaces (the targets are the same either way, so a renderer may
    // otherwise take them over from the frame before).
    r.reuse_unchanged = false;
    for culling in [true, false] {
        r.surface_culling = culling;
        let out = r.render(scene, w, h, method).unwrap_or_else(|e| panic!("{e}"));
        if culling {
            let list = r.read_eye_list().unwrap_or_else(|e| panic!("{e}")).expect("no eye list was made");
            let source = scene_indices(scene);
            // The drawn triangles are the scene's, in the scene's order (a subsequence of it):
            // the same draws in the same order, so a tie in depth resolves the same way.
            let mut rest = source.iter();
            for (i, t) in list.chunks(3).enumerate() {
                assert!(
                    rest.any(|s| s[..] == *t),
                    "{}: drawn triangle {i} {t:?} is out of the scene's order",
                    scene.name
                );
            }
            emptied = (source.len() - list.len() / 3, source.len());
        }
        images.push((out.hdr, out.scatter));
    }
    for (which, a, b) in [("final image", &images[0].0, &images[1].0), ("scatter", &images[0].1, &images[1].1)] {
        let differ = a.pixels.iter().zip(&b.pixels).filter(|(x, y)| x != y).count();
        assert_eq!(differ, 0, "{}, {w}x{h}: {differ} pixels of the {which} differ with the culling", scene.name);
    }
    emptied
}

/// The scene's triangles as SceneGpu lists them: mesh by mesh, each mesh's vertices after the
/// meshes' before it.
fn scene_indices(scene: &Scene) -> Vec<[u32; 3]> {
    let mut base = 0;
    let mut out = Vec::new();
    for m in &scene.meshes {
        out.extend(m.triangles.iter().map(|t| t.map(|i| base + i)));
        base += m.positions.len() as u32;
    }
    out
}

/// A room of 64 spheres tessellated to 100 000 triangles, under its point light and under a sun,
/// at two small sizes (one odd, whose last column and row cut triangles): most triangles lie
/// between pixel centres or on the spheres' far sides (closed solids seen from outside) and are
/// emptied, the rest draw the same image.
#[test]
fn a_finely_tessellated_room_draws_the_same_with_its_tiny_triangles_emptied() {
    let Some(mut r) = renderer() else { return };
    let mut scene = epivox::bench::procedural_scene(100_000);
    scene.grid = epivox::params::Grid { planes: 256, rays: 256, bins: 128, ..Default::default() };
    for size in [(96, 80), (61, 47)] {
        let (emptied, triangles) = same_with_and_without(&mut r, &scene, size, Method::Vsv);
        // The spheres' triangles are a fraction of a pixel at these sizes; the walls are not.
        assert!(emptied * 2 > triangles && emptied < triangles, "{size:?}: {emptied} of {triangles} emptied");
    }
    // Past 256 blocks of 1024 triangles: the blocks' sums take `places` more than one round.
    let mut big = epivox::bench::procedural_scene(300_000);
    big.grid = scene.grid;
    let (emptied, triangles) = same_with_and_without(&mut r, &big, (64, 48), Method::Vsv);
    assert!(triangles > 256 * 1024 && emptied < triangles, "{emptied} of {triangles} left out");
    scene.light = build::directional(Vec3::new(-0.4, 1.0, 0.3));
    let (emptied, triangles) =
        same_with_and_without(&mut r, &scene, (96, 80), Method::Raymarch { steps: 16, jitter: false });
    assert!(emptied * 2 > triangles, "{emptied} of {triangles} emptied under the sun");
}

/// Finely tessellated boxes around the eye (every direction, triangles behind it, w <= 0 at some
/// vertices) and across the near plane beside the view axis: the culling keeps what it cannot
/// project, and the images stay the same.
#[test]
fn triangles_behind_the_eye_and_across_the_near_plane_draw_the_same() {
    let Some(mut r) = renderer() else { return };
    // The light inside the box around the eye, which would otherwise shadow everything.
    let mut scene = common::occluder_scene(point_light(Vec3::new(0.5, 2.0, 4.5)));
    let cam = scene.camera;
    let forward = (cam.target - cam.eye).normalize();
    let right = forward.cross(cam.up).normalize();
    scene.name = "boxes around the eye and across its near plane".into();
    scene.meshes.push(build::tessellated_cuboid("around the eye", cam.eye, Vec3::new(3.0, 2.0, 3.0), 120));
    scene.meshes.push(build::tessellated_cuboid(
        "across the near plane",
        cam.eye + forward * cam.near + right * 0.02,
        Vec3::splat(0.012),
        24,
    ));
    let (emptied, triangles) = same_with_and_without(&mut r, &scene, (96, 80), Method::Vsv);
    assert!(emptied > 0 && emptied < triangles, "{emptied} of {triangles} emptied");
}

/// A triangle with two vertices behind the eye: each projects (x/w, y/w with w < 0) onto the
/// point its mirror image through the eye would, here within a fifth of a pixel of the front
/// vertex's, in a box between pixel centres. Its real image is a wedge from the front vertex out
/// to the image's edge, over many centres; only the test that all three vertices lie in front of
/// the eye keeps it from being emptied.
#[test]
fn a_triangle_through_the_eye_plane_is_kept_though_its_vertices_project_between_centres() {
    let Some(mut r) = renderer() else { return };
    let mut scene = common::occluder_scene(point_light(Vec3::new(0.3, 3.0, 0.2)));
    let (w, h) = (96u32, 80u32);
    let cam = scene.camera;
    let inverse = cam.view_proj(w as f32 / h as f32).inverse();
    // The view direction through pixel coordinates (x right, y down).
    let through = |x: f32, y: f32| {
        let ndc = Vec3::new(x / w as f32 * 2.0 - 1.0, 1.0 - y / h as f32 * 2.0, 0.5);
        (inverse.project_point3(ndc) - cam.eye).normalize()
    };
    // Centres lie at i + 1/2: the box [39.85, 40.1] x [30, 30.2] holds none. The two edges toward
    // the eye leave the front vertex (40, 30) upward, one to each side.
    let front = cam.eye + through(40.0, 30.0) * 2.0;
    let behind_a = cam.eye - through(40.1, 30.2) * 2.0;
    let behind_b = cam.eye - through(39.85, 30.1) * 2.0;
    scene.name = "a triangle through the eye plane".into();
    scene.meshes.push(epivox::scene::Mesh {
        name: "through the eye plane".into(),
        positions: vec![front, behind_a, behind_b],
        triangles: vec![[0, 1, 2]],
        albedo: Vec3::splat(0.8),
    });
    same_with_and_without(&mut r, &scene, (w, h), Method::Vsv);
    // The comparison means something only if the triangle shows.
    r.surface_culling = false;
    let with = r.render(&scene, w, h, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    scene.meshes.pop();
    let without = r.render(&scene, w, h, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let differ = with.hdr.pixels.iter().zip(&without.hdr.pixels).filter(|(a, b)| a != b).count();
    assert!(differ > 50, "the triangle covers only {differ} pixels");
}

/// One frame's images and the number of triangles Surface drew.
fn frame_and_list(r: &mut Renderer, scene: &Scene, (w, h): (u32, u32)) -> (Image, Image, usize) {
    let out = r.render(scene, w, h, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let list = r.read_eye_list().unwrap_or_else(|e| panic!("{e}")).expect("no eye list was made");
    (out.hdr, out.scatter, list.len() / 3)
}

/// From the second frame of a view on, Surface leaves out the triangles behind the depth the first
/// frame left at every pixel they cover (`Renderer::eye_occlusion_culling`, the eye's pyramid):
/// every frame's images are the same to the bit as without it, and a new view (the camera moved,
/// another image size) draws its first frame without it.
#[test]
fn hidden_triangles_are_left_out_from_a_views_second_frame_and_the_images_stay_the_same() {
    let Some(mut r) = renderer() else { return };
    let mut room = epivox::bench::procedural_scene(100_000);
    room.grid = epivox::params::Grid { planes: 256, rays: 256, bins: 128, ..Default::default() };
    // Every frame draws its surfaces (a renderer may otherwise take them over from the frame before).
    r.reuse_unchanged = false;
    let mut views = vec![(room.clone(), room.camera, (160, 120))];
    let mut moved = room.camera;
    moved.eye += (moved.target - moved.eye).normalize() * 0.3 + Vec3::new(0.05, 0.0, 0.0);
    views.push((room.clone(), moved, (160, 120)));
    views.push((room, moved, (150, 120)));
    // The built-in room at 96x80 draws slivers whose depth's plane, steep across them, runs on
    // below their vertices' least at a pixel just past an edge (the margin's slope term).
    let mut builtin = epivox::scene::builtin_scene();
    builtin.grid = epivox::params::Grid { planes: 64, rays: 64, bins: 32, ..Default::default() };
    // (Lit from the middle of the room, where such a pixel shows.)
    builtin.light = point_light(Vec3::new(0.0, builtin.bounds().max.y * 0.5, 0.0));
    views.push((builtin.clone(), builtin.camera, (96, 80)));
    for (scene, camera, size) in views {
        let mut scene = scene;
        scene.camera = camera;
        r.eye_occlusion_culling = false;
        let (hdr, scatter, all) = frame_and_list(&mut r, &scene, size);
        r.eye_occlusion_culling = true;
        let frames: Vec<_> = (0..3).map(|_| frame_and_list(&mut r, &scene, size)).collect();
        for (i, (h, s, _)) in frames.iter().enumerate() {
            assert!(h.pixels == hdr.pixels && s.pixels == scatter.pixels, "{size:?}: frame {i}'s images differ");
        }
        let lists: Vec<usize> = frames.iter().map(|f| f.2).collect();
        // (The frame without the switch made no pyramid: the first one with it draws every triangle.)
        assert_eq!(lists[0], all, "{size:?}: a view's first frame left triangles out");
        assert!(lists[1] < lists[0] && lists[2] == lists[1], "{size:?}: triangles drawn per frame {lists:?}");
    }
}

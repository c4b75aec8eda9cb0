//! A frame whose only changes are the medium's coefficients, its phase function's asymmetry or the
//! light's power takes the shadow map, the surfaces and the shadow volume from the frame before
//! (`Renderer::reuse_unchanged`); one whose changes leave the shadow map's inputs alone (a camera
//! move under a point light; a sun's map follows the view, `ShadowFit`) takes the map. Either must
//! come out the same, bit for bit, as the frame of a renderer that runs every pass, and every
//! other change must run every pass again.

mod common;

use common::{occluder_scene, renderer};
use epivox::gpu::ShaderLibrary;
use epivox::params::{Light, Phase};
use epivox::render::{Method, Pass, RenderOutput, Renderer, SurfaceShadows};
use epivox::scene::Scene;
use glam::Vec3;

const W: u32 = 96;
const H: u32 = 72;

fn render(r: &mut Renderer, scene: &Scene, method: Method) -> RenderOutput {
    r.render(scene, W, H, method).unwrap_or_else(|e| panic!("{}: {e}", scene.name))
}

type MediumEdit = (&'static str, fn(&mut Scene) -> bool);

/// The edits an artist tuning the medium makes: none changes what the passes before Integrate (or
/// Raymarch) read, nor the shader variant (the medium stays coloured, the phase function HG).
/// Each returns whether it applies to the scene.
fn medium_edits() -> Vec<MediumEdit> {
    vec![
        ("scattering", |s| {
            s.medium.scattering *= 1.5;
            true
        }),
        ("absorption", |s| {
            s.medium.absorption += Vec3::splat(0.02);
            true
        }),
        ("density", |s| {
            s.medium.density *= 1.7;
            true
        }),
        ("phase asymmetry", |s| {
            s.medium.phase = Phase::HenyeyGreenstein { g: 0.55 };
            true
        }),
        ("light power", |s| {
            match &mut s.light {
                Light::Point { intensity, .. } => *intensity *= 2.5,
                Light::Directional { irradiance, .. } => *irradiance *= 0.4,
            }
            true
        }),
        ("softening radius", |s| match &mut s.light {
            Light::Point { radius, .. } => {
                *radius += 0.05;
                true
            }
            Light::Directional { .. } => false,
        }),
    ]
}

fn scenes() -> Vec<Scene> {
    let point = Light::Point { position: Vec3::new(0.3, 2.6, 0.2), intensity: Vec3::splat(8.0), radius: 0.0 };
    let sun = Light::Directional { direction: Vec3::new(0.3, 1.0, 0.2).normalize(), irradiance: Vec3::splat(2.0) };
    let mut v = vec![occluder_scene(point), occluder_scene(sun)];
    for s in &mut v {
        s.medium.phase = Phase::HenyeyGreenstein { g: 0.2 };
    }
    v[1].name = "occluder, sun".into();
    v
}

/// Runs `case` for each scene of [`scenes`] and each method, VSV and the march, with a renderer
/// that reuses (`r`) and one that runs every pass (`fresh`), both after two frames of the scene:
/// under the sun the second is the first to read the shadow map's pyramid (tests/occlusion.rs),
/// which changes the uniforms and the map's draw list; from the third on nothing changes.
fn for_each_warm_case(mut case: impl FnMut(&mut Renderer, &mut Renderer, &Scene, Method)) {
    let (Some(mut r), Some(mut fresh)) = (renderer(), renderer()) else { return };
    fresh.reuse_unchanged = false;
    for base in scenes() {
        for method in [Method::Vsv, Method::Raymarch { steps: 48, jitter: false }] {
            for _ in 0..2 {
                render(&mut r, &base, method);
                render(&mut fresh, &base, method);
            }
            case(&mut r, &mut fresh, &base, method);
        }
    }
}

/// The reusing frame equals the fresh renderer's bit for bit, and differs from the frame before.
fn assert_same_images(case: &str, out: &RenderOutput, expected: &RenderOutput, previous: &RenderOutput) {
    assert!(expected.reused.is_empty(), "{case}: reused with reuse_unchanged off");
    assert!(out.scatter.pixels == expected.scatter.pixels, "{case}: the scattered light differs");
    assert!(out.hdr.pixels == expected.hdr.pixels, "{case}: the final image differs");
    // The change moved the picture, so stale results would show.
    assert!(expected.hdr.pixels != previous.hdr.pixels, "{case}: the change altered nothing to check");
}

/// Every edit of the medium, on a point light and a sun, for VSV and the march: the frame reuses
/// what the previous frame drew and equals the frame of a renderer that draws everything anew.
#[test]
fn medium_edits_reuse_the_volume_and_give_the_same_image() {
    for_each_warm_case(|r, fresh, base, method| {
        let mut scene = base.clone();
        let mut previous = render(fresh, &scene, method);
        for (what, edit) in medium_edits() {
            if !edit(&mut scene) {
                continue;
            }
            let case = format!("{} ({method:?}), {what}", scene.name);
            assert!(r.would_reuse(&scene, W, H, method), "{case}: not foreseen");
            let out = render(r, &scene, method);
            let expected = render(fresh, &scene, method);
            let mut drawn = vec![Pass::Surface];
            if !scene.light.is_point() {
                drawn.push(Pass::ShadowFit);
            }
            // Under a sun VSV's surfaces take exact shadows (the default), drawn with no map once
            // the first frame has made Cull's pyramid.
            let exact = !scene.light.is_point()
                && !matches!(method, Method::Raymarch { .. })
                && r.surface_shadows == SurfaceShadows::Exact;
            drawn.push(if exact { Pass::ExactShadows } else { Pass::ShadowMap });
            if method == Method::Vsv {
                // The first hits take their bounds where the bits scan.
                let volume = if out.variant.first_hits { Pass::HitBounds } else { Pass::Scan };
                drawn.extend([Pass::Ranges, Pass::Cull, Pass::Voxelize, volume]);
            }
            assert_eq!(out.reused, drawn, "{case}: ran {:?}", out.passes);
            assert!(out.passes.iter().all(|p| !drawn.contains(p)), "{case}: ran {:?} again", out.passes);
            assert_same_images(&case, &out, &expected, &previous);
            previous = expected;
        }
    });
}

/// Camera moves, on a point light and a sun, for VSV and the march: under the point light the frame
/// takes the shadow map from the frame before and runs every other pass; the sun's map, fitted to
/// the view, is fitted and drawn again. Either way the frame equals the frame of a renderer that
/// draws everything anew; a light move draws the map again.
#[test]
fn camera_moves_reuse_a_point_lights_map_and_give_the_same_image() {
    for_each_warm_case(|r, fresh, base, method| {
        let mut scene = base.clone();
        let mut previous = render(fresh, &scene, method);
        for step in 1..=3 {
            scene.camera.eye += Vec3::new(0.07, 0.02 * step as f32, -0.05);
            let case = format!("{} ({method:?}), camera move {step}", scene.name);
            assert!(!r.would_reuse(&scene, W, H, method), "{case}: foreseen as reusing the volume");
            let out = render(r, &scene, method);
            let expected = render(fresh, &scene, method);
            if scene.light.is_point() {
                assert_eq!(out.reused, vec![Pass::ShadowMap], "{case}: ran {:?}", out.passes);
                assert!(!out.passes.contains(&Pass::ShadowMap), "{case}: drew the map again");
            } else {
                assert!(out.reused.is_empty(), "{case}: reused {:?}", out.reused);
                assert!(out.passes.contains(&Pass::ShadowFit), "{case}: did not fit the map, ran {:?}", out.passes);
            }
            assert!(out.passes.contains(&Pass::Surface), "{case}: ran only {:?}", out.passes);
            assert_same_images(&case, &out, &expected, &previous);
            previous = expected;
        }
        // The light moves: the map is drawn again, and matches the fresh renderer's.
        match &mut scene.light {
            Light::Point { position, .. } => *position += Vec3::new(0.1, 0.0, 0.05),
            Light::Directional { direction, .. } => *direction = (*direction + Vec3::new(0.1, 0.0, 0.0)).normalize(),
        }
        let out = render(r, &scene, method);
        let expected = render(fresh, &scene, method);
        let case = format!("{} ({method:?}), light move", scene.name);
        assert_same_images(&case, &out, &expected, &previous);
        assert!(out.reused.is_empty(), "{case}: reused {:?}", out.reused);
    });
}

/// Whatever the passes before Integrate read makes the next frame run all of them but, where the
/// change leaves the shadow map's inputs alone, the map.
#[test]
fn other_changes_run_every_pass() {
    let Some(mut r) = renderer() else { return };
    let base = scenes().remove(0);
    type Edit = fn(&mut Scene, &mut Renderer);
    // (what, change, whether the map's inputs stay the same)
    let changes: Vec<(&str, Edit, bool)> = vec![
        ("camera", |s, _| s.camera.eye += Vec3::new(0.05, 0.0, 0.0), true),
        (
            "light position",
            |s, _| {
                if let Light::Point { position, .. } = &mut s.light {
                    *position += Vec3::new(0.0, 0.1, 0.0);
                }
            },
            false,
        ),
        // New resources forget everything drawn into the old ones.
        ("grid", |s, _| s.grid.rays /= 2, false),
        ("geometry", |s, _| s.meshes[1].positions.iter_mut().for_each(|p| *p += Vec3::new(0.0, 0.05, 0.0)), false),
        // (A point light's map has no hidden-triangle test, which pruning switches.)
        ("no pruning", |_, r| r.prune = false, true),
        ("shadow map size", |_, r| r.set_shadow_map_size(1024).unwrap_or_else(|e| panic!("{e}")), false),
        ("shader reload", |_, r| r.reload(&ShaderLibrary::embedded()).unwrap_or_else(|e| panic!("{e}")), false),
        ("the geometry grid kept", |_, r| r.set_keep_geometry_grid(true), true),
        ("shadow face culling off", |_, r| r.shadow_face_culling = false, false),
        ("phase function", |s, _| s.medium.phase = Phase::Rayleigh, false),
        // Grey extinction takes one channel's exponentials: another variant of the shaders.
        (
            "a grey medium",
            |s, _| {
                s.medium.scattering = Vec3::splat(0.1);
                s.medium.absorption = Vec3::splat(0.02);
            },
            false,
        ),
    ];
    let mut scene = base.clone();
    render(&mut r, &scene, Method::Vsv);
    assert!(r.would_reuse(&scene, W, H, Method::Vsv), "the same frame again not foreseen as reusing");
    assert!(
        render(&mut r, &scene, Method::Vsv).info().reused_all_before_volume(),
        "the same frame again did not reuse"
    );
    // Another size needs new targets.
    assert!(!r.would_reuse(&scene, W + 8, H, Method::Vsv), "another size foreseen as reusing");
    for (what, change, keeps_map) in changes {
        change(&mut scene, &mut r);
        assert!(!r.would_reuse(&scene, W, H, Method::Vsv), "{what}: foreseen as reusing");
        let out = render(&mut r, &scene, Method::Vsv);
        let map = if keeps_map { vec![Pass::ShadowMap] } else { Vec::new() };
        assert_eq!(out.reused, map, "{what}: ran {:?}", out.passes);
        assert!(out.passes.contains(&Pass::Voxelize), "{what}: ran only {:?}", out.passes);
        assert!(
            render(&mut r, &scene, Method::Vsv).info().reused_all_before_volume(),
            "{what}: the next frame did not reuse"
        );
    }
    // A medium that stops scattering runs no voxel pass; the one after it that scatters again
    // must make its volume.
    scene.medium.density = 0.0;
    render(&mut r, &scene, Method::Vsv);
    scene.medium.density = 1.0;
    let out = render(&mut r, &scene, Method::Vsv);
    assert!(out.passes.contains(&Pass::Voxelize), "scattering again: ran only {:?}", out.passes);
    // Switched off, every frame runs every pass.
    r.reuse_unchanged = false;
    assert!(render(&mut r, &scene, Method::Vsv).reused.is_empty());
    scene.camera.eye += Vec3::new(0.05, 0.0, 0.0);
    assert!(render(&mut r, &scene, Method::Vsv).reused.is_empty());
}

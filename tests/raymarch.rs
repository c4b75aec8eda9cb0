//! The ray-marching baseline against the exact CPU reference (software Vulkan driver in CI).
//!
//! The baseline's error has two parts: the step count (midpoint rule along the ray; a shadow boundary
//! falls inside one step, so that part shrinks like 1/steps) and the shadow map (one nearest texel per
//! step, 1.5 texels of bias). With the default 2048² map the first dominates up to a few hundred
//! steps. Measured at 64x64 on llvmpipe (relative RMSE of the scattered light at 16 / 64 / 256 steps):
//! point light 1.37 / 0.47 / 0.14 %, directional 0.84 / 0.29 / 0.11 %, directional jittered
//! 2.67 / 0.68 / 0.19 %, sky view of the point light 1.08 / - / 0.07 %. Each bound sits at 2.5-3x the
//! measured error at 256 steps: loose enough for float differences between drivers, tight enough that
//! a lost shadow, a wrong phase sign or a dropped sky tail (each several %) fails.

mod common;

use common::*;
use epivox::metrics;
use epivox::params::Light;
use epivox::reference::{self, ReferenceOptions};
use epivox::render::{Method, Renderer};
use epivox::scene::Scene;
use glam::Vec3;

const W: u32 = 64;
const H: u32 = 64;

/// Relative RMSE of the raymarch's scattered light against the reference, for each step count.
fn errors(r: &mut Renderer, scene: &Scene, steps: &[u32], jitter: bool) -> Vec<f64> {
    let reference = reference::render(scene, W, H, &ReferenceOptions { progress: false, ..Default::default() });
    steps
        .iter()
        .map(|&n| {
            let out = r.render(scene, W, H, Method::Raymarch { steps: n, jitter }).unwrap_or_else(|e| panic!("{e}"));
            let s = metrics::compare(&out.scatter, &reference.scatter).unwrap_or_else(|e| panic!("{e}"));
            eprintln!("{} raymarch {n:>4} steps (jitter {jitter}): {s}", scene.name);
            assert_eq!(s.non_finite, 0, "{n} steps");
            dump(&format!("{}_raymarch{n}", scene.name), &out.scatter);
            s.rel_rmse
        })
        .collect()
}

fn assert_converges(e: &[f64], last_bound: f64) {
    for w in e.windows(2) {
        assert!(w[1] < w[0], "the error did not decrease with more steps: {e:?}");
    }
    let last = e[e.len() - 1];
    assert!(last < last_bound, "relative RMSE {last} at the most steps (bound {last_bound}); all: {e:?}");
}

/// Point light with sky pixels above the floor: checks the march to the surface and the sky's tail
/// beyond the scene's box.
#[test]
fn point_light_error_decreases_with_steps() {
    let Some(mut r) = renderer() else { return };
    let scene = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    let e = errors(&mut r, &scene, &[16, 64, 256], false);
    assert_converges(&e, 0.004);
}

#[test]
fn directional_light_error_decreases_with_steps() {
    let Some(mut r) = renderer() else { return };
    let scene = occluder_scene(Light::Directional {
        direction: Vec3::new(0.3, 1.0, 0.2).normalize(),
        irradiance: Vec3::splat(2.0),
    });
    let e = errors(&mut r, &scene, &[16, 64, 256], false);
    assert_converges(&e, 0.003);
}

/// Jitter trades banding for noise and converges too. (With a point light on screen the jittered
/// march is much noisier than the midpoint rule: a sample may land arbitrarily close to the light on
/// a ray that passes near it, where the integrand grows like 1 / d². That is the baseline's nature,
/// measured in docs/results.md; here the directional light checks the convergence itself.)
#[test]
fn jittered_march_converges_too() {
    let Some(mut r) = renderer() else { return };
    let scene = occluder_scene(Light::Directional {
        direction: Vec3::new(0.3, 1.0, 0.2).normalize(),
        irradiance: Vec3::splat(2.0),
    });
    let e = errors(&mut r, &scene, &[16, 64, 256], true);
    assert_converges(&e, 0.005);
}

/// A sky-only view (no surface anywhere on screen) of a point light: everything comes from the
/// march to the box's side and the tail beyond it, which must add up to the whole infinite ray.
#[test]
fn sky_tail_of_a_point_light_adds_up() {
    let Some(mut r) = renderer() else { return };
    let mut scene = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    // Look up, away from the floor: only the occluder's underside may be in view.
    scene.camera.target = Vec3::new(0.0, 6.0, -3.0);
    let e = errors(&mut r, &scene, &[16, 256], false);
    assert_converges(&e, 0.002);
}

/// raymarch.wgsl's `pixel_hash`, the jitter offset u of pixel (x, y), as its integer numerator over
/// 2^24 (u = k / 2^24).
fn jitter_numerator(x: u32, y: u32) -> u32 {
    let mut s = x.wrapping_mul(747796405).wrapping_add(y.wrapping_mul(2891336453)).wrapping_add(12345);
    s = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277803737);
    s = (s >> 22) ^ s;
    s >> 8
}

/// The sky tail's last jittered sample sits at alpha = a0 + (m - 1 + u) da. With u within a few
/// hundred ulps of 1 that rounds to f32(pi/2), whose tangent put the sample 2.3e7 H behind the eye
/// (on an NVIDIA H200 the bunny's jittered march had infinite pixels, presumably its fast tan).
/// Behind the eye a forward-scattering phase (g = 0.9) sees the light straight ahead, so that one
/// sample outweighs the rest of the tail by orders of magnitude. At the pixels whose u is that close
/// to 1, the jittered march must agree with the midpoint rule as closely as elsewhere: both integrate
/// the same smooth sky ray with 1024 + 256 samples (5%: the pixels' own jitter error is far below it;
/// the misplaced sample made them several times too bright).
#[test]
fn jittered_sky_tail_samples_stay_on_the_ray() {
    let Some(mut r) = renderer() else { return };
    let mut scene = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    scene.camera.target = Vec3::new(0.0, 6.0, -3.0);
    scene.medium.phase = epivox::params::Phase::HenyeyGreenstein { g: 0.9 };
    // The smallest image holding pixels with u > 1 - 2^-16 (pixel (165, 106): u = 1 - 27 / 2^24).
    let (w, h) = (166, 107);
    let near_one: Vec<(u32, u32)> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .filter(|&(x, y)| jitter_numerator(x, y) >= (1 << 24) - 256)
        .collect();
    assert!(!near_one.is_empty(), "no pixel with u near 1: the hash above no longer mirrors the shader's");
    let steps = 1024;
    let jittered = r.render(&scene, w, h, Method::Raymarch { steps, jitter: true }).unwrap();
    let midpoint = r.render(&scene, w, h, Method::Raymarch { steps, jitter: false }).unwrap();
    assert_eq!(jittered.scatter.count_non_finite(), 0);
    for &(x, y) in &near_one {
        let i = (y * w + x) as usize;
        let (a, b) = (jittered.scatter.pixels[i], midpoint.scatter.pixels[i]);
        eprintln!(
            "pixel ({x}, {y}), u = 1 - {} / 2^24: jittered {a:?}, midpoint {b:?}",
            (1 << 24) - jitter_numerator(x, y)
        );
        for c in 0..3 {
            assert!(b[c] > 0.0, "pixel ({x}, {y}) is not lit: the test looks at the wrong place");
            let rel = (a[c] - b[c]).abs() / b[c];
            assert!(rel < 0.05, "pixel ({x}, {y}) channel {c}: jittered {} against midpoint {} ({rel})", a[c], b[c]);
        }
    }
}

#[test]
fn timings_name_the_raymarch_pass_and_shadow_map_size_is_a_setting() {
    let Some(mut r) = renderer() else { return };
    let scene = occluder_scene(point_light(Vec3::new(0.2, 3.0, 0.1)));
    r.set_shadow_map_size(512).unwrap();
    assert_eq!(r.shadow_map_size(), 512);
    let small = r.render(&scene, 32, 32, Method::Raymarch { steps: 64, jitter: false }).unwrap();
    if r.ctx.timestamps {
        let names: Vec<&str> = small.timings.iter().map(|t| t.pass.label()).collect();
        assert_eq!(names, ["surface", "shadow_map", "raymarch", "composite"]);
    }
    // Too large for the adapter: refused with the limit, and the old map keeps working.
    let err = r.set_shadow_map_size(1 << 20).unwrap_err().to_string();
    assert!(err.contains("shadow map") && err.contains("allows at most"), "{err}");
    assert_eq!(r.shadow_map_size(), 512);
    assert!(r.set_shadow_map_size(0).is_err());
    let again = r.render(&scene, 32, 32, Method::Raymarch { steps: 64, jitter: false }).unwrap();
    assert_eq!(small.scatter, again.scatter);
    // And VSV still renders after switching back and forth.
    let v = r.render(&scene, 32, 32, Method::Vsv).unwrap();
    assert_eq!(v.scatter.count_non_finite(), 0);
}

//! The first-hit volume (`--volume first-hits`, `Renderer::shadow_volume`): each light ray keeps
//! the angle of its first hit, and a view ray's point is shadowed where that hit comes before it.
//!
//! Tolerances: against the exact reference, as tests/gpu.rs's bit-grid tests (each bound about
//! twice the error measured here on llvmpipe, which is the sampling of the planes and bins: a
//! real break, a shadow missing or the comparison the wrong way round, is 10-40% on these
//! scenes); a closed box is exact (no light ray slips between its triangles, and the pixels'
//! own comparison has no cell to leak through).

mod common;

use common::*;
use epivox::params::Grid;
use epivox::render::{Method, Pass, ShadowVolume, SurfaceShadows, WordBounds};
use glam::Vec3;

#[test]
fn first_hits_match_the_reference_under_a_point_light_and_a_sun() {
    let Some(mut r) = renderer() else { return };
    r.shadow_volume = ShadowVolume::FirstHits;
    // (light, the bound, what was measured)
    // (The bits at this grid: 0.08% and 0.93%, tests/gpu.rs.)
    let cases = [(point_light(Vec3::new(0.2, 3.0, 0.1)), 0.003, "0.11%"), (sun(), 0.012, "0.62%")];
    for (light, bound, measured) in cases {
        let scene = occluder_scene(light);
        let out = r.render(&scene, 96, 96, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        assert!(out.variant.first_hits, "the frame ran as bits: {:?}", out.variant);
        assert!(out.passes.contains(&Pass::HitBounds) && !out.passes.contains(&Pass::Scan), "{:?}", out.passes);
        let (_, _, s) = against_reference(&mut r, &scene, Method::Vsv, 96, 96);
        assert_eq!(s.non_finite, 0);
        assert!(s.rel_rmse < bound, "{:?}: relative RMSE {} (measured {measured})", scene.light, s.rel_rmse);
    }
}

/// A point light inside a closed box: nothing outside it is lit, at the default grid and at a
/// coarse one (the bit grid's test of its own, tests/gpu.rs, with grid surface shadows).
#[test]
fn first_hits_never_leak_light_out_of_a_closed_box() {
    let Some(mut r) = renderer() else { return };
    r.shadow_volume = ShadowVolume::FirstHits;
    let mut s = closed_box_scene();
    for grid in [Grid::default(), Grid { planes: 128, rays: 128, bins: 32, ..Grid::default() }] {
        s.grid = grid;
        let out = r.render(&s, 128, 96, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        assert!(out.variant.first_hits);
        let brightest = brightest(&out.scatter);
        assert!(brightest <= 1e-6, "grid {grid}: light leaked out of the closed box: {brightest}");
    }
}

/// The first hits take `planes x bins` keys where the bits take `planes x rays x bins` bits: a
/// grid whose bits exceed the adapter's storage binding renders with first hits, and the bits
/// say it is too large. With grid surface shadows (which read the bits' ray cells) the same
/// setting keeps the bits.
#[test]
fn first_hits_fit_grids_the_bits_cannot_and_grid_shadows_keep_the_bits() {
    let Some(mut r) = renderer() else { return };
    let mut scene = occluder_scene(sun());
    let limit = r.ctx.device.limits().max_storage_buffer_binding_size;
    // 512 planes x 2048 bins: 128 KiB of bits a ray, 4 MiB of first hits.
    let rays = (1..=8192u32).map(|n| n.next_power_of_two()).find(|&n| 512 * n as u64 * 256 > limit);
    let Some(rays) = rays else {
        eprintln!("SKIPPED: the adapter binds {limit} bytes, more than the largest bit grid");
        return;
    };
    scene.grid = Grid { planes: 512, rays, bins: 2048, ..Grid::default() };
    r.shadow_volume = ShadowVolume::Bits;
    let e = r.render(&scene, 64, 48, Method::Vsv).expect_err("the bits exceed the binding");
    assert!(e.to_string().contains("allows at most"), "{e}");
    r.shadow_volume = ShadowVolume::FirstHits;
    let out = r.render(&scene, 64, 48, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    assert!(out.variant.first_hits);
    r.surface_shadows = SurfaceShadows::Grid;
    scene.grid = Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() };
    let out = r.render(&scene, 64, 48, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    assert!(!out.variant.first_hits && out.passes.contains(&Pass::Scan), "{:?}", out.passes);
}

/// At the same planes and bins the first hits are more accurate than the bits on the occluder
/// under a sun, where the bits' 64 ray cells are coarse: they drop the cells (up to one cell of
/// shadow toward the light) and keep everything else. Measured: 0.95% against the bits' 4.02%;
/// the bound is half the bits' error.
#[test]
fn first_hits_are_more_accurate_than_the_bits_at_the_same_grid() {
    let Some(mut r) = renderer() else { return };
    let mut scene = occluder_scene(sun());
    scene.grid = Grid { planes: 256, rays: 64, bins: 128, ..Grid::default() };
    let mut errors = Vec::new();
    for volume in [ShadowVolume::Bits, ShadowVolume::FirstHits] {
        r.shadow_volume = volume;
        let (_, _, s) = against_reference(&mut r, &scene, Method::Vsv, 96, 96);
        errors.push(s.rel_rmse);
    }
    assert!(errors[1] <= errors[0] * 0.5, "first hits {} against the bits' {}", errors[1], errors[0]);
}

/// HitBounds writes each word's bounds where Integrate reads them (`WordBounds::read`, the layout
/// by fours), the same as `WordBounds::of` its keys, and an occluder's shadow edges give words
/// with a wide middle gap (the keys of a near caster beside a far floor's).
#[test]
fn each_words_bounds_and_gap_are_those_of_its_keys() {
    let Some(mut r) = renderer() else { return };
    r.shadow_volume = ShadowVolume::FirstHits;
    let mut scene = occluder_scene(sun());
    scene.grid = Grid { planes: 256, rays: 64, bins: 256, ..Grid::default() };
    r.render(&scene, 96, 96, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let (grid, volume, words) = r.read_volume().unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((grid, volume), (scene.grid, ShadowVolume::FirstHits));
    let mut edges = 0;
    for i in 0..(grid.planes * grid.words()) as usize {
        let keys: &[u32; 32] = words[32 * i..32 * i + 32].try_into().expect("32 keys a word");
        let read = WordBounds::read(&words, &grid, i);
        assert_eq!(read, WordBounds::of(keys), "word {i}");
        // A wide gap between two groups of hits (not a miss's key 0), room for a pixel's key.
        if read.wide && read.above - read.below > 1 && keys.iter().all(|&k| k != 0) {
            edges += 1;
        }
    }
    assert!(edges > 0, "no word of the occluder's shadow has a wide gap between two groups of hits");
}

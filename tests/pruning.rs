//! Fitting the work to the frame (DESIGN section 6) must not cost accuracy, and must skip what a
//! frame does not need.
//!
//! Margin: pruning spends the same grid on a smaller range, so its error should be *lower*; we
//! allow it to be worse by at most 10% of the unpruned error plus 0.5 percentage points, which
//! absorbs the different sampling positions of the two grids without letting a real loss through
//! (dropping a needed caster costs tens of percent on these scenes).

mod common;

use common::*;
use epivox::params::{Grid, Light, Medium};
use epivox::render::{Method, Renderer};
use epivox::scene::Scene;
use glam::Vec3;

fn error(r: &mut Renderer, scene: &Scene, prune: bool) -> f64 {
    r.prune = prune;
    let (_, _, s) = against_reference(r, scene, Method::Vsv, 64, 64);
    r.prune = true;
    s.rel_rmse
}

fn assert_no_worse(r: &mut Renderer, name: &str, scene: &Scene) {
    let pruned = error(r, scene, true);
    let full = error(r, scene, false);
    eprintln!("{name}: pruned {pruned:.4}, unpruned {full:.4}");
    assert!(pruned <= 1.1 * full + 0.005, "{name}: pruning lost accuracy: {pruned:.4} vs {full:.4}");
}

fn base(light: Light) -> Scene {
    let mut s = occluder_scene(light);
    s.grid = Grid { planes: 256, rays: 256, bins: 64, ..Grid::default() };
    s
}

#[test]
fn pruned_is_as_accurate_with_the_light_on_screen() {
    let Some(mut r) = renderer() else { return };
    // The light in view, above the occluder.
    let mut s = base(point_light(Vec3::new(0.3, 2.6, -1.0)));
    s.camera.target = Vec3::new(0.0, 1.8, 0.0);
    assert_no_worse(&mut r, "light on screen", &s);
}

#[test]
fn pruned_is_as_accurate_with_the_light_far_off_screen() {
    let Some(mut r) = renderer() else { return };
    let s = base(point_light(Vec3::new(12.0, 3.0, 0.5)));
    assert_no_worse(&mut r, "light far off screen", &s);
}

#[test]
fn pruned_is_as_accurate_with_the_light_behind_the_camera() {
    let Some(mut r) = renderer() else { return };
    let s = base(point_light(Vec3::new(1.0, 3.0, 9.0)));
    assert_no_worse(&mut r, "light behind the camera", &s);
}

#[test]
fn pruned_is_as_accurate_with_casters_outside_the_view() {
    let Some(mut r) = renderer() else { return };
    let mut s = base(point_light(Vec3::new(-1.0, 4.0, 2.0)));
    // The only occluder is above the top of the image; its shadow falls into view.
    s.meshes[1] = quad("occluder out of view", Vec3::new(0.0, 3.2, 1.5), Vec3::X * 0.6, Vec3::Z * 0.6);
    let mut open = s.clone();
    open.meshes.truncate(1);
    let shadowed = sum(&r.render(&s, 64, 64, Method::Vsv).unwrap().scatter);
    let unshadowed = sum(&r.render(&open, 64, 64, Method::Vsv).unwrap().scatter);
    assert!(shadowed < 0.98 * unshadowed, "the out-of-view caster cast no shadow");
    assert_no_worse(&mut r, "casters outside the view", &s);
}

#[test]
fn no_medium_runs_no_voxel_pass() {
    let Some(mut r) = renderer() else { return };
    let mut s = base(point_light(Vec3::new(0.2, 3.0, 0.1)));
    s.medium = Medium { scattering: Vec3::ZERO, absorption: Vec3::splat(0.01), ..Medium::default() };
    let out = r.render(&s, 32, 32, Method::Vsv).unwrap();
    for pass in ["ranges", "cull", "voxelize", "scan", "scatter_table"] {
        assert!(!out.passes.contains(&pass), "{pass} ran without a medium: {:?}", out.passes);
    }
    assert!(out.scatter.pixels.iter().all(|p| *p == [0.0; 3]));
    assert!(out.hdr.pixels.iter().any(|p| p[0] > 0.0), "the surfaces should still be lit");
}

/// Looking toward the light with every caster behind the eye, on the far side from the light:
/// they lie past the last visible ray, cannot shadow anything visible, and are not voxelized.
#[test]
fn casters_past_the_last_visible_ray_are_not_voxelized() {
    let Some(mut r) = renderer() else { return };
    let mut s = base(point_light(Vec3::new(0.0, 1.5, -4.0)));
    s.camera.target = Vec3::new(0.0, 1.5, 0.0);
    s.meshes = vec![
        quad("behind the eye 1", Vec3::new(0.0, 1.5, 9.0), Vec3::X, Vec3::Y),
        quad("behind the eye 2", Vec3::new(0.5, 1.0, 11.0), Vec3::X, Vec3::Y),
    ];
    let out = r.render(&s, 32, 32, Method::Vsv).unwrap();
    let report = r.prune_report(&out.info()).unwrap();
    assert_eq!(report.triangles.kept, 0, "{report:?}");
    assert_eq!(report.triangles.culled_view, 4, "{report:?}");
    let grid = r.read_grid().unwrap();
    assert!(grid.iter().all(|&w| w == 0), "a culled caster left bits in the grid");
}

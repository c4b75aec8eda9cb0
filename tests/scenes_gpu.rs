//! VSV against the exact reference on the built-in scene and on shared third-party scenes.
//!
//! Tolerances: measured error (docs/accuracy.md) times about 2-3. These scenes have many shadow
//! boundaries per view ray (grating bars, box edges, the bunny's silhouette), each resolved to
//! one bin and one plane/ray, so their error sits above the single-occluder tests in gpu.rs.

mod common;

use common::*;
use epivox::params::Grid;
use epivox::render::Method;
use epivox::scene::{builtin_scene, Scene};

fn check(scene: Scene, grid: Grid, size: u32, bound: f64) {
    let Some(mut r) = renderer() else { return };
    let mut scene = scene;
    scene.grid = grid;
    let (_, _, s) = against_reference(&mut r, &scene, Method::Vsv, size, size);
    assert_eq!(s.non_finite, 0);
    assert!(s.rel_rmse < bound, "{}: relative RMSE {:.4} over the bound {bound}", scene.name, s.rel_rmse);
}

#[test]
fn builtin_scene_matches_reference() {
    // Measured 2.1% (12.2% with the cell voxelizer).
    check(builtin_scene(), Grid { planes: 512, rays: 512, bins: 256, ..Grid::default() }, 96, 0.05);
}

/// The error falls as the grid grows: it is discretisation, not a bias.
#[test]
fn builtin_scene_error_falls_with_the_grid() {
    let Some(mut r) = renderer() else { return };
    let mut errors = Vec::new();
    for grid in [
        Grid { planes: 128, rays: 128, bins: 64, ..Grid::default() },
        Grid { planes: 1024, rays: 1024, bins: 512, ..Grid::default() },
    ] {
        let mut scene = builtin_scene();
        scene.grid = grid;
        errors.push(against_reference(&mut r, &scene, Method::Vsv, 64, 64).2.rel_rmse);
    }
    assert!(errors[1] < 0.6 * errors[0], "error did not fall with the grid: {errors:?}");
}

#[test]
fn cornell_box_matches_reference() {
    check(
        shared_scene("cornell_box/CornellBox-Original.gltf"),
        Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() },
        96,
        // Measured 1.3% (3.9% with the cell voxelizer).
        0.03,
    );
}

/// The bunny on a floor, lit from behind and above so that its shadow volume runs toward the eye.
#[test]
fn stanford_bunny_matches_reference() {
    let mut scene = shared_scene("stanford_bunny/bun_zipper.ply");
    let b = scene.bounds();
    let (c, r) = (b.center(), b.radius());
    scene.meshes.push(quad(
        "floor",
        glam::Vec3::new(c.x, b.min.y, c.z),
        glam::Vec3::X * 6.0 * r,
        glam::Vec3::Z * 6.0 * r,
    ));
    scene.light = point_light(c + glam::Vec3::new(0.3, 2.0, -2.5) * r);
    if let epivox::params::Light::Point { intensity, .. } = &mut scene.light {
        *intensity = glam::Vec3::splat(10.0 * r * r);
    }
    scene.medium.scattering = glam::Vec3::splat(0.5 / r);
    scene.medium.absorption = glam::Vec3::splat(0.05 / r);
    scene.medium.density = 1.0;
    // Measured 0.32% (0.76% with the cell voxelizer).
    check(scene, Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() }, 96, 0.01);
}

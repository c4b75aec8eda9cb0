//! Closed meshes around the light: no light ray slips through (DESIGN section 3, "leaks come from
//! cracks"). Boxes (plain and tessellated, with shared edges in both diagonal directions) and UV
//! spheres with the point light inside, several light positions and grids (odd plane counts put
//! the seam at phi = 0 in other places; cosine bins move the samples).
//!
//! What is exact (an exact 0 stays 0):
//! - the grid, at every grid: every sampled light ray (every plane x bin) meets the mesh;
//! - the image, at every grid, for view rays that end on the mesh (the own-shadow layer of
//!   integrate.wgsl), and at the default grid for every pixel.
//!
//! What is not: on a grid coarse for the image, a view ray that passes within a grid cell of the
//! mesh's silhouette can see a sliver of light, because Integrate blends neighbouring samples and
//! those may meet the surface at a later gamma than the pixel's own light ray (no interpolation of
//! point samples is exact there; only conservative cells are, at twice the error everywhere,
//! docs/accuracy.md). That sliver is measured and bounded below.

mod common;

use common::renderer;
use epivox::params::{BinSpacing, Grid};
use epivox::reference::Tracer;
use epivox::render::{Method, Renderer, ShadowVolume};
use epivox::scene::build::{cuboid, haze, point, quad, side_camera, sphere, tessellated_cuboid};
use epivox::scene::{Mesh, Scene};
use glam::Vec3;

fn meshes(c: Vec3) -> Vec<Mesh> {
    vec![
        cuboid("box", c, Vec3::splat(0.5), false),
        tessellated_cuboid("tessellated box", c, Vec3::new(0.6, 0.4, 0.5), 4),
        sphere("sphere 9x13", c, 0.55, 9, 13),
        sphere("sphere 24x40", c, 0.5, 24, 40),
    ]
}

/// The light at the centre, near a face and near a corner.
fn lights(c: Vec3) -> [Vec3; 3] {
    [c + Vec3::new(0.01, 0.02, -0.03), c + Vec3::new(0.05, 0.3, 0.1), c + Vec3::new(-0.3, -0.25, 0.28)]
}

fn scene(mesh: Mesh, light: Vec3, grid: Grid) -> Scene {
    Scene {
        name: mesh.name.clone(),
        source: None,
        meshes: vec![quad("floor", Vec3::ZERO, Vec3::X * 4.0, Vec3::Z * 4.0), mesh],
        camera: side_camera(),
        light: point(light, 10.0),
        medium: haze(),
        grid,
    }
}

fn grid(planes: u32, rays: u32, bins: u32, spacing: BinSpacing) -> Grid {
    Grid { planes, rays, bins, spacing }
}

/// Every plane x bin sample of the geometry grid has a hit somewhere along the rays. Without
/// pruning the planes cover the full circle, the rays gamma in [0, pi] and the bins psi in
/// [0, pi], so every sampled light ray leaves the mesh inside the grid.
#[test]
fn every_sampled_light_ray_meets_a_closed_mesh() {
    let Some(mut r) = renderer() else { return };
    r.prune = false;
    r.set_keep_geometry_grid(true);
    let c = Vec3::new(0.0, 1.2, 0.0);
    let grids = [
        grid(64, 64, 32, BinSpacing::UniformAngle),
        grid(97, 61, 64, BinSpacing::UniformAngle),
        grid(256, 128, 128, BinSpacing::UniformCosine),
        grid(512, 256, 256, BinSpacing::UniformAngle),
    ];
    for mesh in meshes(c) {
        for light in lights(c) {
            for g in grids {
                let s = scene(mesh.clone(), light, g);
                r.render(&s, 32, 32, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
                let bits = r.read_geometry_grid().unwrap_or_else(|e| panic!("{e}"));
                let p = g.planes as usize;
                let mut missed = Vec::new();
                for x in 0..g.planes {
                    for k in 0..g.bins as usize {
                        let hit = (0..g.rays).any(|y| bits[g.ray_offset(x, y) + k / 32] >> (k % 32) & 1 == 1);
                        if !hit {
                            missed.push((x, k));
                        }
                    }
                }
                assert!(
                    missed.is_empty(),
                    "{} around the light at {light}, grid {g}: {} of {} sampled light rays slipped through, e.g. (plane, bin) {:?}",
                    s.name,
                    missed.len(),
                    p * g.bins as usize,
                    &missed[..missed.len().min(5)]
                );
            }
        }
    }
}

/// Renders and returns the scattered light per pixel, with whether the view ray ends on the mesh.
fn scatter_and_hits(r: &mut Renderer, s: &Scene, size: u32) -> Vec<(f32, bool)> {
    let out = r.render(s, size, size, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let tracer = Tracer::new(s);
    let eye = s.camera.eye.as_dvec3();
    out.scatter
        .pixels
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = ((i as u32 % size) as f64, (i as u32 / size) as f64);
            let d = s.camera.pixel_dir_f64(x, y, size, size);
            let on_mesh = tracer.first_hit(eye, d, f64::INFINITY).is_some_and(|h| h.mesh == 1);
            (p[0].max(p[1]).max(p[2]), on_mesh)
        })
        .collect()
}

/// The image at the default grid: exactly 0 everywhere.
#[test]
fn no_light_leaks_into_the_image_at_the_default_grid() {
    let Some(mut r) = renderer() else { return };
    let c = Vec3::new(0.0, 1.2, 0.0);
    let size = 64;
    for mesh in meshes(c) {
        for light in lights(c) {
            let g = Grid::default();
            let s = scene(mesh.clone(), light, g);
            let px = scatter_and_hits(&mut r, &s, size);
            let leaks = px.iter().filter(|(v, _)| *v != 0.0).count();
            let max = px.iter().fold(0.0f32, |a, (v, _)| a.max(*v));
            assert_eq!(leaks, 0, "{} around the light at {light}, grid {g}: {leaks} pixels lit, max {max}", s.name);
        }
    }
}

/// On grids coarse for the image (64 or 128 planes for 96 pixels): view rays that end on the mesh
/// are still exactly 0; the slivers along its silhouette stay below 1% of the same light's
/// unshadowed maximum with the bits (measured: at most 0.51%, the tessellated box with the light
/// 0.1 below a face at 64x64x32; 0 to 0.07% for the plain box and the spheres) and below 2% with
/// the first hits, which have no ray cell to hide a neighbouring plane's hit just past the
/// pixel's angle, only half a plane's slack (integrate.wgsl `HIT_SLACK`; measured: at most 1.26%,
/// the same box at 64x64x32).
#[test]
fn coarse_grids_leak_only_along_silhouettes() {
    let Some(mut r) = renderer() else { return };
    let c = Vec3::new(0.0, 1.2, 0.0);
    let size = 96;
    for (volume, bound) in [(ShadowVolume::Bits, 1e-2), (ShadowVolume::FirstHits, 2e-2)] {
        r.shadow_volume = volume;
        for mesh in meshes(c) {
            let light = lights(c)[1];
            for g in [grid(64, 64, 32, BinSpacing::UniformAngle), grid(128, 96, 64, BinSpacing::UniformCosine)] {
                let s = scene(mesh.clone(), light, g);
                let px = scatter_and_hits(&mut r, &s, size);
                let on_mesh_lit = px.iter().filter(|(v, on)| *on && *v != 0.0).count();
                assert_eq!(on_mesh_lit, 0, "{}, grid {g}: {on_mesh_lit} pixels on the mesh lit", s.name);
                let mut open = s.clone();
                open.meshes.truncate(1);
                let open_max = scatter_and_hits(&mut r, &open, size).iter().fold(0.0f32, |a, (v, _)| a.max(*v));
                let max = px.iter().fold(0.0f32, |a, (v, _)| a.max(*v));
                assert!(
                    max <= bound * open_max,
                    "{}, {volume:?}, grid {g}: silhouette leak {max} (unshadowed max {open_max})",
                    s.name
                );
            }
        }
    }
}

//! Shared helpers of the GPU integration tests.
#![allow(dead_code)]

use epivox::gpu::{GpuContext, GpuError, ShaderLibrary};
use epivox::params::{Grid, Light};
use epivox::reference::{self, ReferenceOptions};
use epivox::render::{Method, Renderer};
use epivox::scene::{Mesh, Scene};
use epivox::{metrics, Image};
use glam::Vec3;

/// A renderer on whatever adapter exists (the software Vulkan driver in CI), or `None` with a
/// message when there is no adapter at all.
pub fn renderer() -> Option<Renderer> {
    match GpuContext::headless() {
        Ok(ctx) => Some(Renderer::new(ctx, &ShaderLibrary::embedded()).unwrap_or_else(|e| panic!("{e}"))),
        Err(GpuError::NoAdapter) => {
            eprintln!("SKIPPED: no GPU adapter at all (install mesa-vulkan-drivers for the software one)");
            None
        }
        Err(e) => panic!("{e}"),
    }
}

/// A shared third-party scene from `../shared/scenes` beside the repository (or
/// `$EPIVOX_SHARED_SCENES`); panics when it is missing.
pub fn shared_scene(rel: &str) -> Scene {
    let root = std::env::var_os("EPIVOX_SHARED_SCENES")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes"));
    epivox::scene::load_scene(&root.join(rel))
        .unwrap_or_else(|e| panic!("the shared scenes must be beside the repository: {e}"))
}

// The scene builders are the library's, shared with the `check` cases.
pub use epivox::scene::build::quad;
use epivox::scene::build::{cuboid, haze, point, side_camera};

/// A closed axis-aligned box (12 triangles).
pub fn cube(name: &str, c: Vec3, h: Vec3) -> Mesh {
    cuboid(name, c, h, false)
}

/// A floor with a square occluder above it, seen from the side.
pub fn occluder_scene(light: Light) -> Scene {
    Scene {
        name: "occluder".into(),
        source: None,
        meshes: vec![
            quad("floor", Vec3::ZERO, Vec3::X * 4.0, Vec3::Z * 4.0),
            quad("occluder", Vec3::new(0.0, 1.5, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5),
        ],
        camera: side_camera(),
        light,
        medium: haze(),
        grid: Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() },
    }
}

/// A sun from above and a little aside.
pub fn sun() -> Light {
    Light::Directional { direction: Vec3::new(0.3, 1.0, 0.2).normalize(), irradiance: Vec3::splat(2.0) }
}

pub fn point_light(p: Vec3) -> Light {
    point(p, 10.0)
}

/// The `check` case light/inside-closed-box: a point light inside a closed box above a floor, so
/// that nothing outside the box may be lit.
pub fn closed_box_scene() -> Scene {
    let mut s = epivox::check::cases::floor_scene("inside-closed-box");
    s.light = point_light(Vec3::new(0.1, 1.1, 0.05));
    s.meshes[1] = cuboid("closed box", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.4, 0.3, 0.4), false);
    s
}

/// Renders with the GPU and the reference and returns (gpu scatter, reference scatter, stats).
pub fn against_reference(
    r: &mut Renderer,
    scene: &Scene,
    method: Method,
    w: u32,
    h: u32,
) -> (Image, Image, metrics::ErrorStats) {
    let out = r.render(scene, w, h, method).unwrap_or_else(|e| panic!("{e}"));
    let reference = reference::render(scene, w, h, &ReferenceOptions { progress: false, ..Default::default() });
    let stats = metrics::compare(&out.scatter, &reference.scatter).unwrap_or_else(|e| panic!("{e}"));
    eprintln!("{} ({method:?}, {w}x{h}, grid {}): scatter {stats}", scene.name, scene.grid);
    dump(&format!("{}_{method:?}_gpu", scene.name), &out.scatter);
    dump(&format!("{}_{method:?}_ref", scene.name), &reference.scatter);
    (out.scatter, reference.scatter, stats)
}

pub fn sum(img: &Image) -> f64 {
    img.pixels.iter().map(|p| p.iter().map(|&c| c as f64).sum::<f64>()).sum()
}

/// The largest magnitude of any channel of any pixel (0 for a black image).
pub fn brightest(img: &Image) -> f32 {
    img.pixels.iter().flat_map(|p| p.iter()).fold(0.0f32, |a, &b| a.max(b.abs()))
}

/// Writes `img` normalised to its maximum as a PNG under `$EPIVOX_TEST_IMAGES`, when that is set.
pub fn dump(name: &str, img: &Image) {
    if let Some(dir) = std::env::var_os("EPIVOX_TEST_IMAGES") {
        let mx = img.pixels.iter().flat_map(|p| p.iter()).fold(1e-12f32, |a, &b| a.max(b));
        let mut scaled = img.clone();
        for p in &mut scaled.pixels {
            *p = p.map(|c| c / mx);
        }
        let _ = scaled.write_png(std::path::Path::new(&dir).join(format!("{name}.png")), 0.0);
    }
}

/// A temporary folder holding a copy of the shaders built into the binary, to edit and load with
/// `ShaderLibrary::new` (the folder goes when the value drops).
pub fn shader_copy() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, src) in epivox::gpu::shaders_embedded() {
        std::fs::write(dir.path().join(name), src).unwrap();
    }
    dir
}

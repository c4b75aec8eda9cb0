//! Shared helpers of the GPU integration tests.
#![allow(dead_code)]

use epivox::gpu::{GpuContext, GpuError, ShaderLibrary};
use epivox::params::{Grid, Light, Medium, Phase};
use epivox::reference::{self, ReferenceOptions};
use epivox::render::{Method, Renderer};
use epivox::scene::{Camera, Mesh, Scene};
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

pub fn quad(name: &str, c: Vec3, u: Vec3, v: Vec3) -> Mesh {
    Mesh {
        name: name.into(),
        positions: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        albedo: Vec3::splat(0.6),
    }
}

/// A closed axis-aligned box (12 triangles).
pub fn cube(name: &str, c: Vec3, h: Vec3) -> Mesh {
    let mut positions = Vec::new();
    for i in 0..8 {
        positions.push(
            c + h * Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            ),
        );
    }
    let faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    let triangles = faces.iter().flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]]).collect();
    Mesh { name: name.into(), positions, triangles, albedo: Vec3::splat(0.5) }
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
        camera: Camera {
            eye: Vec3::new(0.0, 1.5, 6.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y_deg: 50.0,
            near: 0.01,
            far: 100.0,
        },
        light,
        medium: Medium {
            scattering: Vec3::new(0.1, 0.08, 0.06),
            absorption: Vec3::splat(0.02),
            density: 1.0,
            phase: Phase::HenyeyGreenstein { g: 0.3 },
        },
        grid: Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() },
    }
}

pub fn point_light(p: Vec3) -> Light {
    Light::Point { position: p, intensity: Vec3::splat(10.0), radius: 0.0 }
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

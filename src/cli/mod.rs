//! The command line: argument types and the headless commands (render, compare).

mod bench;
mod check;
mod edit;

pub use bench::bench;
pub use check::check;
pub use edit::{edit, EditArgs};

use anyhow::{Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use epivox::gpu::{GpuContext, ShaderLibrary};
use epivox::params::{Exposure, Grid, Light};
use epivox::preset::Preset;
use epivox::render::{Method as GpuMethod, RenderOutput, Renderer};
use epivox::scene::{builtin_scene, load_scene, Scene};
use epivox::{metrics, reference, Image};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Parser)]
#[command(
    name = "epivox",
    version,
    about = "Light shafts and volumetric shadows with Voxelized Epipolar Shadow Volumes"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Subcommand)]
pub enum Command {
    /// Open the editor (what `epivox` with no arguments does).
    Edit(EditArgs),
    /// Render a scene to an image (the built-in scene when SCENE is omitted).
    Render(RenderArgs),
    /// Compare two EXR images: relative RMSE, max absolute error and PSNR of A against B.
    Compare {
        /// The image under test.
        a: PathBuf,
        /// The reference.
        b: PathBuf,
        /// Print one JSON object instead of text.
        #[arg(long)]
        json: bool,
    },
    /// Run the matrix of stiff and extreme cases through every method against the reference;
    /// prints a table and exits non-zero when any case fails (docs/stability.md).
    Check(check::CheckArgs),
    /// Measure error against GPU time for every method and the ray-marching baseline; writes
    /// results.csv, report.md and plots into --out.
    Bench(bench::BenchArgs),
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Debug)]
pub enum Method {
    /// Voxelized Epipolar Shadow Volumes on the GPU.
    Vsv,
    /// The paper's screen-space Cartesian variant (directional light along a screen axis).
    Cartesian,
    /// The baseline: ray marching with one shadow-map lookup per step (--steps, --shadow-map, --jitter).
    Raymarch,
    /// The exact f64 CPU reference.
    Reference,
}

#[derive(clap::Args)]
pub struct RenderArgs {
    /// A mesh (.gltf .glb .obj .ply), a folder of meshes or a Mitsuba scene, or a .toml scene file.
    pub scene: Option<PathBuf>,
    /// Output PNG (tone mapped).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Image size as WIDTHxHEIGHT.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    pub size: (u32, u32),
    #[arg(long, value_enum, default_value_t = Method::Vsv)]
    pub method: Method,
    /// A preset file (medium, grid, exposure).
    #[arg(long)]
    pub preset: Option<PathBuf>,
    /// Grid resolution PLANESxRAYSxBINS (bins a multiple of 32).
    #[arg(long, value_parser = parse_grid)]
    pub grid: Option<Grid>,
    /// Camera position x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Camera target x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<Vec3>,
    /// Vertical field of view in degrees.
    #[arg(long)]
    pub fov: Option<f32>,
    /// Make the light a point light at x,y,z (keeps its intensity when it already is one).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, conflicts_with = "light_dir")]
    pub light_pos: Option<Vec3>,
    /// Make the light directional, pointing toward x,y,z (a direction).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light_dir: Option<Vec3>,
    /// Write the in-scattered radiance alone as float RGB OpenEXR.
    #[arg(long)]
    pub scatter_exr: Option<PathBuf>,
    /// Write the final linear image as float RGB OpenEXR.
    #[arg(long)]
    pub hdr_exr: Option<PathBuf>,
    /// Print GPU time per pass (encoder timestamps).
    #[arg(long)]
    pub timings: bool,
    /// Print one JSON object (timings, grid, adapter, counts) on stdout.
    #[arg(long)]
    pub json: bool,
    /// Exposure in stops for the PNG.
    #[arg(long, allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Turn off fitting the work to the frame (DESIGN section 6): full bin range from the casters.
    #[arg(long)]
    pub no_prune: bool,
    /// Reference: visibility samples per view ray.
    #[arg(long, default_value_t = 512)]
    pub samples: usize,
    /// Raymarch: steps per view ray.
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub steps: u32,
    /// Shadow-map texels per side (the surfaces' shadows, and the raymarch baseline's visibility).
    #[arg(long = "shadow-map", value_parser = clap::value_parser!(u32).range(16..=16384))]
    pub shadow_map: Option<u32>,
    /// Raymarch: offset the steps by a per-pixel random fraction (noise instead of banding).
    #[arg(long)]
    pub jitter: bool,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT, e.g. 512x512"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("'{s}': width is not a whole number"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("'{s}': height is not a whole number"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("'{s}': width and height must lie in 1..=16384"));
    }
    Ok((w, h))
}

fn parse_grid(s: &str) -> Result<Grid, String> {
    Grid::parse(s).map_err(|e| e.to_string())
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not three numbers x,y,z"))?;
    if v.len() != 3 || v.iter().any(|c| !c.is_finite()) {
        return Err(format!("'{s}' is not three finite numbers x,y,z"));
    }
    Ok(Vec3::new(v[0], v[1], v[2]))
}

/// Loads the scene and applies every override from the command line, validating the result.
fn build_scene(args: &RenderArgs) -> Result<(Scene, Option<f32>)> {
    let mut scene = match &args.scene {
        Some(p) => load_scene(p)?,
        None => builtin_scene(),
    };
    let mut exposure = None;
    if let Some(p) = &args.preset {
        let preset = Preset::load(p)?;
        preset.apply(&mut scene);
        exposure = preset.exposure;
    }
    if let Some(g) = args.grid {
        scene.grid = g;
    }
    let bounds = scene.bounds();
    let cam = &mut scene.camera;
    if let Some(e) = args.eye {
        cam.eye = e;
    }
    if let Some(t) = args.target {
        cam.target = t;
    }
    if let Some(f) = args.fov {
        cam.fov_y_deg = f;
    }
    if args.eye.is_some() || args.target.is_some() {
        // Keep the clip range sensible for the new viewpoint.
        let b = bounds;
        let reach = (cam.eye - b.center()).length() + b.radius() * 2.0;
        cam.far = cam.far.max(reach);
    }
    if let Some(p) = args.light_pos {
        scene.light = match scene.light {
            Light::Point { intensity, radius, .. } => Light::Point { position: p, intensity, radius },
            Light::Directional { irradiance, .. } => {
                let d2 = scene.bounds().radius().powi(2).max(1e-6);
                Light::Point { position: p, intensity: irradiance * d2, radius: 0.0 }
            }
        };
    }
    if let Some(d) = args.light_dir {
        let irradiance = match scene.light {
            Light::Directional { irradiance, .. } => irradiance,
            Light::Point { intensity, position, .. } => {
                let dist = (position - scene.bounds().center()).length().max(1e-6);
                intensity / (dist * dist)
            }
        };
        if d.length() < 1e-6 {
            anyhow::bail!("--light-dir {d}: the direction must not be zero");
        }
        scene.light = Light::Directional { direction: d, irradiance }.normalized();
    }
    let where_ = args.scene.as_ref().map(|p| p.display().to_string()).unwrap_or_else(|| "built-in scene".into());
    scene.validate().with_context(|| format!("{where_} with the command-line overrides"))?;
    if let Some(e) = args.exposure {
        Exposure::STOPS.check(e as f64).context("--exposure")?;
        exposure = Some(e);
    }
    Ok((scene, exposure))
}

pub fn render(args: RenderArgs) -> Result<()> {
    let (scene, exposure) = build_scene(&args)?;
    let (w, h) = args.size;
    let exposure = exposure.unwrap_or(0.0);
    let pixels = w as u64 * h as u64;
    let started = Instant::now();

    let mut pruned_z = None;
    let (hdr, scatter, out, adapter): (Image, Image, Option<RenderOutput>, String) = match args.method {
        Method::Reference => {
            let opts =
                reference::ReferenceOptions { samples: args.samples, progress: !args.json, ..Default::default() };
            let r = reference::render(&scene, w, h, &opts);
            (r.hdr, r.scatter, None, "cpu reference (f64)".to_string())
        }
        Method::Vsv | Method::Cartesian | Method::Raymarch => {
            let method = match args.method {
                Method::Cartesian => GpuMethod::Cartesian,
                Method::Raymarch => GpuMethod::Raymarch { steps: args.steps, jitter: args.jitter },
                _ => GpuMethod::Vsv,
            };
            let ctx = GpuContext::headless()?;
            let mut renderer = Renderer::new(ctx, &ShaderLibrary::default())?;
            if let Some(size) = args.shadow_map {
                renderer.set_shadow_map_size(size).context("--shadow-map")?;
            }
            renderer.prune = !args.no_prune;
            let o = renderer.render(&scene, w, h, method)?;
            pruned_z = Some(renderer.prune_report(&o.info())?);
            (o.hdr.clone(), o.scatter.clone(), Some(o), renderer.ctx.adapter_name())
        }
    };
    let wall_ms = started.elapsed().as_secs_f64() * 1e3;
    if hdr.count_non_finite() > 0 || scatter.count_non_finite() > 0 {
        eprintln!("warning: the image has {} non-finite values", hdr.count_non_finite() + scatter.count_non_finite());
    }
    hdr.write_png(&args.out, exposure)?;
    if let Some(p) = &args.scatter_exr {
        scatter.write_exr(p)?;
    }
    if let Some(p) = &args.hdr_exr {
        hdr.write_exr(p)?;
    }

    let timings = out.as_ref().map(|o| o.timings.clone()).unwrap_or_default();
    let total_ms: f64 = timings.iter().map(|t| t.ms).sum();
    if args.json {
        let passes: serde_json::Map<String, serde_json::Value> =
            timings.iter().map(|t| (t.pass.to_string(), serde_json::json!(t.ms))).collect();
        let mut j = serde_json::json!({
            "method": format!("{:?}", args.method).to_lowercase(),
            "scene": scene.name,
            "adapter": adapter,
            "width": w, "height": h, "pixels": pixels,
            "triangles": scene.triangle_count(),
            "grid": scene.grid.to_string(),
            "passes_ms": passes,
            "total_ms": total_ms,
            "wall_ms": wall_ms,
        });
        if let Some(o) = &out {
            let m = &o.setup.mapping;
            j["ranges"] = serde_json::json!({
                "phi0": m.phi0, "phi_span": m.phi_span, "gamma": [m.gamma_lo, m.gamma_hi], "z": [m.z_lo, m.z_hi],
            });
        }
        if let Some(p) = &pruned_z {
            j["pruning"] = serde_json::to_value(p)?;
        }
        if args.method == Method::Raymarch {
            j["steps"] = serde_json::json!(args.steps);
            j["jitter"] = serde_json::json!(args.jitter);
            j["shadow_map"] = serde_json::json!(args.shadow_map.unwrap_or(Renderer::SHADOW_MAP_SIZE));
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        eprintln!(
            "{} {}x{} ({} triangles, grid {}) -> {} in {:.0} ms wall",
            scene.name,
            w,
            h,
            scene.triangle_count(),
            scene.grid,
            args.out.display(),
            wall_ms
        );
        if args.timings {
            if timings.is_empty() {
                println!(
                    "no GPU timings: {}",
                    if out.is_some() {
                        "the adapter has no encoder timestamps"
                    } else {
                        "the reference runs on the CPU"
                    }
                );
            } else {
                println!("GPU time per pass on {adapter}:");
                for t in &timings {
                    println!("  {:<14} {:>9.3} ms", t.pass, t.ms);
                }
                println!("  {:<14} {:>9.3} ms", "total", total_ms);
            }
            if let Some(p) = &pruned_z {
                println!(
                    "work kept{}: planes over {:.1} of 360 deg, rays gamma {:.1}..{:.1} deg, bins z {:.4}..{:.4} (casters {:.4}..{:.4}), \
                     {} words/ray, triangles {} of {} (dropped: {} outside the view, {} beyond the visible depth), passes: {}, \
                     shaders specialised to a {}",
                    if p.enabled { "" } else { " (--no-prune)" },
                    p.planes_span_deg,
                    p.rays_gamma_deg[0],
                    p.rays_gamma_deg[1],
                    p.bins_z[0],
                    p.bins_z[1],
                    p.bins_z_casters[0],
                    p.bins_z_casters[1],
                    p.words_per_ray,
                    p.triangles.kept,
                    p.triangles_total,
                    p.triangles.culled_view,
                    p.triangles.culled_depth,
                    p.passes.join(" > "),
                    p.variant
                );
            }
        }
    }
    Ok(())
}

pub fn compare(a: &Path, b: &Path, json: bool) -> Result<()> {
    let ia = Image::read_exr(a)?;
    let ib = Image::read_exr(b)?;
    let stats =
        metrics::compare(&ia, &ib).with_context(|| format!("comparing {} against {}", a.display(), b.display()))?;
    if json {
        println!("{}", serde_json::to_string_pretty(&stats.to_json())?);
    } else {
        println!("{} vs {}: {stats}", a.display(), b.display());
    }
    Ok(())
}

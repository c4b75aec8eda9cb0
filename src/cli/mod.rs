//! The command line: argument types and the headless commands (render, compare).

mod ab;
mod bench;
mod check;
mod edit;
mod outputs;

pub use ab::ab;
pub use bench::bench;
pub use check::check;
pub use edit::{edit, EditArgs};

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand, ValueEnum};
use epivox::epipolar::{EpipolarFrame, LightGeom};
use epivox::gpu::{GpuContext, ShaderLibrary};
use epivox::params::{
    unit_direction, Baseline, Exposure, Grid, ImageSize, Light, Measure, ReferenceQuality, Spec, View,
};
use epivox::preset::Preset;
use epivox::render::{Method as GpuMethod, RenderOutput, Renderer};
use epivox::scene::{builtin_scene, load_scene_with_summary, LoadSummary, Scene};
use epivox::{metrics, reference, Image};
use glam::Vec3;
use outputs::{Output, What};
use std::borrow::Cow;
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
        /// Also write a PNG of the reference, the image and their difference side by side (one
        /// brightness scale for all three; the difference amplified by --gain).
        #[arg(long, value_name = "PNG")]
        diff: Option<PathBuf>,
        /// How much the difference panel of --diff is amplified.
        #[arg(long, default_value_t = 4.0, value_parser = gain_in_range)]
        gain: f32,
    },
    /// Run the matrix of stiff and extreme cases through every method against the reference;
    /// prints a table and exits non-zero when any case fails (docs/stability.md).
    Check(check::CheckArgs),
    /// Measure error against GPU time for every method and the ray-marching baseline; writes
    /// results.csv, report.md and plots into --out.
    Bench(bench::BenchArgs),
    /// Time an edited shader folder (--b) or other renderer settings (--b-*) against the current
    /// ones (--a) on one scene: per-pass GPU medians of whole frames over interleaved rounds, and
    /// whether the images differ.
    Ab(ab::AbArgs),
}

/// How Scan ORs each column of the grid (`Renderer::scan_columns`).
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Debug)]
pub enum ScanBy {
    /// A thread per column (scan.wgsl, scan_words.wgsl): the CPU adapters' default.
    Threads,
    /// A workgroup per plane, its columns' rays split into runs (scan_columns.wgsl): the hardware
    /// GPUs' default.
    Columns,
}

/// Where a VSV frame's surface shadows come from: the library's list.
pub use epivox::render::{ShadowVolume, SurfaceShadows};

/// Which pixels VSV's Integrate integrates (`Renderer::adaptive_pixels`).
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Debug)]
pub enum Pixels {
    /// Every other pixel along the epipolar lines, then the others only where their two
    /// neighbours on the line do not stand for them (integrate.wgsl, "pixels from their
    /// neighbours"): the default.
    Adaptive,
    /// Every pixel.
    All,
}

/// Whether Surface draws the eye's list (`Renderer::surface_culling`).
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum, Debug)]
pub enum EyeList {
    /// The triangles that can draw something, compacted by a compute pass first (surface_cull.wgsl):
    /// the default.
    On,
    /// Every triangle, as the scene holds them.
    Off,
}

/// How the GPU frame's passes run, for `render` and `bench` alike (the renderer's own defaults
/// where a flag is left out).
#[derive(clap::Args)]
pub struct PassChoices {
    /// How Scan ORs the grid's columns (the same image either way) [default: columns on a hardware
    /// GPU, threads on a CPU adapter: `Renderer::scan_columns`].
    #[arg(long, value_enum)]
    pub scan: Option<ScanBy>,
    /// Where VSV's surface shadows come from [default: exact; under a point light the map]. The
    /// raymarch baseline's always come from the shadow map.
    #[arg(long, value_enum)]
    pub surface_shadows: Option<SurfaceShadows>,
    /// How VSV keeps its shadow volume [default: first-hits]: `first-hits` keeps each light ray's
    /// first hit and compares it with the pixel's own angle (no ray cells); `bits`, the paper's
    /// voxels, which the Cartesian grid and grid surface shadows always keep.
    #[arg(long, value_enum)]
    pub volume: Option<ShadowVolume>,
    /// Which pixels VSV integrates [default: adaptive]: `all` integrates every pixel, `adaptive`
    /// every fourth one along the epipolar lines and then those their neighbours cannot stand for.
    #[arg(long, value_enum)]
    pub pixels: Option<Pixels>,
    /// Whether Surface draws only the triangles that can draw something, found by a compute pass
    /// first [default: on]. The images are the same either way.
    #[arg(long, value_enum)]
    pub eye_list: Option<EyeList>,
}

impl PassChoices {
    /// Sets the renderer's choices that were given; keeps its defaults for the others.
    pub fn apply(&self, renderer: &mut Renderer) {
        if let Some(by) = self.scan {
            renderer.scan_columns = by == ScanBy::Columns;
        }
        if let Some(from) = self.surface_shadows {
            renderer.surface_shadows = from;
        }
        if let Some(volume) = self.volume {
            renderer.shadow_volume = volume;
        }
        if let Some(pixels) = self.pixels {
            renderer.adaptive_pixels = pixels == Pixels::Adaptive;
        }
        if let Some(list) = self.eye_list {
            renderer.surface_culling = list == EyeList::On;
        }
    }
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
    #[arg(long, value_name = "TRIANGLES", conflicts_with = "scene",
          value_parser = |s: &str| parse_count::<usize>(&Measure::ROOM, s),
          help = spec_help("Render the bench's procedural room instead of SCENE, at the paper's grid unless --grid", &Measure::ROOM))]
    pub room: Option<usize>,
    /// Output image: .png (tone mapped, 8-bit sRGB) or .exr (the linear image, float RGB).
    #[arg(long, short)]
    pub out: PathBuf,
    #[arg(long, default_value = "512x512", value_parser = parse_size, help = size_help())]
    pub size: (u32, u32),
    #[arg(long, value_enum, default_value_t = Method::Vsv)]
    pub method: Method,
    /// A preset file (medium, grid, exposure).
    #[arg(long)]
    pub preset: Option<PathBuf>,
    #[arg(long, value_parser = parse_grid, help = grid_help())]
    pub grid: Option<Grid>,
    /// Camera position x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// Camera target x,y,z.
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub target: Option<Vec3>,
    #[arg(long, value_parser = parse_fov, help = spec_help("Vertical field of view", &View::FOV_Y))]
    pub fov: Option<f32>,
    /// Make the light a point light at x,y,z (keeps its intensity when it already is one).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, conflicts_with = "light_dir")]
    pub light_pos: Option<Vec3>,
    /// Make the light directional, pointing toward x,y,z (a direction: not zero).
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub light_dir: Option<Vec3>,
    /// Also write the in-scattered radiance alone as float RGB OpenEXR (.exr).
    #[arg(long)]
    pub scatter_exr: Option<PathBuf>,
    /// Also write the final linear image as float RGB OpenEXR (.exr).
    #[arg(long)]
    pub hdr_exr: Option<PathBuf>,
    /// Also write where each view ray ends (distance from the eye; inf for the sky) as OpenEXR
    /// (.exr): the rasterizer's surfaces for the GPU methods, the first hits for the reference.
    #[arg(long)]
    pub depth_exr: Option<PathBuf>,
    /// Reference: end each view ray's scattered light at the distances in this OpenEXR (one that
    /// --depth-exr of a GPU render wrote, same size) instead of at its own first hit: the exact
    /// scattered light along the same view segments, to tell a method's volumetric error from
    /// primary visibility (a rasterizer decides coverage on its sub-pixel grid).
    #[arg(long, value_name = "EXR")]
    pub view_ends: Option<PathBuf>,
    /// Print GPU time per pass (encoder timestamps).
    #[arg(long)]
    pub timings: bool,
    /// Print one JSON object (timings, grid, adapter, counts) on stdout.
    #[arg(long)]
    pub json: bool,
    #[arg(long, allow_hyphen_values = true, value_parser = parse_exposure,
          help = spec_help("Exposure for the PNG", &Exposure::STOPS))]
    pub exposure: Option<f32>,
    /// Turn off fitting the work to the frame (DESIGN section 6, docs/pruning.md): the full circle of planes, every ray
    /// cell of every plane and the casters' whole bin range, and every triangle voxelized but a solid's faces turned
    /// away from the light.
    #[arg(long)]
    pub no_prune: bool,
    /// Spread a sun's shadow map over the casters' whole rectangle instead of narrowing it to what
    /// the view looks up (to compare: the surfaces' shadows and the march's then come from coarser
    /// texels).
    #[arg(long)]
    pub no_shadow_fit: bool,
    #[command(flatten)]
    pub passes: PassChoices,
    #[arg(long, value_parser = parse_samples, help = samples_help())]
    pub samples: Option<usize>,
    #[arg(long, value_parser = parse_steps,
          help = spec_default_help("Raymarch: steps per view ray", &Baseline::STEPS, Baseline::default().steps))]
    pub steps: Option<u32>,
    #[arg(long = "shadow-map", value_parser = parse_shadow_map,
          help = spec_default_help(
              "Shadow-map texels per side of a square (the surfaces' shadows, and the raymarch baseline's visibility; VSV's sun map holds as many, shaped to its rectangle)",
              &Baseline::SHADOW_MAP,
              Baseline::default().shadow_map,
          ))]
    pub shadow_map: Option<u32>,
    /// Raymarch: offset the steps by a per-pixel random fraction (noise instead of banding).
    #[arg(long)]
    pub jitter: bool,
}

// Every numeric flag takes its range from a `Spec` in `params.rs`, and its help text shows it.

fn range_text(spec: &Spec) -> String {
    let unit = if spec.unit.is_empty() { String::new() } else { format!(" {}", spec.unit) };
    format!("[range: {}..={}{unit}]", spec.min, spec.max)
}

pub(crate) fn spec_help(what: &str, spec: &Spec) -> String {
    format!("{what} {}", range_text(spec))
}

pub(crate) fn spec_default_help(what: &str, spec: &Spec, default: impl std::fmt::Display) -> String {
    format!("{what} {} [default: {default}]", range_text(spec))
}

pub(crate) fn size_help() -> String {
    format!("Image size as WIDTHxHEIGHT, each side {}", range_text(&ImageSize::SIDE))
}

pub(crate) fn grid_help() -> String {
    format!(
        "Grid resolution PLANESxRAYSxBINS: planes {}, rays {}, bins {} and a multiple of 32",
        range_text(&Grid::PLANES),
        range_text(&Grid::RAYS),
        range_text(&Grid::BINS)
    )
}

pub(crate) fn samples_help() -> String {
    spec_default_help(
        "Reference: visibility samples per view ray",
        &ReferenceQuality::SAMPLES,
        reference::ReferenceOptions::default().samples,
    )
}

/// A whole number within `spec`.
pub(crate) fn parse_count<T: TryFrom<u64>>(spec: &Spec, s: &str) -> Result<T, String> {
    let v: u64 = s.trim().parse().map_err(|_| format!("'{s}' is not a whole number {}", range_text(spec)))?;
    spec.check(v as f64).map_err(|e| e.to_string())?;
    T::try_from(v).map_err(|_| format!("{} = {v} is too large", spec.name))
}

/// A finite number within `spec`.
fn parse_number(spec: &Spec, s: &str) -> Result<f32, String> {
    let v: f32 = s.trim().parse().map_err(|_| format!("'{s}' is not a number {}", range_text(spec)))?;
    spec.check(v as f64).map_err(|e| e.to_string())?;
    Ok(v)
}

pub(crate) fn parse_samples(s: &str) -> Result<usize, String> {
    parse_count(&ReferenceQuality::SAMPLES, s)
}

fn parse_steps(s: &str) -> Result<u32, String> {
    parse_count(&Baseline::STEPS, s)
}

fn parse_shadow_map(s: &str) -> Result<u32, String> {
    parse_count(&Baseline::SHADOW_MAP, s)
}

fn parse_fov(s: &str) -> Result<f32, String> {
    parse_number(&View::FOV_Y, s).map_err(|e| format!("the vertical field of view: {e}"))
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    parse_number(&Exposure::STOPS, s)
}

pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT, e.g. 512x512"))?;
    let side = |v: &str, what: &str| parse_count::<u32>(&ImageSize::SIDE, v).map_err(|e| format!("{what}: {e}"));
    Ok((side(w, "width")?, side(h, "height")?))
}

pub(crate) fn parse_grid(s: &str) -> Result<Grid, String> {
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

/// Sets up logging for every command: `warn` and above to stderr unless `RUST_LOG` says otherwise,
/// one line per message, control characters escaped.
pub fn init_logging() {
    use std::io::Write;
    let env = env_logger::Env::default().default_filter_or("warn");
    let _ = env_logger::Builder::from_env(env)
        .format(|buf, record| {
            let level = match record.level() {
                log::Level::Error => "error",
                log::Level::Warn => "warning",
                log::Level::Info => "info",
                log::Level::Debug => "debug",
                log::Level::Trace => "trace",
            };
            let text = record.args().to_string();
            let text = escape_controls(&text);
            let target = record.target();
            if target.starts_with("epivox") {
                writeln!(buf, "{level}: {text}")
            } else {
                writeln!(buf, "{level} ({target}): {text}")
            }
        })
        .try_init();
}

/// `text` with every control character but the line break written as an escape (`\u{1b}`), so
/// that names from files and flags cannot move the cursor, recolour or retitle the terminal.
pub fn escape_controls(text: &str) -> Cow<'_, str> {
    if !text.chars().any(|c| c.is_control() && c != '\n') {
        return Cow::Borrowed(text);
    }
    Cow::Owned(
        text.chars()
            .map(|c| if c.is_control() && c != '\n' { c.escape_default().to_string() } else { c.to_string() })
            .collect(),
    )
}

/// An error with its causes, each said once: a cause whose text the message already holds (a
/// library error that prints its source and also returns it from `source()`) is left out.
pub fn error_message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if text.is_empty() || out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    escape_controls(&out).into_owned()
}

/// The scene as the command line asks for it, and what it was made from.
struct Built {
    scene: Scene,
    exposure: Option<f32>,
    /// The scene file for messages ("built-in scene" without one).
    source: String,
    summary: LoadSummary,
    /// Every file read: outputs must not be written over them.
    inputs: Vec<PathBuf>,
}

/// The bench's procedural room of at least `triangles` triangles at the paper's grid, as the
/// bench's triangle sweep renders it (`render --room`, `ab --room`).
pub(crate) fn procedural_room(triangles: usize) -> Scene {
    let mut room = epivox::bench::procedural_scene(triangles);
    room.grid = epivox::bench::PAPER_GRID;
    room
}

/// Loads the scene and applies every override from the command line, validating the result.
fn build_scene(args: &RenderArgs) -> Result<Built> {
    let (mut scene, summary) = match (&args.scene, args.room) {
        (Some(p), _) => load_scene_with_summary(p)?,
        (None, Some(n)) => (procedural_room(n), LoadSummary::default()),
        (None, None) => (builtin_scene(), LoadSummary::default()),
    };
    let mut inputs = summary.files.clone();
    inputs.extend(args.scene.clone());
    let mut exposure = None;
    if let Some(p) = &args.preset {
        let preset = Preset::load(p)?;
        preset.apply(&mut scene);
        exposure = preset.exposure;
        inputs.push(p.clone());
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
        let direction = unit_direction("--light-dir direction", d)?;
        scene.light = Light::Directional { direction, irradiance };
    }
    let source = match (&args.scene, args.room) {
        (Some(p), _) => p.display().to_string(),
        (None, Some(_)) => scene.name.clone(),
        (None, None) => "built-in scene".into(),
    };
    let overrides = args.eye.is_some()
        || args.target.is_some()
        || args.fov.is_some()
        || args.light_pos.is_some()
        || args.light_dir.is_some()
        || args.grid.is_some()
        || args.preset.is_some();
    let with = if overrides { " with the command-line overrides" } else { "" };
    scene.validate().with_context(|| format!("{source}{with}"))?;
    // Every method needs epipolar planes; say so before a GPU or the reference starts.
    if EpipolarFrame::new(scene.camera.eye.as_dvec3(), LightGeom::from(&scene.light)).is_none() {
        bail!("{source}{with}: the eye sits exactly on the point light; move one of them");
    }
    if let Some(e) = args.exposure {
        exposure = Some(e);
    }
    Ok(Built { scene, exposure, source, summary, inputs })
}

pub fn render(args: RenderArgs) -> Result<()> {
    let Built { scene, exposure, source, summary, inputs } = build_scene(&args)?;
    // Checked before the (possibly long) render: formats, folders, clashes with inputs and each other.
    let mut wanted = vec![Output::new("--out", &args.out, What::Final)];
    wanted.extend(args.scatter_exr.as_ref().map(|p| Output::new("--scatter-exr", p, What::Scatter)));
    wanted.extend(args.hdr_exr.as_ref().map(|p| Output::new("--hdr-exr", p, What::Hdr)));
    wanted.extend(args.depth_exr.as_ref().map(|p| Output::new("--depth-exr", p, What::Depth)));
    let mut inputs = inputs;
    inputs.extend(args.view_ends.clone());
    let outputs = outputs::plan(wanted, &inputs)?;
    let (w, h) = args.size;
    let view_ends = match &args.view_ends {
        Some(_) if args.method != Method::Reference => {
            bail!("--view-ends: only the reference (--method reference) takes its view rays' ends from a file")
        }
        Some(p) => Some(read_view_ends(p, w, h)?),
        None => None,
    };
    let exposure = exposure.unwrap_or(0.0);
    let steps = args.steps.unwrap_or(Baseline::default().steps);
    let pixels = w as u64 * h as u64;
    let started = Instant::now();

    let mut pruned_z = None;
    // Whether VSV's Integrate took the adaptive path (`--pixels`), for the JSON.
    let mut adaptive_pixels = None;
    let mut segments_differing = None;
    // Where the view rays end, when something will be written from it.
    let depth: Option<Vec<f32>>;
    let (hdr, scatter, out, adapter): (Image, Image, Option<RenderOutput>, String) = match args.method {
        Method::Reference => {
            let mut opts = reference::ReferenceOptions { progress: !args.json, ..Default::default() };
            if let Some(n) = args.samples {
                opts.samples = n;
            }
            let ends = match &view_ends {
                Some(e) => reference::ViewEnds::Given(e),
                None => reference::ViewEnds::OwnHits,
            };
            let r = reference::render_ending(&scene, w, h, &opts, ends);
            if view_ends.is_some() {
                segments_differing = Some(r.segments_differing);
            }
            depth = Some(r.depth);
            (r.hdr, r.scatter, None, "cpu reference (f64)".to_string())
        }
        Method::Vsv | Method::Cartesian | Method::Raymarch => {
            let method = match args.method {
                Method::Cartesian => GpuMethod::Cartesian,
                Method::Raymarch => GpuMethod::Raymarch { steps, jitter: args.jitter },
                _ => GpuMethod::Vsv,
            };
            let ctx = GpuContext::headless()?;
            let mut renderer = Renderer::new(ctx, &ShaderLibrary::default())?;
            if let Some(size) = args.shadow_map {
                renderer.set_shadow_map_size(size).context("--shadow-map")?;
            }
            renderer.prune = !args.no_prune;
            renderer.fit_shadow_map = !args.no_shadow_fit;
            args.passes.apply(&mut renderer);
            let o = renderer.render(&scene, w, h, method).with_context(|| source.clone())?;
            // (Only VSV's and the Cartesian grid's Integrate takes it.)
            adaptive_pixels = matches!(method, GpuMethod::Vsv | GpuMethod::Cartesian).then_some(o.adaptive_pixels);
            pruned_z = Some(renderer.prune_report(&o.info())?);
            depth = args.depth_exr.is_some().then(|| renderer.read_view_distances()).transpose()?;
            (o.hdr.clone(), o.scatter.clone(), Some(o), renderer.ctx.adapter_name())
        }
    };
    let wall_ms = started.elapsed().as_secs_f64() * 1e3;
    if hdr.count_non_finite() > 0 || scatter.count_non_finite() > 0 {
        log::warn!("the image has {} non-finite values", hdr.count_non_finite() + scatter.count_non_finite());
    }
    let depth = depth.map(|d| Image::from_pixels(w, h, d.iter().map(|&t| [t; 3]).collect())).transpose()?;
    outputs::write_all(&outputs, &outputs::Rendered { hdr: &hdr, scatter: &scatter, depth: depth.as_ref() }, exposure)?;

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
            "degenerate_triangles_dropped": summary.degenerate_triangles,
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
            let from = match (o.setup.grid_shadowed(), o.setup.exact_shadowed()) {
                (true, _) => "grid",
                (false, true) => "exact",
                (false, false) => "map",
            };
            j["surface_shadows"] = serde_json::json!(from);
            let volume = if o.setup.first_hits() { ShadowVolume::FirstHits } else { ShadowVolume::Bits };
            j["volume"] = serde_json::json!(volume.label());
            if let Some(adaptive) = adaptive_pixels {
                j["integrated_pixels"] = serde_json::json!(if adaptive { "adaptive" } else { "all" });
            }
        }
        if let Some(p) = &pruned_z {
            j["pruning"] = serde_json::to_value(p)?;
        }
        if let Some(n) = segments_differing {
            j["view_ends_differing"] = serde_json::json!(n);
        }
        if args.method == Method::Raymarch {
            j["steps"] = serde_json::json!(steps);
            j["jitter"] = serde_json::json!(args.jitter);
            j["shadow_map"] =
                serde_json::json!(args.shadow_map.unwrap_or(epivox::params::Baseline::default().shadow_map));
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        let dropped = match summary.degenerate_triangles {
            0 => String::new(),
            n => format!(", {n} zero-area dropped"),
        };
        let line = format!(
            "{} {}x{} ({} triangles{dropped}, grid {}) -> {} in {:.0} ms wall",
            scene.name,
            w,
            h,
            scene.triangle_count(),
            scene.grid,
            args.out.display(),
            wall_ms
        );
        eprintln!("{}", escape_controls(&line));
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
                     {} words/ray, {:.1}% of the plane x ray cells (those the pixels read), triangles {} of {} (dropped: {} outside the view, {} beyond the visible depth, {} solids' faces away from the light, \
                     {} hidden from the light), passes: {}, \
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
                    p.plane_ray_cells * 100.0,
                    p.triangles.kept,
                    p.triangles_total,
                    p.triangles.culled_view,
                    p.triangles.culled_depth,
                    p.triangles.culled_back,
                    p.triangles.culled_hidden,
                    p.passes.iter().map(|p| p.label()).collect::<Vec<_>>().join(" > "),
                    p.variant
                );
            }
        }
    }
    Ok(())
}

/// `--view-ends`: one distance per pixel from the red channel of a `w x h` OpenEXR, each finite and
/// at least 0 or `+inf` (the sky).
fn read_view_ends(path: &Path, w: u32, h: u32) -> Result<Vec<f32>> {
    let img = Image::read_exr(path).with_context(|| format!("--view-ends {}", path.display()))?;
    if (img.width, img.height) != (w, h) {
        bail!(
            "--view-ends {}: the file is {}x{}, the render {w}x{h}; write it with --depth-exr at the same --size",
            path.display(),
            img.width,
            img.height
        );
    }
    let ends: Vec<f32> = img.pixels.iter().map(|p| p[0]).collect();
    if let Some(i) = ends.iter().position(|d| d.is_nan() || *d < 0.0) {
        bail!(
            "--view-ends {}: pixel ({}, {}) holds {}, not a distance (0 or more, inf for the sky)",
            path.display(),
            i % w as usize,
            i / w as usize,
            ends[i]
        );
    }
    Ok(ends)
}

/// `--gain`: 1 to 1000.
fn gain_in_range(s: &str) -> Result<f32, String> {
    let g: f32 = s.trim().parse().map_err(|_| format!("'{s}' is not a number"))?;
    if !(1.0..=1000.0).contains(&g) {
        return Err(format!("{g} is out of range [1, 1000]"));
    }
    Ok(g)
}

/// The fractions of the pixels `compare` reports the worst of ([`metrics::worst_pixels_share`]).
const WORST_FRACTIONS: [f64; 3] = [0.001, 0.01, 0.1];

/// `0.1%`, `1%`, `10%`.
fn percent(f: f64) -> String {
    format!("{}%", f * 100.0)
}

pub fn compare(a: &Path, b: &Path, json: bool, diff: Option<&Path>, gain: f32) -> Result<()> {
    if let Some(d) = diff {
        if d.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()) != Some("png".into()) {
            anyhow::bail!("--diff {}: the picture is a PNG; name it .png", d.display());
        }
        outputs::check_not_input("--diff", d, &[a.to_path_buf(), b.to_path_buf()])?;
    }
    let ia = Image::read_exr(a)?;
    let ib = Image::read_exr(b)?;
    let stats =
        metrics::compare(&ia, &ib).with_context(|| format!("comparing {} against {}", a.display(), b.display()))?;
    if let Some(d) = diff {
        let (w, h, rgb) = metrics::comparison_picture(&ia, &ib, gain)?;
        let mut png = Vec::new();
        image::ImageEncoder::write_image(
            image::codecs::png::PngEncoder::new(&mut png),
            &rgb,
            w,
            h,
            image::ExtendedColorType::Rgb8,
        )
        .with_context(|| format!("encoding --diff {}", d.display()))?;
        epivox::fsx::write_bytes_atomic(d, &png).with_context(|| format!("writing --diff {}", d.display()))?;
    }
    // Where the error lies: in a few pixels (edges) or all over (WORST_FRACTIONS).
    let worst = metrics::worst_pixels_share(&ia, &ib, &WORST_FRACTIONS)?;
    if json {
        let mut j = stats.to_json();
        if let Some(w) = &worst {
            let shares: serde_json::Map<_, _> =
                WORST_FRACTIONS.iter().zip(w).map(|(f, s)| (percent(*f), serde_json::Value::from(*s))).collect();
            j["worst_pixels_share"] = shares.into();
        }
        println!("{}", serde_json::to_string_pretty(&j)?);
    } else {
        let mut line = format!("{} vs {}: {stats}", a.display(), b.display());
        if let Some(w) = &worst {
            let fractions: Vec<String> = WORST_FRACTIONS.iter().map(|f| percent(*f)).collect();
            let shares: Vec<String> = w.iter().map(|s| format!("{:.0}%", s * 100.0)).collect();
            line += &format!(
                " | the worst {} of the pixels hold {} of the squared error",
                fractions.join(" / "),
                shares.join(" / ")
            );
        }
        println!("{}", escape_controls(&line));
    }
    Ok(())
}

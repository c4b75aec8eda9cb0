//! `epivox ab`: the command-line side of [`epivox::bench::ab`].

use anyhow::{bail, Context, Result};
use epivox::bench::ab::{self, AbImages, AbOptions, AbResult, RoundSummary};
use epivox::gpu::{GpuContext, ShaderLibrary};
use epivox::params::{Baseline, Grid, Measure};
use epivox::render::{Method as GpuMethod, Renderer};
use epivox::scene::{builtin_scene, load_scene};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct AbArgs {
    /// A mesh, a folder of meshes, a Mitsuba scene or a .toml scene file (the built-in scene when
    /// omitted).
    pub scene: Option<PathBuf>,
    #[arg(long, value_name = "TRIANGLES", conflicts_with = "scene",
          value_parser = |s: &str| super::parse_count::<usize>(&Measure::ROOM, s),
          help = super::spec_help("Time the bench's procedural room instead of SCENE, at the paper's grid unless --grid", &Measure::ROOM))]
    pub room: Option<usize>,
    /// The shader folder under test (a copy of shaders/ with an edit) [default: A's folder, to time
    /// a B that differs only by the --b-* settings, or to see the machine's noise].
    #[arg(long, value_name = "DIR")]
    pub b: Option<PathBuf>,
    /// The shader folder to compare it with [default: $EPIVOX_SHADER_DIR, ./shaders, or the
    /// shaders built into the binary].
    #[arg(long, value_name = "DIR")]
    pub a: Option<PathBuf>,
    #[arg(long, default_value = "512x512", value_parser = super::parse_size, help = super::size_help())]
    pub size: (u32, u32),
    /// The GPU method whose frames are timed.
    #[arg(long, value_enum, default_value_t = AbMethod::Vsv)]
    pub method: AbMethod,
    #[arg(long, value_parser = super::parse_grid, help = super::grid_help())]
    pub grid: Option<Grid>,
    #[arg(long, default_value_t = 5, value_parser = |s: &str| super::parse_count::<u32>(&Measure::FRAMES, s),
          help = super::spec_help("Frames timed per side and round", &Measure::FRAMES))]
    pub frames: u32,
    #[arg(long, default_value_t = 1, value_parser = |s: &str| super::parse_count::<u32>(&Measure::WARMUP, s),
          help = super::spec_help("Frames each side renders before the first round", &Measure::WARMUP))]
    pub warmup: u32,
    #[arg(long, default_value_t = 4, value_parser = |s: &str| super::parse_count::<u32>(&Measure::ROUNDS, s),
          help = super::spec_help(
              "Rounds, each timing both sides, in alternating order (a drift of the machine's speed \
               then falls on both)",
              &Measure::ROUNDS,
          ))]
    pub rounds: u32,
    #[command(flatten)]
    pub passes: super::PassChoices,
    #[command(flatten)]
    pub b_side: BSettings,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// What the B side's renderer does differently from A's besides its shaders: the same choices as
/// `--scan`, `--surface-shadows`, `--pixels` and `--eye-list` (which set both sides), for B alone,
/// the Voxelize work list's runs, the shadow map's size and the sun map's shape. A change to the
/// renderer's settings is then timed against the current ones in one process, like a shader edit
/// (two binaries in alternating processes mislead on a shared machine: docs/results.md,
/// session 35).
#[derive(clap::Args)]
pub struct BSettings {
    /// B's --scan.
    #[arg(id = "b_scan", long = "b-scan", value_enum, value_name = "SCAN")]
    pub scan: Option<super::ScanBy>,
    /// B's --surface-shadows.
    #[arg(id = "b_surface_shadows", long = "b-surface-shadows", value_enum, value_name = "FROM")]
    pub surface_shadows: Option<super::SurfaceShadows>,
    /// B's --volume.
    #[arg(id = "b_volume", long = "b-volume", value_enum, value_name = "VOLUME")]
    pub volume: Option<super::ShadowVolume>,
    /// B's --grid: B renders at this grid, A at the scene's (or --grid).
    #[arg(id = "b_grid", long = "b-grid", value_name = "GRID", value_parser = super::parse_grid)]
    pub grid: Option<Grid>,
    /// B's --pixels.
    #[arg(id = "b_pixels", long = "b-pixels", value_enum, value_name = "PIXELS")]
    pub pixels: Option<super::Pixels>,
    /// B's --eye-list.
    #[arg(id = "b_eye_list", long = "b-eye-list", value_enum, value_name = "LIST")]
    pub eye_list: Option<super::EyeList>,
    #[arg(id = "b_voxelize_run", long = "b-voxelize-run", value_name = "ITEMS",
          value_parser = |s: &str| super::parse_count::<u32>(&Measure::VOXELIZE_RUN, s),
          help = super::spec_help("B's Voxelize work items a thread (and Cull's triangles a thread)", &Measure::VOXELIZE_RUN))]
    pub voxelize_run: Option<u32>,
    #[arg(id = "b_shadow_map", long = "b-shadow-map", value_name = "TEXELS",
          value_parser = |s: &str| super::parse_count::<u32>(&Baseline::SHADOW_MAP, s),
          help = super::spec_help(
              "B's shadow-map texels per side (the surfaces' shadows; with --method raymarch the march's visibility too)",
              &Baseline::SHADOW_MAP,
          ))]
    pub shadow_map: Option<u32>,
    /// B draws VSV's sun map as the budget's square instead of shaped to its rectangle
    /// (`Renderer::shape_shadow_map` off).
    #[arg(id = "b_square_map", long = "b-square-map")]
    pub square_map: bool,
    /// B clears the whole grid before Voxelize instead of only the cells its passes write
    /// (`Renderer::clear_kept_cells` off; it is on for CPU adapters).
    #[arg(id = "b_whole_grid_clear", long = "b-whole-grid-clear")]
    pub whole_grid_clear: bool,
}

impl BSettings {
    /// Sets B's renderer apart from A's, after the choices both sides share.
    fn apply(&self, renderer: &mut Renderer) -> Result<()> {
        let choices = super::PassChoices {
            scan: self.scan,
            surface_shadows: self.surface_shadows,
            volume: self.volume,
            pixels: self.pixels,
            eye_list: self.eye_list,
        };
        choices.apply(renderer);
        if let Some(run) = self.voxelize_run {
            renderer.set_voxelize_work(run, renderer.voxelize_work().1);
        }
        if let Some(size) = self.shadow_map {
            renderer.set_shadow_map_size(size).context("--b-shadow-map")?;
        }
        if self.square_map {
            renderer.shape_shadow_map = false;
        }
        if self.whole_grid_clear {
            renderer.clear_kept_cells = false;
        }
        Ok(())
    }

    /// The settings given, as the flags that set them (empty when B differs by its shaders alone).
    fn describe(&self) -> Vec<String> {
        fn name(v: &impl clap::ValueEnum) -> String {
            v.to_possible_value().map(|p| p.get_name().to_string()).unwrap_or_default()
        }
        let mut flags = Vec::new();
        if let Some(v) = &self.scan {
            flags.push(format!("--b-scan {}", name(v)));
        }
        if let Some(v) = &self.surface_shadows {
            flags.push(format!("--b-surface-shadows {}", name(v)));
        }
        if let Some(v) = &self.volume {
            flags.push(format!("--b-volume {}", name(v)));
        }
        if let Some(g) = &self.grid {
            flags.push(format!("--b-grid {g}"));
        }
        if let Some(v) = &self.pixels {
            flags.push(format!("--b-pixels {}", name(v)));
        }
        if let Some(v) = &self.eye_list {
            flags.push(format!("--b-eye-list {}", name(v)));
        }
        if let Some(run) = self.voxelize_run {
            flags.push(format!("--b-voxelize-run {run}"));
        }
        if let Some(size) = self.shadow_map {
            flags.push(format!("--b-shadow-map {size}"));
        }
        if self.square_map {
            flags.push("--b-square-map".into());
        }
        if self.whole_grid_clear {
            flags.push("--b-whole-grid-clear".into());
        }
        flags
    }
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum, Debug)]
pub enum AbMethod {
    /// Voxelized Epipolar Shadow Volumes.
    Vsv,
    /// The paper's screen-space Cartesian variant.
    Cartesian,
    /// The ray-marching baseline at its default steps and shadow map.
    Raymarch,
}

pub fn ab(args: AbArgs) -> Result<()> {
    let mut scene = match (&args.scene, args.room) {
        (Some(p), _) => load_scene(p)?,
        (None, Some(n)) => super::procedural_room(n),
        (None, None) => builtin_scene(),
    };
    if let Some(g) = args.grid {
        scene.grid = g;
    }
    for dir in args.a.iter().chain(args.b.iter()) {
        if !dir.is_dir() {
            bail!("{}: not a folder of shaders", dir.display());
        }
    }
    let ctx = GpuContext::headless()?;
    // Both renderers on one device: the same adapter, queue and memory for both sides.
    let side = |dir: Option<&Path>, which: &str| -> Result<Renderer> {
        let lib = ShaderLibrary::new(dir.map(Path::to_path_buf));
        let mut r = Renderer::new(ctx.clone(), &lib).with_context(|| format!("the shaders of {which}"))?;
        args.passes.apply(&mut r);
        Ok(r)
    };
    let mut a = side(args.a.as_deref(), "A")?;
    let mut b = side(args.b.as_deref().or(args.a.as_deref()), "B")?;
    args.b_side.apply(&mut b)?;
    let method = match args.method {
        AbMethod::Vsv => GpuMethod::Vsv,
        AbMethod::Cartesian => GpuMethod::Cartesian,
        AbMethod::Raymarch => {
            let steps = epivox::params::Baseline::default().steps;
            GpuMethod::Raymarch { steps, jitter: false }
        }
    };
    let (w, h) = args.size;
    let opts = AbOptions {
        width: w,
        height: h,
        method,
        warmup: args.warmup as usize,
        frames: args.frames as usize,
        rounds: args.rounds as usize,
        progress: !args.json,
        b_grid: args.b_side.grid,
    };
    let (a_dir, mut b_dir) = (shader_folder(&a), shader_folder(&b));
    let settings = args.b_side.describe();
    if !settings.is_empty() {
        b_dir = format!("{b_dir} with {}", settings.join(" "));
    }
    if !args.json {
        eprintln!(
            "ab: {} at {w}x{h} ({}, grid {}) on {}, {} rounds of {} frames a side",
            scene.name,
            format!("{:?}", args.method).to_lowercase(),
            scene.grid,
            ctx.adapter_name(),
            opts.rounds,
            opts.frames
        );
    }
    let r = ab::run(&mut a, &mut b, &scene, &opts).context("timing A against B")?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&to_json(&r, &scene.name, &a_dir, &b_dir, &ctx.adapter_name()))?);
    } else {
        print_table(&r, &a_dir, &b_dir);
    }
    Ok(())
}

/// Where a renderer's shaders come from, in words.
fn shader_folder(r: &Renderer) -> String {
    match r.shader_dir() {
        Some(d) => d.display().to_string(),
        None => "the shaders built into the binary".into(),
    }
}

fn print_table(r: &AbResult, a_dir: &str, b_dir: &str) {
    println!("A: {a_dir}");
    println!("B: {b_dir}");
    println!("{:<14} {:>10} {:>10} {:>7}  B/A by round", "pass (ms)", "A", "B", "B/A");
    let mut passes: Vec<_> = r.a.timing.passes.iter().map(|(p, _)| *p).collect();
    passes.extend(r.b.timing.passes.iter().map(|(p, _)| *p).filter(|p| !r.a.timing.passes.iter().any(|(q, _)| q == p)));
    let of = |side: &[(epivox::render::Pass, f64)], p| side.iter().find(|(q, _)| *q == p).map(|(_, ms)| *ms);
    let cell = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |ms| format!("{ms:.2}"));
    for p in passes {
        let (x, y) = (of(&r.a.timing.passes, p), of(&r.b.timing.passes, p));
        let ratio = x.zip(y).filter(|(x, _)| *x > 0.0).map_or_else(|| "-".into(), |(x, y)| format!("{:.3}", y / x));
        let rounds = by_round(&r.round_ratios(Some(p)));
        println!("{:<14} {:>10} {:>10} {:>7}  {rounds}", p.to_string(), cell(x), cell(y), ratio);
    }
    println!(
        "{:<14} {:>10.2} {:>10.2} {:>7.3}  {}",
        "total",
        r.a.timing.total_ms,
        r.b.timing.total_ms,
        r.b.timing.total_ms / r.a.timing.total_ms.max(f64::MIN_POSITIVE),
        by_round(&r.round_ratios(None))
    );
    println!(
        "{:<14} {:>10.2} {:>10.2} {:>7.3}",
        "wall",
        r.a.wall_ms,
        r.b.wall_ms,
        r.b.wall_ms / r.a.wall_ms.max(f64::MIN_POSITIVE)
    );
    let rounds: Vec<String> =
        r.a.timing.round_ms.iter().zip(&r.b.timing.round_ms).map(|(a, b)| format!("{a:.1} / {b:.1}")).collect();
    println!("by round (A / B total ms): {}", rounds.join(", "));
    if r.a.timing.passes.is_empty() && r.b.timing.passes.is_empty() {
        println!("(no GPU timestamps on this adapter: only the wall-clock times are measured)");
    }
    println!("scattered light: {}", describe(&r.scatter));
    println!("final image: {}", describe(&r.hdr));
}

/// B/A's range over the rounds, in how many B was faster and the sign test's p-value:
/// "0.912-0.957, faster in 4 of 4, p 0.125" (under ~0.05 a difference that held round after
/// round; 4 rounds can never show one).
fn by_round(ratios: &[f64]) -> String {
    let Some(s) = RoundSummary::of(ratios) else { return "-".into() };
    let mut text = format!("{:.3}-{:.3}, faster in {} of {}", s.min, s.max, s.faster, s.rounds);
    if s.faster + s.slower < s.rounds {
        text.push_str(&format!(" ({} equal)", s.rounds - s.faster - s.slower));
    }
    text.push_str(&format!(", p {:.3}", s.sign_test_p()));
    text
}

fn describe(images: &AbImages) -> String {
    match images {
        AbImages::Same => "the same bits".into(),
        AbImages::Differ(Some(e)) => {
            format!("B differs from A: rel RMSE {:.4}%, max abs {:.2e}", 100.0 * e.rel_rmse, e.max_abs)
        }
        AbImages::Differ(None) => "B differs from A (A holds non-finite values: no error against it)".into(),
    }
}

fn to_json(r: &AbResult, scene: &str, a_dir: &str, b_dir: &str, adapter: &str) -> serde_json::Value {
    let side = |s: &ab::AbSide, dir: &str| {
        let passes: serde_json::Map<String, serde_json::Value> =
            s.timing.passes.iter().map(|(p, ms)| (p.to_string(), serde_json::json!(ms))).collect();
        serde_json::json!({
            "shaders": dir,
            "passes_ms": passes,
            "total_ms": s.timing.total_ms,
            "wall_ms": s.wall_ms,
            "round_ms": s.timing.round_ms,
        })
    };
    let images = |i: &AbImages| match i {
        AbImages::Same => serde_json::json!({ "same": true }),
        AbImages::Differ(e) => serde_json::json!({ "same": false, "error": e.map(|e| e.to_json()) }),
    };
    // B over A in each round alone, per pass and for the total.
    let mut by_round: serde_json::Map<String, serde_json::Value> =
        r.a.timing.passes.iter().map(|(p, _)| (p.to_string(), serde_json::json!(r.round_ratios(Some(*p))))).collect();
    by_round.insert("total".into(), serde_json::json!(r.round_ratios(None)));
    let total = RoundSummary::of(&r.round_ratios(None));
    serde_json::json!({
        "adapter": adapter,
        "scene": scene,
        "a": side(&r.a, a_dir),
        "b": side(&r.b, b_dir),
        "b_over_a_by_round": by_round,
        // The sign test over the rounds' totals (null without rounds).
        "total_sign_test_p": total.map(|s| s.sign_test_p()),
        "scatter": images(&r.scatter),
        "final": images(&r.hdr),
    })
}

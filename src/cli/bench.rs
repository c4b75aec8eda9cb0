//! `epivox bench`: the command-line side of [`epivox::bench`].

use anyhow::{Context, Result};
use epivox::bench::{self, BenchOptions, CacheStatus};
use epivox::gpu::{GpuContext, ShaderLibrary};
use epivox::params::{Grid, Measure};
use epivox::render::Renderer;
use epivox::scene::{builtin_scene, load_scene_with_summary};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// A mesh, a folder of meshes, a Mitsuba scene or a .toml scene file (the built-in scene when
    /// omitted).
    pub scene: Option<PathBuf>,
    /// Folder for results.csv, report.md and the plots (created when missing).
    #[arg(long, short)]
    pub out: PathBuf,
    #[arg(long, value_parser = super::parse_size,
          help = format!("{} [default: 1024x1024, 64x64 with --quick]", super::size_help()))]
    pub size: Option<(u32, u32)>,
    /// Tiny sweeps (two or three points per method, small scaling sweeps): for CI and smoke tests.
    #[arg(long)]
    pub quick: bool,
    #[arg(long, value_parser = |s: &str| super::parse_count::<u32>(&Measure::FRAMES, s),
          help = super::spec_help(
              "Frames measured per point; the report gives their median [default: 5, 3 with --quick]",
              &Measure::FRAMES,
          ))]
    pub frames: Option<u32>,
    #[arg(long, value_parser = |s: &str| super::parse_count::<u32>(&Measure::WARMUP, s),
          help = super::spec_help("Frames rendered before measuring (pipeline compilation, caches) [default: 1]",
                                  &Measure::WARMUP))]
    pub warmup: Option<u32>,
    #[arg(long, value_parser = |s: &str| super::parse_count::<u32>(&Measure::ROUNDS, s),
          help = super::spec_help(
              "Times the error sweep is timed, interleaved: a slow phase of a shared machine then \
               falls on every point alike [default: 1]",
              &Measure::ROUNDS,
          ))]
    pub rounds: Option<u32>,
    /// Where reference images are cached [default: OUT/cache].
    #[arg(long)]
    pub cache_dir: Option<PathBuf>,
    /// Skip the time-against-triangles and time-against-resolution sweeps.
    #[arg(long)]
    pub no_scaling: bool,
    #[command(flatten)]
    pub passes: super::PassChoices,
    #[arg(long, value_parser = super::parse_samples, help = super::samples_help())]
    pub samples: Option<usize>,
    #[arg(long = "grid", value_name = "GRID", value_parser = super::parse_grid, help = format!(
        "Another VSV grid to measure, after the sweep's own (repeat for more; one the adapter \
         cannot hold is noted and skipped). {}", super::grid_help()))]
    pub grids: Vec<Grid>,
}

pub fn bench(args: BenchArgs) -> Result<()> {
    let (scene, summary) = match &args.scene {
        Some(p) => load_scene_with_summary(p)?,
        None => (builtin_scene(), Default::default()),
    };
    // The folder receives results.csv, report.md, plots and the cache: never over an input.
    if args.out.is_file() {
        anyhow::bail!("--out {}: is a file; bench writes a folder of results", args.out.display());
    }
    let mut inputs = summary.files;
    inputs.extend(args.scene.clone());
    super::outputs::check_not_input("--out", &args.out, &inputs)?;
    let mut opts = BenchOptions::new(&args.out, args.quick);
    if let Some((w, h)) = args.size {
        opts.width = w;
        opts.height = h;
    }
    if let Some(f) = args.frames {
        opts.frames = f as usize;
    }
    if let Some(w) = args.warmup {
        opts.warmup = w as usize;
    }
    if let Some(r) = args.rounds {
        opts.rounds = r as usize;
    }
    if let Some(c) = &args.cache_dir {
        opts.cache_dir = c.clone();
    }
    opts.scaling = !args.no_scaling;
    opts.extra_grids = args.grids.clone();
    opts.progress = true;
    if let Some(n) = args.samples {
        opts.reference.samples = n;
    }

    let ctx = GpuContext::headless()?;
    let mut renderer = Renderer::new(ctx, &ShaderLibrary::default())?;
    args.passes.apply(&mut renderer);
    eprintln!(
        "benchmarking {} ({} triangles) at {}x{} on {}",
        scene.name,
        scene.triangle_count(),
        opts.width,
        opts.height,
        renderer.ctx.adapter_name()
    );
    let r =
        bench::run(&mut renderer, &scene, &opts).with_context(|| format!("benchmark into {}", args.out.display()))?;

    println!(
        "{:<10} {:<24} {:>11} {:>11}  the cheapest raymarch point as accurate, time over this one's",
        "method", "setting", "total ms", "rel RMSE"
    );
    for row in &r.rows {
        let against = match row.point.method_name() {
            "raymarch" => String::new(),
            _ => bench::baseline_ratio(&r.rows, row).describe(),
        };
        println!(
            "{:<10} {:<24} {:>11.3} {:>10.3}%  {against}",
            row.point.method_name(),
            row.point.setting(),
            row.timing.total_ms,
            row.scatter.rel_rmse * 100.0
        );
    }
    for p in &bench::scaling_points_of(&r.triangle_rows) {
        if let Some(g) = bench::triangle_growth(&r.triangle_rows, p) {
            println!("time against triangles, {} {}: {}", p.method_name(), p.setting(), g.describe());
        }
    }
    for e in &r.edit_rows {
        println!(
            "a medium edit, {} {}: {:.1} ms against {:.1} ms for a whole frame (wall clock)",
            e.point.method_name(),
            e.point.setting(),
            e.edit_ms,
            e.whole_ms
        );
    }
    for n in &r.notes {
        println!("note: {n}");
    }
    let reference = match r.reference_status {
        CacheStatus::Hit => "from the cache".to_string(),
        CacheStatus::Rendered { seconds } => format!("rendered in {seconds:.1} s"),
    };
    println!("reference {reference} ({})", r.reference_path.display());
    println!("wrote, in {:.0} s:", r.seconds);
    for f in &r.files {
        println!("  {}", f.display());
    }
    Ok(())
}

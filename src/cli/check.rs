//! `epivox check`: runs the matrix of stiff and extreme cases (`epivox::check`), prints the table
//! (or JSON) and fails when any case fails.

use anyhow::{bail, Context, Result};
use epivox::check::{self, CheckOptions};
use epivox::gpu::{GpuContext, ShaderLibrary};
use epivox::render::Renderer;
use std::io::Write;

#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// Only the quick subset (the one the test command runs).
    #[arg(long)]
    pub quick: bool,
    /// Print one JSON object on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Only the cases whose name contains this text, e.g. `medium/` or `thick`.
    #[arg(long)]
    pub only: Option<String>,
    /// Just list the selected cases with what they test and why their bounds are what they are.
    #[arg(long)]
    pub list: bool,
    /// Write each compared pair of images to this folder as text (x y reference rgb, method rgb).
    #[arg(long)]
    pub dump: Option<std::path::PathBuf>,
    /// Run every case at this grid PLANESxRAYSxBINS instead of its own (a diagnostic: the bounds
    /// were measured at the cases' own grids).
    #[arg(long, value_parser = |s: &str| epivox::params::Grid::parse(s).map_err(|e| e.to_string()))]
    pub grid: Option<epivox::params::Grid>,
    /// How VSV keeps its shadow volume in every case [default: the renderer's]
    /// (`Renderer::shadow_volume`).
    #[arg(long, value_enum)]
    pub volume: Option<epivox::render::ShadowVolume>,
}

pub fn check(args: CheckArgs) -> Result<()> {
    let ctx = GpuContext::headless().context("epivox check needs a GPU adapter (the software one will do)")?;
    let limits = ctx.device.limits();
    let opts = CheckOptions {
        quick: args.quick,
        filter: args.only.clone(),
        dump: args.dump.clone(),
        grid: args.grid,
        ..CheckOptions::default()
    };
    let cases = check::select(&limits, &opts)?;
    if args.list {
        for c in &cases {
            let runs: Vec<String> = c.runs.iter().map(|(m, e)| format!("{} {}", m.label(), e.describe())).collect();
            println!(
                "{}{}\n    {}\n    bound: {}\n    runs: {}",
                c.name,
                if c.quick { " (quick)" } else { "" },
                c.about,
                c.reason,
                runs.join(", ")
            );
        }
        return Ok(());
    }
    let mut renderer = Renderer::new(ctx, &ShaderLibrary::default())?;
    if let Some(volume) = args.volume {
        renderer.shadow_volume = volume;
    }
    let json = args.json;
    let total: usize = cases.iter().map(|c| c.runs.len()).sum();
    let mut done = 0usize;
    let report = check::run(Some(&mut renderer), &cases, &opts, |r| {
        done += 1;
        if !json {
            // Progress on stderr; the table goes to stdout at the end.
            eprint!("\r[{done}/{total}] {:<40} {:<14} {}", r.case, r.method, if r.pass { "pass" } else { "FAIL" });
            let _ = std::io::stderr().flush();
        }
    })?;
    if !json {
        eprintln!();
        print!("{}", report.table());
    } else {
        println!("{}", serde_json::to_string_pretty(&report.to_json())?);
    }
    let failed: Vec<String> = report.failures().map(|r| format!("{} ({})", r.case, r.method)).collect();
    if !failed.is_empty() {
        bail!("{} of {} runs failed: {}", failed.len(), report.results.len(), failed.join(", "));
    }
    Ok(())
}

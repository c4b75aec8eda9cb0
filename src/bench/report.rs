//! The benchmark's files: results.csv, the scaling CSVs, the three plots and report.md.

use super::plot::{self, Plot, Series, COLORS};
use super::{pareto_front, time_at_error, BenchError, BenchResults, CacheStatus, Row, ScalingRow, PAPER_GRID};
use crate::render::Pass;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

fn write(path: &Path, text: &str) -> Result<(), BenchError> {
    crate::fsx::write_bytes_atomic(path, text.as_bytes()).map_err(|source| BenchError::Io {
        op: "write",
        path: path.to_path_buf(),
        source,
    })
}

fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn num(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else if v.is_nan() {
        "nan".into()
    } else if v > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

/// The passes any of `timings` ran, in frame order.
fn pass_columns<'a>(timings: impl Iterator<Item = &'a super::Timing>) -> Vec<Pass> {
    let mut cols: Vec<Pass> = Vec::new();
    for t in timings {
        for (p, _) in &t.passes {
            if !cols.contains(p) {
                cols.push(*p);
            }
        }
    }
    cols.sort();
    cols
}

fn pass_ms(t: &super::Timing, pass: Pass) -> String {
    t.passes.iter().find(|p| p.0 == pass).map(|p| num(p.1)).unwrap_or_default()
}

/// `results.csv`: method, setting, total_ms, rel_rmse, max_abs, psnr, one `<pass>_ms` column per
/// pass (empty where the method has no such pass), then volume_ms (the method's own passes),
/// hdr_rel_rmse (the final image's error), frames, width, height.
pub fn results_csv(r: &BenchResults) -> String {
    let cols = pass_columns(r.rows.iter().map(|x| &x.timing));
    let mut s = String::from("method,setting,total_ms,rel_rmse,max_abs,psnr");
    for c in &cols {
        let _ = write!(s, ",{c}_ms");
    }
    s.push_str(",volume_ms,hdr_rel_rmse,frames,width,height\n");
    for row in &r.rows {
        let _ = write!(
            s,
            "{},{},{},{},{},{}",
            row.point.method_name(),
            csv_field(&row.point.setting()),
            num(row.timing.total_ms),
            num(row.scatter.rel_rmse),
            num(row.scatter.max_abs),
            num(row.scatter.psnr)
        );
        for c in &cols {
            let _ = write!(s, ",{}", pass_ms(&row.timing, *c));
        }
        let _ = writeln!(
            s,
            ",{},{},{},{},{}",
            num(row.timing.volume_ms),
            num(row.hdr.rel_rmse),
            row.timing.frames,
            r.width,
            r.height
        );
    }
    s
}

fn scaling_csv(rows: &[ScalingRow]) -> String {
    let cols = pass_columns(rows.iter().map(|x| &x.timing));
    let mut s = String::from("method,setting,triangles,width,height,total_ms");
    for c in &cols {
        let _ = write!(s, ",{c}_ms");
    }
    s.push_str(",volume_ms,frames\n");
    for row in rows {
        let _ = write!(
            s,
            "{},{},{},{},{},{}",
            row.point.method_name(),
            csv_field(&row.point.setting()),
            row.triangles,
            row.width,
            row.height,
            num(row.timing.total_ms)
        );
        for c in &cols {
            let _ = write!(s, ",{}", pass_ms(&row.timing, *c));
        }
        let _ = writeln!(s, ",{},{}", num(row.timing.volume_ms), row.timing.frames);
    }
    s
}

/// Methods in the order they first appear.
fn methods(rows: &[Row]) -> Vec<&'static str> {
    let mut m = Vec::new();
    for r in rows {
        if !m.contains(&r.point.method_name()) {
            m.push(r.point.method_name());
        }
    }
    m
}

/// (total_ms, rel_rmse) of one method's rows, and their Pareto front.
fn curve(rows: &[Row], method: &str) -> (Vec<(f64, f64)>, Vec<bool>) {
    let pts: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.point.method_name() == method)
        .map(|r| (r.timing.total_ms, r.scatter.rel_rmse))
        .collect();
    let front = pareto_front(&pts);
    (pts, front)
}

fn front_points(rows: &[Row], method: &str) -> Vec<(f64, f64)> {
    let (pts, front) = curve(rows, method);
    pts.into_iter().zip(front).filter(|(_, f)| *f).map(|(p, _)| p).collect()
}

fn scaling_series(rows: &[ScalingRow], x: impl Fn(&ScalingRow) -> f64) -> Vec<Series> {
    let mut names: Vec<String> = Vec::new();
    for r in rows {
        let n = format!("{} {}", r.point.method_name(), r.point.setting());
        if !names.contains(&n) {
            names.push(n);
        }
    }
    names
        .iter()
        .enumerate()
        .map(|(i, n)| Series {
            name: n.clone(),
            color: COLORS[i % COLORS.len()],
            points: rows
                .iter()
                .filter(|r| &format!("{} {}", r.point.method_name(), r.point.setting()) == n)
                .map(|r| (x(r), r.timing.total_ms))
                .collect(),
            front: None,
        })
        .collect()
}

/// Writes every file; returns their paths.
pub fn write_all(r: &BenchResults, dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let [csv, md, err_png, tri_png, res_png] = super::output_files(dir);
    let mut files = Vec::new();
    write(&csv, &results_csv(r))?;
    files.push(csv);
    if !r.triangle_rows.is_empty() {
        let p = dir.join("scaling_triangles.csv");
        write(&p, &scaling_csv(&r.triangle_rows))?;
        files.push(p);
    }
    if !r.resolution_rows.is_empty() {
        let p = dir.join("scaling_resolution.csv");
        write(&p, &scaling_csv(&r.resolution_rows))?;
        files.push(p);
    }
    // The tables before the plots: a plot that cannot be drawn must not cost the numbers.
    write_markdown(r, dir)?;
    files.push(md);

    let series = methods(&r.rows)
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let (points, front) = curve(&r.rows, m);
            Series { name: m.to_string(), color: COLORS[i % COLORS.len()], points, front: Some(front) }
        })
        .collect();
    let title = format!("{}: error against time, {}x{}", r.scene, r.width, r.height);
    plot::draw(
        &Plot { title: &title, x_desc: "GPU time per frame (ms)", y_desc: "relative RMSE of scattered light", series },
        &err_png,
        900,
        640,
    )?;
    files.push(err_png);
    // The scaling plots only when their sweeps ran (not with --no-scaling): no empty charts.
    if !r.triangle_rows.is_empty() {
        let title = format!("time against triangles (procedural rooms, {}x{})", r.width, r.height);
        plot::draw(
            &Plot {
                title: &title,
                x_desc: "triangles",
                y_desc: "GPU time per frame (ms)",
                series: scaling_series(&r.triangle_rows, |x| x.triangles as f64),
            },
            &tri_png,
            900,
            640,
        )?;
        files.push(tri_png);
    }
    if !r.resolution_rows.is_empty() {
        let title = format!("{}: time against resolution", r.scene);
        plot::draw(
            &Plot {
                title: &title,
                x_desc: "pixels per side (square images)",
                y_desc: "GPU time per frame (ms)",
                series: scaling_series(&r.resolution_rows, |x| x.width as f64),
            },
            &res_png,
            900,
            640,
        )?;
        files.push(res_png);
    }
    Ok(files)
}

/// The machine: CPU model and counts from /proc/cpuinfo, the threads this process may use, memory.
pub fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        info.lines()
            .find(|l| l.split(':').next().is_some_and(|k| k.trim() == name))
            .and_then(|l| l.split_once(':'))
            .map(|(_, v)| v.trim().to_string())
    };
    let logical = info.lines().filter(|l| l.split(':').next().is_some_and(|k| k.trim() == "processor")).count();
    let usable = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0);
    let mem = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|m| m.lines().find(|l| l.starts_with("MemTotal:")).map(|l| l.to_string()))
        .and_then(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()))
        .map(|kb| format!(", {:.0} GiB memory", kb / 1024.0 / 1024.0))
        .unwrap_or_default();
    let model = field("model name").unwrap_or_else(|| "unknown CPU (no /proc/cpuinfo)".into());
    let cores = field("cpu cores").map(|c| format!(", {c} cores per socket")).unwrap_or_default();
    // Other work on the machine slows a software rasterizer down: say how busy it was.
    let load = std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|l| {
            format!(
                "; load average {} (1, 5, 15 min) when the report was written",
                l.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
            )
        })
        .unwrap_or_default();
    format!("{model}: {logical} logical CPUs in /proc/cpuinfo{cores}, {usable} usable by this process{mem}{load}")
}

/// Days since 1970-01-01 to a civil date (Howard Hinnant's algorithm).
fn date_utc(secs: u64) -> String {
    let z = (secs / 86400) as i64 + 719468;
    let era = z.div_euclid(146097);
    let doe = z - era * 146097;
    let yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + if m <= 2 { 1 } else { 0 };
    let s = secs % 86400;
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02} UTC", s / 3600, (s / 60) % 60)
}

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:.3} %", v * 100.0)
    } else {
        num(v)
    }
}

fn ms(v: f64) -> String {
    if !v.is_finite() {
        num(v)
    } else if v >= 100.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.2}")
    } else {
        format!("{v:.3}")
    }
}

/// report.md.
pub fn write_markdown(r: &BenchResults, dir: &Path) -> Result<(), BenchError> {
    write(&dir.join("report.md"), &markdown(r))
}

pub fn markdown(r: &BenchResults) -> String {
    let mut s = String::new();
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0);
    let _ = writeln!(s, "# Benchmark: {}\n", r.scene);
    let _ = writeln!(s, "| | |\n|---|---|");
    let _ = writeln!(s, "| date | {} |", date_utc(now));
    let _ = writeln!(s, "| adapter | {} |", r.adapter);
    let _ = writeln!(s, "| machine | {} |", machine());
    let _ = writeln!(s, "| scene | {} ({} triangles) |", r.scene, r.triangles);
    let _ = writeln!(s, "| light | {} |", r.light);
    let _ = writeln!(s, "| medium | {} |", r.medium);
    let _ = writeln!(s, "| image | {}x{} |", r.width, r.height);
    let rounds = match r.rounds {
        1 => String::new(),
        n => format!(", pooled over {n} interleaved rounds of the error sweep"),
    };
    let _ = writeln!(
        s,
        "| timing | {}; per point the median of the measured frames after warm-up{rounds} |",
        r.timing_source
    );
    let reference = match r.reference_status {
        CacheStatus::Hit => "read from the cache".to_string(),
        CacheStatus::Rendered { seconds } => format!("rendered in {seconds:.1} s and cached"),
    };
    let _ = writeln!(s, "| reference | {reference}: `{}` (key {}) |", r.reference_path.display(), r.reference_key);
    if r.seconds > 0.0 {
        let _ = writeln!(s, "| benchmark run time | {:.0} s |", r.seconds);
    }
    let _ = writeln!(
        s,
        "\nErrors are of the in-scattered radiance against the f64 reference (relative RMSE = RMSE over the \
         mean reference value; PSNR with the brightest reference value as peak); `final` is the relative \
         RMSE of the whole image. `volume` is the method's own passes (VSV and Cartesian: every pass but the \
         four below; raymarch: raymarch); `total` adds the surface, the sun's shadow-map fit, the shadow map \
         and composite passes every method runs (VSV with `--surface-shadows grid` draws no map: the notes \
         say which). ● marks a point on its method's Pareto front.\n"
    );

    let _ = writeln!(s, "## Error against time\n\n![error against time](error_vs_time.png)\n");
    let _ = writeln!(
        s,
        "Scattered light of the reference and of each method's most accurate point, at one exposure: \
         `scatter_reference.png`{}.\n",
        methods(&r.rows).iter().map(|m| format!(", `scatter_{m}.png`")).collect::<String>()
    );
    let _ = writeln!(
        s,
        "| method | setting | total ms | volume ms | rel RMSE | max abs | PSNR dB | final rel RMSE | front |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|:-:|");
    for m in methods(&r.rows) {
        let (_, front) = curve(&r.rows, m);
        for (row, f) in r.rows.iter().filter(|x| x.point.method_name() == m).zip(front) {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {:.2e} | {:.1} | {} | {} |",
                m,
                row.point.setting(),
                ms(row.timing.total_ms),
                ms(row.timing.volume_ms),
                pct(row.scatter.rel_rmse),
                row.scatter.max_abs,
                row.scatter.psnr,
                pct(row.hdr.rel_rmse),
                if f { "●" } else { "" }
            );
        }
    }

    // Every grid point against the cheapest raymarch point that is at least as accurate.
    if methods(&r.rows).contains(&"raymarch") {
        let _ = writeln!(
            s,
            "\n### Against the cheapest as-accurate baseline point\n\nFor every grid point: the cheapest raymarch point of \
             the sweep whose scattered light is at least as accurate, and its frame time over the grid point's (the \
             speed-up at equal or better error). \"none\": no raymarch point of the sweep is that accurate; the \
             ratio is then the sweep's most accurate raymarch point's time over the grid point's (the cheapest of \
             those within 1% of its best error; ≥: a lower bound, the baseline would need more than its whole sweep). \"By round\": the smallest and the largest ratio of \
             each round's medians alone, with several rounds: how far a slow phase of the machine moved it.\n"
        );
        let _ = writeln!(
            s,
            "| method | setting | rel RMSE | ms | cheapest as-accurate raymarch | its ms | ratio | by round |"
        );
        let _ = writeln!(s, "|---|---|---:|---:|---|---:|---:|---:|");
        for row in r.rows.iter().filter(|x| x.point.method_name() != "raymarch") {
            let b = super::baseline_ratio(&r.rows, row);
            let (setting, t, ratio) = match (&b.baseline, b.ratio, &b.most_accurate) {
                (Some((setting, t)), Some(x), _) => (setting.clone(), ms(*t), format!("{x:.2}x")),
                (_, _, Some((setting, t, err, x))) => {
                    (format!("none (most accurate: {setting}, {})", pct(*err)), ms(*t), format!("≥ {x:.2}x"))
                }
                _ => ("none".into(), "—".into(), "—".into()),
            };
            let by_round = match b.round_range() {
                Some((lo, hi)) => format!("{lo:.2}x – {hi:.2}x"),
                None => "—".into(),
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {setting} | {t} | {ratio} | {by_round} |",
                row.point.method_name(),
                row.point.setting(),
                pct(row.scatter.rel_rmse),
                ms(row.timing.total_ms)
            );
        }
    }

    // What the editor waits for while an artist tunes the medium.
    if !r.edit_rows.is_empty() {
        let _ = writeln!(
            s,
            "\n### A medium edit\n\nWall-clock medians of a frame (submitted and waited for, without reading the \
             images back) at VSV's default grid and at the baseline point its ratio is taken against: a whole \
             frame, and a frame in which only the medium's density changed, which takes the shadow map, the \
             surfaces and the shadow volume from the frame before (`Renderer::reuse_unchanged`; the sweeps \
             above time whole frames).\n"
        );
        let _ = writeln!(s, "| method | setting | whole frame ms | medium edit ms |");
        let _ = writeln!(s, "|---|---|---:|---:|");
        for e in &r.edit_rows {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} |",
                e.point.method_name(),
                e.point.setting(),
                ms(e.whole_ms),
                ms(e.edit_ms)
            );
        }
    }

    // Equal error: for each VSV front point, the baseline's time at the same error.
    let ms_of = methods(&r.rows);
    if ms_of.contains(&"raymarch") {
        let base = front_points(&r.rows, "raymarch");
        for m in ms_of.iter().filter(|m| **m != "raymarch") {
            let _ = writeln!(
                s,
                "\n### {m} against the raymarch at equal error\n\nFor each point on {m}'s front: the time the raymarch \
                 needs for the same error, interpolated in log-log along its front (≤: the raymarch's fastest point is \
                 already that accurate; —: no raymarch point in the sweep is).\n"
            );
            let _ =
                writeln!(s, "| {m} setting | rel RMSE | {m} ms | raymarch ms | speed-up |\n|---|---:|---:|---:|---:|");
            let (pts, front) = curve(&r.rows, m);
            let rows: Vec<&Row> = r.rows.iter().filter(|x| x.point.method_name() == *m).collect();
            for ((row, p), f) in rows.iter().zip(pts).zip(front) {
                if !f {
                    continue;
                }
                let fastest = base.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
                let (t, cell) = match time_at_error(&base, p.1) {
                    Some(t) if t <= fastest => (t, format!("≤ {}", ms(t))),
                    Some(t) => (t, ms(t)),
                    None => (f64::NAN, "—".into()),
                };
                let speed = if t.is_finite() { format!("{:.2}x", t / p.0) } else { "—".into() };
                let _ = writeln!(s, "| {} | {} | {} | {} | {} |", row.point.setting(), pct(p.1), ms(p.0), cell, speed);
            }
        }
    }

    paper_section(&mut s, r);

    let _ = writeln!(s, "\n## Time per pass (ms, medians)\n");
    let cols = pass_columns(r.rows.iter().map(|x| &x.timing));
    let _ = write!(s, "| method | setting |");
    for c in &cols {
        let _ = write!(s, " {c} |");
    }
    let _ = write!(s, " total | frames |\n|---|---|");
    for _ in &cols {
        let _ = write!(s, "---:|");
    }
    let _ = writeln!(s, "---:|---:|");
    for row in &r.rows {
        let _ = write!(s, "| {} | {} |", row.point.method_name(), row.point.setting());
        for c in &cols {
            let v = row.timing.passes.iter().find(|p| p.0 == *c).map(|p| ms(p.1)).unwrap_or_default();
            let _ = write!(s, " {v} |");
        }
        let _ = writeln!(s, " {} | {} |", ms(row.timing.total_ms), row.timing.frames);
    }

    // (The last field: whether the section gives each point's growth, issue 11's target 3.)
    for (title, png, rows, what, growth) in [
        (
            "Time against triangles",
            "time_vs_triangles.png",
            &r.triangle_rows,
            "procedural rooms of 64 spheres, point light",
            true,
        ),
        ("Time against resolution", "time_vs_resolution.png", &r.resolution_rows, "this scene, square images", false),
    ] {
        if rows.is_empty() {
            let _ = writeln!(s, "\n## {title}\n\nNot run (--no-scaling).");
            continue;
        }
        let _ = writeln!(s, "\n## {title}\n\n![{title}]({png})\n\n{what}.\n");
        if growth {
            // The time at the most triangles over the time at a tenth of them.
            for p in &super::scaling_points_of(rows) {
                if let Some(g) = super::triangle_growth(rows, p) {
                    let _ = writeln!(s, "- {} {}: {}", p.method_name(), p.setting(), g.describe());
                }
            }
            let _ = writeln!(s, "\nMedians over {} rounds, each timing every room in turn.\n", r.rounds);
        }
        let cols = pass_columns(rows.iter().map(|x| &x.timing));
        let _ = write!(s, "| method | setting | triangles | image | total ms |");
        for c in &cols {
            let _ = write!(s, " {c} |");
        }
        let _ = write!(s, "\n|---|---|---:|---|---:|");
        for _ in &cols {
            let _ = write!(s, "---:|");
        }
        s.push('\n');
        for row in rows.iter() {
            let _ = write!(
                s,
                "| {} | {} | {} | {}x{} | {} |",
                row.point.method_name(),
                row.point.setting(),
                row.triangles,
                row.width,
                row.height,
                ms(row.timing.total_ms)
            );
            for c in &cols {
                let v = row.timing.passes.iter().find(|p| p.0 == *c).map(|p| ms(p.1)).unwrap_or_default();
                let _ = write!(s, " {v} |");
            }
            s.push('\n');
        }
    }

    if !r.notes.is_empty() {
        let _ = writeln!(s, "\n## Notes\n");
        for n in &r.notes {
            let _ = writeln!(s, "- {n}");
        }
    }
    s
}

/// The paper's stage timings (Section 5, GTX 480, 1024x1024 image, 1024x1024 x 256 grid), beside
/// ours at the same grid when the sweep has that point.
pub const PAPER_STAGES_MS: [(Pass, &str, f64, f64); 3] = [
    (Pass::Voxelize, "voxelize", 0.5, 2.5),
    (Pass::Scan, "scan (256 bins = 2 x 0.65 ms per 128 bins)", 1.3, 1.3),
    (Pass::Integrate, "integrate", 1.0, 1.0),
];

fn paper_section(s: &mut String, r: &BenchResults) {
    let paper_grid = |row: &&Row| {
        let g = row.point.grid;
        row.point.method_name() == "vsv"
            && (g.planes, g.rays, g.bins) == (PAPER_GRID.planes, PAPER_GRID.rays, PAPER_GRID.bins)
    };
    let Some(row) = r.rows.iter().find(paper_grid) else { return };
    let _ = writeln!(
        s,
        "\n## Beside the paper\n\nThe paper's stage timings on a GTX 480 (1024x1024 image, 1024x1024 x 256 grid) \
         against this run's {} grid on {} at {}x{}. The ratio is ours over the paper's (upper end of its range).\n",
        row.point.setting(),
        r.adapter,
        r.width,
        r.height
    );
    let _ = writeln!(s, "| stage | paper ms (GTX 480) | ours ms | ratio |\n|---|---:|---:|---:|");
    let mut ours_sum = 0.0;
    let time = |pass: Pass| row.timing.passes.iter().find(|p| p.0 == pass).map(|p| p.1);
    for (pass, name, lo, hi) in PAPER_STAGES_MS {
        // The first-hit volume has no scan: HitBounds runs in its place.
        let (ours, name) = match (time(pass), pass) {
            (None, Pass::Scan) => match time(Pass::HitBounds) {
                Some(t) => (t, format!("{name}; ours: the first hits' bounds in its place")),
                None => (f64::NAN, name.to_string()),
            },
            (t, _) => (t.unwrap_or(f64::NAN), name.to_string()),
        };
        ours_sum += if ours.is_finite() { ours } else { 0.0 };
        let paper = if lo == hi { format!("{lo}") } else { format!("{lo} to {hi}") };
        // Two decimals below 10: a GPU's stages are a fraction of the paper's.
        let ratio = ours / hi;
        let ratio = if ratio < 10.0 { format!("{ratio:.2}") } else { format!("{ratio:.0}") };
        let _ = writeln!(s, "| {name} | {paper} | {} | {ratio}x |", ms(ours));
    }
    let _ = writeln!(
        s,
        "| whole frame | (target: < 1 ms on a current NVIDIA GPU) | {} (stages above: {}) | |",
        ms(row.timing.total_ms),
        ms(ours_sum)
    );
}

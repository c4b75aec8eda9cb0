//! `epivox check`: numerical stability on stiff and extreme cases (DESIGN section 5).
//!
//! A named matrix of hard cases ([`cases::matrix`]) runs through every GPU method that applies to it
//! and through the exact `f64` reference; each (case, method) pair is one [`RunResult`] with the
//! worst channel's relative RMSE, the largest absolute error, the count of NaN/Inf values and a
//! pass/fail against the case's stated bound ([`Expect`]). `docs/stability.md` holds the last full
//! table and the reason behind every bound.
//!
//! [`mirror`] holds `f32` mirrors of the shaders' per-run formulas (checked against `f64` by the
//! property tests) and a CPU `f32` evaluator of the in-scattering integral with a planted variant
//! (separate exponents) that shows the check can fail.

pub mod cases;
pub mod mirror;

use crate::gpu::GpuError;
use crate::image::Image;
use crate::metrics::{self, MetricsError};
use crate::reference::{self, RaySample, ReferenceOptions};
use crate::render::{Method, Renderer};
use crate::scene::Scene;
use std::fmt::Write as _;
use std::time::Instant;

pub use cases::{matrix, quick_matrix};

/// Why the check itself could not run (a failing case is a result, not an error).
#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("case {case}: {source}")]
    Metrics { case: String, source: MetricsError },
    #[error("case {case} needs a GPU renderer for {method}, and none was given")]
    NoRenderer { case: String, method: String },
    #[error("no case name contains '{0}'")]
    NoCase(String),
}

/// Which image a case compares.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// The in-scattered radiance `L_scatter` alone.
    Scatter,
    /// The final image (surfaces attenuated by the view path, plus `L_scatter`).
    Hdr,
}

/// A square of pixels, `(2 radius + 1)^2`, around `(x, y)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelWindow {
    pub x: u32,
    pub y: u32,
    pub radius: u32,
}

impl PixelWindow {
    pub fn contains(&self, x: u32, y: u32) -> bool {
        x.abs_diff(self.x) <= self.radius && y.abs_diff(self.y) <= self.radius
    }
}

/// What a (case, method) pair must achieve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expect {
    /// Every value finite and the worst channel's relative RMSE at most `rel_rmse`. Pixels inside
    /// `exclude` (a light's own pixels, thousands of times the mean) are left out of it; when
    /// `window_rel` is given, the sum over the window must match the reference's to that relative
    /// error (per channel), otherwise (where the exact answer is infinite) they need only be finite.
    RelRmse { rel_rmse: f64, exclude: Option<PixelWindow>, window_rel: Option<f64> },
    /// Every value finite and within `max_abs` of the reference (where the exact answer is 0 or
    /// below `f32`'s range, a relative error means nothing).
    MaxAbs { max_abs: f64 },
    /// The method must refuse the frame with an error message (a degenerate frame: never NaN).
    Refused,
}

impl Expect {
    pub fn rel(rel_rmse: f64) -> Expect {
        Expect::RelRmse { rel_rmse, exclude: None, window_rel: None }
    }
    /// `rel_rmse` outside `window`; inside it only finite values.
    pub fn rel_outside(rel_rmse: f64, window: PixelWindow) -> Expect {
        Expect::RelRmse { rel_rmse, exclude: Some(window), window_rel: None }
    }
    /// `rel_rmse` outside `window`, and the window's sum within `window_rel`.
    pub fn rel_split(rel_rmse: f64, window: PixelWindow, window_rel: f64) -> Expect {
        Expect::RelRmse { rel_rmse, exclude: Some(window), window_rel: Some(window_rel) }
    }
    pub fn max_abs(max_abs: f64) -> Expect {
        Expect::MaxAbs { max_abs }
    }

    /// The bound as the table shows it.
    pub fn describe(&self) -> String {
        match self {
            Expect::RelRmse { rel_rmse, exclude: None, .. } => format!("rel <= {}", pct(*rel_rmse)),
            Expect::RelRmse { rel_rmse, exclude: Some(w), window_rel } => {
                let n = 2 * w.radius + 1;
                match window_rel {
                    Some(wr) => format!("rel <= {} + {n}x{n} sum <= {}", pct(*rel_rmse), pct(*wr)),
                    None => format!("rel <= {} outside {n}x{n}", pct(*rel_rmse)),
                }
            }
            Expect::MaxAbs { max_abs } => format!("abs <= {max_abs:.0e}"),
            Expect::Refused => "refused".into(),
        }
    }
}

/// How a case is rendered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CheckMethod {
    /// One of the GPU methods.
    Gpu(Method),
    /// The CPU `f32` evaluator of [`mirror::cpu_f32_scatter`] over the reference's exact lit runs
    /// (point lights, `L_scatter` only). With `separate_exponents` it is the *planted failure*:
    /// `exp(-sigma_t d) * exp(-sigma_t t)` instead of one combined exponent.
    CpuF32 { separate_exponents: bool },
}

impl CheckMethod {
    pub fn label(&self) -> String {
        match self {
            CheckMethod::Gpu(Method::Vsv) => "vsv".into(),
            CheckMethod::Gpu(Method::Cartesian) => "cartesian".into(),
            CheckMethod::Gpu(Method::Raymarch { steps, jitter }) => {
                format!("raymarch-{steps}{}", if *jitter { "j" } else { "" })
            }
            CheckMethod::CpuF32 { separate_exponents: false } => "cpu-f32".into(),
            CheckMethod::CpuF32 { separate_exponents: true } => "cpu-f32-naive".into(),
        }
    }
}

/// One named hard case.
#[derive(Debug, Clone)]
pub struct Case {
    /// `group/name`, e.g. `medium/thick-100`.
    pub name: String,
    pub group: &'static str,
    /// What the scene is.
    pub about: String,
    /// Why the bounds are what they are.
    pub reason: String,
    /// Part of `epivox check --quick` (and of the test command).
    pub quick: bool,
    /// Image size.
    pub size: (u32, u32),
    pub target: Target,
    pub scene: Scene,
    /// The methods it runs through, each with its bound.
    pub runs: Vec<(CheckMethod, Expect)>,
}

/// The outcome of one (case, method) pair.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RunResult {
    pub case: String,
    pub method: String,
    /// Worst channel's RMSE over its reference mean (inf with any non-finite value).
    pub rel_rmse: f64,
    /// Largest absolute difference (inf with any non-finite value).
    pub max_abs: f64,
    /// Largest reference value (the scale of `max_abs`).
    pub max_ref: f64,
    /// NaN and infinite values in the method's image, channels counted separately.
    pub non_finite: usize,
    /// Relative error of the sum over the case's pixel window, when the bound has one (else NaN).
    pub window_rel: f64,
    pub bound: String,
    pub pass: bool,
    /// Why it failed, or what the refusal said.
    pub note: String,
    /// Wall-clock seconds of the method's render.
    pub seconds: f64,
}

/// Every result of a check run.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub adapter: String,
    pub results: Vec<RunResult>,
    /// Wall-clock seconds of the reference renders, summed.
    pub reference_seconds: f64,
    pub seconds: f64,
}

impl Report {
    pub fn passed(&self) -> bool {
        self.results.iter().all(|r| r.pass)
    }

    pub fn failures(&self) -> impl Iterator<Item = &RunResult> {
        self.results.iter().filter(|r| !r.pass)
    }

    /// The table: case, method, relative RMSE, max error, largest reference value, NaN/Inf count,
    /// bound, result.
    #[allow(clippy::write_literal)] // the header's column names line up with the rows' format
    pub fn table(&self) -> String {
        let mut s = String::new();
        let w = self.results.iter().map(|r| r.case.len()).max().unwrap_or(4).max(4);
        let _ = writeln!(
            s,
            "{:<w$}  {:<13} {:>9} {:>9} {:>9} {:>8} {:>7}  {:<30} {}",
            "case", "method", "rel RMSE", "max err", "max ref", "window", "NaN/Inf", "bound", "result"
        );
        for r in &self.results {
            let _ = write!(
                s,
                "{:<w$}  {:<13} {:>9} {:>9} {:>9} {:>8} {:>7}  {:<30} {}",
                r.case,
                r.method,
                if r.rel_rmse.is_nan() { "-".into() } else { pct(r.rel_rmse) },
                sci(r.max_abs),
                sci(r.max_ref),
                if r.window_rel.is_nan() { "-".into() } else { pct(r.window_rel) },
                r.non_finite,
                r.bound,
                if r.pass { "pass" } else { "FAIL" }
            );
            if !r.note.is_empty() {
                let _ = write!(s, "  ({})", r.note);
            }
            s.push('\n');
        }
        let failed = self.failures().count();
        let _ = writeln!(
            s,
            "{} of {} runs passed on {} ({:.1} s, of which reference {:.1} s){}",
            self.results.len() - failed,
            self.results.len(),
            self.adapter,
            self.seconds,
            self.reference_seconds,
            if failed > 0 { format!("; {failed} FAILED") } else { String::new() }
        );
        s
    }

    pub fn to_json(&self) -> serde_json::Value {
        let f = |v: f64| {
            if v.is_finite() {
                serde_json::Value::from(v)
            } else if v.is_nan() {
                serde_json::Value::Null
            } else {
                serde_json::Value::from(if v > 0.0 { "inf" } else { "-inf" })
            }
        };
        serde_json::json!({
            "adapter": self.adapter,
            "passed": self.passed(),
            "seconds": self.seconds,
            "results": self.results.iter().map(|r| serde_json::json!({
                "case": r.case,
                "method": r.method,
                "rel_rmse": f(r.rel_rmse),
                "max_abs": f(r.max_abs),
                "max_ref": f(r.max_ref),
                "non_finite": r.non_finite,
                "window_rel": f(r.window_rel),
                "bound": r.bound,
                "pass": r.pass,
                "note": r.note,
                "seconds": r.seconds,
            })).collect::<Vec<_>>(),
        })
    }
}

fn pct(x: f64) -> String {
    if !x.is_finite() {
        return "inf".into();
    }
    let p = x * 100.0;
    if p >= 100.0 {
        format!("{p:.0}%")
    } else if p >= 0.1 || p == 0.0 {
        format!("{p:.2}%")
    } else {
        format!("{p:.1e}%")
    }
}

fn sci(x: f64) -> String {
    if x.is_nan() {
        "-".into()
    } else if !x.is_finite() {
        "inf".into()
    } else {
        format!("{x:.1e}")
    }
}

/// Error statistics of a method's image against the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stats {
    /// `max over channels of RMSE_c / mean_c` over the compared pixels (a channel with reference
    /// mean 0 counts 0 when it matches exactly, inf otherwise). Per channel, because a strongly
    /// coloured medium's dim channel would otherwise hide behind the bright one.
    pub rel_rmse: f64,
    pub max_abs: f64,
    pub max_ref: f64,
    /// Non-finite values anywhere in the image (excluded pixels too).
    pub non_finite: usize,
    /// Worst channel's relative error of the sum over the excluded window (0 without one).
    pub window_rel: f64,
}

/// Compares `test` with `reference`, leaving the pixels in `exclude` out of the error figures.
pub fn stats(test: &Image, reference: &Image, exclude: Option<PixelWindow>) -> Result<Stats, MetricsError> {
    // Sizes, pixel counts and a finite reference are checked by metrics::compare.
    metrics::compare(test, reference)?;
    let mut sum_sq = [0.0f64; 3];
    let mut sum_ref = [0.0f64; 3];
    let mut n = 0usize;
    let (mut max_abs, mut max_ref, mut non_finite) = (0.0f64, 0.0f64, 0usize);
    let (mut win_test, mut win_ref) = ([0.0f64; 3], [0.0f64; 3]);
    for (i, (a, b)) in test.pixels.iter().zip(&reference.pixels).enumerate() {
        non_finite += a.iter().filter(|c| !c.is_finite()).count();
        let (x, y) = ((i as u32) % test.width, (i as u32) / test.width);
        if exclude.is_some_and(|w| w.contains(x, y)) {
            for c in 0..3 {
                win_test[c] += a[c] as f64;
                win_ref[c] += b[c] as f64;
            }
            continue;
        }
        n += 1;
        for c in 0..3 {
            let (a, b) = (a[c] as f64, b[c] as f64);
            let d = a - b;
            sum_sq[c] += d * d;
            sum_ref[c] += b;
            max_abs = max_abs.max(d.abs());
            max_ref = max_ref.max(b.abs());
        }
    }
    let mut rel_rmse = 0.0f64;
    for c in 0..3 {
        let rmse = (sum_sq[c] / n.max(1) as f64).sqrt();
        let mean = sum_ref[c] / n.max(1) as f64;
        let rel = if rmse == 0.0 {
            0.0
        } else if mean > 0.0 {
            rmse / mean
        } else {
            f64::INFINITY
        };
        rel_rmse = rel_rmse.max(rel);
    }
    let mut window_rel = 0.0f64;
    for c in 0..3 {
        let d = (win_test[c] - win_ref[c]).abs();
        let rel = if d == 0.0 {
            0.0
        } else if win_ref[c] > 0.0 {
            d / win_ref[c]
        } else {
            f64::INFINITY
        };
        window_rel = window_rel.max(rel);
    }
    if non_finite > 0 || rel_rmse.is_nan() || max_abs.is_nan() {
        rel_rmse = f64::INFINITY;
        max_abs = f64::INFINITY;
        window_rel = f64::INFINITY;
    }
    Ok(Stats { rel_rmse, max_abs, max_ref, non_finite, window_rel })
}

/// Judges `stats` against `expect` (for a method that rendered).
fn judge(expect: &Expect, s: &Stats) -> (bool, String) {
    if s.non_finite > 0 {
        return (false, format!("{} non-finite values", s.non_finite));
    }
    match *expect {
        Expect::RelRmse { rel_rmse, window_rel, .. } => {
            if s.rel_rmse > rel_rmse {
                return (false, format!("relative RMSE above {}", pct(rel_rmse)));
            }
            if let Some(wr) = window_rel {
                if s.window_rel > wr {
                    return (false, format!("the window's sum is off by {}", pct(s.window_rel)));
                }
            }
            (true, String::new())
        }
        Expect::MaxAbs { max_abs } => {
            let ok = s.max_abs <= max_abs;
            (ok, if ok { String::new() } else { format!("max error above {max_abs:.0e}") })
        }
        Expect::Refused => (false, "rendered a frame instead of refusing it".into()),
    }
}

/// Settings of a check run.
#[derive(Debug, Clone, PartialEq)]
pub struct CheckOptions {
    /// Only the cases marked quick.
    pub quick: bool,
    /// Only the cases whose name contains this.
    pub filter: Option<String>,
    /// The reference renderer's settings.
    pub reference: ReferenceOptions,
    /// Write every compared pair of images here as text (`x y reference[3] method[3]` per pixel).
    pub dump: Option<std::path::PathBuf>,
    /// Run every case at this grid instead of its own (a diagnostic: the bounds were measured at
    /// the cases' own grids).
    pub grid: Option<crate::params::Grid>,
}

impl Default for CheckOptions {
    fn default() -> Self {
        CheckOptions {
            quick: false,
            filter: None,
            reference: ReferenceOptions { progress: false, ..Default::default() },
            dump: None,
            grid: None,
        }
    }
}

/// The cases `opts` selects from the full matrix for an adapter with `limits`.
pub fn select(limits: &wgpu::Limits, opts: &CheckOptions) -> Result<Vec<Case>, CheckError> {
    let all = if opts.quick { quick_matrix(limits) } else { matrix(limits) };
    let chosen: Vec<Case> = match &opts.filter {
        Some(f) => all.into_iter().filter(|c| c.name.contains(f.as_str())).collect(),
        None => all,
    };
    if chosen.is_empty() {
        return Err(CheckError::NoCase(opts.filter.clone().unwrap_or_default()));
    }
    let mut chosen = chosen;
    if let Some(g) = opts.grid {
        for c in &mut chosen {
            c.scene.grid = g;
        }
    }
    Ok(chosen)
}

/// The reference's samples for every pixel of `case` (row-major).
pub fn reference_samples(case: &Case, opts: &ReferenceOptions) -> Vec<RaySample> {
    let (w, h) = case.size;
    let pixels: Vec<(u32, u32)> = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect();
    reference::render_pixels(&case.scene, w, h, &pixels, opts)
}

fn image_of(case: &Case, samples: &[RaySample]) -> Image {
    let (w, h) = case.size;
    let mut img = Image::new(w, h);
    for (p, s) in img.pixels.iter_mut().zip(samples) {
        let v = match case.target {
            Target::Scatter => s.scatter,
            Target::Hdr => s.hdr,
        };
        *p = v.map(|x| x as f32);
    }
    img
}

/// Runs one case through each of its methods; GPU methods need `renderer`. Returns the results and
/// the seconds spent in the reference.
pub fn run_case(
    mut renderer: Option<&mut Renderer>,
    case: &Case,
    opts: &ReferenceOptions,
    dump: Option<&std::path::Path>,
) -> Result<(Vec<RunResult>, f64), CheckError> {
    // The reference renders unless every run must refuse; the CPU evaluator reads its samples.
    let needs_reference =
        case.runs.iter().any(|(m, e)| *e != Expect::Refused || matches!(m, CheckMethod::CpuF32 { .. }));
    let started = Instant::now();
    let samples = if needs_reference { reference_samples(case, opts) } else { Vec::new() };
    let reference_seconds = started.elapsed().as_secs_f64();
    let reference_image = needs_reference.then(|| image_of(case, &samples));
    let (w, h) = case.size;
    let mut out = Vec::new();
    for (method, expect) in &case.runs {
        let label = method.label();
        let started = Instant::now();
        let rendered: Result<Image, String> = match method {
            CheckMethod::Gpu(m) => {
                let r = renderer
                    .as_deref_mut()
                    .ok_or_else(|| CheckError::NoRenderer { case: case.name.clone(), method: label.clone() })?;
                // The renderer only re-uploads geometry when the triangle count changes.
                r.set_scene(&case.scene);
                r.render(&case.scene, w, h, *m)
                    .map(|o| match case.target {
                        Target::Scatter => o.scatter,
                        Target::Hdr => o.hdr,
                    })
                    .map_err(|e| e.to_string())
            }
            CheckMethod::CpuF32 { separate_exponents } => {
                if case.target != Target::Scatter {
                    Err("cpu-f32 evaluates the in-scattering only".into())
                } else {
                    mirror::cpu_f32_scatter(&case.scene, w, h, &samples, *separate_exponents).map_err(|e| e.to_string())
                }
            }
        };
        let seconds = started.elapsed().as_secs_f64();
        let bound = expect.describe();
        let nan = f64::NAN;
        let result = match (rendered, expect) {
            (Err(msg), Expect::Refused) => RunResult {
                case: case.name.clone(),
                method: label,
                rel_rmse: nan,
                max_abs: nan,
                max_ref: nan,
                non_finite: 0,
                window_rel: nan,
                bound,
                pass: true,
                note: format!("refused: {msg}"),
                seconds,
            },
            (Err(msg), _) => RunResult {
                case: case.name.clone(),
                method: label,
                rel_rmse: nan,
                max_abs: nan,
                max_ref: nan,
                non_finite: 0,
                window_rel: nan,
                bound,
                pass: false,
                note: format!("error: {msg}"),
                seconds,
            },
            (Ok(img), Expect::Refused) => RunResult {
                case: case.name.clone(),
                method: label,
                rel_rmse: nan,
                max_abs: nan,
                max_ref: nan,
                non_finite: img.count_non_finite(),
                window_rel: nan,
                bound,
                pass: false,
                note: "rendered a frame instead of refusing it".into(),
                seconds,
            },
            (Ok(img), e) => {
                let (exclude, has_window_bound) = match e {
                    Expect::RelRmse { exclude, window_rel, .. } => (*exclude, window_rel.is_some()),
                    _ => (None, false),
                };
                let reference_image = reference_image.as_ref().ok_or_else(|| CheckError::Metrics {
                    case: case.name.clone(),
                    source: MetricsError::Empty { width: 0, height: 0 },
                })?;
                if let Some(dir) = dump {
                    dump_pair(dir, &format!("{}_{}", case.name.replace('/', "_"), label), reference_image, &img);
                }
                let s = stats(&img, reference_image, exclude)
                    .map_err(|source| CheckError::Metrics { case: case.name.clone(), source })?;
                let (pass, note) = judge(e, &s);
                RunResult {
                    case: case.name.clone(),
                    method: label,
                    rel_rmse: s.rel_rmse,
                    max_abs: s.max_abs,
                    max_ref: s.max_ref,
                    non_finite: s.non_finite,
                    window_rel: if has_window_bound { s.window_rel } else { nan },
                    bound,
                    pass,
                    note,
                    seconds,
                }
            }
        };
        out.push(result);
    }
    Ok((out, reference_seconds))
}

/// Best effort: a debugging aid, a failed write only loses the dump.
fn dump_pair(dir: &std::path::Path, name: &str, reference: &Image, test: &Image) {
    let mut text = String::new();
    for (i, (r, t)) in reference.pixels.iter().zip(&test.pixels).enumerate() {
        let _ = writeln!(
            text,
            "{} {} {:e} {:e} {:e} {:e} {:e} {:e}",
            i as u32 % reference.width,
            i as u32 / reference.width,
            r[0],
            r[1],
            r[2],
            t[0],
            t[1],
            t[2]
        );
    }
    let _ = std::fs::create_dir_all(dir);
    let _ = std::fs::write(dir.join(format!("{name}.txt")), text);
}

/// Runs `cases`, calling `on_result` after each (case, method) pair.
pub fn run(
    mut renderer: Option<&mut Renderer>,
    cases: &[Case],
    opts: &CheckOptions,
    mut on_result: impl FnMut(&RunResult),
) -> Result<Report, CheckError> {
    let started = Instant::now();
    let adapter = renderer.as_ref().map_or_else(|| "no GPU".to_string(), |r| r.ctx.adapter_name());
    let mut results = Vec::new();
    let mut reference_seconds = 0.0;
    for case in cases {
        let (rs, secs) = run_case(renderer.as_deref_mut(), case, &opts.reference, opts.dump.as_deref())?;
        reference_seconds += secs;
        for r in rs {
            on_result(&r);
            results.push(r);
        }
    }
    Ok(Report { adapter, results, reference_seconds, seconds: started.elapsed().as_secs_f64() })
}

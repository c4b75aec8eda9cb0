//! `epivox bench`: error against run time for every method, side by side with the ray-marching
//! baseline (DESIGN section 4).
//!
//! ```text
//! scene ──► reference (cached on disk, cache.rs) ─────────────────────────┐
//!   │                                                                      ▼
//!   └──► sweep: VSV grids, Cartesian grids (when the light allows), ──► metrics::compare ──► Row
//!        raymarch steps and shadow-map sizes; per point the median
//!        GPU time of several frames after warm-up (encoder timestamps)
//! procedural rooms (procedural.rs) and image sizes ──► time only ──► ScalingRow
//! rows ──► results.csv, report.md, error_vs_time.png, time_vs_triangles.png, time_vs_resolution.png
//! ```
//!
//! A benchmark measures; it asserts nothing. Every number in the report comes from this run (or,
//! for the reference image, from the cache entry whose key says it was rendered from the same data).

pub mod ab;
mod cache;
mod plot;
mod procedural;
mod report;

pub use cache::{cached_reference, reference_key, CacheStatus, CachedReference, KeyHasher};
pub use procedural::procedural_scene;

use crate::gpu::GpuError;
use crate::image::ImageError;
use crate::metrics::{self, ErrorStats, MetricsError};
use crate::params::Grid;
use crate::reference::ReferenceOptions;
use crate::render::{FrameSetup, Method, Renderer};
use crate::render::{Pass, RenderError, ShadowVolume, SurfaceShadows};
use crate::scene::Scene;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Why a benchmark could not run or write its results.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error("comparing against the reference: {0}")]
    Metrics(#[from] MetricsError),
    #[error("cannot {op} {}: {source}", path.display())]
    Io {
        op: &'static str,
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("cannot draw the plot {}: {message}", path.display())]
    Plot { path: PathBuf, message: String },
    #[error("no benchmark point could be rendered; the first failure: {0}")]
    NothingRendered(String),
}

/// How a benchmark runs.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Image size of the error sweep (and of the triangle sweep).
    pub width: u32,
    pub height: u32,
    /// Tiny sweeps for CI (well under a minute on a software driver).
    pub quick: bool,
    /// Frames rendered and thrown away before measuring (pipeline compilation, caches).
    pub warmup: usize,
    /// Frames measured per point; the report gives their median.
    pub frames: usize,
    /// Rounds of the error sweep ([`crate::params::Measure::ROUNDS`]): every point is timed once
    /// per round, so a phase of a shared machine that slows it down falls on all points alike
    /// instead of on the few measured during it. 1: each point is timed once, in sweep order.
    pub rounds: usize,
    /// Where results.csv, report.md and the plots go.
    pub out_dir: PathBuf,
    /// Where reference images are cached.
    pub cache_dir: PathBuf,
    /// Progress bars on stderr.
    pub progress: bool,
    /// Also run the time-against-triangles and time-against-resolution sweeps.
    pub scaling: bool,
    /// More VSV grids for the error sweep, measured after the built-in ones ([`add_grids`];
    /// `epivox bench --grid`): to place a grid of one's own on the error-against-time front.
    pub extra_grids: Vec<Grid>,
    pub reference: ReferenceOptions,
}

impl BenchOptions {
    /// Defaults: 1024x1024 (64x64 quick), 1 warm-up frame, 5 measured (3 quick), the cache in
    /// `out_dir/cache`, both scaling sweeps.
    pub fn new(out_dir: impl Into<PathBuf>, quick: bool) -> BenchOptions {
        let out_dir = out_dir.into();
        let size = if quick { 64 } else { 1024 };
        BenchOptions {
            width: size,
            height: size,
            quick,
            warmup: 1,
            frames: if quick { 3 } else { 5 },
            rounds: 1,
            cache_dir: out_dir.join("cache"),
            out_dir,
            progress: false,
            scaling: true,
            extra_grids: Vec::new(),
            reference: ReferenceOptions::default(),
        }
    }
}

/// One setting of one method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub method: Method,
    /// The grid (VSV, Cartesian); unused by the raymarch.
    pub grid: Grid,
    /// Shadow-map texels per side (every method shades its surfaces with it; the raymarch also
    /// looks its visibility up in it).
    pub shadow_map: u32,
}

/// The paper's grid (Section 5: 1024x1024 planes x rays, 256 bins): the scaling sweeps' VSV point
/// and the one the report sets beside the paper's stage timings.
pub const PAPER_GRID: Grid =
    Grid { planes: 1024, rays: 1024, bins: 256, spacing: crate::params::BinSpacing::UniformAngle };

impl Point {
    fn grid(method: Method, planes: u32, rays: u32, bins: u32, shadow_map: u32) -> Point {
        Point { method, grid: Grid { planes, rays, bins, ..Grid::default() }, shadow_map }
    }
    fn vsv(grid: Grid, shadow_map: u32) -> Point {
        Point { method: Method::Vsv, grid, shadow_map }
    }
    fn march(steps: u32, shadow_map: u32, jitter: bool) -> Point {
        Point { method: Method::Raymarch { steps, jitter }, grid: Grid::default(), shadow_map }
    }

    pub fn method_name(&self) -> &'static str {
        match self.method {
            Method::Vsv => "vsv",
            Method::Cartesian => "cartesian",
            Method::Raymarch { .. } => "raymarch",
        }
    }

    /// `1024x1024x256` or `256 steps, map 2048` (plus `, jitter`).
    pub fn setting(&self) -> String {
        match self.method {
            Method::Raymarch { steps, jitter } => {
                format!("{steps} steps, map {}{}", self.shadow_map, if jitter { ", jitter" } else { "" })
            }
            _ => self.grid.to_string(),
        }
    }
}

/// The error sweep: VSV grids (bins 32 to 1024 at 512² planes x rays, 256² / 1024² at a few bin
/// counts, the default grid, 1024, 1536 and 2048 planes of 512x512 and 2048x512x768), the
/// same for the Cartesian grid at fewer points, and the raymarch at 16 to 1024 steps with a 2048²
/// shadow map plus 512² to 4096² maps at 256 steps (and a jittered point, and 512 and 1024 steps
/// on the 4096² map). `quick`: two or three tiny points per method. [`run`] then extends the march
/// on the [`CHASE_MAPS`] while it is less accurate than VSV's most accurate grid.
pub fn error_sweep(quick: bool) -> Vec<Point> {
    use Method::{Cartesian, Vsv};
    if quick {
        return vec![
            Point::grid(Vsv, 64, 64, 32, 512),
            Point::grid(Vsv, 128, 128, 64, 512),
            Point::grid(Cartesian, 64, 64, 32, 512),
            Point::grid(Cartesian, 128, 128, 64, 512),
            Point::march(16, 256, false),
            Point::march(64, 512, false),
        ];
    }
    let map = crate::params::Baseline::default().shadow_map;
    let mut v = Vec::new();
    for bins in [32, 64, 128, 256, 512, 1024] {
        v.push(Point::grid(Vsv, 512, 512, bins, map));
    }
    for (pr, bins) in [(256, 64), (256, 256), (1024, 64), (1024, 256), (1024, 1024)] {
        v.push(Point::grid(Vsv, pr, pr, bins, map));
    }
    // The product's default, the defaults until sessions 11 and 12 (1024 and 1536 x 512 x 512),
    // 2048 planes of 512 bins and the default since session 13 (2048x512x768), each once: the
    // earlier reports have them. 2048x512x768's error is below the 4096² map's limit (1.1% on the
    // classroom), so the march needs the 8192² map to keep up (CHASE_MAPS).
    let g = Grid::default();
    v.push(Point::vsv(g, map));
    for (planes, bins) in [(1024, 512), (1536, 512), (2048, 512), (2048, 768)] {
        let other = Grid { planes, rays: 512, bins, ..g };
        if other != g {
            v.push(Point::vsv(other, map));
        }
    }
    for (pr, bins) in [(512, 64), (512, 256), (1024, 256), (1024, 1024)] {
        v.push(Point::grid(Cartesian, pr, pr, bins, map));
    }
    for steps in [16, 32, 64, 128, 256, 512, 1024] {
        v.push(Point::march(steps, map, false));
    }
    for m in [512, 1024, 4096] {
        v.push(Point::march(256, m, false));
    }
    v.push(Point::march(512, 4096, false));
    v.push(Point::march(1024, 4096, false));
    v.push(Point::march(64, map, true));
    v
}

/// Appends a VSV point for each of `grids` that `points` lacks, in order and once each, on the
/// shadow map of the sweep's VSV points (the surfaces' shading: the same for every grid).
pub fn add_grids(points: &mut Vec<Point>, grids: &[Grid]) {
    let map = points
        .iter()
        .find(|p| p.method == Method::Vsv)
        .map_or(crate::params::Baseline::default().shadow_map, |p| p.shadow_map);
    for &g in grids {
        let p = Point::vsv(g, map);
        if !points.contains(&p) {
            points.push(p);
        }
    }
}

/// The baseline's maps, in order, when the sweep is extended to reach VSV's error: on each the
/// march's steps double from the sweep's most accurate point on that map (from
/// [`CHASE_FIRST_STEPS`] on a map the sweep lacks) up to [`CHASE_MAX_STEPS`], until it is as
/// accurate or stops improving (the map's own limit); then the next, finer map.
pub const CHASE_MAPS: [u32; 2] = [4096, 8192];
pub const CHASE_FIRST_STEPS: u32 = 1024;
/// Where the steps stop doubling on a map. The bunny's march is limited by its steps, not its
/// map: on the H200 the 4096-step march (0.0403%) was still 13% better than the 2048-step one
/// and short of VSV (docs/results.md, session 23), so the chase goes on past 4096 steps there.
pub const CHASE_MAX_STEPS: u32 = crate::params::Baseline::STEPS.max as u32;
/// A map's chase stops once its march takes this many times the chased VSV point's frame: the
/// ratio's lower bound is then already twice issue 11's 10x, and a software adapter would spend
/// minutes a frame on the next doubling (the bunny's 4096-step march takes 23 s on llvmpipe).
pub const CHASE_MAX_RATIO: f64 = 20.0;

/// The march the chase measures next, or `None` once a march of `rows` is as accurate as their
/// most accurate VSV point or every map in `maps` is spent. On each map in turn the steps double
/// from the map's finest march (from [`CHASE_FIRST_STEPS`] on a map without one) up to
/// [`CHASE_MAX_STEPS`]; a map is spent there, once doubling the steps lowered the error by less
/// than 2% (its texels are then the limit), or once its finest march takes [`CHASE_MAX_RATIO`]
/// times that VSV point's frame.
pub fn next_chase_point(rows: &[Row], maps: &[u32]) -> Option<Point> {
    let vsv = rows
        .iter()
        .filter(|r| r.point.method == Method::Vsv)
        .min_by(|a, b| a.scatter.rel_rmse.total_cmp(&b.scatter.rel_rmse))?;
    let target = vsv.scatter.rel_rmse;
    let march = rows
        .iter()
        .filter(|r| matches!(r.point.method, Method::Raymarch { jitter: false, .. }))
        .map(|r| r.scatter.rel_rmse)
        .min_by(|a, b| a.total_cmp(b));
    if march.is_some_and(|e| e <= target) {
        return None;
    }
    for &map in maps {
        // (steps, error, frame ms) of the plain marches on this map.
        let on: Vec<(u32, f64, f64)> = rows
            .iter()
            .filter(|r| r.point.shadow_map == map)
            .filter_map(|r| match r.point.method {
                Method::Raymarch { steps, jitter: false } => Some((steps, r.scatter.rel_rmse, r.timing.total_ms)),
                _ => None,
            })
            .collect();
        let Some(&(top, e_top, ms_top)) = on.iter().max_by_key(|(steps, _, _)| *steps) else {
            return Some(Point::march(CHASE_FIRST_STEPS, map, false));
        };
        if top >= CHASE_MAX_STEPS {
            continue;
        }
        if on.iter().any(|&(steps, e, _)| steps == top / 2 && e_top >= 0.98 * e) {
            continue;
        }
        // Past the ratio's cap (the next map starts again at fewer steps).
        if ms_top >= CHASE_MAX_RATIO * vsv.timing.total_ms {
            continue;
        }
        return Some(Point::march(top * 2, map, false));
    }
    None
}

/// The two settings the scaling sweeps time: [`PAPER_GRID`] and a 256-step march.
pub fn scaling_points(quick: bool) -> [Point; 2] {
    if quick {
        [Point::grid(Method::Vsv, 64, 64, 32, 512), Point::march(32, 256, false)]
    } else {
        [
            Point::vsv(PAPER_GRID, crate::params::Baseline::default().shadow_map),
            Point::march(256, crate::params::Baseline::default().shadow_map, false),
        ]
    }
}

/// Triangle counts of the procedural rooms.
pub fn triangle_sweep(quick: bool) -> Vec<usize> {
    if quick {
        vec![2_000, 8_000]
    } else {
        vec![10_000, 100_000, 300_000, 1_000_000]
    }
}

/// Square image sizes of the resolution sweep.
pub fn resolution_sweep(quick: bool) -> Vec<u32> {
    if quick {
        vec![32, 64]
    } else {
        vec![256, 512, 1024, 2048]
    }
}

/// Passes every method runs (but a VSV frame with grid shadows, which draws no map:
/// `Renderer::surface_shadows`: grid); the rest are the method's own ("volume" time).
pub const SHARED_PASSES: [Pass; 4] = [Pass::Surface, Pass::ShadowFit, Pass::ShadowMap, Pass::Composite];

/// Median times of one point.
#[derive(Debug, Clone, PartialEq)]
pub struct Timing {
    /// Median of the per-frame totals.
    pub total_ms: f64,
    /// Median of the per-frame sums of the method's own passes (not in [`SHARED_PASSES`]).
    pub volume_ms: f64,
    /// Median per pass, in pass order (empty without GPU timestamps: then the totals are wall clock).
    pub passes: Vec<(Pass, f64)>,
    pub frames: usize,
    /// Median of the per-frame totals of each round alone ([`BenchOptions::rounds`]), in order.
    pub round_ms: Vec<f64>,
}

/// One point of the error sweep.
#[derive(Debug, Clone)]
pub struct Row {
    pub point: Point,
    pub timing: Timing,
    /// The scattered light against the reference's.
    pub scatter: ErrorStats,
    /// The final image against the reference's.
    pub hdr: ErrorStats,
}

/// What a medium edit costs against a whole frame at one point, in wall-clock milliseconds (the
/// medians of `render_frame` followed by a wait for the GPU: what the editor waits for, without the
/// images' read-back). In an edit frame only the medium's density changes, so the renderer takes
/// the shadow map, the surfaces and the volume from the frame before ([`Renderer::reuse_unchanged`]).
#[derive(Debug, Clone)]
pub struct EditRow {
    pub point: Point,
    pub whole_ms: f64,
    pub edit_ms: f64,
}

/// One point of a scaling sweep.
#[derive(Debug, Clone)]
pub struct ScalingRow {
    pub point: Point,
    pub triangles: usize,
    pub width: u32,
    pub height: u32,
    pub timing: Timing,
}

/// Everything one benchmark measured.
#[derive(Debug, Clone)]
pub struct BenchResults {
    pub scene: String,
    pub triangles: usize,
    pub light: String,
    pub medium: String,
    pub width: u32,
    pub height: u32,
    pub adapter: String,
    /// "GPU timestamps" (on a CPU adapter with what their per-pass shares are good to) or, on an
    /// adapter without them, "wall clock (a frame submitted and waited for)".
    pub timing_source: &'static str,
    /// Rounds the error sweep was timed in ([`BenchOptions::rounds`]).
    pub rounds: usize,
    pub reference_key: String,
    pub reference_status: CacheStatus,
    pub reference_path: PathBuf,
    pub rows: Vec<Row>,
    pub triangle_rows: Vec<ScalingRow>,
    pub resolution_rows: Vec<ScalingRow>,
    /// A medium edit against a whole frame: VSV at the default grid and the baseline point its
    /// ratio is taken against.
    pub edit_rows: Vec<EditRow>,
    /// What was skipped and why.
    pub notes: Vec<String>,
    /// The files written.
    pub files: Vec<PathBuf>,
    pub seconds: f64,
}

/// The measured frames of one point: per frame its passes' GPU times and its wall-clock time.
#[derive(Debug, Clone, Default)]
struct Frames {
    passes: Vec<Vec<(Pass, f64)>>,
    wall: Vec<f64>,
    /// Frames per round, in order (they sum to `wall.len()`).
    rounds: Vec<usize>,
}

impl Frames {
    /// Adds `more` as one more round.
    fn pool(&mut self, more: Frames) {
        self.rounds.push(more.wall.len());
        self.passes.extend(more.passes);
        self.wall.extend(more.wall);
    }

    /// Medians over the frames: GPU timestamps where the adapter has them, else wall clock.
    fn timing(&self, timestamps: bool) -> Timing {
        let frames = self.wall.len();
        let totals: Vec<f64> = if timestamps {
            self.passes.iter().map(|f| f.iter().map(|p| p.1).sum()).collect()
        } else {
            self.wall.clone()
        };
        let round_ms = self.by_round(&totals).map(|r| median(r.to_vec())).collect();
        if !timestamps {
            return Timing { total_ms: median(totals), volume_ms: f64::NAN, passes: Vec::new(), frames, round_ms };
        }
        let per_frame = &self.passes;
        let total = median(totals);
        let volume = median(
            per_frame.iter().map(|f| f.iter().filter(|p| !SHARED_PASSES.contains(&p.0)).map(|p| p.1).sum()).collect(),
        );
        Timing { total_ms: total, volume_ms: volume, passes: pass_medians(per_frame), frames, round_ms }
    }

    /// Per round, the median of each pass over that round's frames alone (empty per round without
    /// GPU timestamps).
    fn round_pass_medians(&self) -> Vec<Vec<(Pass, f64)>> {
        self.by_round(&self.passes).map(pass_medians).collect()
    }

    /// `per_frame` (one entry a frame, in order) cut into the rounds' frames.
    fn by_round<'a, T>(&self, per_frame: &'a [T]) -> impl Iterator<Item = &'a [T]> + use<'a, '_, T> {
        self.rounds.iter().scan(0, move |start, &n| {
            let end = (*start + n).min(per_frame.len());
            let round = &per_frame[(*start).min(end)..end];
            *start = end;
            Some(round)
        })
    }
}

/// The median of each pass over `frames`, in the first frame's pass order.
fn pass_medians(frames: &[Vec<(Pass, f64)>]) -> Vec<(Pass, f64)> {
    let Some(first) = frames.first() else { return Vec::new() };
    first
        .iter()
        .map(|&(pass, _)| {
            let v = frames.iter().filter_map(|f| f.iter().find(|p| p.0 == pass).map(|p| p.1)).collect();
            (pass, median(v))
        })
        .collect()
}

/// Renders `warmup + frames` frames of `point` and returns the timed frames and the last one's
/// info. The frames follow each other with nothing but the next frame's set-up between them: a
/// hardware GPU is not left idle between timed frames (where it may lower its clocks) while
/// images are read back and compared (the error sweep does that once per point, after the timing).
fn time_frames(
    r: &mut Renderer,
    scene: &mut Scene,
    width: u32,
    height: u32,
    point: &Point,
    warmup: usize,
    frames: usize,
) -> Result<(Frames, crate::render::FrameInfo), RenderError> {
    r.set_shadow_map_size(point.shadow_map.min(r.ctx.device.limits().max_texture_dimension_2d))?;
    scene.grid = point.grid;
    for _ in 0..warmup {
        r.render_frame(scene, width, height, point.method)?;
    }
    let frames = frames.max(1);
    let mut timed =
        Frames { passes: Vec::with_capacity(frames), wall: Vec::with_capacity(frames), rounds: vec![frames] };
    let mut last = None;
    for _ in 0..frames {
        let started = Instant::now();
        let info = r.render_frame(scene, width, height, point.method)?;
        // (Reading the timestamps waits for the frame; without them this does.)
        r.ctx.wait()?;
        timed.wall.push(started.elapsed().as_secs_f64() * 1e3);
        timed.passes.push(info.timings.iter().map(|t| (t.pass, t.ms)).collect());
        last = Some(info);
    }
    let Some(last) = last else { unreachable!("frames >= 1") };
    Ok((timed, last))
}

/// Times `frames` whole frames of `point`, then `frames` frames that each change only the medium's
/// density (by 1%, back and forth), reusing what the edit leaves alone.
fn measure_edits(
    r: &mut Renderer,
    scene: &mut Scene,
    width: u32,
    height: u32,
    point: &Point,
    frames: usize,
) -> Result<EditRow, RenderError> {
    r.set_shadow_map_size(point.shadow_map.min(r.ctx.device.limits().max_texture_dimension_2d))?;
    scene.grid = point.grid;
    let density = scene.medium.density;
    let time = |r: &mut Renderer, scene: &mut Scene, reuse: bool| -> Result<f64, RenderError> {
        r.reuse_unchanged = reuse;
        // The warm-up frame, and the frame the first edit reuses.
        r.render_frame(scene, width, height, point.method)?;
        let mut wall = Vec::with_capacity(frames);
        for k in 0..frames.max(1) {
            if reuse {
                scene.medium.density = density * (1.0 + 0.01 * (k % 2) as f32);
            }
            let started = Instant::now();
            r.render_frame(scene, width, height, point.method)?;
            r.ctx.wait()?;
            wall.push(started.elapsed().as_secs_f64() * 1e3);
        }
        Ok(median(wall))
    };
    let times = time(r, scene, false).and_then(|whole| Ok((whole, time(r, scene, true)?)));
    r.reuse_unchanged = false;
    scene.medium.density = density;
    let (whole_ms, edit_ms) = times?;
    Ok(EditRow { point: *point, whole_ms, edit_ms })
}

fn median(mut v: Vec<f64>) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Errors closer than this (relative) count as equal on the Pareto front: a point that is slower
/// for a 0.1 % better error is not worth a place on it (and such differences are below the
/// run-to-run noise of the shadow map and the driver).
pub const PARETO_ERROR_TOLERANCE: f64 = 0.005;

/// For each (time, error) point: on the Pareto front, i.e. no other point is at least as fast and
/// at least as accurate (within [`PARETO_ERROR_TOLERANCE`]) and strictly better in one. Non-finite
/// points are never on it.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|a| {
            ok(a)
                && !points.iter().any(|b| {
                    ok(b) && b.0 <= a.0 && b.1 <= a.1 * (1.0 + PARETO_ERROR_TOLERANCE) && (b.0 < a.0 || b.1 < a.1)
                })
        })
        .collect()
}

/// The time a method needs to reach `error`, read off its Pareto front (time, error) by linear
/// interpolation in log-log between the two front points around it. `None` when no point of the
/// front is that accurate; the fastest front point's time when even it is more accurate (then the
/// true time may be lower: the sweep did not go faster).
pub fn time_at_error(front: &[(f64, f64)], error: f64) -> Option<f64> {
    let mut f: Vec<(f64, f64)> = front.iter().copied().filter(|p| p.0 > 0.0 && p.1 > 0.0).collect();
    f.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = f.iter().position(|p| p.1 <= error)?;
    if i == 0 {
        return Some(f[0].0);
    }
    let (a, b) = (f[i - 1], f[i]);
    let s = (error.ln() - a.1.ln()) / (b.1.ln() - a.1.ln());
    Some((a.0.ln() + s * (b.0.ln() - a.0.ln())).exp())
}

/// How a grid method's point compares with the baseline's sweep: the cheapest raymarch point that is
/// at least as accurate (its scattered light's relative RMSE no larger), and that point's time over
/// this one's. `None` when no raymarch point of the sweep is that accurate: then this point is
/// better than the whole sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselineRatio {
    /// The cheapest as-accurate raymarch point's setting and total time (ms).
    pub baseline: Option<(String, f64)>,
    /// `baseline time / this point's time`.
    pub ratio: Option<f64>,
    /// When no raymarch point is as accurate: the sweep's most accurate one (setting, time in ms,
    /// relative RMSE) and its time over this point's, a lower bound of the speed-up. Of the points
    /// within [`SAME_ERROR`] of the best error, the cheapest: errors that close are one error, and
    /// a dearer point that is better by a hair would only inflate the bound (the bunny on an H200:
    /// 0.04034% on the 8192 map against 0.0403% on the 4096 one, 62.6 against 35.0 ms).
    pub most_accurate: Option<(String, f64, f64, f64)>,
    /// The ratio (or its lower bound) of each round's medians alone, when both points were timed
    /// in the same rounds and there were at least two: how much a slow phase of the machine moved it.
    pub by_round: Vec<f64>,
}

impl BaselineRatio {
    /// `12.3x (vs 256 steps, map 2048)`, or for a point more accurate than the whole sweep
    /// `no raymarch point as accurate; the most accurate (..) takes 14.7x as long`; with
    /// `, 11.9x to 12.8x by round` after several rounds.
    pub fn describe(&self) -> String {
        let main = match (&self.baseline, self.ratio, &self.most_accurate) {
            (Some((setting, _)), Some(r), _) => format!("{r:.2}x (vs {setting})"),
            (_, _, Some((setting, _, err, r))) => format!(
                "no raymarch point as accurate; the most accurate ({setting}, {:.3}%) takes {r:.2}x as long",
                err * 100.0
            ),
            _ => return "no raymarch point as accurate".into(),
        };
        match self.round_range() {
            Some((lo, hi)) => format!("{main}, {lo:.2}x to {hi:.2}x by round"),
            None => main,
        }
    }

    /// The smallest and the largest of [`BaselineRatio::by_round`], when there are any.
    pub fn round_range(&self) -> Option<(f64, f64)> {
        let lo = self.by_round.iter().copied().reduce(f64::min)?;
        let hi = self.by_round.iter().copied().reduce(f64::max)?;
        Some((lo, hi))
    }
}

/// `baseline`'s time over `row`'s in each round alone (empty unless both have the same two or more).
fn ratios_by_round(baseline: &Row, row: &Row) -> Vec<f64> {
    let (b, r) = (&baseline.timing.round_ms, &row.timing.round_ms);
    if b.len() < 2 || b.len() != r.len() {
        return Vec::new();
    }
    b.iter().zip(r).map(|(b, r)| b / r).collect()
}

/// How a scaling point's frame grows with the scene: its time at the sweep's most triangles over
/// its time at the count nearest a tenth of that (issue 11's target 3: a million against 100 000).
#[derive(Debug, Clone, PartialEq)]
pub struct Growth {
    /// (triangles, ms) at the smaller and the larger count.
    pub small: (usize, f64),
    pub large: (usize, f64),
    /// `large / small` of the medians over all rounds.
    pub ratio: f64,
    /// The same ratio of each round's medians alone (empty with fewer than two rounds).
    pub by_round: Vec<f64>,
}

impl Growth {
    /// `107532 -> 1032204 triangles: 121 -> 259 ms, 2.14x (1.98x to 2.20x by round)`.
    pub fn describe(&self) -> String {
        let (sn, sm) = self.small;
        let (ln, lm) = self.large;
        let main = format!("{sn} -> {ln} triangles: {sm:.0} -> {lm:.0} ms, {:.2}x", self.ratio);
        let lo = self.by_round.iter().copied().reduce(f64::min);
        let hi = self.by_round.iter().copied().reduce(f64::max);
        match lo.zip(hi) {
            Some((lo, hi)) => format!("{main} ({lo:.2}x to {hi:.2}x by round)"),
            None => main,
        }
    }
}

/// The points of scaling `rows`, each once, in their order.
pub fn scaling_points_of(rows: &[ScalingRow]) -> Vec<Point> {
    let mut points: Vec<Point> = Vec::new();
    for row in rows {
        if !points.contains(&row.point) {
            points.push(row.point);
        }
    }
    points
}

/// [`Growth`] of `point` over the triangle sweep's `rows`; `None` with fewer than two counts.
pub fn triangle_growth(rows: &[ScalingRow], point: &Point) -> Option<Growth> {
    let mine: Vec<&ScalingRow> = rows.iter().filter(|r| r.point == *point).collect();
    let large = *mine.iter().max_by_key(|r| r.triangles)?;
    let tenth = large.triangles as f64 / 10.0;
    let small = *mine
        .iter()
        .filter(|r| r.triangles < large.triangles)
        .min_by(|a, b| (a.triangles as f64 - tenth).abs().total_cmp(&(b.triangles as f64 - tenth).abs()))?;
    let (s, l) = (&small.timing, &large.timing);
    let by_round = if s.round_ms.len() >= 2 && s.round_ms.len() == l.round_ms.len() {
        s.round_ms.iter().zip(&l.round_ms).map(|(s, l)| l / s).collect()
    } else {
        Vec::new()
    };
    Some(Growth {
        small: (small.triangles, s.total_ms),
        large: (large.triangles, l.total_ms),
        ratio: l.total_ms / s.total_ms,
        by_round,
    })
}

/// Relative difference of two errors below which [`BaselineRatio::most_accurate`] takes them as
/// the same.
pub const SAME_ERROR: f64 = 0.01;

/// [`BaselineRatio`] of `row` against the raymarch rows of `rows` (every point of the baseline's
/// sweep with a finite error counts).
pub fn baseline_ratio(rows: &[Row], row: &Row) -> BaselineRatio {
    let cheapest = rows
        .iter()
        .filter(|b| b.point.method_name() == "raymarch")
        .filter(|b| b.scatter.rel_rmse.is_finite() && b.timing.total_ms.is_finite())
        .filter(|b| b.scatter.rel_rmse <= row.scatter.rel_rmse)
        .min_by(|a, b| a.timing.total_ms.total_cmp(&b.timing.total_ms));
    match cheapest {
        Some(b) => BaselineRatio {
            baseline: Some((b.point.setting(), b.timing.total_ms)),
            ratio: Some(b.timing.total_ms / row.timing.total_ms),
            most_accurate: None,
            by_round: ratios_by_round(b, row),
        },
        None => {
            let marches = || {
                rows.iter()
                    .filter(|b| b.point.method_name() == "raymarch")
                    .filter(|b| b.scatter.rel_rmse.is_finite() && b.timing.total_ms.is_finite())
            };
            let least = marches().map(|b| b.scatter.rel_rmse).reduce(f64::min);
            let best = least.and_then(|e| {
                marches()
                    .filter(|b| b.scatter.rel_rmse <= e * (1.0 + SAME_ERROR))
                    .min_by(|a, b| a.timing.total_ms.total_cmp(&b.timing.total_ms))
            });
            BaselineRatio {
                baseline: None,
                ratio: None,
                most_accurate: best.map(|b| {
                    (b.point.setting(), b.timing.total_ms, b.scatter.rel_rmse, b.timing.total_ms / row.timing.total_ms)
                }),
                by_round: best.map(|b| ratios_by_round(b, row)).unwrap_or_default(),
            }
        }
    }
}

fn style(len: u64, progress: bool) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if !progress {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    if let Ok(s) = ProgressStyle::with_template("{prefix:>10} [{bar:30}] {pos}/{len} {elapsed_precise} {wide_msg}") {
        bar.set_style(s.progress_chars("=> "));
    }
    bar
}

/// Runs the whole benchmark of `scene` on `renderer` and writes the files into `opts.out_dir`.
pub fn run(renderer: &mut Renderer, scene: &Scene, opts: &BenchOptions) -> Result<BenchResults, BenchError> {
    // Every timed frame runs every pass: the sweep repeats identical frames, which would otherwise
    // take the shadow map, the surfaces and the volume from the frame before and time the rest.
    let reuse = std::mem::replace(&mut renderer.reuse_unchanged, false);
    let results = run_sweeps(renderer, scene, opts);
    renderer.reuse_unchanged = reuse;
    results
}

fn run_sweeps(renderer: &mut Renderer, scene: &Scene, opts: &BenchOptions) -> Result<BenchResults, BenchError> {
    let started = Instant::now();
    let (w, h) = (opts.width, opts.height);
    let out = &opts.out_dir;
    std::fs::create_dir_all(out).map_err(|source| BenchError::Io { op: "create", path: out.clone(), source })?;
    let mut notes = Vec::new();

    // The reference first: it is what every point is compared against.
    let reference = cached_reference(
        scene,
        w,
        h,
        &ReferenceOptions { progress: opts.progress, ..opts.reference },
        &opts.cache_dir,
    )?;
    if let CacheStatus::Rendered { seconds } = reference.status {
        if opts.progress {
            eprintln!("reference rendered in {seconds:.1} s and cached as {}", reference.path.display());
        }
    }

    notes.push(if renderer.scan_columns {
        "Scan: a workgroup per plane where rays start on four words (scan_columns.wgsl; \
         `--scan columns`, a hardware GPU's default), a thread per column elsewhere"
            .into()
    } else {
        "Scan: a thread per column (scan.wgsl, scan_words.wgsl; `--scan threads`, a CPU adapter's default)".into()
    });
    // What the choice means is SurfaceShadows::doc's; the note adds where the report shows it.
    let shadows = renderer.surface_shadows;
    let shown = match shadows {
        SurfaceShadows::Grid => " `final` shows what that does to the surfaces.",
        SurfaceShadows::Exact => " `exact_shadows` in the table, counted in VSV's volume time.",
        SurfaceShadows::Map => "",
    };
    notes.push(format!("VSV's surface shadows (`--surface-shadows {}`): {}.{shown}", shadows.label(), shadows.doc()));
    let volume = renderer.shadow_volume;
    let shown = match volume {
        ShadowVolume::FirstHits => " `hit_bounds` in the table takes `scan`'s place.",
        ShadowVolume::Bits => "",
    };
    notes.push(format!("VSV's shadow volume (`--volume {}`): {}.{shown}", volume.label(), volume.doc()));
    notes.push(if renderer.adaptive_pixels {
        "VSV's Integrate: every fourth pixel along the epipolar lines, then the others where their neighbours \
         on the line do not stand for them (`--pixels adaptive`, the default)"
            .into()
    } else {
        "VSV's Integrate: every pixel (`--pixels all`)".into()
    });
    let mut points = error_sweep(opts.quick);
    add_grids(&mut points, &opts.extra_grids);
    if let Err(e) = FrameSetup::new(scene, w, h, Method::Cartesian) {
        notes.push(format!("cartesian: skipped, it does not apply to this view and light: {e}"));
        points.retain(|p| p.method != Method::Cartesian);
    }
    let scaling = scaling_points(opts.quick);
    let tri_counts = if opts.scaling { triangle_sweep(opts.quick) } else { Vec::new() };
    let sizes = if opts.scaling { resolution_sweep(opts.quick) } else { Vec::new() };
    // The triangle sweep runs in rounds too (it is what issue 11's target 3 reads), the image sizes
    // once.
    let total = points.len() + scaling.len() * (tri_counts.len() * opts.rounds.max(1) + sizes.len());
    let bar = style(total as u64, opts.progress);
    bar.set_prefix("bench");

    let mut work = scene.clone();
    let mut rows: Vec<Row> = Vec::new();
    // Each row's timed frames, pooled over the rounds.
    let mut timed: Vec<Frames> = Vec::new();
    // The most accurate scattered-light image of each method, for a look beside the reference.
    let mut best: Vec<(&'static str, f64, crate::image::Image)> = Vec::new();
    let mut first_failure = None;
    let max_map = renderer.ctx.device.limits().max_texture_dimension_2d;
    let timestamps = renderer.ctx.timestamps;
    let mut measure_point = |p: &Point,
                             frames: usize,
                             rows: &mut Vec<Row>,
                             timed: &mut Vec<Frames>,
                             notes: &mut Vec<String>|
     -> Result<(), BenchError> {
        bar.set_message(format!("{} {}", p.method_name(), p.setting()));
        let measured = time_frames(renderer, &mut work, w, h, p, opts.warmup, frames)
            .and_then(|(frames, last)| Ok((frames, renderer.read_output(last)?)));
        match measured {
            Ok((frames, o)) => {
                let timing = frames.timing(timestamps);
                timed.push(frames);
                let scatter = metrics::compare(&o.scatter, &reference.scatter)?;
                let hdr = metrics::compare(&o.hdr, &reference.hdr)?;
                let name = p.method_name();
                match best.iter_mut().find(|b| b.0 == name) {
                    Some(b) if scatter.rel_rmse < b.1 => *b = (name, scatter.rel_rmse, o.scatter),
                    Some(_) => {}
                    None => best.push((name, scatter.rel_rmse, o.scatter)),
                }
                rows.push(Row { point: *p, timing, scatter, hdr });
            }
            Err(e) => {
                let msg = format!("{} {}: skipped, it failed: {e}", p.method_name(), p.setting());
                bar.println(&msg);
                first_failure.get_or_insert_with(|| msg.clone());
                notes.push(msg);
            }
        }
        bar.inc(1);
        Ok(())
    };
    for p in &points {
        measure_point(p, opts.frames, &mut rows, &mut timed, &mut notes)?;
    }
    // Equal error needs a baseline point as accurate as each VSV point: while the sweep has none
    // for the most accurate one, refine the march on the chase maps in turn.
    if !opts.quick {
        let mut maps: Vec<u32> = CHASE_MAPS.iter().map(|&m| m.min(max_map)).collect();
        maps.dedup();
        while let Some(p) = next_chase_point(&rows, &maps) {
            bar.inc_length(1);
            let before = rows.len();
            // These take seconds a frame: three are enough for a median.
            measure_point(&p, opts.frames.min(3), &mut rows, &mut timed, &mut notes)?;
            if rows.len() == before {
                break; // it failed (noted): a finer march would fail too
            }
        }
    }
    // Further rounds time every point again, in the same order and with as many frames, so that a
    // slow phase of a shared machine falls on all of them alike; a point's time is the median of
    // its frames from all rounds (its image and error are those of the first).
    let per_round: Vec<usize> = timed.iter().map(|f| f.wall.len()).collect();
    for round in 2..=opts.rounds {
        bar.inc_length(rows.len() as u64);
        for ((row, pooled), &frames) in rows.iter_mut().zip(timed.iter_mut()).zip(&per_round) {
            let (name, setting) = (row.point.method_name(), row.point.setting());
            bar.set_message(format!("round {round} of {}: {name} {setting}", opts.rounds));
            match time_frames(renderer, &mut work, w, h, &row.point, opts.warmup, frames) {
                Ok((more, _)) => {
                    pooled.pool(more);
                    row.timing = pooled.timing(timestamps);
                }
                Err(e) => notes
                    .push(format!("{name} {setting}: round {round} failed, its time is from the rounds before: {e}")),
            }
            bar.inc(1);
        }
    }
    if rows.is_empty() {
        return Err(BenchError::NothingRendered(first_failure.unwrap_or_else(|| "the sweep is empty".into())));
    }

    // What the editor waits for when an artist tunes the medium: VSV at the default grid and the
    // baseline point its ratio is taken against.
    let mut edit_rows = Vec::new();
    let vsv = rows.iter().find(|r| r.point.method == Method::Vsv && r.point.grid == Grid::default());
    let march = vsv.and_then(|v| {
        let setting = baseline_ratio(&rows, v).baseline?.0;
        rows.iter().find(|r| r.point.method_name() == "raymarch" && r.point.setting() == setting)
    });
    let edit_points: Vec<Point> = vsv.into_iter().chain(march).map(|r| r.point).collect();
    bar.inc_length(edit_points.len() as u64);
    for p in &edit_points {
        bar.set_message(format!("a medium edit: {} {}", p.method_name(), p.setting()));
        match measure_edits(renderer, &mut work, w, h, p, opts.frames.min(5)) {
            Ok(row) => edit_rows.push(row),
            Err(e) => {
                notes.push(format!("a medium edit, {} {}: skipped, it failed: {e}", p.method_name(), p.setting()))
            }
        }
        bar.inc(1);
    }

    // Every round times every room once, in the same order, so that a slow phase of the machine
    // falls on all of them alike; each row pools its rounds' frames (`Frames::pool`).
    let mut rooms: Vec<Scene> = tri_counts.iter().map(|&n| procedural_scene(n)).collect();
    let mut triangle_frames: Vec<(Point, usize, Frames)> = Vec::new();
    for round in 1..=opts.rounds.max(1) {
        for room in rooms.iter_mut() {
            let tri = room.triangle_count();
            for p in &scaling {
                bar.set_message(format!(
                    "round {round}: {} {} at {w}x{h}, {tri} triangles",
                    p.method_name(),
                    p.setting()
                ));
                // Median of 3 after one warm-up: these points only time, and the largest take long.
                match time_frames(renderer, room, w, h, p, 1, opts.frames.min(3)) {
                    Ok((frames, _)) => match triangle_frames.iter_mut().find(|(q, n, _)| q == p && *n == tri) {
                        Some((_, _, pooled)) => pooled.pool(frames),
                        None => triangle_frames.push((*p, tri, frames)),
                    },
                    Err(e) => notes.push(format!(
                        "{} {} at {w}x{h} with {tri} triangles, round {round}: skipped, it failed: {e}",
                        p.method_name(),
                        p.setting(),
                    )),
                }
                bar.inc(1);
            }
        }
    }
    drop(rooms);
    let triangle_rows: Vec<ScalingRow> = triangle_frames
        .into_iter()
        .map(|(point, triangles, frames)| ScalingRow {
            point,
            triangles,
            width: w,
            height: h,
            timing: frames.timing(timestamps),
        })
        .collect();

    let mut scale = |scene: &mut Scene,
                     tri: usize,
                     size: (u32, u32),
                     sink: &mut Vec<ScalingRow>,
                     notes: &mut Vec<String>| {
        for p in &scaling {
            bar.set_message(format!("{} {} at {}x{}, {tri} triangles", p.method_name(), p.setting(), size.0, size.1));
            // Median of 3 after one warm-up: these points only time, and the largest take long.
            match time_frames(renderer, scene, size.0, size.1, p, 1, opts.frames.min(3)) {
                Ok((frames, _)) => {
                    let timing = frames.timing(timestamps);
                    sink.push(ScalingRow { point: *p, triangles: tri, width: size.0, height: size.1, timing })
                }
                Err(e) => notes.push(format!(
                    "{} {} at {}x{} with {tri} triangles: skipped, it failed: {e}",
                    p.method_name(),
                    p.setting(),
                    size.0,
                    size.1
                )),
            }
            bar.inc(1);
        }
    };
    let mut resolution_rows = Vec::new();
    for &s in &sizes {
        let tri = work.triangle_count();
        scale(&mut work, tri, (s, s), &mut resolution_rows, &mut notes);
    }
    bar.finish_and_clear();
    if !opts.scaling {
        notes.push("the triangle and resolution sweeps were not run (--no-scaling)".into());
    }

    let timing_source = match (renderer.ctx.timestamps, renderer.ctx.info.device_type) {
        // llvmpipe takes a timestamp at its next flush (src/gpu/timing.rs): a frame's total is
        // exact, but a few ms can land in the pass before or after their own.
        (true, wgpu::DeviceType::Cpu) => "GPU timestamps (a frame's total exact; on this CPU adapter a pass's share good to a few ms, docs/results.md session 38)",
        (true, _) => "GPU timestamps",
        (false, _) => "wall clock (a frame submitted and waited for)",
    };
    let light = match scene.light {
        crate::params::Light::Point { position, intensity, radius } => {
            format!("point light at {position}, intensity {intensity}, radius {radius}")
        }
        crate::params::Light::Directional { direction, irradiance } => {
            format!("directional light toward {direction}, irradiance {irradiance}")
        }
    };
    let m = &scene.medium;
    let medium = format!("sigma_s {}, sigma_t {}, phase {:?}", m.sigma_s(), m.sigma_t(), m.phase);
    let mut results = BenchResults {
        scene: scene.name.clone(),
        triangles: scene.triangle_count(),
        light,
        medium,
        width: w,
        height: h,
        adapter: renderer.ctx.adapter_name(),
        timing_source,
        rounds: opts.rounds.max(1),
        reference_key: reference.key.clone(),
        reference_status: reference.status,
        reference_path: reference.path.clone(),
        rows,
        triangle_rows,
        resolution_rows,
        edit_rows,
        notes,
        files: Vec::new(),
        seconds: 0.0,
    };
    results.files = report::write_all(&results, out)?;
    results.files.extend(write_scatter_images(&reference.scatter, &best, out)?);
    results.seconds = started.elapsed().as_secs_f64();
    // The report states the run time: write it once more now that it is known.
    report::write_markdown(&results, out)?;
    Ok(results)
}

/// `scatter_reference.png` and `scatter_<method>.png` (each method's most accurate point), all at
/// one exposure: the reference's 99.5th percentile maps to 2.5 before tone mapping.
fn write_scatter_images(
    reference: &crate::image::Image,
    best: &[(&'static str, f64, crate::image::Image)],
    dir: &Path,
) -> Result<Vec<PathBuf>, BenchError> {
    let mut v: Vec<f32> = reference.pixels.iter().flat_map(|p| p.iter().copied()).filter(|c| c.is_finite()).collect();
    v.sort_by(|a, b| a.total_cmp(b));
    let p = v.get(v.len().saturating_sub(1).min(v.len() * 995 / 1000)).copied().unwrap_or(0.0);
    let exposure = if p > 0.0 { (2.5 / p).log2() } else { 0.0 };
    let mut files = Vec::new();
    let path = dir.join("scatter_reference.png");
    reference.write_png(&path, exposure)?;
    files.push(path);
    for (name, _, img) in best {
        let path = dir.join(format!("scatter_{name}.png"));
        img.write_png(&path, exposure)?;
        files.push(path);
    }
    Ok(files)
}

/// The directory's files a benchmark writes.
pub fn output_files(dir: &Path) -> [PathBuf; 5] {
    [
        dir.join("results.csv"),
        dir.join("report.md"),
        dir.join("error_vs_time.png"),
        dir.join("time_vs_triangles.png"),
        dir.join("time_vs_resolution.png"),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let p = [(1.0, 0.5), (2.0, 0.2), (3.0, 0.3), (4.0, 0.1), (2.0, 0.25), (f64::NAN, 0.0)];
        assert_eq!(pareto_front(&p), [true, true, false, true, false, false]);
        // Slower for an error better by less than the tolerance: off the front.
        assert_eq!(pareto_front(&[(1.0, 0.1002), (2.0, 0.1)]), [true, false]);
        assert_eq!(pareto_front(&[(1.0, 0.11), (2.0, 0.1)]), [true, true]);
    }

    #[test]
    fn time_at_error_interpolates_in_log_log() {
        let f = [(1.0, 0.1), (100.0, 0.001)];
        assert!((time_at_error(&f, 0.01).unwrap() - 10.0).abs() < 1e-9);
        assert_eq!(time_at_error(&f, 0.5), Some(1.0));
        assert_eq!(time_at_error(&f, 1e-4), None);
    }

    #[test]
    fn extra_grids_join_the_sweep_once_each_on_its_map() {
        let mut points = error_sweep(false);
        let before = points.len();
        let map = points[0].shadow_map;
        let new = Grid { planes: 4096, rays: 256, bins: 768, ..Grid::default() };
        // The default grid is in the sweep already; the new one is asked for twice.
        add_grids(&mut points, &[Grid::default(), new, new]);
        assert_eq!(points.len(), before + 1);
        assert_eq!(points[before], Point::vsv(new, map));
        assert_eq!(points.iter().filter(|p| p.method == Method::Vsv && p.grid == Grid::default()).count(), 1);
        // A sweep without VSV points takes the baseline's default map.
        let mut none = Vec::new();
        add_grids(&mut none, &[new]);
        assert_eq!(none, [Point::vsv(new, crate::params::Baseline::default().shadow_map)]);
    }

    fn row(point: Point, ms: f64, err: f64) -> Row {
        let stats =
            ErrorStats { rel_rmse: err, rmse: err, max_abs: err, psnr: 0.0, mean_ref: 1.0, non_finite: 0, pixels: 1 };
        Row {
            point,
            timing: Timing { total_ms: ms, volume_ms: ms, passes: Vec::new(), frames: 1, round_ms: vec![ms] },
            scatter: stats,
            hdr: stats,
        }
    }

    #[test]
    fn triangle_growth_divides_the_most_triangles_by_the_count_nearest_a_tenth() {
        let vsv = Point::vsv(PAPER_GRID, 2048);
        let march = Point::march(256, 2048, false);
        let scaling = |point, triangles, rounds: &[f64]| ScalingRow {
            point,
            triangles,
            width: 8,
            height: 8,
            timing: Timing {
                total_ms: median(rounds.to_vec()),
                volume_ms: f64::NAN,
                passes: Vec::new(),
                frames: rounds.len(),
                round_ms: rounds.to_vec(),
            },
        };
        let rows = [
            scaling(vsv, 10_000, &[80.0, 90.0, 85.0]),
            scaling(vsv, 100_000, &[100.0, 130.0, 120.0]),
            scaling(vsv, 300_000, &[150.0, 150.0, 150.0]),
            scaling(vsv, 1_000_000, &[200.0, 240.0, 300.0]),
            scaling(march, 10_000, &[50.0]),
        ];
        assert_eq!(scaling_points_of(&rows), [vsv, march]);
        let g = triangle_growth(&rows, &vsv).unwrap();
        // Against 100 000 (nearest 1 000 000 / 10), not 300 000 or 10 000.
        assert_eq!((g.small, g.large), ((100_000, 120.0), (1_000_000, 240.0)));
        assert_eq!(g.ratio, 2.0);
        // A slow phase in the second round moves both counts: each round's own ratio.
        assert_eq!(g.by_round, [2.0, 240.0 / 130.0, 2.5]);
        assert!(g.describe().ends_with("2.00x (1.85x to 2.50x by round)"), "{}", g.describe());
        // One count is no growth.
        assert_eq!(triangle_growth(&rows, &march), None);
    }

    #[test]
    fn baseline_ratio_takes_the_cheapest_as_accurate_march() {
        let rows = [
            row(Point::march(16, 2048, false), 10.0, 0.20),
            row(Point::march(64, 2048, false), 40.0, 0.05),
            row(Point::march(256, 4096, false), 100.0, 0.03),
            row(Point::march(1024, 2048, false), 300.0, 0.04),
            row(Point::grid(Method::Vsv, 1024, 1024, 256, 2048), 20.0, 0.04),
            row(Point::grid(Method::Vsv, 1024, 1024, 1024, 2048), 25.0, 0.01),
        ];
        let r = baseline_ratio(&rows, &rows[4]);
        assert_eq!(r.baseline, Some(("256 steps, map 4096".to_string(), 100.0)));
        assert_eq!(r.ratio, Some(5.0));
        let better = baseline_ratio(&rows, &rows[5]);
        assert_eq!((&better.baseline, better.ratio), (&None, None));
        assert_eq!(better.most_accurate, Some(("256 steps, map 4096".to_string(), 100.0, 0.03, 4.0)));
        assert!(better.describe().contains("no raymarch point as accurate; the most accurate"));
        // A dearer point better by a hair (within SAME_ERROR) does not raise the bound.
        let mut hair = rows.to_vec();
        hair.push(row(Point::march(4096, 8192, false), 400.0, 0.0299));
        let bound = baseline_ratio(&hair, &hair[5]);
        assert_eq!(bound.most_accurate, Some(("256 steps, map 4096".to_string(), 100.0, 0.03, 4.0)));
        // One better by more is the bound.
        hair.push(row(Point::march(4096, 4096, false), 300.0, 0.02));
        let bound = baseline_ratio(&hair, &hair[5]);
        assert_eq!(bound.most_accurate, Some(("4096 steps, map 4096".to_string(), 300.0, 0.02, 12.0)));
    }

    #[test]
    fn each_round_has_its_own_median_and_ratio() {
        // Two rounds of three frames; the second round is slower (a slow phase of the machine).
        let frames = Frames { passes: Vec::new(), wall: vec![10.0, 11.0, 30.0, 20.0, 21.0, 22.0], rounds: vec![3, 3] };
        let t = frames.timing(false);
        assert_eq!(t.round_ms, vec![11.0, 21.0]);
        assert_eq!(t.total_ms, 20.5);
        // With timestamps the rounds split the per-frame sums of the passes.
        let passes = Frames {
            passes: vec![
                vec![(Pass::Scan, 1.0), (Pass::Integrate, 2.0)],
                vec![(Pass::Scan, 3.0), (Pass::Integrate, 4.0)],
            ],
            wall: vec![100.0, 100.0],
            rounds: vec![1, 1],
        };
        assert_eq!(passes.timing(true).round_ms, vec![3.0, 7.0]);

        let mut vsv = row(Point::grid(Method::Vsv, 2048, 512, 768, 2048), 100.0, 0.01);
        vsv.timing.round_ms = vec![100.0, 125.0];
        let mut march = row(Point::march(1024, 8192, false), 400.0, 0.009);
        march.timing.round_ms = vec![420.0, 375.0];
        let r = baseline_ratio(&[vsv.clone(), march.clone()], &vsv);
        assert_eq!(r.by_round, vec![4.2, 3.0]);
        assert_eq!(r.round_range(), Some((3.0, 4.2)));
        assert_eq!(r.describe(), "4.00x (vs 1024 steps, map 8192), 3.00x to 4.20x by round");
        // Points timed in different numbers of rounds are not compared round by round.
        march.timing.round_ms = vec![400.0];
        assert!(baseline_ratio(&[vsv.clone(), march], &vsv).by_round.is_empty());
    }

    #[test]
    fn the_chase_refines_the_march_map_by_map_until_it_is_as_accurate() {
        let maps = [4096, 8192];
        let vsv = row(Point::grid(Method::Vsv, 2048, 512, 768, 2048), 270.0, 0.0099);
        let mut rows = vec![
            vsv.clone(),
            row(Point::march(512, 4096, false), 520.0, 0.0163),
            row(Point::march(1024, 4096, false), 900.0, 0.01235),
            // A jittered march never counts toward the chase (nor is it a map to refine).
            row(Point::march(4096, 2048, true), 3000.0, 0.02),
        ];
        assert_eq!(next_chase_point(&rows, &maps), Some(Point::march(2048, 4096, false)));
        rows.push(row(Point::march(2048, 4096, false), 1800.0, 0.0116));
        assert_eq!(next_chase_point(&rows, &maps), Some(Point::march(4096, 4096, false)));
        // Still 2.6% better for twice the steps, and 12x VSV's time: on to 8192 steps.
        rows.push(row(Point::march(4096, 4096, false), 3300.0, 0.0113));
        assert_eq!(next_chase_point(&rows, &maps), Some(Point::march(8192, 4096, false)));
        // Under 2% better: the map's texels are the limit, so the finer map starts at CHASE_FIRST_STEPS.
        rows.push(row(Point::march(8192, 4096, false), 6600.0, 0.0111));
        assert_eq!(next_chase_point(&rows, &maps), Some(Point::march(1024, 8192, false)));
        rows.push(row(Point::march(1024, 8192, false), 1150.0, 0.00976));
        assert_eq!(next_chase_point(&rows, &maps), None, "as accurate as VSV: done");
        // A map whose doubled steps gain under 2% is spent; with no finer map the chase ends.
        let limited = vec![
            vsv.clone(),
            row(Point::march(1024, 4096, false), 900.0, 0.0124),
            row(Point::march(2048, 4096, false), 1800.0, 0.0123),
        ];
        assert_eq!(next_chase_point(&limited, &[4096]), None);
        assert_eq!(next_chase_point(&limited, &maps), Some(Point::march(1024, 8192, false)));
        // Nothing to chase without a VSV point.
        assert_eq!(next_chase_point(&limited[1..], &maps), None);
        // A march limited by its steps (the bunny on the H200): the steps go on doubling past
        // 4096 while the march costs under CHASE_MAX_RATIO times VSV's frame...
        let bunny = row(Point::grid(Method::Vsv, 2048, 512, 768, 2048), 3.66, 0.00030);
        let mut steps = vec![
            bunny.clone(),
            row(Point::march(2048, 4096, false), 23.0, 0.000465),
            row(Point::march(4096, 4096, false), 34.9, 0.000403),
        ];
        assert_eq!(next_chase_point(&steps, &[4096]), Some(Point::march(8192, 4096, false)));
        // ...and the map is spent once its march takes that much (73.2 ms here): the lower bound
        // is then at least 20x.
        steps.push(row(Point::march(8192, 4096, false), 74.0, 0.000350));
        assert_eq!(next_chase_point(&steps, &[4096]), None);
        assert_eq!(next_chase_point(&steps, &maps), Some(Point::march(1024, 8192, false)));
        // The steps' own limit.
        let top = vec![
            bunny,
            row(Point::march(CHASE_MAX_STEPS / 2, 4096, false), 30.0, 0.00050),
            row(Point::march(CHASE_MAX_STEPS, 4096, false), 60.0, 0.00040),
        ];
        assert_eq!(next_chase_point(&top, &[4096]), None);
    }

    #[test]
    fn medians() {
        assert_eq!(median(vec![3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(vec![4.0, 1.0, 2.0, 3.0]), 2.5);
        assert!(median(vec![]).is_nan());
    }
}

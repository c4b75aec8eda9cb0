//! Progressive refinement: how coarse a preview must be to arrive within the budget, judged from
//! how long recent frames took on this machine.
//!
//! Frames made while the hand moves (interactive: the UI repaints flat out and takes its share of
//! a software driver's cores) are modelled apart from the others: on 2 cores the same preview
//! costs two to three times more during a drag than after it. Frames that compiled shaders (a
//! renderer's first frame, the first after a reload) are not recorded at all (`record`'s caller).
//!
//! A frame's time is modelled as `a + b * units`, where the units are the frame's grid cells
//! (planes x rays: voxelization, which dominates on the software driver, draws one texel per cell
//! a triangle covers) plus its pixels at a third of a cell each (measured on llvmpipe: about
//! 2.4 us per cell and 0.7 us per pixel). A preview scales both by `s^2` (pixels and planes and rays
//! each by `s`), keeps the method, and so looks like the full frame, only coarser.

use crate::params::Grid;
use crate::render::Method;
use std::collections::VecDeque;

/// What a preview should take (ms): about what a hand notices as lag.
pub const PREVIEW_BUDGET_MS: f64 = 120.0;

/// The preview scales tried, largest first (steps of sqrt(2), so sizes stay stable while the
/// estimate moves a little).
pub const LEVELS: [f32; 9] = [0.707, 0.5, 0.354, 0.25, 0.177, 0.125, 0.088, 0.0625, 0.044];

/// The work of a frame in the model's units.
pub fn work_units(width: u32, height: u32, grid: Grid, method: Method) -> f64 {
    let pixels = width as f64 * height as f64 * 0.3;
    match method {
        // Each pixel marches its steps; 16 steps cost about what one VSV pixel does.
        Method::Raymarch { steps, .. } => pixels * (steps as f64 / 16.0).max(1.0),
        _ => pixels + grid.planes as f64 * grid.rays as f64,
    }
}

/// The pixels' scale at grid scale `s`: the pixels cost far less than the grid (for VSV), so they
/// are cut less — at most to half the side, never below the grid's scale.
pub fn pixel_scale(s: f32) -> f32 {
    (2.0 * s).min(0.5).max(s)
}

/// The frame at preview level `s`: a grid with `s` times the planes, rays and bins, and
/// [`pixel_scale`]`(s)` times the pixels per side, within the grid's ranges.
pub fn scaled(width: u32, height: u32, grid: Grid, s: f32) -> (u32, u32, Grid) {
    let sp = pixel_scale(s);
    let px = |v: u32| ((v as f32 * sp).round() as u32).clamp(8.min(v), v);
    let cells = |v: u32, min: f64| ((v as f32 * s).round() as u32).max(min as u32).min(v);
    // Bins in whole words, at least one.
    let bins = (((grid.bins as f32 * s) / 32.0).round() as u32).max(1) * 32;
    let g = Grid {
        planes: cells(grid.planes, Grid::PLANES.min),
        rays: cells(grid.rays, Grid::RAYS.min),
        bins: bins.min(grid.bins),
        ..grid
    };
    (px(width), px(height), g)
}

/// Recent frame times of one method family, and the prediction from them.
#[derive(Debug, Clone)]
pub struct FrameTimes {
    /// (method is ray marching, made while interactive, units, ms), newest last.
    samples: VecDeque<(bool, bool, f64, f64)>,
    /// The model before any frame was measured: (a ms, b ms per unit).
    prior: (f64, f64),
}

impl FrameTimes {
    const KEEP: usize = 12;

    /// `software`: the adapter is a CPU (the software Vulkan driver), where frames take seconds.
    pub fn new(software: bool) -> FrameTimes {
        // Software: ~0.15 s of fixed work (shadow map, passes' set-up) and ~2.4 us per unit, as
        // measured on llvmpipe with the default grid. A GPU: about a thousand times less.
        let prior = if software { (150.0, 2.4e-3) } else { (1.0, 2.0e-6) };
        FrameTimes { samples: VecDeque::new(), prior }
    }

    /// A frame of `units` with `method` took `ms`; `interactive`: made while the input moved.
    pub fn record(&mut self, method: Method, interactive: bool, units: f64, ms: f64) {
        if !(ms.is_finite() && ms >= 0.0 && units > 0.0) {
            return;
        }
        self.samples.push_back((matches!(method, Method::Raymarch { .. }), interactive, units, ms));
        while self.samples.len() > Self::KEEP {
            self.samples.pop_front();
        }
    }

    /// Predicted time (ms) of a frame of `units` with `method`, made while `interactive` or not
    /// (from the frames made the same way when there are any, else from all of the family).
    pub fn predict(&self, method: Method, interactive: bool, units: f64) -> f64 {
        let march = matches!(method, Method::Raymarch { .. });
        let family = || self.samples.iter().filter(|(m, ..)| *m == march);
        let same: Vec<(f64, f64)> =
            family().filter(|(_, i, ..)| *i == interactive).map(|(.., u, t)| (*u, *t)).collect();
        let s = if same.is_empty() { family().map(|(.., u, t)| (*u, *t)).collect() } else { same };
        let (a0, b0) = self.prior;
        let prior = |u: f64| a0 + b0 * u;
        if s.is_empty() {
            return prior(units);
        }
        let (lo, hi) = s.iter().fold((f64::MAX, 0.0f64), |(lo, hi), (u, _)| (lo.min(*u), hi.max(*u)));
        if s.len() >= 3 && hi >= 2.0 * lo {
            // Least squares for a + b u over samples that span sizes.
            let n = s.len() as f64;
            let (mu, mt) = (s.iter().map(|p| p.0).sum::<f64>() / n, s.iter().map(|p| p.1).sum::<f64>() / n);
            let suu: f64 = s.iter().map(|p| (p.0 - mu).powi(2)).sum();
            let sut: f64 = s.iter().map(|p| (p.0 - mu) * (p.1 - mt)).sum();
            let b = (sut / suu).max(0.0);
            let a = (mt - b * mu).max(0.0);
            return a + b * units;
        }
        // Too few sizes to fit a line: the prior's shape scaled to the observed times (median of
        // the ratios, so one frame slowed by other work does not decide).
        let mut k: Vec<f64> = s.iter().map(|(u, t)| t / prior(*u)).collect();
        k.sort_by(f64::total_cmp);
        k[k.len() / 2] * prior(units)
    }

    /// The largest preview level predicted to fit `budget_ms` for a full frame of `width x height`
    /// with `grid`. Where a frame's fixed cost alone exceeds the budget (the software driver's
    /// per-triangle work), no level fits: then the largest one within a quarter more time than
    /// the smallest, since a much finer picture costs little more.
    pub fn preview_scale(
        &self,
        width: u32,
        height: u32,
        grid: Grid,
        method: Method,
        interactive: bool,
        budget_ms: f64,
    ) -> f32 {
        let time = |s: f32| {
            let (w, h, g) = scaled(width, height, grid, s);
            self.predict(method, interactive, work_units(w, h, g, method))
        };
        let smallest = LEVELS[LEVELS.len() - 1];
        let target = budget_ms.max(1.25 * time(smallest));
        LEVELS.iter().copied().find(|s| time(*s) <= target).unwrap_or(smallest)
    }

    /// Whether a full frame of `units` is slow enough that a preview should come first.
    pub fn wants_preview(&self, method: Method, interactive: bool, units: f64, budget_ms: f64) -> bool {
        self.predict(method, interactive, units) > budget_ms * 1.5
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fit_follows_measured_frames_and_picks_a_scale_within_budget() {
        let mut t = FrameTimes::new(true);
        // A machine where a frame costs 50 ms plus 1 us per unit.
        let truth = |u: f64| 50.0 + 1e-3 * u;
        let full = work_units(640, 480, Grid::default(), Method::Vsv);
        for s in [1.0f64, 0.5, 0.25, 0.125] {
            let u = full * s * s;
            t.record(Method::Vsv, false, u, truth(u));
        }
        for u in [1e4, 1e5, 1e6] {
            assert!((t.predict(Method::Vsv, false, u) - truth(u)).abs() < 1.0, "{u}");
        }
        assert!(t.wants_preview(Method::Vsv, false, full, PREVIEW_BUDGET_MS));
        let s = t.preview_scale(640, 480, Grid::default(), Method::Vsv, false, PREVIEW_BUDGET_MS);
        let units = |s: f32| {
            let (w, h, g) = scaled(640, 480, Grid::default(), s);
            work_units(w, h, g, Method::Vsv)
        };
        assert!(truth(units(s)) <= PREVIEW_BUDGET_MS, "scale {s}");
        // The next level up would not have fit.
        let i = LEVELS.iter().position(|l| *l == s).unwrap();
        assert!(i == 0 || truth(units(LEVELS[i - 1])) > PREVIEW_BUDGET_MS);
        // Ray marching is a family of its own: no samples yet, the prior decides.
        assert_eq!(t.predict(Method::Raymarch { steps: 64, jitter: true }, false, 100.0), 150.0 + 2.4e-3 * 100.0);
    }

    #[test]
    fn a_fixed_cost_over_the_budget_buys_a_finer_preview() {
        let mut t = FrameTimes::new(true);
        // 300 ms whatever the size, plus 0.1 us per unit: no preview fits 120 ms.
        let truth = |u: f64| 300.0 + 1e-4 * u;
        for s in [1.0f32, 0.5, 0.25, 0.1] {
            let (w, h, g) = scaled(640, 480, Grid::default(), s);
            let u = work_units(w, h, g, Method::Vsv);
            t.record(Method::Vsv, false, u, truth(u));
        }
        let s = t.preview_scale(640, 480, Grid::default(), Method::Vsv, false, PREVIEW_BUDGET_MS);
        assert!(s >= 0.25, "took {s}: the smallest preview saves almost nothing here");
    }

    #[test]
    fn one_size_scales_the_prior_and_a_fast_machine_needs_no_preview() {
        let mut t = FrameTimes::new(false);
        t.record(Method::Vsv, false, 1e6, 4.0);
        assert!((t.predict(Method::Vsv, false, 1e6) - 4.0).abs() < 1e-9);
        assert!(!t.wants_preview(Method::Vsv, false, 1e6, PREVIEW_BUDGET_MS));
    }

    #[test]
    fn frames_made_during_a_drag_predict_the_next_drag_preview() {
        // Measured on llvmpipe, 2 cores, built-in scene: a full frame alone (1.16 M units, 985 ms)
        // and previews during a drag, when the window's painting takes its share of the cores.
        let mut t = FrameTimes::new(true);
        t.record(Method::Vsv, false, 1.16e6, 985.0);
        t.record(Method::Vsv, true, 11.5e3, 186.0);
        t.record(Method::Vsv, true, 93.0e3, 460.0);
        // The drag's own frames decide: a 93k preview takes what it took, not the ~250 ms a fit
        // through the quiet full frame would promise.
        assert!((t.predict(Method::Vsv, true, 93.0e3) - 460.0).abs() < 1.0);
        assert!(t.predict(Method::Vsv, false, 93.0e3) < 400.0);
        // ... and the next drag preview is the one near the fixed cost, not the 93k one.
        let s = t.preview_scale(538, 688, Grid::default(), Method::Vsv, true, PREVIEW_BUDGET_MS);
        let (w, h, g) = scaled(538, 688, Grid::default(), s);
        assert!(work_units(w, h, g, Method::Vsv) < 40e3, "scale {s}");
    }

    #[test]
    fn previews_stay_valid_grids() {
        let g = Grid { planes: 100, rays: 20, bins: 64, ..Grid::default() };
        let (w, h, p) = scaled(50, 40, g, 0.125);
        // The pixels are cut less than the grid (to a quarter here), never below 8.
        assert_eq!((w, h), (13, 10));
        assert!(p.validate().is_ok(), "{p}");
        assert_eq!((p.planes, p.rays, p.bins), (13, 8, 32));
        assert_eq!(scaled(50, 40, g, 0.044).0, 8);
        assert_eq!(pixel_scale(0.707), 0.707);
        assert_eq!(pixel_scale(0.354), 0.5);
        let (_, _, same) = scaled(50, 40, g, 1.0);
        assert_eq!(same, g);
    }
}

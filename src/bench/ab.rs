//! Two shader folders timed against each other (`epivox ab`): one scene, whole frames (nothing
//! reused from the frame before), per-pass GPU medians of interleaved rounds on one device, and
//! whether the two images differ.
//!
//! ```text
//! shaders A ──► renderer A ─┐ round r: A's frames then B's (r even), B's then A's (r odd),
//! shaders B ──► renderer B ─┘   each side's first frame after the other's untimed
//!                               ──► per pass: the median over every round's frames
//! then one frame each, read back ──► the same bits, or B's error against A (metrics::compare)
//! ```
//!
//! It answers the question of shader work, "is the edit faster, and did it change the picture?",
//! from one run on one machine. A shared machine's speed drifts by tens of percent over minutes
//! (docs/results.md): rounds that alternate which side goes first put a drift on both sides alike,
//! and the per-round totals show how large it was. Within a round the two sides run one after
//! the other, seconds apart, so B over A in each round alone ([`AbResult::round_ratios`]) is the
//! steadier reading: its range over the rounds, and in how many of them B was faster, with the
//! sign test's two-sided p-value ([`RoundSummary::sign_test_p`]): with two sides of the same
//! speed, B is faster in all of 6 rounds once in 64 runs, in all of 4 once in 16, and in 8 of 12
//! (or more, either way) 39 times in 100. On a shared machine a run of 8 of 12 is not a result.

use super::{style, time_frames, BenchError, Frames, Point, Timing};
use crate::metrics::{self, ErrorStats};
use crate::params::Grid;
use crate::render::{Method, Pass, Renderer};
use crate::scene::Scene;
use crate::Image;

/// How the two sides are timed.
#[derive(Debug, Clone)]
pub struct AbOptions {
    pub width: u32,
    pub height: u32,
    pub method: Method,
    /// Frames each side renders before the first round (pipeline builds, caches).
    pub warmup: usize,
    /// Frames timed per side and round.
    pub frames: usize,
    pub rounds: usize,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// B renders the scene at this grid instead of its own (`--b-grid`): a grid against another
    /// in one process.
    pub b_grid: Option<Grid>,
}

/// One side's measurements and images.
#[derive(Debug, Clone)]
pub struct AbSide {
    /// Per pass, the total and per round: medians over all the timed frames (GPU timestamps; wall
    /// clock without them, `passes` then empty), as the bench's.
    pub timing: Timing,
    /// Per round, per pass: the medians of that round's frames alone (empty rounds without GPU
    /// timestamps).
    pub round_passes: Vec<Vec<(Pass, f64)>>,
    /// The median wall-clock time of a frame, from recording to the GPU's end (ms).
    pub wall_ms: f64,
    pub scatter: Image,
    pub hdr: Image,
}

/// How B's image compares with A's.
#[derive(Debug, Clone)]
pub enum AbImages {
    /// Bit for bit the same.
    Same,
    /// B's error against A (A is the reference); `None` where A's image holds non-finite values
    /// (`metrics::compare` refuses such a reference).
    Differ(Option<ErrorStats>),
}

impl AbImages {
    fn of(b: &Image, a: &Image) -> AbImages {
        if a.pixels.iter().flatten().map(|v| v.to_bits()).eq(b.pixels.iter().flatten().map(|v| v.to_bits())) {
            return AbImages::Same;
        }
        AbImages::Differ(metrics::compare(b, a).ok())
    }
}

#[derive(Debug, Clone)]
pub struct AbResult {
    pub a: AbSide,
    pub b: AbSide,
    pub scatter: AbImages,
    pub hdr: AbImages,
}

impl AbResult {
    /// B's time over A's in each round alone, in round order: for `pass`, or the frame's total
    /// (`None`; the wall clock's without GPU timestamps). A round where either side lacks the pass
    /// or A took no time is left out.
    pub fn round_ratios(&self, pass: Option<Pass>) -> Vec<f64> {
        let Some(pass) = pass else {
            return ratios(self.a.timing.round_ms.iter().copied().zip(self.b.timing.round_ms.iter().copied()));
        };
        let of = |round: &[(Pass, f64)]| round.iter().find(|(p, _)| *p == pass).map(|(_, ms)| *ms);
        let pairs = self.a.round_passes.iter().zip(&self.b.round_passes).filter_map(|(a, b)| of(a).zip(of(b)));
        ratios(pairs)
    }
}

/// What B/A by round says: its range, and in how many rounds B was faster and slower.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoundSummary {
    pub min: f64,
    pub max: f64,
    pub faster: usize,
    pub slower: usize,
    pub rounds: usize,
}

impl RoundSummary {
    /// `None` for no rounds.
    pub fn of(ratios: &[f64]) -> Option<RoundSummary> {
        let min = ratios.iter().copied().reduce(f64::min)?;
        let max = ratios.iter().copied().reduce(f64::max)?;
        Some(RoundSummary {
            min,
            max,
            faster: ratios.iter().filter(|&&r| r < 1.0).count(),
            slower: ratios.iter().filter(|&&r| r > 1.0).count(),
            rounds: ratios.len(),
        })
    }

    /// The sign test's two-sided p-value: the chance that two sides of the same speed split the
    /// rounds (ties left out) at least this unevenly, either way. 1 with no untied round.
    pub fn sign_test_p(&self) -> f64 {
        let n = self.faster + self.slower;
        let k = self.faster.max(self.slower);
        // P(X >= k) for X ~ Binomial(n, 1/2), the binomial coefficients summed in f64 (exact
        // for any number of rounds a person runs; C(n, i) / 2^n taken as a running product).
        let mut term = 0.5f64.powi(n as i32); // C(n, 0) / 2^n
        let mut tail = 0.0;
        for i in 0..=n {
            if i >= k {
                tail += term;
            }
            term *= (n - i) as f64 / (i + 1) as f64;
        }
        (2.0 * tail).min(1.0)
    }
}

fn ratios(pairs: impl Iterator<Item = (f64, f64)>) -> Vec<f64> {
    pairs.filter(|(a, _)| *a > 0.0).map(|(a, b)| b / a).collect()
}

/// Times `a` and `b` on `scene` (see the module's header) and compares their last frames.
pub fn run(a: &mut Renderer, b: &mut Renderer, scene: &Scene, opts: &AbOptions) -> Result<AbResult, BenchError> {
    let (w, h) = (opts.width, opts.height);
    let frames = opts.frames.max(1);
    let rounds = opts.rounds.max(1);
    let bar = style((2 * (opts.warmup + rounds * (frames + 1))) as u64, opts.progress);
    bar.set_prefix("ab");
    let b_scene = Scene { grid: opts.b_grid.unwrap_or(scene.grid), ..scene.clone() };
    let scenes = [scene, &b_scene];
    let mut work = [scene.clone(), b_scene.clone()];
    // Whole frames: a frame that took its shadow volume from the one before would time nothing.
    // Each side keeps its own shadow-map size (time_frames sets the point's).
    let mut points = Vec::with_capacity(2);
    for (r, s) in [&mut *a, &mut *b].into_iter().zip(scenes) {
        r.reuse_unchanged = false;
        points.push(Point { method: opts.method, grid: s.grid, shadow_map: r.shadow_map_size() });
    }
    for ((name, r), s) in [("A", &mut *a), ("B", &mut *b)].into_iter().zip(scenes) {
        bar.set_message(format!("warming up {name}"));
        for _ in 0..opts.warmup {
            r.render_frame(s, w, h, opts.method)?;
            bar.inc(1);
        }
    }
    let mut timed = [Frames::default(), Frames::default()];
    for round in 0..rounds {
        let order = if round % 2 == 0 { [0, 1] } else { [1, 0] };
        for side in order {
            let r = if side == 0 { &mut *a } else { &mut *b };
            bar.set_message(format!("round {} of {rounds}, {}", round + 1, ["A", "B"][side]));
            // The first frame after the other side's is not timed (time_frames' warm-up): timed,
            // the side that more often followed the other read 3% slower on the very same shaders
            // (llvmpipe, session 27).
            let (more, _) = time_frames(r, &mut work[side], w, h, &points[side], 1, frames)?;
            timed[side].pool(more);
            bar.inc(frames as u64 + 1);
        }
    }
    bar.finish_and_clear();
    let mut sides = Vec::with_capacity(2);
    for ((r, frames), s) in [(&mut *a, &timed[0]), (&mut *b, &timed[1])].into_iter().zip(scenes) {
        let out = r.render(s, w, h, opts.method)?;
        sides.push(side(frames, r.ctx.timestamps, out.scatter, out.hdr));
    }
    let (Some(b_side), Some(a_side)) = (sides.pop(), sides.pop()) else { unreachable!("two sides") };
    Ok(AbResult {
        scatter: AbImages::of(&b_side.scatter, &a_side.scatter),
        hdr: AbImages::of(&b_side.hdr, &a_side.hdr),
        a: a_side,
        b: b_side,
    })
}

/// One side's medians from its pooled frames.
fn side(frames: &Frames, timestamps: bool, scatter: Image, hdr: Image) -> AbSide {
    let round_passes = if timestamps { frames.round_pass_medians() } else { Vec::new() };
    AbSide { timing: frames.timing(timestamps), round_passes, wall_ms: frames.timing(false).total_ms, scatter, hdr }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(v: f32) -> Image {
        Image::from_pixels(2, 1, vec![[v, 1.0, 1.0], [1.0, 1.0, 1.0]]).unwrap()
    }

    #[test]
    fn the_sign_test_is_the_binomial_tail_both_ways() {
        let p = |faster: usize, slower: usize| {
            RoundSummary { min: 0.9, max: 1.1, faster, slower, rounds: faster + slower }.sign_test_p()
        };
        assert!((p(4, 0) - 0.125).abs() < 1e-12);
        assert!((p(0, 6) - 2.0 / 64.0).abs() < 1e-12);
        // 2 (C(12,8) + C(12,9) + C(12,10) + C(12,11) + C(12,12)) / 2^12 = 2 * 794 / 4096.
        assert!((p(8, 4) - 2.0 * 794.0 / 4096.0).abs() < 1e-12);
        assert_eq!(p(6, 6), 1.0);
        assert_eq!(p(0, 0), 1.0);
        // Ties are left out: 3 faster, 0 slower of 5 rounds is 3 of 3.
        let tied = RoundSummary { min: 0.9, max: 1.0, faster: 3, slower: 0, rounds: 5 };
        assert!((tied.sign_test_p() - 0.25).abs() < 1e-12);
        // A long run stays finite and exact enough: 100 of 100.
        assert!((p(100, 0) - 2.0 * 0.5f64.powi(100)).abs() < 1e-40);
    }

    #[test]
    fn images_are_the_same_only_bit_for_bit() {
        assert!(matches!(AbImages::of(&image(1.0), &image(1.0)), AbImages::Same));
        match AbImages::of(&image(1.5), &image(1.0)) {
            AbImages::Differ(Some(e)) => assert!((e.max_abs - 0.5).abs() < 1e-9, "{e:?}"),
            other => panic!("{other:?}"),
        }
        // -0 and +0 compare equal as numbers, not as bits: a change all the same.
        assert!(matches!(AbImages::of(&image(-0.0), &image(0.0)), AbImages::Differ(_)));
    }

    #[test]
    fn medians_are_per_pass_over_all_frames_and_per_round_of_totals() {
        let round = |frames: &[(f64, f64)]| Frames {
            passes: frames.iter().map(|&(s, v)| vec![(Pass::Surface, s), (Pass::Voxelize, v)]).collect(),
            wall: frames.iter().map(|&(s, v)| 2.0 * (s + v)).collect(),
            rounds: vec![frames.len()],
        };
        let mut frames = Frames::default();
        frames.pool(round(&[(1.0, 10.0), (3.0, 30.0)]));
        frames.pool(round(&[(2.0, 20.0), (5.0, 50.0)]));
        let s = side(&frames, true, image(0.0), image(0.0));
        assert_eq!(s.timing.passes, vec![(Pass::Surface, 2.5), (Pass::Voxelize, 25.0)]);
        assert_eq!(s.timing.total_ms, 27.5);
        assert_eq!(s.wall_ms, 55.0);
        assert_eq!(s.timing.round_ms, vec![22.0, 38.5]);
        assert_eq!(
            s.round_passes,
            vec![
                vec![(Pass::Surface, 2.0), (Pass::Voxelize, 20.0)],
                vec![(Pass::Surface, 3.5), (Pass::Voxelize, 35.0)]
            ]
        );
    }

    #[test]
    fn ratios_by_round_pair_each_round_of_a_with_the_same_round_of_b() {
        let frames = |rounds: &[(f64, f64)]| {
            let mut all = Frames::default();
            for &(s, v) in rounds {
                all.pool(Frames {
                    passes: vec![vec![(Pass::Surface, s), (Pass::Voxelize, v)]],
                    wall: vec![s + v],
                    rounds: vec![1],
                });
            }
            side(&all, true, image(0.0), image(0.0))
        };
        // The machine slows round by round (A's Voxelize 10, 20, 40 ms); B is 10% faster in
        // Voxelize within every round, whatever the drift.
        let a = frames(&[(1.0, 10.0), (1.0, 20.0), (1.0, 40.0)]);
        let b = frames(&[(2.0, 9.0), (1.0, 18.0), (0.5, 36.0)]);
        let r = AbResult { a, b, scatter: AbImages::Same, hdr: AbImages::Same };
        let v = r.round_ratios(Some(Pass::Voxelize));
        assert_eq!(v.len(), 3);
        assert!(v.iter().all(|x| (x - 0.9).abs() < 1e-12), "{v:?}");
        let s = RoundSummary::of(&r.round_ratios(Some(Pass::Surface))).unwrap();
        assert_eq!((s.min, s.max, s.faster, s.slower, s.rounds), (0.5, 2.0, 1, 1, 3));
        // The totals' ratios come from each round's total, a pass missing from a side from none.
        assert_eq!(r.round_ratios(None).len(), 3);
        assert!(r.round_ratios(Some(Pass::Scan)).is_empty());
        assert_eq!(RoundSummary::of(&[]), None);
    }
}

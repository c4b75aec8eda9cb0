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
//! and the per-round totals show how large it was.

use super::{median, style, BenchError};
use crate::metrics::{self, ErrorStats};
use crate::render::{Method, Pass, Renderer};
use crate::scene::Scene;
use crate::Image;
use std::time::Instant;

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
}

/// One side's measurements and images.
#[derive(Debug, Clone)]
pub struct AbSide {
    /// Each pass that ran and the median of its GPU time (ms) over all the timed frames.
    pub passes: Vec<(Pass, f64)>,
    /// The median of the frames' summed pass times (ms; 0 without GPU timestamps).
    pub total_ms: f64,
    /// The median wall-clock time of a frame, from recording to the GPU's end (ms).
    pub wall_ms: f64,
    /// The median total of each round alone (ms).
    pub round_ms: Vec<f64>,
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

/// Times `a` and `b` on `scene` (see the module's header) and compares their last frames.
pub fn run(a: &mut Renderer, b: &mut Renderer, scene: &Scene, opts: &AbOptions) -> Result<AbResult, BenchError> {
    let (w, h, method) = (opts.width, opts.height, opts.method);
    let frames = opts.frames.max(1);
    let rounds = opts.rounds.max(1);
    let bar = style((2 * (opts.warmup + rounds * (frames + 1))) as u64, opts.progress);
    bar.set_prefix("ab");
    // Whole frames: a frame that took its shadow volume from the one before would time nothing.
    for r in [&mut *a, &mut *b] {
        r.reuse_unchanged = false;
    }
    for (name, r) in [("A", &mut *a), ("B", &mut *b)] {
        bar.set_message(format!("warming up {name}"));
        for _ in 0..opts.warmup {
            r.render_frame(scene, w, h, method)?;
            bar.inc(1);
        }
    }
    let mut timed: [Vec<TimedFrame>; 2] = [Vec::new(), Vec::new()];
    for round in 0..rounds {
        let order = if round % 2 == 0 { [0, 1] } else { [1, 0] };
        for side in order {
            let r = if side == 0 { &mut *a } else { &mut *b };
            bar.set_message(format!("round {} of {rounds}, {}", round + 1, ["A", "B"][side]));
            // The first frame after the other side's is not timed: timed, the side that more often
            // followed the other read 3% slower on the very same shaders (llvmpipe, session 27).
            r.render_frame(scene, w, h, method)?;
            bar.inc(1);
            for _ in 0..frames {
                let started = Instant::now();
                let info = r.render_frame(scene, w, h, method)?;
                // (Reading the timestamps waits for the frame; without them this does.)
                r.ctx.wait()?;
                let wall = started.elapsed().as_secs_f64() * 1e3;
                timed[side].push(TimedFrame {
                    round,
                    wall,
                    passes: info.timings.iter().map(|t| (t.pass, t.ms)).collect(),
                });
                bar.inc(1);
            }
        }
    }
    bar.finish_and_clear();
    let mut sides = Vec::with_capacity(2);
    for (r, frames) in [(&mut *a, &timed[0]), (&mut *b, &timed[1])] {
        let out = r.render(scene, w, h, method)?;
        sides.push(side(frames, rounds, out.scatter, out.hdr));
    }
    let (Some(b_side), Some(a_side)) = (sides.pop(), sides.pop()) else { unreachable!("two sides") };
    Ok(AbResult {
        scatter: AbImages::of(&b_side.scatter, &a_side.scatter),
        hdr: AbImages::of(&b_side.hdr, &a_side.hdr),
        a: a_side,
        b: b_side,
    })
}

/// A timed frame: the round it belongs to, its wall-clock time and its passes' GPU times (ms).
struct TimedFrame {
    round: usize,
    wall: f64,
    passes: Vec<(Pass, f64)>,
}

/// One side's medians from its timed frames.
fn side(frames: &[TimedFrame], rounds: usize, scatter: Image, hdr: Image) -> AbSide {
    // The passes in the order the frames ran them (a pass run per chunk counts once, summed).
    let mut order: Vec<Pass> = Vec::new();
    for f in frames {
        for (p, _) in &f.passes {
            if !order.contains(p) {
                order.push(*p);
            }
        }
    }
    let time_of = |f: &TimedFrame, p: Pass| f.passes.iter().filter(|(q, _)| *q == p).map(|(_, ms)| ms).sum();
    let passes = order
        .iter()
        .map(|&p| {
            let ran = frames.iter().filter(|f| f.passes.iter().any(|(q, _)| *q == p));
            (p, median(ran.map(|f| time_of(f, p)).collect()))
        })
        .collect();
    let total = |f: &TimedFrame| f.passes.iter().map(|(_, ms)| ms).sum::<f64>();
    let round_ms = (0..rounds).map(|r| median(frames.iter().filter(|f| f.round == r).map(total).collect())).collect();
    AbSide {
        passes,
        total_ms: median(frames.iter().map(total).collect()),
        wall_ms: median(frames.iter().map(|f| f.wall).collect()),
        round_ms,
        scatter,
        hdr,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(v: f32) -> Image {
        Image::from_pixels(2, 1, vec![[v, 1.0, 1.0], [1.0, 1.0, 1.0]]).unwrap()
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
        let frame = |round, s: f64, v: f64| TimedFrame {
            round,
            wall: 2.0 * (s + v),
            passes: vec![(Pass::Surface, s), (Pass::Voxelize, v)],
        };
        let frames = vec![frame(0, 1.0, 10.0), frame(0, 3.0, 30.0), frame(1, 2.0, 20.0), frame(1, 5.0, 50.0)];
        let s = side(&frames, 2, image(0.0), image(0.0));
        assert_eq!(s.passes, vec![(Pass::Surface, 2.5), (Pass::Voxelize, 25.0)]);
        assert_eq!(s.total_ms, 27.5);
        assert_eq!(s.wall_ms, 55.0);
        assert_eq!(s.round_ms, vec![22.0, 38.5]);
    }
}

//! Globally adaptive Gauss–Kronrod (7-15) quadrature of an RGB-valued integrand over a set of
//! intervals, and bisection of a boolean function's change.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Kronrod 15-point abscissae on `[-1, 1]` (non-negative half, descending).
#[allow(clippy::excessive_precision)] // the published 30-digit values
const XK: [f64; 8] = [
    0.991_455_371_120_812_639_206_854_697_526_329,
    0.949_107_912_342_758_524_526_189_684_047_851,
    0.864_864_423_359_769_072_789_712_788_640_926,
    0.741_531_185_599_394_439_863_864_773_280_788,
    0.586_087_235_467_691_130_294_144_845_693_013,
    0.405_845_151_377_397_166_906_606_412_076_961,
    0.207_784_955_007_898_467_600_689_403_773_245,
    0.0,
];
/// Kronrod weights matching [`XK`].
#[allow(clippy::excessive_precision)] // the published 30-digit values
const WK: [f64; 8] = [
    0.022_935_322_010_529_224_963_732_008_058_970,
    0.063_092_092_629_978_553_290_700_663_189_204,
    0.104_790_010_322_250_183_839_876_322_541_518,
    0.140_653_259_715_525_918_745_189_590_510_238,
    0.169_004_726_639_267_902_826_583_426_598_550,
    0.190_350_578_064_785_409_913_256_402_421_014,
    0.204_432_940_075_298_892_414_161_999_234_649,
    0.209_482_141_084_727_828_012_999_174_891_714,
];
/// Gauss 7-point weights for the odd-indexed Kronrod abscissae `XK[1], XK[3], XK[5], XK[7]`.
#[allow(clippy::excessive_precision)] // the published 30-digit values
const WG: [f64; 4] = [
    0.129_484_966_168_869_693_270_611_432_679_082,
    0.279_705_391_489_276_667_901_467_771_423_780,
    0.381_830_050_505_118_944_950_369_775_488_975,
    0.417_959_183_673_469_387_755_102_040_816_327,
];

/// An RGB value.
pub type Rgb = [f64; 3];

/// The result of [`integrate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadrature {
    /// The integral per channel.
    pub value: Rgb,
    /// Estimated absolute error per channel (sum of `|K15 - G7|` over the final subintervals:
    /// pessimistic for smooth integrands, where the K15 error is far below the G7 one).
    pub error: Rgb,
    /// Integrand evaluations.
    pub evals: usize,
    /// Whether the tolerance was met before the subdivision limit.
    pub converged: bool,
}

/// One Gauss–Kronrod 7-15 rule on `[a, b]`: (K15 value, |K15 - G7|).
fn gk15(f: &mut impl FnMut(f64) -> Rgb, a: f64, b: f64) -> (Rgb, Rgb) {
    let c = 0.5 * (a + b);
    let h = 0.5 * (b - a);
    let mut k = [0.0; 3];
    let mut g = [0.0; 3];
    let fc = f(c);
    for ch in 0..3 {
        k[ch] = WK[7] * fc[ch];
        g[ch] = WG[3] * fc[ch];
    }
    for j in 0..7 {
        let dx = h * XK[j];
        let f1 = f(c - dx);
        let f2 = f(c + dx);
        for ch in 0..3 {
            let s = f1[ch] + f2[ch];
            k[ch] += WK[j] * s;
            if j % 2 == 1 {
                g[ch] += WG[j / 2] * s;
            }
        }
    }
    let mut val = [0.0; 3];
    let mut err = [0.0; 3];
    for ch in 0..3 {
        val[ch] = k[ch] * h;
        err[ch] = ((k[ch] - g[ch]) * h).abs();
    }
    (val, err)
}

struct Seg {
    a: f64,
    b: f64,
    val: Rgb,
    err: Rgb,
    /// Priority: the error relative to the current total (max over channels).
    key: f64,
}

impl PartialEq for Seg {
    fn eq(&self, o: &Self) -> bool {
        self.key == o.key
    }
}
impl Eq for Seg {}
impl PartialOrd for Seg {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Seg {
    fn cmp(&self, o: &Self) -> Ordering {
        self.key.total_cmp(&o.key)
    }
}

/// Smallest magnitude treated as non-zero when forming relative errors.
const TINY: f64 = 1e-300;

/// Integrates `f` over the union of `intervals` (disjoint, each `a < b`) to a relative tolerance
/// `rel_tol` per channel: stops when, for every channel, the summed error estimate is at most
/// `rel_tol * |value|` (or below `1e-300` absolute). Subdivides the interval with the largest
/// relative error first (global adaptivity), at most `max_splits` times.
pub fn integrate(
    mut f: impl FnMut(f64) -> Rgb,
    intervals: &[(f64, f64)],
    rel_tol: f64,
    max_splits: usize,
) -> Quadrature {
    let mut heap = BinaryHeap::new();
    let mut total = [0.0; 3];
    let mut total_err = [0.0; 3];
    let mut evals = 0;
    for &(a, b) in intervals {
        if !(b > a) {
            continue;
        }
        let (val, err) = gk15(&mut f, a, b);
        evals += 15;
        for ch in 0..3 {
            total[ch] += val[ch];
            total_err[ch] += err[ch];
        }
        heap.push(Seg { a, b, val, err, key: 0.0 });
    }
    let key = |err: &Rgb, total: &Rgb| (0..3).map(|ch| err[ch] / total[ch].abs().max(TINY)).fold(0.0, f64::max);
    // Keys depend on the total; set them once it is known.
    let mut heap: BinaryHeap<Seg> = heap
        .into_iter()
        .map(|mut s| {
            s.key = key(&s.err, &total);
            s
        })
        .collect();
    let done = |total: &Rgb, err: &Rgb| (0..3).all(|ch| err[ch] <= rel_tol * total[ch].abs() || err[ch] <= TINY);
    let mut splits = 0;
    while !done(&total, &total_err) {
        if splits >= max_splits {
            break;
        }
        let Some(s) = heap.pop() else { break };
        let m = 0.5 * (s.a + s.b);
        if !(m > s.a && m < s.b) {
            // The interval cannot be split further in floating point: keep it as it is.
            let mut s = s;
            s.key = -1.0;
            heap.push(s);
            splits += 1;
            continue;
        }
        let (v1, e1) = gk15(&mut f, s.a, m);
        let (v2, e2) = gk15(&mut f, m, s.b);
        evals += 30;
        for ch in 0..3 {
            total[ch] += v1[ch] + v2[ch] - s.val[ch];
            total_err[ch] += e1[ch] + e2[ch] - s.err[ch];
        }
        heap.push(Seg { a: s.a, b: m, val: v1, err: e1, key: key(&e1, &total) });
        heap.push(Seg { a: m, b: s.b, val: v2, err: e2, key: key(&e2, &total) });
        splits += 1;
        // Re-summing now and then keeps the running sums free of cancellation drift.
        if splits.is_multiple_of(64) {
            total = [0.0; 3];
            total_err = [0.0; 3];
            for s in heap.iter() {
                for ch in 0..3 {
                    total[ch] += s.val[ch];
                    total_err[ch] += s.err[ch];
                }
            }
        }
    }
    // Final exact re-summation.
    let mut value = [0.0; 3];
    let mut error = [0.0; 3];
    for s in heap.iter() {
        for ch in 0..3 {
            value[ch] += s.val[ch];
            error[ch] += s.err[ch];
        }
    }
    Quadrature { value, error, evals, converged: done(&value, &error) }
}

/// Locates the change of a boolean function between `a` (where it is `fa`) and `b` (where it is
/// `!fa`) by bisection until the bracket is at most `tol` wide or `max_iter` halvings were made;
/// returns the bracket's midpoint.
pub fn bisect(mut f: impl FnMut(f64) -> bool, mut a: f64, mut b: f64, fa: bool, tol: f64, max_iter: usize) -> f64 {
    for _ in 0..max_iter {
        if (b - a).abs() <= tol {
            break;
        }
        let m = 0.5 * (a + b);
        if m <= a.min(b) || m >= a.max(b) {
            break;
        }
        if f(m) == fa {
            a = m;
        } else {
            b = m;
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gk15_is_exact_for_polynomials_up_to_degree_22() {
        // K15 integrates degree <= 22 exactly: x^22 on [0, 1] = 1/23.
        let q = integrate(|x| [x.powi(22), x.powi(5), 1.0], &[(0.0, 1.0)], 1e-14, 0);
        assert!((q.value[0] - 1.0 / 23.0).abs() < 1e-15);
        assert!((q.value[1] - 1.0 / 6.0).abs() < 1e-15);
        assert!((q.value[2] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn adaptive_reaches_tolerance_per_channel() {
        // Three channels of very different magnitude and a sharp peak.
        let f = |x: f64| {
            let p = 1.0 / (1e-4 + (x - 0.3) * (x - 0.3));
            [p, 1e-200 * x.exp(), (-50.0 * x).exp()]
        };
        let exact0 = ((0.7f64 / 1e-2).atan() + (0.3f64 / 1e-2).atan()) / 1e-2;
        let exact1 = 1e-200 * (1f64.exp() - 1.0);
        let exact2 = (1.0 - (-50f64).exp()) / 50.0;
        let q = integrate(f, &[(0.0, 1.0)], 1e-9, 10_000);
        assert!(q.converged);
        assert!(((q.value[0] - exact0) / exact0).abs() < 1e-9, "{:?}", q);
        assert!(((q.value[1] - exact1) / exact1).abs() < 1e-9, "{:?}", q);
        assert!(((q.value[2] - exact2) / exact2).abs() < 1e-9, "{:?}", q);
    }

    #[test]
    fn zero_integrand_converges_at_once() {
        let q = integrate(|_| [0.0; 3], &[(0.0, 1.0), (2.0, 3.0)], 1e-6, 100);
        assert!(q.converged && q.value == [0.0; 3] && q.evals == 30);
    }

    #[test]
    fn bisection_finds_the_edge() {
        let x = bisect(|x| x < 0.123_456_789, 0.0, 1.0, true, 1e-12, 100);
        assert!((x - 0.123_456_789).abs() < 1e-12);
        // Reversed bracket.
        let x = bisect(|x| x < 0.75, 1.0, 0.0, false, 1e-12, 100);
        assert!((x - 0.75).abs() < 1e-12);
    }
}

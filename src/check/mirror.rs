//! Rust mirrors of the shaders' per-run formulas, in `f32` (what the GPU computes) and `f64` (the
//! same formulas in double precision), plus independent `f64` evaluations of the same integrals and
//! a CPU `f32` evaluator of the whole in-scattering integral with a planted failure.
//!
//! The mirrored WGSL (keep these in step with it):
//! - `phase`, `phase_of_angle`, `one_minus_exp_over_x` of `shaders/common.wgsl`;
//! - `integrand` and the per-row cumulative table of `shaders/scatter_table.wgsl`, and `table_g` /
//!   the point-light weight `(pi - gamma) / h` of `shaders/integrate.wgsl`;
//! - the pieces of `shaders/integrate.wgsl` (`build_pieces`, `piece_integral_grey`: a directional
//!   light in the medium's box).
//!
//! [`f32m`] and [`f64m`] are generated from one macro, so they are the same formulas; the property
//! tests in `tests/proptest_integrals.rs` compare `f32m` with `f64m` (rounding alone) and with the
//! independent evaluations [`exact_point_run`] / [`exact_box_integral`] (rounding and
//! discretisation), over random inputs including the extremes.

// `!(b > a)` is deliberate: it treats NaN bounds as an empty range.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::image::Image;
use crate::params::{Light, Phase};
use crate::reference::{integrate, RaySample};
use crate::scene::Scene;
use glam::{DVec3, Vec3};

/// Why [`cpu_f32_scatter`] cannot evaluate a scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MirrorError {
    #[error("the CPU f32 evaluator covers point lights only")]
    NotPointLight,
    #[error("{samples} reference samples for a {width}x{height} image")]
    SampleCount { samples: usize, width: u32, height: u32 },
}

/// Rows x columns of the point-light table (`TABLE_ROWS`, `TABLE_COLS` of `render::frame`).
pub const TABLE_COLS: usize = crate::render::TABLE_COLS as usize;

macro_rules! formulas {
    ($name:ident, $F:ty, $doc:literal) => {
        #[doc = $doc]
        pub mod $name {
            #![allow(clippy::excessive_precision)]
            pub const PI: $F = std::f64::consts::PI as $F;
            const INV_4PI: $F = (0.25 / std::f64::consts::PI) as $F;

            /// `d = 1 + g^2 - 2 g c` written as a sum of non-negative terms: `(1 - g)^2 + 2 g (1 - c)`
            /// for `g >= 0`, `(1 + g)^2 - 2 g (1 + c)` for `g < 0` (`omc = 1 - c`, `opc = 1 + c`).
            fn lobe_den(g: $F, omc: $F, opc: $F) -> $F {
                if g >= 0.0 {
                    (1.0 - g) * (1.0 - g) + 2.0 * g * omc
                } else {
                    (1.0 + g) * (1.0 + g) - 2.0 * g * opc
                }
            }

            fn phase_core(id: u32, g: $F, c: $F, omc: $F, opc: $F) -> $F {
                match id {
                    1 => {
                        // Henyey-Greenstein
                        let d = lobe_den(g, omc, opc);
                        (1.0 - g) * (1.0 + g) * INV_4PI / (d * d.sqrt())
                    }
                    2 => {
                        // Schlick
                        let k = 1.55 * g - 0.55 * g * g * g;
                        let d = if k >= 0.0 { (1.0 - k) + k * omc } else { (1.0 + k) - k * opc };
                        (1.0 - k) * (1.0 + k) * INV_4PI / (d * d)
                    }
                    3 => {
                        // Cornette-Shanks
                        let d = lobe_den(g, omc, opc);
                        3.0 * (1.0 - g) * (1.0 + g) * (1.0 + c * c) / (8.0 * PI * (2.0 + g * g) * d * d.sqrt())
                    }
                    4 => 3.0 * (1.0 + c * c) / (16.0 * PI),
                    _ => INV_4PI,
                }
            }

            /// `phase(id, g, c)` of common.wgsl: the phase function of the cosine `c`.
            pub fn phase(id: u32, g: $F, c: $F) -> $F {
                phase_core(id, g, c, 1.0 - c, 1.0 + c)
            }

            /// `phase_of_angle(id, g, theta)` of common.wgsl: the phase function of the deflection
            /// angle itself, with `1 -+ cos` from half-angle sines, exact near the lobes' peaks.
            pub fn phase_of_angle(id: u32, g: $F, theta: $F) -> $F {
                let s = (0.5 * theta).sin();
                let co = (0.5 * theta).cos();
                phase_core(id, g, theta.cos(), 2.0 * s * s, 2.0 * co * co)
            }

            /// `one_minus_exp_over_x` of common.wgsl: `(1 - exp(-x)) / x`.
            pub fn one_minus_exp_over_x(x: $F) -> $F {
                if x.abs() < 0.5 {
                    1.0 - x
                        * (0.5
                            - x * (1.0 / 6.0
                                - x * (1.0 / 24.0 - x * (1.0 / 120.0 - x * (1.0 / 720.0 - x * (1.0 / 5040.0))))))
                } else {
                    (1.0 - (-x).exp()) / x.max(1e-30)
                }
            }

            /// `integrand` of scatter_table.wgsl for one channel: the unshadowed in-scattering per
            /// unit `psi` times `h`, with `exp(-sigma_t D)` factored out (it is applied by the
            /// integrate pass, combined with the log of the prefactor).
            #[allow(clippy::too_many_arguments)]
            pub fn table_integrand(
                gamma: $F,
                psi: $F,
                h2: $F,
                dist: $F,
                sigma_t: $F,
                radius: $F,
                id: u32,
                g: $F,
            ) -> $F {
                let s = (gamma + psi).sin();
                // t + d - D = D (sin psi + sin gamma - sin(gamma + psi)) / sin(gamma + psi), written
                // without cancellation.
                let sg = (0.5 * gamma).sin();
                let sp = (0.5 * psi).sin();
                let excess = 2.0 * dist * (psi.sin() * sg * sg + gamma.sin() * sp * sp) / s.max(1e-30);
                let expo = if sigma_t == 0.0 { 0.0 } else { sigma_t * excess };
                let mut soft = 1.0;
                if radius > 0.0 {
                    soft = h2 / (h2 + radius * radius * s * s);
                }
                phase_of_angle(id, g, gamma + psi) * (-expo).exp() * soft
            }

            /// One row of the table: `cols + 1` cumulative values of `G / (pi - gamma)`, each column
            /// integrated with 4-point Gauss-Legendre (the loop of scatter_table.wgsl).
            pub fn table_row(gamma: $F, dist: $F, sigma_t: $F, radius: $F, id: u32, g: $F, cols: usize) -> Vec<$F> {
                let h = dist * gamma.sin();
                let h2 = h * h;
                let width = (PI - gamma) / cols as $F;
                let x: [$F; 4] = [0.0694318442, 0.3300094782, 0.6699905218, 0.9305681558];
                let w: [$F; 4] = [0.1739274226, 0.3260725774, 0.3260725774, 0.1739274226];
                let mut row = Vec::with_capacity(cols + 1);
                row.push(0.0);
                let mut acc: $F = 0.0;
                for c in 0..cols {
                    let a = c as $F * width;
                    let mut cell: $F = 0.0;
                    for q in 0..4 {
                        cell += w[q] * table_integrand(gamma, a + x[q] * width, h2, dist, sigma_t, radius, id, g);
                    }
                    acc += cell / cols as $F;
                    row.push(acc);
                }
                row
            }

            /// `table_row` + the column interpolation of `table_g` (integrate.wgsl) at `psi`, for a
            /// row computed at the pixel's own `gamma` (no interpolation between rows).
            pub fn table_lookup(row: &[$F], gamma: $F, psi: $F) -> $F {
                let cols = row.len() - 1;
                let u = (psi / (PI - gamma).max(1e-7)).clamp(0.0, 1.0);
                let c = u * cols as $F;
                let c0 = (c as usize).min(cols - 1);
                let t = c - c0 as $F;
                row[c0] * (1.0 - t) + row[c0 + 1] * t
            }

            /// The weight `(pi - gamma) / h` of integrate.wgsl that turns a table difference into the
            /// run integral (per unit `sigma_s I0 exp(-sigma_t D)`).
            pub fn point_weight(gamma: $F, dist: $F) -> $F {
                let x = PI - gamma;
                if x > 1e-4 {
                    x / (dist * gamma.sin()).max(1e-7 * dist)
                } else {
                    1.0 / dist
                }
            }

            /// The unshadowed in-scattering of the stretch `[psi_a, psi_b]` of the view ray `gamma`,
            /// per unit `sigma_s I0 exp(-sigma_t D)`, as the integrate pass computes it.
            pub fn point_run(row: &[$F], gamma: $F, dist: $F, psi_a: $F, psi_b: $F) -> $F {
                point_weight(gamma, dist) * (table_lookup(row, gamma, psi_b) - table_lookup(row, gamma, psi_a))
            }

            fn safe(d: $F) -> $F {
                if d.abs() < 1e-20 {
                    if d < 0.0 {
                        -1e-20
                    } else {
                        1e-20
                    }
                } else {
                    d
                }
            }

            /// The pieces of integrate.wgsl (`build_pieces`, `piece_integral_grey`) for one channel:
            /// `integral_a^b exp(-sigma_t (l(t) + t - t_in)) dt` along `e + t v`, with `l` the
            /// distance toward the light `w` to the box `[lo, hi]`. (A coloured medium's
            /// `piece_integral` takes `exp(-sigma_t g_min) len E(x)` per channel, the same value.)
            #[allow(clippy::too_many_arguments)]
            pub fn box_integral(
                e: [$F; 3],
                v: [$F; 3],
                w: [$F; 3],
                lo: [$F; 3],
                hi: [$F; 3],
                sigma_t: $F,
                t_in: $F,
                a: $F,
                b: $F,
            ) -> $F {
                if b <= a {
                    return 0.0;
                }
                let w = [safe(w[0]), safe(w[1]), safe(w[2])];
                let mut alpha = [0.0; 3];
                let mut beta = [0.0; 3];
                for i in 0..3 {
                    let bound = if w[i] > 0.0 { hi[i] } else { lo[i] };
                    alpha[i] = (bound - e[i]) / w[i];
                    beta[i] = -v[i] / w[i];
                }
                let mut cuts: [$F; 5] = [a, b, b, b, b];
                let mut n = 1;
                for i in 0..3 {
                    for j in i + 1..3 {
                        let den = beta[i] - beta[j];
                        if den.abs() > 1e-12 {
                            let t = (alpha[j] - alpha[i]) / den;
                            if t > a && t < b {
                                cuts[n] = t;
                                n += 1;
                            }
                        }
                    }
                }
                cuts[n] = b;
                n += 1;
                cuts[..n].sort_by(|x, y| x.total_cmp(y));
                let mut sum = 0.0;
                for i in 0..n - 1 {
                    let (p0, p1) = (cuts[i], cuts[i + 1]);
                    if p1 <= p0 {
                        continue;
                    }
                    let mid = 0.5 * (p0 + p1);
                    let ls = [alpha[0] + beta[0] * mid, alpha[1] + beta[1] * mid, alpha[2] + beta[2] * mid];
                    let mut k = 0;
                    if ls[1] < ls[k] {
                        k = 1;
                    }
                    if ls[2] < ls[k] {
                        k = 2;
                    }
                    let g0 = (alpha[k] + beta[k] * p0).max(0.0) + p0 - t_in;
                    let g1 = (alpha[k] + beta[k] * p1).max(0.0) + p1 - t_in;
                    // piece_integral_grey: the exponential at both ends of the exponent, their
                    // difference over sigma_t |k| where x >= 1/2, E's series below.
                    let e_lo = (-sigma_t * g0.min(g1).max(0.0)).exp();
                    let e_hi = (-sigma_t * g0.max(g1).max(0.0)).exp();
                    let x = sigma_t * (g1 - g0).abs();
                    let len = p1 - p0;
                    sum += if x < 0.5 {
                        e_lo * len * one_minus_exp_over_x(x)
                    } else {
                        (e_lo - e_hi) / (sigma_t * ((g1 - g0) / len).abs()).max(1e-30)
                    };
                }
                sum
            }
        }
    };
}

formulas!(f32m, f32, "The shaders' formulas in `f32`, as the GPU evaluates them.");
formulas!(f64m, f64, "The same formulas in `f64`: the difference to [`f32m`] is rounding alone.");

/// The unshadowed in-scattering of `[psi_a, psi_b]` along the view ray `gamma` of a point light at
/// distance `dist`, per unit `sigma_s I0 exp(-sigma_t D)`, evaluated independently of the mirror:
/// adaptive Gauss-Kronrod in `f64` over `psi` of `p(cos theta) exp(-sigma_t (t + d - D)) / (d^2 +
/// r^2) dt/dpsi` with `t`, `d` from the law of sines and [`Phase::eval`].
#[allow(clippy::too_many_arguments)]
pub fn exact_point_run(
    gamma: f64,
    psi_a: f64,
    psi_b: f64,
    dist: f64,
    sigma_t: f64,
    radius: f64,
    phase: Phase,
    tol: f64,
) -> f64 {
    if !(psi_b > psi_a) {
        return 0.0;
    }
    let f = |psi: f64| {
        let s = (gamma + psi).sin();
        if s <= 0.0 {
            return [0.0; 3];
        }
        let t = dist * psi.sin() / s;
        let d = dist * gamma.sin() / s;
        // dt/dpsi = D sin(gamma) / sin^2(gamma + psi) = d^2 / h
        let h = dist * gamma.sin();
        let dt = d * d / h;
        let excess = t + d - dist;
        let tr = if sigma_t == 0.0 { 1.0 } else { (-(sigma_t * excess)).exp() };
        let v = phase.eval((gamma + psi).cos()) * tr * dt / (d * d + radius * radius);
        [v, 0.0, 0.0]
    };
    // Split the domain geometrically toward both ends, where the thick medium's boundary layer and
    // the lobes' peaks are.
    let mut cuts = vec![psi_a, psi_b];
    let span = psi_b - psi_a;
    let mut off = span;
    while off > 1e-12 * span {
        off *= 0.125;
        cuts.push(psi_a + off);
        cuts.push(psi_b - off);
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let pieces: Vec<(f64, f64)> = cuts.windows(2).map(|w| (w[0], w[1])).filter(|(a, b)| b > a).collect();
    integrate(f, &pieces, tol, 20_000).value[0]
}

/// `integral_a^b exp(-sigma_t (l(t) + t - t_in)) dt` in `f64` by adaptive quadrature, with `l(t)`
/// the exit distance from `e + t v` toward `w` through the box, found by a slab test per sample.
#[allow(clippy::too_many_arguments)]
pub fn exact_box_integral(
    e: DVec3,
    v: DVec3,
    w: DVec3,
    lo: DVec3,
    hi: DVec3,
    sigma_t: f64,
    t_in: f64,
    a: f64,
    b: f64,
    tol: f64,
) -> f64 {
    if !(b > a) {
        return 0.0;
    }
    let exit = |p: DVec3| {
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            if w[k] != 0.0 {
                let s = ((if w[k] > 0.0 { hi[k] } else { lo[k] }) - p[k]) / w[k];
                t1 = t1.min(s);
            }
        }
        t1.max(0.0)
    };
    let f = |t: f64| {
        let x = exit(e + v * t) + t - t_in;
        [if sigma_t == 0.0 { 1.0 } else { (-(sigma_t * x)).exp() }, 0.0, 0.0]
    };
    // Kinks of l(t): where two slabs swap; plus geometric grading toward both ends.
    let mut cuts = vec![a, b];
    for i in 0..3 {
        for j in i + 1..3 {
            if w[i] != 0.0 && w[j] != 0.0 {
                let bi = if w[i] > 0.0 { hi[i] } else { lo[i] };
                let bj = if w[j] > 0.0 { hi[j] } else { lo[j] };
                let (ai, ci) = ((bi - e[i]) / w[i], -v[i] / w[i]);
                let (aj, cj) = ((bj - e[j]) / w[j], -v[j] / w[j]);
                if ci != cj {
                    let t = (aj - ai) / (ci - cj);
                    if t > a && t < b {
                        cuts.push(t);
                    }
                }
            }
        }
    }
    let span = b - a;
    let mut off = span;
    while off > 1e-12 * span {
        off *= 0.125;
        cuts.push(a + off);
        cuts.push(b - off);
    }
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    let pieces: Vec<(f64, f64)> = cuts.windows(2).map(|w| (w[0], w[1])).filter(|(a, b)| b > a).collect();
    integrate(f, &pieces, tol, 20_000).value[0]
}

/// Composite Gauss-Legendre panels per lit run of [`cpu_f32_scatter`].
const CPU_PANELS: usize = 96;

/// A CPU `f32` evaluator of a point light's `L_scatter` per pixel: the reference's exact lit runs
/// (`samples`, from [`crate::reference::render_pixels`] in row-major order), each integrated in the
/// reference's angle variable `alpha = atan((t - t_c) / H)` with composite 4-point Gauss-Legendre
/// ([`CPU_PANELS`] panels) in `f32`. Visibility is exact, so the only differences to the reference
/// are `f32` arithmetic and the quadrature.
///
/// `separate_exponents` is the planted failure: the transmittance as the product
/// `exp(-sigma_t d) * exp(-sigma_t t)`, multiplied into the prefactor afterwards. Otherwise the
/// exponents and the log of the prefactor are combined before one `exp`, as the shaders do.
pub fn cpu_f32_scatter(
    scene: &Scene,
    width: u32,
    height: u32,
    samples: &[RaySample],
    separate_exponents: bool,
) -> Result<Image, MirrorError> {
    let Light::Point { position, intensity, radius } = scene.light else {
        return Err(MirrorError::NotPointLight);
    };
    if samples.len() != width as usize * height as usize {
        return Err(MirrorError::SampleCount { samples: samples.len(), width, height });
    }
    let sigma_s = scene.medium.sigma_s();
    let sigma_t = scene.medium.sigma_t();
    let (id, g) = (scene.medium.phase.id(), scene.medium.phase.g());
    let eye = scene.camera.eye;
    let wv = position - eye;
    let gx: [f32; 4] = [-0.861_136_3, -0.339_981_04, 0.339_981_04, 0.861_136_3];
    let gw: [f32; 4] = [0.347_854_85, 0.652_145_15, 0.652_145_15, 0.347_854_85];
    let mut img = Image::new(width, height);
    for (i, s) in samples.iter().enumerate() {
        let (px, py) = (i as u32 % width, i as u32 / width);
        let v = scene.camera.pixel_dir_f64(px as f64, py as f64, width, height).as_vec3();
        let tc = wv.dot(v);
        let h = wv.cross(v).length();
        let hh = (h * h + radius * radius).sqrt().max(1e-7 * wv.length());
        let mut sum = Vec3::ZERO;
        for &(ta, tb) in &s.lit {
            let alpha =
                |t: f64| if t.is_infinite() { std::f32::consts::FRAC_PI_2 } else { ((t as f32) - tc).atan2(hh) };
            let (a0, a1) = (alpha(ta), alpha(tb));
            if !(a1 > a0) {
                continue;
            }
            let step = (a1 - a0) / CPU_PANELS as f32;
            for k in 0..CPU_PANELS {
                let mid = a0 + (k as f32 + 0.5) * step;
                for q in 0..4 {
                    let a = mid + 0.5 * step * gx[q];
                    let (sn, cs) = a.sin_cos();
                    if cs <= 0.0 {
                        continue;
                    }
                    let along = hh * sn / cs; // t - t_c
                    let t = tc + along;
                    let d = (h * h + along * along).sqrt();
                    let cos_theta = if d > 0.0 { -along / d } else { 0.0 };
                    let p = f32m::phase(id, g, cos_theta);
                    // dt / (d^2 + r^2) = d(alpha) / H
                    let pre = sigma_s * intensity * (p / hh) * (0.5 * step * gw[q]);
                    let value = if separate_exponents {
                        let td = (-(sigma_t * d)).exp();
                        let tt = (-(sigma_t * t.max(0.0))).exp();
                        pre * (td * tt)
                    } else {
                        let x = sigma_t * (d + t.max(0.0));
                        let ln = Vec3::new(pre.x.ln(), pre.y.ln(), pre.z.ln());
                        let e = ln - x;
                        Vec3::new(e.x.exp(), e.y.exp(), e.z.exp())
                    };
                    sum += value;
                }
            }
        }
        img.pixels[i] = sum.to_array();
    }
    Ok(img)
}

//! The exact CPU reference renderer, in `f64` (DESIGN sections 1 and 4).
//!
//! It shares the scene, camera, light and medium types with the GPU path and nothing else: its own
//! ray tracer ([`Tracer`], a BVH over every triangle), its own parameterisation of the in-scattering
//! integral and its own quadrature.
//!
//! # What is computed
//!
//! For the view ray `P(t) = E + t v` of a pixel (`v` from [`crate::Camera::pixel_dir_f64`] at the
//! pixel centre, `E` the eye), with `ds` the distance to the first triangle (infinite for the sky):
//!
//! **Point light** at `L`, intensity `I0`, softening radius `r`; the medium fills all space:
//!
//! ```text
//! L_scatter = ∫_0^ds σs p(cosθ) V(t) I0 exp(-σt (d + t)) / (d² + r²) dt,   d = |L - P|,
//! cosθ = dot(unit(P - L), unit(E - P))       (1 = forward scattering into the eye)
//! ```
//!
//! **Directional light** toward `w`, irradiance `E0`; the medium fills only the box
//! [`Scene::medium_bounds`] (σ = 0 outside):
//!
//! ```text
//! L_scatter = ∫_{[0, ds] ∩ box} σs p(dot(w, v)) V(t) E0 exp(-σt (l(t) + m(t))) dt
//! ```
//!
//! with `l(t)` the length inside the box of the segment from `P(t)` toward the light and `m(t)` that
//! of the view segment from `E` to `P(t)`. `V` is 1 when the segment from the light to `P` (point)
//! or the ray from `P` toward `w` (directional) meets no triangle.
//!
//! **Surface** (Lambertian, opaque, every mesh casts and receives): the first hit `P_s` with the
//! geometric normal flipped to face the eye, `n`, gets `L_surface = albedo/π · max(dot(n, l), 0) ·
//! V_s · E_in`, where `E_in = I0 exp(-σt d)/(d² + r²)` (point) or `E0 exp(-σt l(P_s))`
//! (directional) and `V_s` comes from a shadow ray leaving `P_s + 1e-6 · diagonal · n`
//! (`diagonal` of the triangles' bounding box). A sheet lit from behind stays dark in front.
//! Then `hdr = L_surface · T_view + L_scatter` with `T_view = exp(-σt ds)` (point) or
//! `exp(-σt m(ds))` (directional); sky pixels get `hdr = L_scatter`. No ambient term, no near/far
//! clipping (the camera's `near`/`far` are ignored: every triangle in front of the eye counts).
//!
//! # Integration variable
//!
//! Point lights are integrated in `α = atan((t - t_c) / H)`, where `t_c = dot(L - E, v)` is the
//! distance to the point of closest approach, `h = |(L - E) × v|` the ray's distance from the light
//! and `H = sqrt(h² + r²)`. Since `d² + r² = H² / cos²α` and `dt = H dα / cos²α`,
//!
//! ```text
//! L_scatter = σs I0 / H ∫_{α(0)}^{α(ds)} p(cosθ) V exp(-σt (d + t)) dα,   α(∞) = π/2,
//! cosθ = -H sinα / q,   d = q / cosα,   q = sqrt(H² sin²α + h² cos²α),
//! ```
//!
//! a bounded, smooth integrand on a finite interval, including sky rays and rays through the light
//! (`h = 0`: then `H = r`). For an ideal point light (`r = 0`) `α = ψ - (π/2 - γ)` is the angle `ψ` at
//! the light of DESIGN section 2 shifted by a constant, so the visibility samples below are evenly
//! spaced in `ψ` exactly as DESIGN section 4 asks; for `r > 0` they are evenly spaced in the
//! unshadowed in-scattering weight of a clear isotropic medium. Only an ideal point light lying
//! exactly on a view ray (`h = r = 0`) has an infinite integral; there `H` is clamped to
//! `1e-12 · max(D, diagonal)` and the pixel is huge but finite. Directional lights are integrated
//! in `t` over the ray's part inside the box, split where `l(t)` has kinks.
//!
//! # Visibility and accuracy
//!
//! Per view ray, visibility is sampled at [`ReferenceOptions::samples`] points evenly spaced over
//! the integration domain (the two end samples are moved inward by `1e-9` of the domain so that no
//! sample sits exactly on the surface), every adjacent pair that differs is bisected to `1e-10` of
//! the domain (at most 64 halvings), and every lit interval is integrated by globally adaptive
//! Gauss–Kronrod 7-15 to the relative tolerance [`ReferenceOptions::tolerance`] per channel. The
//! initial partition is graded geometrically (ratio 8, down to `1e-14` of the domain) toward the
//! domain's ends and the point of closest approach, where the integrand's only narrow features are
//! (forward/backward phase peaks, the exponential boundary layer of thick media, the `cosθ` jump of
//! a ray passing close to a soft light); so narrow peaks are never missed by the first nodes.
//! Exponents are summed before `exp` (never `exp(a) · exp(b)`), so `σt D` of 1000 or more underflows
//! cleanly to 0 instead of producing `0 · ∞`.
//!
//! The reference's own error, per pixel:
//! - **missed visibility features**: a shadow (or a lit gap) narrower than one sample spacing,
//!   `domain / (samples - 1)` in `α` (point) or `t` (directional), that falls between two samples is
//!   missed entirely, as is any even number of changes between two samples. Its effect on
//!   `L_scatter` is at most its share of the integral: for a clear isotropic medium and a point
//!   light, at most `1 / (samples - 1)` of the full unshadowed value per missed feature;
//! - **bisection**: each located boundary is off by at most `1e-10` of the domain, an error of at
//!   most `1e-10 · domain · max|integrand|` per boundary (below `1e-9` relative for any lit ray);
//! - **quadrature**: the estimated error (sum of `|K15 - G7|`, pessimistic for smooth integrands)
//!   is below `tolerance` relative per channel; pixels where the subdivision limit
//!   ([`ReferenceOptions::max_splits`]) stopped it first are counted in
//!   [`RenderStats::unconverged`];
//! - geometry is exact in `f64` (triangle vertices are the scene's `f32` values converted exactly),
//!   with a barycentric slack of `1e-12` so that rays through shared edges never leak.

// `!(b > a)` is deliberate throughout: it treats NaN bounds as an empty range.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod quadrature;
mod tracer;

pub use quadrature::{bisect, integrate, Quadrature, Rgb};
pub use tracer::{Hit, TraceStats, Tracer};

use crate::image::Image;
use crate::params::{Light, Phase};
use crate::scene::Scene;
use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// Settings of the reference renderer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceOptions {
    /// Dense visibility samples per view ray, evenly spaced in the integration variable.
    pub samples: usize,
    /// Relative quadrature tolerance per channel.
    pub tolerance: f64,
    /// Show an `indicatif` progress bar (pixels) on stderr.
    pub progress: bool,
    /// Bisection stops when the bracket is this fraction of the domain.
    pub bisection: f64,
    /// Most interval splits of the adaptive quadrature per view ray.
    pub max_splits: usize,
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        ReferenceOptions { samples: 512, tolerance: 1e-6, progress: false, bisection: 1e-10, max_splits: 4000 }
    }
}

/// Work done by a render, summed over pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderStats {
    /// Ray queries: view rays are closest-hit queries, every shadow ray is an any-hit query.
    pub trace: TraceStats,
    /// Integrand evaluations of the quadrature.
    pub evals: u64,
    /// Visibility changes located by bisection.
    pub boundaries: u64,
    /// Pixels whose quadrature hit the subdivision limit before the tolerance.
    pub unconverged: u64,
    /// Wall-clock seconds of the render (0 for [`render_pixels`]).
    pub seconds: f64,
}

impl RenderStats {
    fn add(&mut self, o: &RenderStats) {
        self.trace.add(&o.trace);
        self.evals += o.evals;
        self.boundaries += o.boundaries;
        self.unconverged += o.unconverged;
    }
}

/// A rendered reference image.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceImage {
    /// In-scattered radiance `L_scatter` only.
    pub scatter: Image,
    /// Final linear radiance `L_surface · T_view + L_scatter`.
    pub hdr: Image,
    /// Distance `t` along the unit view ray to the first hit per pixel; `f32::INFINITY` for sky.
    pub depth: Vec<f32>,
    /// With [`ViewEnds::Given`] ends: the pixels whose given end is not the reference's own first
    /// hit (another surface, or sky against surface); 0 otherwise.
    pub segments_differing: usize,
    pub stats: RenderStats,
}

/// Everything the reference knows about one view ray.
#[derive(Debug, Clone, PartialEq)]
pub struct RaySample {
    /// `L_scatter`.
    pub scatter: Rgb,
    /// `L_surface` at the hit, before the view transmittance (0 for sky).
    pub surface: Rgb,
    /// `T_view` to the hit (1 for sky).
    pub transmittance: Rgb,
    /// `L_surface · T_view + L_scatter`.
    pub hdr: Rgb,
    /// The first hit, if any.
    pub hit: Option<Hit>,
    /// Lit intervals along the ray, in `t`.
    pub lit: Vec<(f64, f64)>,
    pub stats: RenderStats,
}

/// The light in `f64`.
#[derive(Debug, Clone, Copy, PartialEq)]
enum LightF64 {
    Point { pos: DVec3, intensity: Rgb, radius: f64 },
    Directional { w: DVec3, irradiance: Rgb },
}

/// A prepared reference renderer: the scene's light, medium and materials in `f64` and a borrowed
/// [`Tracer`].
#[derive(Debug, Clone)]
pub struct Reference<'a> {
    tracer: &'a Tracer,
    opts: ReferenceOptions,
    light: LightF64,
    sigma_s: Rgb,
    sigma_t: Rgb,
    phase: Phase,
    albedo: Vec<Rgb>,
    box_lo: DVec3,
    box_hi: DVec3,
    diagonal: f64,
}

fn rgb(v: glam::Vec3) -> Rgb {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// `exp(-sigma * x)` with `0 · ∞ = 0` in the exponent (a clear channel transmits everything).
#[inline]
fn transmit(sigma: f64, x: f64) -> f64 {
    if sigma == 0.0 {
        1.0
    } else {
        (-(sigma * x)).exp()
    }
}

/// Entry and exit distances of the line `o + t d` through the box (`t` may be negative), or `None`.
fn box_span(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for k in 0..3 {
        if d[k] == 0.0 {
            if o[k] < lo[k] || o[k] > hi[k] {
                return None;
            }
            continue;
        }
        let a = (lo[k] - o[k]) / d[k];
        let b = (hi[k] - o[k]) / d[k];
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Length of the part of the ray `o + s d`, `s` in `[0, smax]`, inside the box.
fn length_in_box(o: DVec3, d: DVec3, smax: f64, lo: DVec3, hi: DVec3) -> f64 {
    match box_span(o, d, lo, hi) {
        Some((a, b)) => (b.min(smax) - a.max(0.0)).max(0.0),
        None => 0.0,
    }
}

/// A unit vector perpendicular to `v`.
fn any_perpendicular(v: DVec3) -> DVec3 {
    let helper = if v.x.abs() < 0.6 { DVec3::X } else { DVec3::Y };
    v.cross(helper).normalize()
}

/// Point-light geometry of one view ray.
#[derive(Debug, Clone, Copy)]
struct PointRay {
    v: DVec3,
    /// Unit vector perpendicular to `v`, from the ray toward the light.
    n: DVec3,
    light: DVec3,
    tc: f64,
    h: f64,
    hh: f64,
}

/// Geometry at one value of `α`.
struct PointAt {
    cos_theta: f64,
    /// `d + t`.
    path: f64,
    d: f64,
    /// Unit direction from the light toward `P`.
    from_light: DVec3,
}

impl PointRay {
    fn alpha_of_t(&self, t: f64) -> f64 {
        if t.is_infinite() {
            FRAC_PI_2
        } else {
            (t - self.tc).atan2(self.hh)
        }
    }

    fn t_of_alpha(&self, a: f64) -> f64 {
        let (s, c) = a.sin_cos();
        if c <= 0.0 {
            f64::INFINITY
        } else {
            self.tc + self.hh * s / c
        }
    }

    fn at(&self, a: f64) -> PointAt {
        let (s, c) = a.sin_cos();
        let c = c.max(0.0);
        let hs = self.hh * s;
        let hc = self.h * c;
        let q = (hs * hs + hc * hc).sqrt();
        let (cos_theta, from_light) = if q > 0.0 { (-hs / q, (self.v * hs - self.n * hc) / q) } else { (0.0, self.v) };
        let (d, t) = if c > 0.0 { (q / c, self.tc + hs / c) } else { (f64::INFINITY, f64::INFINITY) };
        PointAt { cos_theta, path: d + t, d, from_light }
    }
}

/// Directional-light geometry of one view ray.
#[derive(Debug, Clone, Copy)]
struct DirRay {
    e: DVec3,
    v: DVec3,
    w: DVec3,
    /// Where the view ray enters the box (clamped to 0): `m(t) = t - t_enter`.
    t_enter: f64,
}

/// Geometrically graded points toward `f` inside `[lo, hi]` (ratio 8, down to `1e-14` of the
/// domain), on both sides.
fn graded_points(f: f64, lo: f64, hi: f64, out: &mut Vec<f64>) {
    let span = hi - lo;
    for (side, len) in [(1.0, hi - f), (-1.0, f - lo)] {
        let mut off = len;
        loop {
            off *= 0.125;
            if off < 1e-14 * span {
                break;
            }
            out.push(f + side * off);
        }
    }
    if f > lo && f < hi {
        out.push(f);
    }
}

/// Splits every interval at the (sorted) points strictly inside it.
fn split_intervals(intervals: &[(f64, f64)], points: &[f64]) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(intervals.len() + points.len());
    for &(a, b) in intervals {
        let mut start = a;
        let first = points.partition_point(|&p| p <= a);
        for &p in &points[first..] {
            if p >= b {
                break;
            }
            if p > start {
                out.push((start, p));
                start = p;
            }
        }
        if b > start {
            out.push((start, b));
        }
    }
    out
}

impl<'a> Reference<'a> {
    /// Prepares the reference for `scene`, tracing against `tracer` (built from the same scene).
    pub fn new(scene: &Scene, tracer: &'a Tracer, opts: ReferenceOptions) -> Reference<'a> {
        let light = match scene.light {
            Light::Point { position, intensity, radius } => {
                LightF64::Point { pos: position.as_dvec3(), intensity: rgb(intensity), radius: radius as f64 }
            }
            Light::Directional { direction, irradiance } => {
                LightF64::Directional { w: direction.as_dvec3().normalize_or(DVec3::Y), irradiance: rgb(irradiance) }
            }
        };
        let mb = scene.medium_bounds();
        Reference {
            tracer,
            opts,
            light,
            sigma_s: rgb(scene.medium.sigma_s()),
            sigma_t: rgb(scene.medium.sigma_t()),
            phase: scene.medium.phase,
            albedo: scene.meshes.iter().map(|m| rgb(m.albedo)).collect(),
            box_lo: mb.min.as_dvec3(),
            box_hi: mb.max.as_dvec3(),
            diagonal: tracer.diagonal(),
        }
    }

    pub fn options(&self) -> &ReferenceOptions {
        &self.opts
    }

    fn point_ray(&self, origin: DVec3, v: DVec3, pos: DVec3, radius: f64) -> PointRay {
        let w = pos - origin;
        let tc = w.dot(v);
        let h = w.cross(v).length();
        let perp = w - v * tc;
        let n = if perp.length_squared() > 0.0 { perp.normalize() } else { any_perpendicular(v) };
        let scale = w.length().max(self.diagonal);
        let h_min = if scale > 0.0 { 1e-12 * scale } else { 1e-300 };
        let hh = (h * h + radius * radius).sqrt().max(h_min);
        PointRay { v, n, light: pos, tc, h, hh }
    }

    /// Samples the visibility `vis` at `samples` points evenly spaced over `[a, b]`, bisects every
    /// change and returns the lit intervals.
    fn lit_intervals_in(
        &self,
        a: f64,
        b: f64,
        mut vis: impl FnMut(f64) -> bool,
        stats: &mut RenderStats,
    ) -> Vec<(f64, f64)> {
        if !(b > a) {
            return Vec::new();
        }
        let n = self.opts.samples.max(2);
        let span = b - a;
        let inset = 1e-9 * span;
        let xs: Vec<f64> = (0..n)
            .map(|k| {
                if k == 0 {
                    a + inset
                } else if k == n - 1 {
                    b - inset
                } else {
                    a + span * (k as f64 / (n - 1) as f64)
                }
            })
            .collect();
        let vs: Vec<bool> = xs.iter().map(|&x| vis(x)).collect();
        let tol = self.opts.bisection * span;
        let mut out = Vec::new();
        let mut start = a;
        for k in 0..n - 1 {
            if vs[k] != vs[k + 1] {
                let x = bisect(&mut vis, xs[k], xs[k + 1], vs[k], tol, 64);
                stats.boundaries += 1;
                if vs[k] {
                    out.push((start, x));
                }
                start = x;
            }
        }
        if vs[n - 1] {
            out.push((start, b));
        }
        out
    }

    /// The in-scattered radiance `L_scatter` along `origin + t dir`, `t` in `[0, t_surface]`
    /// (`f64::INFINITY` for the sky), with exact visibility. `dir` is normalised first; `t` is a
    /// distance. The surface at `t_surface` is not looked up: pass the first hit's distance.
    pub fn scatter_along_ray(&self, origin: DVec3, dir: DVec3, t_surface: f64) -> Rgb {
        self.scatter_range(origin, dir, 0.0, t_surface, true, &mut RenderStats::default()).0
    }

    /// `L_scatter` over `t` in `[t0, t1]` ignoring every occluder (`V = 1`): the unshadowed
    /// integral, with the same quadrature.
    pub fn scatter_unoccluded(&self, origin: DVec3, dir: DVec3, t0: f64, t1: f64) -> Rgb {
        self.scatter_range(origin, dir, t0, t1, false, &mut RenderStats::default()).0
    }

    /// The lit intervals (in `t`) along `origin + t dir` up to `t_surface`.
    pub fn lit_intervals(&self, origin: DVec3, dir: DVec3, t_surface: f64) -> Vec<(f64, f64)> {
        self.scatter_range(origin, dir, 0.0, t_surface, true, &mut RenderStats::default()).1
    }

    /// `L_scatter` over `t` in `[t0, t1]` (with visibility when `shadows`) and the lit intervals.
    fn scatter_range(
        &self,
        origin: DVec3,
        dir: DVec3,
        t0: f64,
        t1: f64,
        shadows: bool,
        stats: &mut RenderStats,
    ) -> (Rgb, Vec<(f64, f64)>) {
        let v = dir.normalize();
        let t0 = t0.max(0.0);
        if !(t1 > t0) || !v.is_finite() {
            return ([0.0; 3], Vec::new());
        }
        let power = match self.light {
            LightF64::Point { intensity, .. } => intensity,
            LightF64::Directional { irradiance, .. } => irradiance,
        };
        let k: Rgb = std::array::from_fn(|c| self.sigma_s[c] * power[c]);
        if k.iter().all(|&x| x == 0.0) {
            return ([0.0; 3], vec![(t0, t1)]);
        }
        match self.light {
            LightF64::Point { pos, radius, .. } => {
                let g = self.point_ray(origin, v, pos, radius);
                let (a0, a1) = (g.alpha_of_t(t0), g.alpha_of_t(t1));
                if !(a1 > a0) {
                    return ([0.0; 3], Vec::new());
                }
                let lit = if shadows {
                    let tracer = self.tracer;
                    let mut ts = TraceStats::default();
                    let lit = self.lit_intervals_in(
                        a0,
                        a1,
                        |a| {
                            let p = g.at(a);
                            !tracer.occluded_stats(g.light, p.from_light, p.d, &mut ts)
                        },
                        stats,
                    );
                    stats.trace.add(&ts);
                    lit
                } else {
                    vec![(a0, a1)]
                };
                let mut pts = Vec::new();
                graded_points(a0, a0, a1, &mut pts);
                graded_points(a1, a0, a1, &mut pts);
                if 0.0 > a0 && 0.0 < a1 {
                    graded_points(0.0, a0, a1, &mut pts);
                }
                pts.sort_by(f64::total_cmp);
                let pieces = split_intervals(&lit, &pts);
                let scale: Rgb = std::array::from_fn(|c| k[c] / g.hh);
                let (sigma_t, phase) = (self.sigma_t, self.phase);
                let q = integrate(
                    |a| {
                        let p = g.at(a);
                        let ph = phase.eval(p.cos_theta);
                        std::array::from_fn(|c| scale[c] * ph * transmit(sigma_t[c], p.path))
                    },
                    &pieces,
                    self.opts.tolerance,
                    self.opts.max_splits,
                );
                stats.evals += q.evals as u64;
                stats.unconverged += u64::from(!q.converged);
                let to_t = |a: f64| {
                    if a <= a0 {
                        t0
                    } else if a >= a1 {
                        t1
                    } else {
                        g.t_of_alpha(a).clamp(t0, t1)
                    }
                };
                let lit_t = lit.iter().map(|&(a, b)| (to_t(a), to_t(b))).collect();
                (q.value, lit_t)
            }
            LightF64::Directional { w, .. } => {
                let Some((bin, bout)) = box_span(origin, v, self.box_lo, self.box_hi) else {
                    return ([0.0; 3], Vec::new());
                };
                let (ta, tb) = (t0.max(bin), t1.min(bout));
                if !(tb > ta) {
                    return ([0.0; 3], Vec::new());
                }
                let g = DirRay { e: origin, v, w, t_enter: bin.max(0.0) };
                let lit = if shadows {
                    let tracer = self.tracer;
                    let mut ts = TraceStats::default();
                    let lit = self.lit_intervals_in(
                        ta,
                        tb,
                        |t| !tracer.occluded_stats(g.e + g.v * t, g.w, f64::INFINITY, &mut ts),
                        stats,
                    );
                    stats.trace.add(&ts);
                    lit
                } else {
                    vec![(ta, tb)]
                };
                // Kinks of l(t) = min_k (B_k - e_k - t v_k) / w_k where two planes swap.
                let mut lines: Vec<(f64, f64)> = Vec::new(); // l_k(t) = c0 + c1 t
                for k in 0..3 {
                    if w[k] != 0.0 {
                        let bound = if w[k] > 0.0 { self.box_hi[k] } else { self.box_lo[k] };
                        lines.push(((bound - origin[k]) / w[k], -v[k] / w[k]));
                    }
                }
                let mut pts = Vec::new();
                for i in 0..lines.len() {
                    for j in i + 1..lines.len() {
                        let dc1 = lines[i].1 - lines[j].1;
                        if dc1 != 0.0 {
                            let t = (lines[j].0 - lines[i].0) / dc1;
                            if t > ta && t < tb {
                                graded_points(t, ta, tb, &mut pts);
                            }
                        }
                    }
                }
                graded_points(ta, ta, tb, &mut pts);
                graded_points(tb, ta, tb, &mut pts);
                pts.sort_by(f64::total_cmp);
                let pieces = split_intervals(&lit, &pts);
                let ph = self.phase.eval(w.dot(v));
                let scale: Rgb = std::array::from_fn(|c| k[c] * ph);
                let sigma_t = self.sigma_t;
                let (lo, hi) = (self.box_lo, self.box_hi);
                let q = integrate(
                    |t| {
                        let p = g.e + g.v * t;
                        let l = length_in_box(p, g.w, f64::INFINITY, lo, hi);
                        let m = (t - g.t_enter).max(0.0);
                        let x = l + m;
                        std::array::from_fn(|c| scale[c] * transmit(sigma_t[c], x))
                    },
                    &pieces,
                    self.opts.tolerance,
                    self.opts.max_splits,
                );
                stats.evals += q.evals as u64;
                stats.unconverged += u64::from(!q.converged);
                (q.value, lit)
            }
        }
    }

    /// Traces the view ray `origin + t dir` and returns everything the reference knows about it.
    pub fn shade_ray(&self, origin: DVec3, dir: DVec3) -> RaySample {
        self.shade_ray_ending(origin, dir, None)
    }

    /// [`Reference::shade_ray`], with the scattered light integrated up to `end` (infinity: the
    /// sky) instead of the ray's own first hit when `end` is given. The surface term stays the
    /// one at the ray's own first hit.
    pub fn shade_ray_ending(&self, origin: DVec3, dir: DVec3, end: Option<f64>) -> RaySample {
        let mut stats = RenderStats::default();
        let v = dir.normalize();
        let hit = self.tracer.first_hit_stats(origin, v, f64::INFINITY, &mut stats.trace);
        let ds = hit.map_or(f64::INFINITY, |h| h.t);
        let (scatter, lit) = self.scatter_range(origin, v, 0.0, end.unwrap_or(ds), true, &mut stats);
        let mut surface = [0.0; 3];
        let mut transmittance = [1.0; 3];
        if let Some(h) = hit {
            let ps = origin + v * ds;
            let albedo = self.albedo.get(h.mesh).copied().unwrap_or([0.0; 3]);
            let (to_light, e_in): (DVec3, Rgb) = match self.light {
                LightF64::Point { pos, intensity, radius } => {
                    let dvec = pos - ps;
                    let d = dvec.length();
                    let l = if d > 0.0 { dvec / d } else { -v };
                    let den = (d * d + radius * radius).max(f64::MIN_POSITIVE);
                    (l, std::array::from_fn(|c| intensity[c] * transmit(self.sigma_t[c], d) / den))
                }
                LightF64::Directional { w, irradiance } => {
                    let l = length_in_box(ps, w, f64::INFINITY, self.box_lo, self.box_hi);
                    (w, std::array::from_fn(|c| irradiance[c] * transmit(self.sigma_t[c], l)))
                }
            };
            // Opaque surfaces: only the side facing the eye is seen, and it is lit only when the
            // light is on that side too (a sheet lit from behind stays dark in front).
            let n_eye = if h.normal.dot(v) < 0.0 { h.normal } else { -h.normal };
            let cos_i = n_eye.dot(to_light);
            if cos_i > 0.0 && albedo.iter().any(|&a| a != 0.0) {
                let n_l = n_eye;
                let o = ps + n_l * (1e-6 * self.diagonal);
                let tmax = match self.light {
                    LightF64::Point { pos, .. } => (pos - o).length(),
                    LightF64::Directional { .. } => f64::INFINITY,
                };
                let dir_l = match self.light {
                    LightF64::Point { pos, .. } => (pos - o).normalize_or(to_light),
                    LightF64::Directional { w, .. } => w,
                };
                if !self.tracer.occluded_stats(o, dir_l, tmax, &mut stats.trace) {
                    let f = cos_i.abs() / PI;
                    surface = std::array::from_fn(|c| albedo[c] * f * e_in[c]);
                }
            }
            let path = match self.light {
                LightF64::Point { .. } => ds,
                LightF64::Directional { .. } => length_in_box(origin, v, ds, self.box_lo, self.box_hi),
            };
            transmittance = std::array::from_fn(|c| transmit(self.sigma_t[c], path));
        }
        let hdr = std::array::from_fn(|c| surface[c] * transmittance[c] + scatter[c]);
        RaySample { scatter, surface, transmittance, hdr, hit, lit, stats }
    }
}

/// `L_scatter` along `origin + t dir` for `t` in `[0, t_surface]` (infinity: sky) in `scene`, with
/// exact visibility against `tracer` (built from the same scene).
pub fn scatter_along_ray(
    scene: &Scene,
    tracer: &Tracer,
    opts: &ReferenceOptions,
    origin: DVec3,
    dir: DVec3,
    t_surface: f64,
) -> Rgb {
    Reference::new(scene, tracer, *opts).scatter_along_ray(origin, dir, t_surface)
}

/// Renders the pixels `(px, py)` of a `width x height` image of `scene` (rays through the pixel
/// centres, row 0 at the top, as [`crate::Camera::pixel_dir_f64`]), in parallel.
pub fn render_pixels(
    scene: &Scene,
    width: u32,
    height: u32,
    pixels: &[(u32, u32)],
    opts: &ReferenceOptions,
) -> Vec<RaySample> {
    let tracer = Tracer::new(scene);
    let r = Reference::new(scene, &tracer, *opts);
    let eye = scene.camera.eye.as_dvec3();
    pixels
        .par_iter()
        .map(|&(px, py)| r.shade_ray(eye, scene.camera.pixel_dir_f64(px as f64, py as f64, width, height)))
        .collect()
}

/// Renders the whole `width x height` image, rows in parallel.
pub fn render(scene: &Scene, width: u32, height: u32, opts: &ReferenceOptions) -> ReferenceImage {
    render_ending(scene, width, height, opts, ViewEnds::OwnHits)
}

/// Where each view ray of [`render_ending`] ends its scattered light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ViewEnds<'a> {
    /// At the ray's own first hit (the exact image).
    OwnHits,
    /// At the given distance per pixel (rows top to bottom; infinity for the sky), e.g. where a
    /// GPU method's rasterizer put the surface ([`crate::render::Renderer::read_view_distances`]). The
    /// scattered light is then exact along the *same view segments* the method integrated, which
    /// separates its volumetric error from primary visibility: a rasterizer decides coverage on
    /// its sub-pixel grid (1/256 pixel on llvmpipe), so a pixel centre that close to a silhouette
    /// edge can land on either side of it.
    Given(&'a [f32]),
}

/// [`render`], with the view rays' scattered light ending where `ends` says. With
/// [`ViewEnds::Given`], [`ReferenceImage::depth`] still holds the reference's own first hits and
/// [`ReferenceImage::segments_differing`] counts the pixels whose given end differs from them.
///
/// Panics if a given `ends` slice is not `width * height` long (the caller checks the file).
pub fn render_ending(
    scene: &Scene,
    width: u32,
    height: u32,
    opts: &ReferenceOptions,
    ends: ViewEnds,
) -> ReferenceImage {
    let ends = match ends {
        ViewEnds::OwnHits => None,
        ViewEnds::Given(e) => Some(e),
    };
    assert!(ends.is_none_or(|e| e.len() == width as usize * height as usize), "one view end per pixel");
    let start = Instant::now();
    let tracer = Tracer::new(scene);
    let r = Reference::new(scene, &tracer, *opts);
    let eye = scene.camera.eye.as_dvec3();
    let bar = if opts.progress {
        let b = ProgressBar::new(width as u64 * height as u64);
        if let Ok(style) =
            ProgressStyle::with_template("reference {bar:40} {pos}/{len} px  {elapsed_precise} (eta {eta})")
        {
            b.set_style(style);
        }
        b
    } else {
        ProgressBar::hidden()
    };
    let rows: Vec<(Vec<RaySample>, RenderStats)> = (0..height)
        .into_par_iter()
        .map(|py| {
            let mut st = RenderStats::default();
            let row: Vec<RaySample> = (0..width)
                .map(|px| {
                    let end = ends.map(|e| e[(py * width + px) as usize] as f64);
                    let dir = scene.camera.pixel_dir_f64(px as f64, py as f64, width, height);
                    let s = r.shade_ray_ending(eye, dir, end);
                    st.add(&s.stats);
                    s
                })
                .collect();
            bar.inc(width as u64);
            (row, st)
        })
        .collect();
    bar.finish_and_clear();
    let mut scatter = Image::new(width, height);
    let mut hdr = Image::new(width, height);
    let mut depth = Vec::with_capacity(width as usize * height as usize);
    let mut stats = RenderStats::default();
    let mut segments_differing = 0;
    for (py, (row, st)) in rows.into_iter().enumerate() {
        stats.add(&st);
        for (px, s) in row.into_iter().enumerate() {
            let i = py * width as usize + px;
            scatter.pixels[i] = s.scatter.map(|x| x as f32);
            hdr.pixels[i] = s.hdr.map(|x| x as f32);
            let own = s.hit.map_or(f32::INFINITY, |h| h.t as f32);
            if let Some(e) = ends {
                // A different surface, not f32 rounding of the same one: 0.1% of the distance.
                let same = (own.is_infinite() && e[i].is_infinite()) || (own - e[i]).abs() <= 1e-3 * own.min(e[i]);
                segments_differing += usize::from(!same);
            }
            depth.push(own);
        }
    }
    stats.seconds = start.elapsed().as_secs_f64();
    ReferenceImage { scatter, hdr, depth, segments_differing, stats }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_helpers() {
        let (lo, hi) = (DVec3::splat(-1.0), DVec3::splat(1.0));
        assert_eq!(box_span(DVec3::new(-3.0, 0.0, 0.0), DVec3::X, lo, hi), Some((2.0, 4.0)));
        assert_eq!(box_span(DVec3::new(-3.0, 2.0, 0.0), DVec3::X, lo, hi), None);
        assert_eq!(length_in_box(DVec3::ZERO, DVec3::Y, f64::INFINITY, lo, hi), 1.0);
        assert_eq!(length_in_box(DVec3::new(0.0, -3.0, 0.0), DVec3::Y, 2.5, lo, hi), 0.5);
        assert_eq!(length_in_box(DVec3::new(0.0, 3.0, 0.0), DVec3::Y, 9.0, lo, hi), 0.0);
    }

    #[test]
    fn graded_partition() {
        let mut p = Vec::new();
        graded_points(0.0, 0.0, 1.0, &mut p);
        p.sort_by(f64::total_cmp);
        assert!(p[0] < 1e-13 && p[0] > 0.0 && p.len() < 20, "{p:?}");
        let pieces = split_intervals(&[(0.0, 0.5), (0.7, 1.0)], &p);
        assert_eq!(pieces.first().unwrap().0, 0.0);
        assert_eq!(pieces.last().unwrap(), &(0.7, 1.0));
        let total: f64 = pieces.iter().map(|(a, b)| b - a).sum();
        assert!((total - 0.8).abs() < 1e-15);
        assert!(pieces.iter().all(|(a, b)| b > a));
    }

    /// The α parameterisation reproduces the geometry computed from 3-D points.
    #[test]
    fn alpha_geometry_matches_3d() {
        let v = DVec3::new(1.0, 0.2, -0.1).normalize();
        let (l, r) = (DVec3::new(2.0, 1.0, 0.5), 0.3);
        // Eye at the origin.
        let tc = l.dot(v);
        let h = l.cross(v).length();
        let g = PointRay { v, n: (l - v * tc).normalize(), light: l, tc, h, hh: (h * h + r * r).sqrt() };
        for t in [0.0, 0.3, 1.0, 2.2, 5.0, 40.0] {
            let a = g.alpha_of_t(t);
            assert!((g.t_of_alpha(a) - t).abs() < 1e-12 * (1.0 + t));
            let p = v * t;
            let at = g.at(a);
            let d = (l - p).length();
            assert!((at.d - d).abs() < 1e-12 * (1.0 + d));
            assert!((at.path - (d + t)).abs() < 1e-12 * (1.0 + d + t));
            assert!((at.from_light - (p - l).normalize()).length() < 1e-12);
            if t > 0.0 {
                let cos = (p - l).normalize().dot(-v);
                assert!((at.cos_theta - cos).abs() < 1e-12);
            }
        }
    }
}

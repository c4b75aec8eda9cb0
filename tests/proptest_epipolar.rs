//! Property tests of the epipolar mapping (`src/epipolar.rs`) over random inputs, extremes included:
//! eyes up to 1e6 from the origin, lights from 1e-4 to 1e6 away, points from 1e-4 to 1e6 away, every
//! direction, point and directional lights.
//!
//! Tolerances follow from `f64` rounding (`EPS = 2^-52`) and the conditioning of each step; they are
//! stated next to each property. None of them is tuned to pass: each is a first-order error bound
//! with a safety factor of 16-64 over the handful of roundings it covers.

use epivox::epipolar::{angle_between, EpipolarFrame, GridMapping, LightGeom};
use epivox::params::{BinSpacing, Grid};
use epivox::scene::{Aabb, Camera};
use glam::{DVec3, Vec3};
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};

const EPS: f64 = f64::EPSILON;

/// A uniformly distributed unit vector, or (one time in five) a world axis: the basis of the frame
/// is built from the least aligned world axis, so axis-aligned inputs are an edge case.
fn unit() -> impl Strategy<Value = DVec3> {
    prop_oneof![
        4 => (-1.0f64..1.0, 0.0f64..TAU).prop_map(|(z, a): (f64, f64)| {
            let r = (1.0 - z * z).max(0.0).sqrt();
            DVec3::new(r * a.cos(), r * a.sin(), z)
        }),
        1 => prop::sample::select(vec![DVec3::X, DVec3::NEG_X, DVec3::Y, DVec3::NEG_Y, DVec3::Z, DVec3::NEG_Z]),
    ]
}

/// Log-uniform in [10^lo, 10^hi].
fn magnitude(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo..hi).prop_map(|e| 10f64.powf(e))
}

/// Eyes near the origin or far from it.
fn eye() -> impl Strategy<Value = DVec3> {
    prop_oneof![
        (unit(), magnitude(-3.0, 1.0)).prop_map(|(u, m)| u * m),
        (unit(), magnitude(1.0, 6.0)).prop_map(|(u, m)| u * m),
    ]
}

/// `PROPTEST_RNG_SEED` when set, otherwise a fixed seed.
fn fixed_seed() -> proptest::test_runner::RngSeed {
    let seed = std::env::var("PROPTEST_RNG_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(0x00e9_1705);
    proptest::test_runner::RngSeed::Fixed(seed)
}

proptest! {
    // A fixed seed: the test command must not pass or fail by chance (PROPTEST_RNG_SEED
    // explores others).
    #![proptest_config(ProptestConfig {
        cases: 2000,
        max_global_rejects: 100_000,
        rng_seed: fixed_seed(),
        ..ProptestConfig::default()
    })]

    /// World -> (phi, gamma, psi) -> world for a point light. The angles are computed from
    /// differences of vectors of size up to `S = |E| + D + t + d`, so each carries an absolute error
    /// of about `delta = EPS S / min(D, d, t)`. The reconstruction `t = D sin(psi) / sin(beta)`
    /// (beta = pi - gamma - psi, the angle at P) amplifies that by `1/sin(psi) + 1/sin(beta)`; the
    /// direction adds `t delta`. Bound: 64 x that sum.
    #[test]
    fn point_light_round_trip(e in eye(), to_l in unit(), dist in magnitude(-4.0, 6.0), dir in unit(), t in magnitude(-4.0, 6.0)) {
        let l = e + to_l * dist;
        let f = EpipolarFrame::new(e, LightGeom::Point(l)).unwrap();
        let p = e + dir * t;
        let c = f.coords(p);
        prop_assume!(c.gamma > 1e-6 && c.gamma < PI - 1e-6); // on the axis phi is arbitrary
        let d = (l - p).length();
        prop_assume!(d > 0.0);
        let beta = PI - c.gamma - c.z;
        let s = e.length() + dist + t + d;
        let delta = EPS * s / dist.min(d).min(t);
        let dt = t * delta * (1.0 / c.z.sin().max(1e-300) + 1.0 / beta.sin().max(1e-300));
        let tol = 64.0 * (dt + t * delta + EPS * s);
        let q = f.point(c);
        prop_assert!((q - p).length() <= tol, "|q - p| = {} > {tol}: {c:?}", (q - p).length());
        prop_assert!((0.0..TAU).contains(&c.phi));
        prop_assert!((0.0..=PI).contains(&c.z) && c.gamma + c.z <= PI + 1e-12);
    }

    /// The same for a directional light: `z = r` (distance from the axis), `t = r / sin(gamma)`.
    #[test]
    fn directional_light_round_trip(e in eye(), w in unit(), dir in unit(), t in magnitude(-4.0, 6.0)) {
        let f = EpipolarFrame::new(e, LightGeom::Directional(w)).unwrap();
        let p = e + dir * t;
        let c = f.coords(p);
        prop_assume!(c.gamma > 1e-6 && c.gamma < PI - 1e-6);
        let s = e.length() + t;
        let delta = EPS * s / t;
        let tol = 64.0 * (t * delta * (1.0 + 1.0 / c.gamma.sin()) + EPS * s);
        let q = f.point(c);
        prop_assert!((q - p).length() <= tol, "|q - p| = {} > {tol}: {c:?}", (q - p).length());
    }

    /// Moving away from the light along a light ray, gamma never decreases and phi and z stay put
    /// (DESIGN section 2: the scan runs along increasing gamma). Tolerance on each: the angle error
    /// `delta` of the first property, times 64.
    #[test]
    fn gamma_grows_along_light_rays(e in eye(), to_l in unit(), dist in magnitude(-4.0, 6.0), dir in unit(),
                                    t in magnitude(-4.0, 6.0), step in magnitude(-4.0, 6.0), point in any::<bool>()) {
        let (light, ray) = if point {
            let l = e + to_l * dist;
            let p = e + dir * t;
            prop_assume!((p - l).length() > 0.0);
            (LightGeom::Point(l), (p - l).normalize())
        } else {
            (LightGeom::Directional(to_l), -to_l)
        };
        let f = EpipolarFrame::new(e, light).unwrap();
        let p0 = e + dir * t;
        let p1 = p0 + ray * step;
        let (c0, c1) = (f.coords(p0), f.coords(p1));
        prop_assume!(c0.gamma > 1e-6 && c0.gamma < PI - 1e-6 && c1.gamma < PI - 1e-6);
        let d0 = match light { LightGeom::Point(l) => (p0 - l).length(), _ => f64::INFINITY };
        let s = e.length() + dist + t + step + (p1 - e).length();
        let r0 = (p0 - e).length().min((p1 - e).length()).min(d0);
        let delta = 64.0 * EPS * s / r0;
        prop_assert!(c1.gamma >= c0.gamma - delta, "gamma fell from {} to {}", c0.gamma, c1.gamma);
        let dphi = (c1.phi - c0.phi).abs();
        prop_assert!(dphi.min(TAU - dphi) * c0.gamma.sin().min(c1.gamma.sin()) <= delta, "phi moved by {dphi}");
        let z_tol = if point { delta } else { 64.0 * EPS * s };
        prop_assert!((c1.z - c0.z).abs() <= z_tol, "z moved from {} to {}", c0.z, c1.z);
    }

    /// Along a view ray, z (psi or r) grows with t, and t(z) grows with z: the bins of a ray are in
    /// order. `z_of` is atan2 of rounded values (a few EPS of pi); `t_of` is monotone up to its own
    /// rounding, a few EPS relative.
    #[test]
    fn z_and_t_are_monotonic_along_view_rays(e in eye(), to_l in unit(), dist in magnitude(-4.0, 6.0),
                                             gamma in 1e-6f64..(PI - 1e-6), ta in magnitude(-4.0, 6.0),
                                             tb in magnitude(-4.0, 6.0), point in any::<bool>()) {
        let light = if point { LightGeom::Point(e + to_l * dist) } else { LightGeom::Directional(to_l) };
        let f = EpipolarFrame::new(e, light).unwrap();
        let (t1, t2) = (ta.min(tb), ta.max(tb));
        let (z1, z2) = (f.z_of(gamma, t1), f.z_of(gamma, t2));
        prop_assert!(z1 <= z2 + 16.0 * EPS * (1.0 + z2), "z({t1}) = {z1} > z({t2}) = {z2}");
        let (b1, b2) = (f.t_of(gamma, z1), f.t_of(gamma, z2));
        prop_assert!(b1 <= b2 * (1.0 + 16.0 * EPS) || b2.is_infinite(), "t({z1}) = {b1} > t({z2}) = {b2}");
    }

    /// The fitted grid: every bin coordinate maps back to itself and bins are in order of z, for
    /// both spacings, over random cameras, lights and caster boxes. Uniform spacing is linear: a few
    /// EPS of `bins`. Cosine spacing goes through acos, whose error is `EPS / sin z` in z, i.e.
    /// `bins EPS / |cos z_lo - cos z_hi|` in bin units: tiny psi ranges (a light far away) lose
    /// bins, stated by the bound.
    #[test]
    fn grid_mapping_round_trips_and_orders_bins(e in eye(), to_l in unit(), dist in magnitude(-3.0, 5.0), fwd in unit(),
                                                fov in 5.0f32..170.0, aspect in 0.2f64..5.0, c_off in unit(),
                                                c_dist in magnitude(-2.0, 3.0), c_size in magnitude(-3.0, 2.0),
                                                k in 0.0f64..1.0, k2 in 0.0f64..1.0, cosine in any::<bool>(), point in any::<bool>()) {
        let light = if point { LightGeom::Point(e + to_l * dist) } else { LightGeom::Directional(to_l) };
        let f = EpipolarFrame::new(e, light).unwrap();
        let up = if fwd.cross(DVec3::Y).length() > 1e-3 { Vec3::Y } else { Vec3::X };
        let cam = Camera { eye: e.as_vec3(), target: (e + fwd).as_vec3(), up, fov_y_deg: fov, near: 1e-3, far: 1e6 };
        prop_assume!(cam.validate().is_ok());
        let centre = (e + c_off * c_dist).as_vec3();
        let casters = Aabb { min: centre - Vec3::splat(c_size as f32), max: centre + Vec3::splat(c_size as f32) };
        let spacing = if cosine { BinSpacing::UniformCosine } else { BinSpacing::UniformAngle };
        let grid = Grid { planes: 256, rays: 256, bins: 256, spacing };
        let m = GridMapping::fit(&f, &cam, aspect, &casters, grid);
        prop_assume!(m.z_hi > m.z_lo);
        // Cosine bins used to divide 0 by 0 when cos(z_lo) == cos(z_hi) (a range narrower than
        // cos's resolution); both directions are now products of sines and such ranges stay in.
        prop_assert!(m.gamma_lo >= 0.0 && m.gamma_hi <= PI && m.gamma_lo < m.gamma_hi);
        let bins = grid.bins as f64;
        // Both spacings subtract z_lo from z: the round trip loses what z's own rounding is of the range.
        let tol_k = 64.0 * bins * EPS * (1.0 + m.z_hi.abs() / (m.z_hi - m.z_lo));
        let kk = k * bins;
        let back = m.bin_coord(m.z_of_bin(kk));
        prop_assert!((back - kk).abs() <= tol_k.max(1e-9), "bin {kk} -> {back} (tol {tol_k}, {m:?})");
        let (za, zb) = (m.z_of_bin(k.min(k2) * bins), m.z_of_bin(k.max(k2) * bins));
        prop_assert!(za <= zb + 16.0 * EPS * (1.0 + zb), "z of bins out of order: {za} > {zb}");
        let y = k * grid.rays as f64;
        prop_assert!((m.ray_coord(m.gamma_of_ray(y)) - y).abs() <= 64.0 * EPS * grid.rays as f64 * (1.0 + m.gamma_hi / (m.gamma_hi - m.gamma_lo)));
        // Every view direction on the image's border maps inside the fitted ray range.
        let [r, u, fw] = cam.basis_f64();
        let th = ((fov as f64).to_radians() * 0.5).tan();
        let d = (DVec3::from(fw) + DVec3::from(r) * (th * aspect * (2.0 * k2 - 1.0)) + DVec3::from(u) * th).normalize();
        let g = angle_between(f.axis, d);
        prop_assert!(g >= m.gamma_lo - 1e-9 && g <= m.gamma_hi + 1e-9, "border ray gamma {g} outside [{}, {}]", m.gamma_lo, m.gamma_hi);
    }
}

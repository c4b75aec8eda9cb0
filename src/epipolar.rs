//! Epipolar coordinates (DESIGN section 2), shared by the CPU code, the tests and — through the
//! uniforms in [`crate::render::FrameUniforms`] — by every shader.
//!
//! For an eye `E` and a light, the *axis* is the line through `E` toward the light (unit `a`). A
//! world point `P` has:
//! - `phi`: which epipolar half-plane, the angle of `P - E` around the axis, in `[0, 2 pi)`, measured
//!   in the basis `(b1, b2)` perpendicular to `a`. Computed in 3-D, so it needs no division by the
//!   light's clip-space `w` and stays defined when the light is behind the camera or in its plane.
//! - `gamma`: which view ray in the plane, the angle at the eye between `a` and `P - E`, in `[0, pi]`.
//!   Monotonic (the paper's `h = D sin gamma` folds at 90 degrees).
//! - `z`: which light ray in the plane. Point light: `psi`, the angle at the light between `L -> E`
//!   and `L -> P`, in `[0, pi]`. Directional light: the distance `r = t sin(gamma)` from the axis.
//!
//! Along a light ray (fixed `phi`, `z`), moving away from the light, `gamma` grows: the shadow scan
//! runs along increasing `gamma`. Along a view ray (fixed `phi`, `gamma`) for a point light, by the law
//! of sines `t(psi) = D sin(psi) / sin(gamma + psi)` and `d(psi) = D sin(gamma) / sin(gamma + psi)`.

use crate::params::{BinSpacing, Grid, Light};
use crate::scene::{Aabb, Camera};
use glam::DVec3;
use std::f64::consts::{PI, TAU};

/// Which kind of light rays the frame has.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightGeom {
    /// Light rays leave this point.
    Point(DVec3),
    /// Light rays travel along `-dir`; `dir` points toward the light (unit).
    Directional(DVec3),
}

impl From<&Light> for LightGeom {
    fn from(l: &Light) -> Self {
        match *l {
            Light::Point { position, .. } => LightGeom::Point(position.as_dvec3()),
            Light::Directional { direction, .. } => LightGeom::Directional(direction.as_dvec3().normalize()),
        }
    }
}

/// The epipolar frame of one eye and one light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpipolarFrame {
    pub eye: DVec3,
    pub light: LightGeom,
    /// Unit axis from the eye toward the light.
    pub axis: DVec3,
    /// Basis perpendicular to the axis; `phi = atan2(dot(v, b2), dot(v, b1))`.
    pub b1: DVec3,
    pub b2: DVec3,
    /// Eye-light distance `D` (point light); infinity for a directional light.
    pub dist: f64,
}

/// Epipolar coordinates of a point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EpiCoord {
    pub phi: f64,
    pub gamma: f64,
    /// `psi` (point light) or `r` (directional).
    pub z: f64,
}

/// A robust angle between two non-zero vectors, in `[0, pi]` (acos loses all precision near 0 and pi).
pub fn angle_between(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

impl EpipolarFrame {
    /// Returns `None` when the eye sits exactly on a point light: there are no epipolar planes.
    pub fn new(eye: DVec3, light: LightGeom) -> Option<Self> {
        let (axis, dist) = match light {
            LightGeom::Point(l) => {
                let d = (l - eye).length();
                if d.is_nan() || d <= 0.0 || !d.is_finite() {
                    return None;
                }
                ((l - eye) / d, d)
            }
            LightGeom::Directional(w) => (w.normalize(), f64::INFINITY),
        };
        // Helper axis: the world axis least aligned with `axis`, so the basis is well conditioned.
        let helper = if axis.x.abs() <= axis.y.abs() && axis.x.abs() <= axis.z.abs() {
            DVec3::X
        } else if axis.y.abs() <= axis.z.abs() {
            DVec3::Y
        } else {
            DVec3::Z
        };
        let b1 = axis.cross(helper).normalize();
        let b2 = axis.cross(b1);
        Some(EpipolarFrame { eye, light, axis, b1, b2, dist })
    }

    pub fn is_point(&self) -> bool {
        matches!(self.light, LightGeom::Point(_))
    }

    /// The plane angle of a direction, in `[0, 2 pi)`.
    pub fn phi_of_dir(&self, v: DVec3) -> f64 {
        let p = v.dot(self.b2).atan2(v.dot(self.b1));
        if p < 0.0 {
            p + TAU
        } else {
            p
        }
    }

    /// The unit view direction of `(phi, gamma)`.
    pub fn dir(&self, phi: f64, gamma: f64) -> DVec3 {
        let n = self.b1 * phi.cos() + self.b2 * phi.sin();
        self.axis * gamma.cos() + n * gamma.sin()
    }

    /// Coordinates of a world point (undefined on the axis itself, where `phi` is arbitrary).
    pub fn coords(&self, p: DVec3) -> EpiCoord {
        let v = p - self.eye;
        let phi = self.phi_of_dir(v);
        let gamma = angle_between(self.axis, v);
        let z = match self.light {
            LightGeom::Point(l) => angle_between(self.eye - l, p - l),
            LightGeom::Directional(_) => (v - self.axis * v.dot(self.axis)).length(),
        };
        EpiCoord { phi, gamma, z }
    }

    /// Distance `t` from the eye along the view ray `gamma` to light ray `z`; infinity where the two
    /// do not meet (`gamma + psi >= pi`).
    pub fn t_of(&self, gamma: f64, z: f64) -> f64 {
        match self.light {
            LightGeom::Point(_) => {
                let s = (gamma + z).sin();
                if gamma + z >= PI || s <= 0.0 {
                    f64::INFINITY
                } else {
                    self.dist * z.sin() / s
                }
            }
            LightGeom::Directional(_) => {
                let s = gamma.sin();
                if s <= 0.0 {
                    f64::INFINITY
                } else {
                    z / s
                }
            }
        }
    }

    /// The world point of `(phi, gamma, z)`.
    pub fn point(&self, c: EpiCoord) -> DVec3 {
        self.eye + self.dir(c.phi, c.gamma) * self.t_of(c.gamma, c.z)
    }

    /// `z` of the point at distance `t` along the view ray `gamma`.
    pub fn z_of(&self, gamma: f64, t: f64) -> f64 {
        match self.light {
            LightGeom::Point(_) => {
                if t.is_infinite() {
                    return PI - gamma;
                }
                // Angle at L in the triangle E-L-P, with |E-L| = D, |E-P| = t, angle gamma at E.
                let (s, c) = gamma.sin_cos();
                (t * s).atan2(self.dist - t * c)
            }
            LightGeom::Directional(_) => t * gamma.sin(),
        }
    }
}

/// How the grid's three axes map to angles and distances for one frame: the ranges the frame needs,
/// fitted to the camera and the casters' bounds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridMapping {
    pub grid: Grid,
    /// First plane angle and the angular span of all planes (`2 pi` when the epipole is on screen).
    pub phi0: f64,
    pub phi_span: f64,
    /// Whether plane `planes - 1` wraps around to plane 0.
    pub phi_wraps: bool,
    /// `gamma` range of the rays (the visible view rays).
    pub gamma_lo: f64,
    pub gamma_hi: f64,
    /// `z` range of the bins (where casters can be); outside it everything is lit.
    pub z_lo: f64,
    pub z_hi: f64,
    /// Bin spacing in effect (always uniform distance for a directional light).
    pub spacing: BinSpacing,
}

/// The image's border as view directions: where the extremes of gamma and phi over the image lie
/// (unless the light's point or its opposite is on screen, which `on_screen` tells).
struct ImageBorder {
    r: DVec3,
    u: DVec3,
    f: DVec3,
    /// tan of the half fields of view across and up.
    tw: f64,
    th: f64,
}

impl ImageBorder {
    fn new(camera: &Camera, aspect: f64) -> ImageBorder {
        let [r, u, f] = camera.basis_f64();
        let th = ((camera.fov_y_deg as f64).to_radians() * 0.5).tan();
        ImageBorder { r: DVec3::from(r), u: DVec3::from(u), f: DVec3::from(f), tw: th * aspect, th }
    }

    fn on_screen(&self, d: DVec3) -> bool {
        let z = d.dot(self.f);
        z > 0.0 && (d.dot(self.r) / z).abs() <= self.tw && (d.dot(self.u) / z).abs() <= self.th
    }

    /// Direction `i` of `4 n` around the border (`n` per side, bottom, right, top, left).
    fn dir(&self, i: usize, n: usize) -> DVec3 {
        let s = (i % n) as f64 / n as f64 * 2.0 - 1.0;
        let (x, y) = match i / n {
            0 => (s, -1.0),
            1 => (1.0, s),
            2 => (-s, 1.0),
            _ => (-1.0, -s),
        };
        (self.f + self.r * (x * self.tw) + self.u * (y * self.th)).normalize()
    }
}

impl GridMapping {
    /// Fits the ranges: planes and rays to what a `width x height` image of `camera` sees, bins to the
    /// casters inside `casters` (their bounds).
    pub fn fit(frame: &EpipolarFrame, camera: &Camera, aspect: f64, casters: &Aabb, grid: Grid) -> GridMapping {
        let border = ImageBorder::new(camera, aspect);
        let epipole_on = border.on_screen(frame.axis);
        let anti_on = border.on_screen(-frame.axis);

        // Sample the image border: extremes of gamma and phi over the image lie on it unless the
        // (anti-)epipole is inside.
        const N: usize = 256;
        let mut phis = Vec::with_capacity(4 * N);
        let (mut g_lo, mut g_hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..4 * N {
            let d = border.dir(i, N);
            let g = angle_between(frame.axis, d);
            g_lo = g_lo.min(g);
            g_hi = g_hi.max(g);
            phis.push(frame.phi_of_dir(d));
        }
        if epipole_on {
            g_lo = 0.0;
        }
        if anti_on {
            g_hi = PI;
        }
        let pad = (g_hi - g_lo) * 0.005 + 1e-9;
        let gamma_lo = (g_lo - pad).max(0.0);
        let gamma_hi = (g_hi + pad).min(PI);

        let (phi0, phi_span, phi_wraps) = if epipole_on || anti_on {
            (0.0, TAU, true)
        } else {
            // Smallest arc holding every border sample: the complement of the largest gap.
            phis.sort_by(|a, b| a.total_cmp(b));
            let mut best = (TAU - phis[phis.len() - 1] + phis[0], 0usize);
            for i in 1..phis.len() {
                let gap = phis[i] - phis[i - 1];
                if gap > best.0 {
                    best = (gap, i);
                }
            }
            let start = phis[best.1];
            let span = TAU - best.0;
            let pad = span * 0.005 + 1e-9;
            if span + 2.0 * pad >= TAU {
                (0.0, TAU, true)
            } else {
                ((start - pad).rem_euclid(TAU), span + 2.0 * pad, false)
            }
        };

        let (z_lo, z_hi) = caster_z_range(frame, casters);
        let spacing = if frame.is_point() { grid.spacing } else { BinSpacing::UniformAngle };
        GridMapping { grid, phi0, phi_span, phi_wraps, gamma_lo, gamma_hi, z_lo, z_hi, spacing }
    }

    /// Continuous plane coordinate in `[0, planes)` (plane `i` covers `[i, i + 1)`); values outside
    /// mean the direction is outside the fitted wedge.
    pub fn plane_coord(&self, phi: f64) -> f64 {
        (phi - self.phi0).rem_euclid(TAU) / self.phi_span * self.grid.planes as f64
    }
    pub fn phi_of_plane(&self, x: f64) -> f64 {
        (self.phi0 + x / self.grid.planes as f64 * self.phi_span).rem_euclid(TAU)
    }
    /// Continuous ray coordinate in `[0, rays)`.
    pub fn ray_coord(&self, gamma: f64) -> f64 {
        (gamma - self.gamma_lo) / (self.gamma_hi - self.gamma_lo) * self.grid.rays as f64
    }
    pub fn gamma_of_ray(&self, y: f64) -> f64 {
        self.gamma_lo + y / self.grid.rays as f64 * (self.gamma_hi - self.gamma_lo)
    }
    /// Continuous bin coordinate in `[0, bins)` for `z` inside `[z_lo, z_hi]`.
    pub fn bin_coord(&self, z: f64) -> f64 {
        let b = self.grid.bins as f64;
        match self.spacing {
            BinSpacing::UniformAngle => (z - self.z_lo) / (self.z_hi - self.z_lo) * b,
            // (cos z_lo - cos z) / (cos z_lo - cos z_hi) with both differences as products of
            // sines: the plain form is 0/0 in f32 once the range is below ~3e-4 rad.
            BinSpacing::UniformCosine => {
                let num = (0.5 * (self.z_lo + z)).sin() * (0.5 * (z - self.z_lo)).sin();
                let den = (0.5 * (self.z_lo + self.z_hi)).sin() * (0.5 * (self.z_hi - self.z_lo)).sin();
                num / den.max(f64::MIN_POSITIVE) * b
            }
        }
    }
    pub fn z_of_bin(&self, k: f64) -> f64 {
        let s = k / self.grid.bins as f64;
        match self.spacing {
            BinSpacing::UniformAngle => self.z_lo + s * (self.z_hi - self.z_lo),
            // cos z = cos z_lo - s (cos z_lo - cos z_hi), solved for sin^2(z / 2) and cos^2(z / 2)
            // and put back together with atan2, which keeps the precision at both ends where cos
            // is flat (z near 0 and near pi; acos and asin lose half the digits there).
            BinSpacing::UniformCosine => {
                let p = s * (0.5 * (self.z_lo + self.z_hi)).sin() * (0.5 * (self.z_hi - self.z_lo)).sin();
                let (sh, ch) = (0.5 * self.z_lo).sin_cos();
                let sin2 = (sh * sh + p).max(0.0);
                let cos2 = (ch * ch - p).max(0.0);
                2.0 * sin2.sqrt().atan2(cos2.sqrt())
            }
        }
    }
}

/// Planes either side of a pixel's plane coordinate whose rays it may read: Integrate blends the
/// two planes around it (integrate.wgsl), so plane x serves the pixels whose coordinate lies in
/// [x - 0.5, x + 1.5); one plane more either side for the f32 angles and safety.
pub const PLANE_RAYS_PLANE_MARGIN: f64 = 2.5;
/// Ray cells kept below the lowest and above the highest cell a plane's pixels lie in, on top of
/// the rays' pad: room for the GPU's f32 angles against these f64 ones.
pub const PLANE_RAYS_CELL_MARGIN: u32 = 4;

impl GridMapping {
    /// Per plane, the ray cells `[first, end)` that the frame's pixels can read (the
    /// `plane_rays` buffer of voxelize.wgsl and the scan shaders): Voxelize sets no bit past
    /// `end` and clamps every caster below `first` into `first`, and Scan walks only those cells.
    /// The prefix-OR then gives every cell in `[first, end)` the same bits as the whole grid
    /// would, so the image is the same to the bit, while rays that no pixel reads cost neither
    /// atomics nor the scan.
    ///
    /// The pixels of an image of aspect ratio `aspect` lie inside its border, so the gamma range
    /// of plane x is the range of the border's directions whose plane coordinate lies within
    /// [`PLANE_RAYS_PLANE_MARGIN`] of it (along an epipolar line gamma is monotonic, so its
    /// extremes lie where the line crosses the border), down to 0 when the light's point is on
    /// screen and up to pi when the opposite point is. The border is cut into short segments and
    /// each segment's gamma range goes to every plane its coordinates reach; the rays' global pad
    /// and [`PLANE_RAYS_CELL_MARGIN`] cells go on top. Planes no pixel reads get `[0, 0)`.
    pub fn plane_rays(&self, frame: &EpipolarFrame, camera: &Camera, aspect: f64) -> Vec<[u32; 2]> {
        let planes = self.grid.planes as usize;
        let rays = self.grid.rays;
        let border = ImageBorder::new(camera, aspect);
        let epipole_on = border.on_screen(frame.axis);
        let anti_on = border.on_screen(-frame.axis);
        let mut lo = vec![f64::INFINITY; planes];
        let mut hi = vec![f64::NEG_INFINITY; planes];
        // Two samples per plane along each side: a segment's gamma between its ends strays from
        // them by ~(its angle)^2, far below the pad.
        let n = (2 * planes).max(256);
        let sample = |i: usize| {
            let d = border.dir(i, n);
            (self.plane_coord(frame.phi_of_dir(d)), angle_between(frame.axis, d))
        };
        let p = planes as f64;
        let mut spread = |ca: f64, cb: f64, g0: f64, g1: f64| {
            let (a, b) = (ca.min(cb) - PLANE_RAYS_PLANE_MARGIN, ca.max(cb) + PLANE_RAYS_PLANE_MARGIN);
            let mut x = a.floor();
            while x <= b {
                let i = if self.phi_wraps {
                    Some(x.rem_euclid(p) as usize)
                } else {
                    (x >= 0.0 && x < p).then_some(x as usize)
                };
                if let Some(i) = i.filter(|&i| i < planes) {
                    lo[i] = lo[i].min(g0.min(g1));
                    hi[i] = hi[i].max(g0.max(g1));
                }
                x += 1.0;
            }
        };
        let mut prev = sample(0);
        for i in 1..=4 * n {
            let next = sample(i % (4 * n));
            let (mut ca, cb) = (prev.0, next.0);
            // Across the seam of a full circle: the shorter way round.
            if self.phi_wraps && (cb - ca).abs() > p / 2.0 {
                ca += if cb > ca { p } else { -p };
            }
            spread(ca, cb, prev.1, next.1);
            prev = next;
        }
        let pad = (self.gamma_hi - self.gamma_lo) * 0.005 + 1e-9;
        let m = PLANE_RAYS_CELL_MARGIN as f64;
        (0..planes)
            .map(|i| {
                if lo[i] > hi[i] {
                    return [0, 0];
                }
                let g_lo = if epipole_on { 0.0 } else { lo[i] - pad };
                let g_hi = if anti_on { PI } else { hi[i] + pad };
                let first = (self.ray_coord(g_lo).floor() - m).clamp(0.0, rays as f64);
                let end = (self.ray_coord(g_hi).floor() + 1.0 + m).clamp(0.0, rays as f64);
                [first as u32, (end as u32).max(first as u32)]
            })
            .collect()
    }
}

/// The `z` range that casters inside `b` can occupy, from its bounding sphere (conservative).
pub fn caster_z_range(frame: &EpipolarFrame, b: &Aabb) -> (f64, f64) {
    if b.is_empty() {
        return (0.0, 1.0);
    }
    let c = b.center().as_dvec3();
    let rho = b.radius() as f64 * 1.001 + 1e-9;
    match frame.light {
        LightGeom::Point(l) => {
            let to_c = c - l;
            let dc = to_c.length();
            if dc <= rho {
                return (0.0, PI);
            }
            let alpha = angle_between(frame.eye - l, to_c);
            let beta = (rho / dc).asin();
            ((alpha - beta).max(0.0), (alpha + beta).min(PI))
        }
        LightGeom::Directional(_) => {
            let v = c - frame.eye;
            let dist = (v - frame.axis * v.dot(frame.axis)).length();
            ((dist - rho).max(0.0), dist + rho)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// Cosine bins over a range too narrow for cos to resolve (a far point light, psi < 3e-4 rad in
    /// f32 and < 1e-8 in f64) map and invert without 0/0: the sine-product forms keep it exact.
    #[test]
    fn cosine_bins_survive_ranges_cos_cannot_resolve() {
        for (lo, hi) in [(0.0, 1e-9), (0.2, 0.2 + 1e-9), (1e-6, 3e-6), (0.1, 2.9)] {
            let m = GridMapping {
                grid: Grid { planes: 8, rays: 8, bins: 64, spacing: BinSpacing::UniformCosine },
                phi0: 0.0,
                phi_span: std::f64::consts::TAU,
                phi_wraps: true,
                gamma_lo: 0.1,
                gamma_hi: 1.0,
                z_lo: lo,
                z_hi: hi,
                spacing: BinSpacing::UniformCosine,
            };
            for k in [0.0, 1.0, 17.5, 63.0, 64.0] {
                let z = m.z_of_bin(k);
                assert!(
                    z.is_finite() && z >= lo * (1.0 - 1e-12) && z <= hi * (1.0 + 1e-12),
                    "{lo}..{hi}: bin {k} -> z {z}"
                );
                let back = m.bin_coord(z);
                assert!((back - k).abs() < 1e-3, "{lo}..{hi}: bin {k} -> z {z} -> bin {back}");
            }
            // The middle of the range in cos, not in angle, for a wide range.
            let mid = m.z_of_bin(32.0);
            let want = (0.5 * (lo.cos() + hi.cos())).acos();
            assert!((mid - want).abs() <= 1e-9 * (1.0 + want) || hi - lo < 1e-4, "{mid} vs {want}");
        }
    }

    fn frames() -> Vec<(&'static str, EpipolarFrame)> {
        let eye = DVec3::new(0.3, 1.2, 4.0);
        vec![
            ("point in front", EpipolarFrame::new(eye, LightGeom::Point(DVec3::new(0.5, 2.0, -1.0))).unwrap()),
            ("point behind", EpipolarFrame::new(eye, LightGeom::Point(DVec3::new(0.0, 1.5, 9.0))).unwrap()),
            ("point in eye plane", EpipolarFrame::new(eye, LightGeom::Point(eye + DVec3::new(3.0, 0.0, 0.0))).unwrap()),
            (
                "directional",
                EpipolarFrame::new(eye, LightGeom::Directional(DVec3::new(-0.86, 0.42, -0.28).normalize())).unwrap(),
            ),
            ("directional along -z", EpipolarFrame::new(eye, LightGeom::Directional(DVec3::Z)).unwrap()),
        ]
    }

    /// Deterministic pseudo-random points around the eye.
    fn points(n: usize) -> impl Iterator<Item = DVec3> {
        let mut s = 0x9e3779b97f4a7c15u64;
        (0..n).map(move |_| {
            let mut next = || {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
            };
            DVec3::new(next() * 5.0, next() * 5.0, next() * 5.0)
        })
    }

    #[test]
    fn world_point_round_trips() {
        for (name, f) in frames() {
            for p in points(2000) {
                let c = f.coords(p);
                if c.gamma < 1e-6 || c.gamma > PI - 1e-6 {
                    continue; // on the axis phi is arbitrary
                }
                assert!((0.0..TAU).contains(&c.phi), "{name}: phi {}", c.phi);
                let q = f.point(c);
                let err = (q - p).length() / (1.0 + (p - f.eye).length());
                assert!(err < 1e-9, "{name}: {p} -> {c:?} -> {q} (err {err})");
                // z along the view ray agrees with the closed form t(psi).
                let t = (p - f.eye).length();
                assert!((f.z_of(c.gamma, t) - c.z).abs() < 1e-9 * (1.0 + c.z), "{name}: z_of");
            }
        }
    }

    #[test]
    fn gamma_grows_along_light_rays() {
        for (name, f) in frames() {
            for p in points(300) {
                let dir = match f.light {
                    LightGeom::Point(l) => (p - l).normalize(),
                    LightGeom::Directional(w) => -w,
                };
                let c0 = f.coords(p);
                let c1 = f.coords(p + dir * 0.01);
                if c0.gamma < 1e-6 {
                    continue;
                }
                assert!(c1.gamma >= c0.gamma - 1e-12, "{name}: gamma decreased along a light ray");
                assert!((c1.z - c0.z).abs() < 1e-9 * (1.0 + c0.z), "{name}: z changed along a light ray");
                let dphi = (c1.phi - c0.phi).abs();
                assert!(dphi.min(TAU - dphi) < 1e-9, "{name}: phi changed along a light ray");
            }
        }
    }

    fn camera() -> Camera {
        Camera {
            eye: Vec3::new(0.3, 1.2, 4.0),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_y_deg: 50.0,
            near: 0.01,
            far: 100.0,
        }
    }

    /// Every pixel of the image maps inside the fitted plane and ray ranges, and grid coordinates
    /// round trip, for the light in front, behind, in the eye's plane and directional.
    #[test]
    fn fitted_ranges_cover_every_pixel() {
        let cam = camera();
        let casters = Aabb { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) };
        let (w, h) = (64u32, 48u32);
        let grid = Grid { planes: 256, rays: 256, bins: 64, ..Grid::default() };
        for (name, f) in frames() {
            let m = GridMapping::fit(&f, &cam, w as f64 / h as f64, &casters, grid);
            for py in 0..h {
                for px in 0..w {
                    let d = cam.pixel_dir_f64(px as f64, py as f64, w, h);
                    let x = m.plane_coord(f.phi_of_dir(d));
                    let y = m.ray_coord(angle_between(f.axis, d));
                    assert!((0.0..grid.planes as f64).contains(&x), "{name}: pixel ({px},{py}) plane {x}");
                    assert!((0.0..=grid.rays as f64).contains(&y), "{name}: pixel ({px},{py}) ray {y}");
                    let phi = m.phi_of_plane(x);
                    let x2 = m.plane_coord(phi);
                    assert!((x2 - x).abs() < 1e-6 || (x2 - x).abs() > grid.planes as f64 - 1e-6, "{name}: plane");
                    assert!((m.ray_coord(m.gamma_of_ray(y)) - y).abs() < 1e-9);
                }
            }
            for k in [0.0, 1.5, 17.0, 63.99] {
                assert!((m.bin_coord(m.z_of_bin(k)) - k).abs() < 1e-6, "{name}: bin round trip");
            }
        }
    }

    /// Every ray cell a pixel reads lies inside its planes' `plane_rays`, with margin: the cell
    /// itself and two either side, on the four planes around the pixel (Integrate's two and one
    /// more on either side), for each frame of `frames`, at
    /// two aspect ratios. And the ranges prune something: the test would pass with every cell
    /// kept, so it also checks that some frame keeps under 90% of them.
    #[test]
    fn plane_rays_hold_every_cell_a_pixel_reads() {
        let cam = camera();
        let casters = Aabb { min: Vec3::splat(-2.0), max: Vec3::splat(2.0) };
        let grid = Grid { planes: 384, rays: 256, bins: 64, ..Grid::default() };
        let mut least_kept = 1.0f64;
        for (w, h) in [(96u32, 64u32), (40, 72)] {
            for (name, f) in frames() {
                let m = GridMapping::fit(&f, &cam, w as f64 / h as f64, &casters, grid);
                let cells = m.plane_rays(&f, &cam, w as f64 / h as f64);
                assert_eq!(cells.len(), grid.planes as usize);
                let kept: u32 = cells.iter().map(|c| c[1] - c[0]).sum();
                least_kept = least_kept.min(kept as f64 / (grid.planes * grid.rays) as f64);
                let p = grid.planes as i64;
                for py in 0..h {
                    for px in 0..w {
                        let d = cam.pixel_dir_f64(px as f64, py as f64, w, h);
                        let x0 = (m.plane_coord(f.phi_of_dir(d)) - 0.5).floor() as i64;
                        let y = m.ray_coord(angle_between(f.axis, d)).floor().clamp(0.0, grid.rays as f64 - 1.0) as u32;
                        for x in x0 - 1..=x0 + 2 {
                            let x = if m.phi_wraps { x.rem_euclid(p) } else { x.clamp(0, p - 1) } as usize;
                            let [first, end] = cells[x];
                            assert!(
                                first <= y.saturating_sub(2) && (y + 2 < end || end == grid.rays),
                                "{name} at {w}x{h}: pixel ({px},{py}) reads cell {y} of plane {x}, which keeps {first}..{end}"
                            );
                        }
                    }
                }
            }
        }
        assert!(least_kept < 0.9, "no frame pruned a tenth of the cells: {least_kept}");
    }

    #[test]
    fn light_behind_camera_uses_a_narrow_wedge_off_screen() {
        let cam = camera();
        // Far to the side and behind: the epipole is off screen, so planes must cover < 2 pi.
        let f = EpipolarFrame::new(cam.eye.as_dvec3(), LightGeom::Point(DVec3::new(30.0, 1.2, 10.0))).unwrap();
        let m = GridMapping::fit(&f, &cam, 1.0, &Aabb { min: Vec3::splat(-1.0), max: Vec3::ONE }, Grid::default());
        assert!(!m.phi_wraps && m.phi_span < PI, "span {}", m.phi_span);
    }

    #[test]
    fn eye_on_the_light_has_no_frame() {
        assert!(EpipolarFrame::new(DVec3::ONE, LightGeom::Point(DVec3::ONE)).is_none());
    }
}

//! The named matrix of hard cases (DESIGN section 5, issue 5): small procedural scenes, each with
//! the methods it runs through and a stated bound with its reason (`docs/stability.md` holds the
//! measurements the bounds come from).
//!
//! Every scene is built from three pieces: a floor (8 x 8 units) with a square caster 1.5 above it and
//! a closed box post, seen from 6 units away ([`floor_scene`]); or three floating boxes with no
//! floor, seen horizontally so that the world axes are screen axes ([`floating_scene`]). The cases
//! change one thing at a time: the medium, the phase function, where the light is, where the eye
//! is, the scale, the camera planes, the grid.

// Each group reads as a list of `v.push(case)`, one case per statement.
#![allow(clippy::vec_init_then_push)]

use super::{Case, CheckMethod, Expect, PixelWindow, Target};
use crate::params::{Grid, Light, Medium, Phase};
use crate::render::Method;
use crate::scene::{Camera, Scene};
use glam::{DVec3, Vec3};

/// The largest `f32` not above 0.999. (`0.999f32` itself is 0.99900001; `Spec::check` now meets
/// bounds to f32 precision and accepts it too, but the cases keep the value they were measured at.)
pub const G_MAX: f32 = 0.998_999_95;

/// Image size of every case (the reference costs grow with the pixel count).
pub const SIZE: u32 = 48;

/// The grid most cases use: planes and rays several per pixel of a 48 x 48 image, and the default
/// 256 bins (the depth resolution does not shrink with the image).
pub fn default_grid() -> Grid {
    Grid { planes: 256, rays: 256, bins: 256, ..Grid::default() }
}

/// The ray-marching baseline as the check runs it: enough steps that its own sampling error stays
/// below the bounds (it is the shadow map and the step count that limit it, not the numerics).
pub const RAYMARCH: Method = Method::Raymarch { steps: 256, jitter: false };

// The building blocks are shared with the integration tests (`tests/common`).
pub use crate::scene::build::haze as default_medium;
pub use crate::scene::build::{cuboid, directional, point, quad};

/// Floor, a square caster 1.5 above it and a closed box post; the eye 6 units away, looking
/// slightly down. The default light is a point light above the caster.
pub fn floor_scene(name: &str) -> Scene {
    Scene {
        name: name.into(),
        source: None,
        meshes: vec![
            quad("floor", Vec3::ZERO, Vec3::X * 4.0, Vec3::Z * 4.0),
            quad("caster", Vec3::new(0.0, 1.5, 0.0), Vec3::X * 0.5, Vec3::Z * 0.5),
            cuboid("post", Vec3::new(1.3, 0.6, -0.9), Vec3::new(0.25, 0.6, 0.25), false),
        ],
        camera: crate::scene::build::side_camera(),
        light: point(Vec3::new(0.2, 3.0, 0.1), 10.0),
        medium: default_medium(),
        grid: default_grid(),
    }
}

/// Three floating boxes and two small markers that stretch the medium's box around the eye; no
/// floor. The camera looks horizontally along -z, so its right/up axes are world +x/+y.
pub fn floating_scene(name: &str) -> Scene {
    Scene {
        name: name.into(),
        source: None,
        meshes: vec![
            cuboid("a", Vec3::new(-1.4, 0.6, -1.0), Vec3::splat(0.5), false),
            cuboid("b", Vec3::new(1.1, 1.9, 0.2), Vec3::splat(0.4), false),
            cuboid("c", Vec3::new(0.1, 1.1, 2.0), Vec3::new(0.3, 0.3, 0.3), false),
            cuboid("marker back", Vec3::new(0.0, -0.4, -4.0), Vec3::splat(0.1), false),
            cuboid("marker front", Vec3::new(0.0, 3.2, 8.0), Vec3::splat(0.1), false),
        ],
        camera: Camera {
            eye: Vec3::new(0.0, 1.5, 6.0),
            target: Vec3::new(0.0, 1.5, 0.0),
            up: Vec3::Y,
            fov_y_deg: 50.0,
            near: 0.01,
            far: 100.0,
        },
        light: directional(Vec3::new(0.3, 1.0, 0.2)),
        medium: Medium { scattering: Vec3::new(0.15, 0.12, 0.1), ..default_medium() },
        grid: default_grid(),
    }
}

/// Camera basis (right, up, forward) and the tangents of the half field of view (x, y).
fn basis(cam: &Camera, aspect: f64) -> (DVec3, DVec3, DVec3, f64, f64) {
    let [r, u, f] = cam.basis_f64();
    let th = ((cam.fov_y_deg as f64).to_radians() * 0.5).tan();
    (DVec3::from(r), DVec3::from(u), DVec3::from(f), th * aspect, th)
}

/// Scales every length of `s` by `k`: positions, camera planes, light radius; coefficients by
/// `1/k` and a point light's intensity by `k^2`, so the image is the same radiance at any scale.
pub fn scaled(mut s: Scene, k: f32, offset: Vec3) -> Scene {
    for m in &mut s.meshes {
        for p in &mut m.positions {
            *p = *p * k + offset;
        }
    }
    let c = &mut s.camera;
    c.eye = c.eye * k + offset;
    c.target = c.target * k + offset;
    c.near *= k;
    c.far *= k;
    s.light = match s.light {
        Light::Point { position, intensity, radius } => {
            Light::Point { position: position * k + offset, intensity: intensity * k * k, radius: radius * k }
        }
        l => l,
    };
    s.medium.scattering /= k;
    s.medium.absorption /= k;
    s
}

/// The largest grid the adapter holds: planes = rays = the largest allowed side, bins as many as the
/// buffer limit allows (halving the rays while not even 32 bins fit).
pub fn largest_grid(limits: &wgpu::Limits) -> Grid {
    let side = (Grid::PLANES.max as u32).min(limits.max_texture_dimension_2d);
    let bytes = crate::gpu::max_binding(limits);
    let (planes, mut rays) = (side, side);
    loop {
        let words = bytes / (planes as u64 * rays as u64 * 4);
        let bins = (words * 32).min(Grid::BINS.max as u64) as u32 / 32 * 32;
        if bins >= 32 || rays <= Grid::RAYS.min as u32 {
            return Grid { planes, rays, bins: bins.max(32), ..Grid::default() };
        }
        rays /= 2;
    }
}

/// Builder shorthand.
struct C {
    case: Case,
}

impl C {
    fn new(group: &'static str, name: &str, scene: Scene) -> C {
        C {
            case: Case {
                name: format!("{group}/{name}"),
                group,
                about: String::new(),
                reason: String::new(),
                quick: false,
                size: (SIZE, SIZE),
                target: Target::Scatter,
                scene,
                runs: Vec::new(),
            },
        }
    }
    fn about(mut self, s: &str) -> C {
        self.case.about = s.into();
        self
    }
    fn reason(mut self, s: &str) -> C {
        self.case.reason = s.into();
        self
    }
    fn quick(mut self) -> C {
        self.case.quick = true;
        self
    }
    fn target(mut self, t: Target) -> C {
        self.case.target = t;
        self
    }
    fn run(mut self, m: Method, e: Expect) -> C {
        self.case.runs.push((CheckMethod::Gpu(m), e));
        self
    }
    fn vsv(self, rel: f64) -> C {
        self.run(Method::Vsv, Expect::rel(rel))
    }
    fn cartesian(self, rel: f64) -> C {
        self.run(Method::Cartesian, Expect::rel(rel))
    }
    fn march(self, rel: f64) -> C {
        self.run(RAYMARCH, Expect::rel(rel))
    }
    fn done(self) -> Case {
        self.case
    }
}

/// The pixel of the case image whose area holds the world point `p` (None off screen or behind).
pub fn pixel_of(cam: &Camera, p: Vec3) -> Option<(u32, u32)> {
    let (r, u, f, tw, th) = basis(cam, 1.0);
    let d = p.as_dvec3() - cam.eye.as_dvec3();
    let z = d.dot(f);
    if z <= 0.0 {
        return None;
    }
    let (sx, sy) = (d.dot(r) / z / tw, d.dot(u) / z / th);
    let px = ((sx + 1.0) * 0.5 * SIZE as f64).floor();
    let py = ((1.0 - sy) * 0.5 * SIZE as f64).floor();
    let inside = |v: f64| (0.0..SIZE as f64).contains(&v);
    (inside(px) && inside(py)).then_some((px as u32, py as u32))
}

/// The 3 x 3 pixels around the light's own pixel.
fn light_window(s: &Scene) -> Option<PixelWindow> {
    match s.light {
        Light::Point { position, .. } => pixel_of(&s.camera, position).map(|(x, y)| PixelWindow { x, y, radius: 1 }),
        Light::Directional { .. } => None,
    }
}

/// The light `dist` units from the eye along the view ray of pixel `(px, py)` of the case image.
fn on_pixel_ray(cam: &Camera, px: u32, py: u32, dist: f64) -> Vec3 {
    (cam.eye.as_dvec3() + cam.pixel_dir_f64(px as f64, py as f64, SIZE, SIZE) * dist).as_vec3()
}

/// The full matrix for an adapter with `limits` (the largest-grid case depends on them).
pub fn matrix(limits: &wgpu::Limits) -> Vec<Case> {
    let mut v = Vec::new();
    v.extend(media());
    v.extend(phases());
    v.extend(point_lights());
    v.extend(directional_lights());
    v.extend(eyes());
    v.extend(scales());
    v.extend(grids(limits));
    v
}

/// The subset that runs in the test command (well under a minute on two cores with the software
/// Vulkan driver).
pub fn quick_matrix(limits: &wgpu::Limits) -> Vec<Case> {
    matrix(limits).into_iter().filter(|c| c.quick).collect()
}

fn media() -> Vec<Case> {
    let mut v = Vec::new();
    v.push(
        C::new("medium", "default", floor_scene("default"))
            .about("the baseline: light haze, HG g = 0.3, point light above the caster")
            .reason("grid discretisation: a shadow edge resolves to one bin, ray and plane (measured 0.65%); raymarch: the shadow map")
            .quick()
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    // A fog lamp 0.85 from the eye: sigma_t x floor size = 100, sigma_t D = 10.6. The integrand
    // decays on 1/sigma_t = 0.08, about one bin; a small caster next to the lamp throws a shadow
    // wedge through the bright fog.
    let lamp = |name: &str, sigma_t: f32, off: Vec3, caster: f32| {
        let mut s = floor_scene(name);
        let eye = s.camera.eye;
        let l = eye + off;
        s.light = point(l, 10.0);
        let k = off.length();
        s.meshes.push(quad("lamp shade", l + Vec3::new(0.0, -0.1 * k, -0.15 * k), Vec3::X * caster, Vec3::Z * caster));
        s.medium = Medium {
            scattering: Vec3::splat(sigma_t * 0.8),
            absorption: Vec3::splat(sigma_t * 0.2),
            density: 1.0,
            phase: Phase::HenyeyGreenstein { g: 0.3 },
        };
        s
    };
    v.push(
        C::new("medium", "thick-100", lamp("thick-100", 12.5, Vec3::new(0.3, 0.2, -0.75), 0.06))
            .about("sigma_t x scene size = 100: a lamp 0.85 from the eye in thick fog, a small shade below it")
            .reason(
                "the integrand falls by e per 0.08 units, about a bin: the table integrates each run exactly (0.03%)",
            )
            .quick()
            .vsv(0.005)
            .march(0.005)
            .done(),
    );
    v.push(
        C::new("medium", "thick-1000", lamp("thick-1000", 125.0, Vec3::new(0.03, 0.02, -0.075), 0.006))
            .about("sigma_t x scene size = 1000: the same lamp scaled to 0.085 from the eye")
            .reason(
                "as thick-100, ten times steeper; raymarch-256 cannot resolve the 0.008-unit boundary layer \
                     (63%: its sampling, not its numerics)",
            )
            .vsv(0.005)
            .march(1.0)
            .done(),
    );
    let mut s = floor_scene("thick-1e4");
    s.medium.scattering = Vec3::splat(1000.0);
    s.medium.absorption = Vec3::splat(250.0);
    v.push(
        C::new("medium", "thick-1e4-underflow", s)
            .about("sigma_t x scene size = 1e4, light 6 from the eye (sigma_t D = 7600): the exact answer is below f32's range")
            .reason("exact answer 0 in f32: every value must be finite and 0 (no 0 x inf = NaN)")
            .quick()
            .run(Method::Vsv, Expect::max_abs(f32::MIN_POSITIVE as f64))
            .run(RAYMARCH, Expect::max_abs(f32::MIN_POSITIVE as f64))
            .done(),
    );
    // Bright light, sigma_t D = 95: the radiance (~1e-33) is a normal f32, but exp(-sigma_t d) *
    // exp(-sigma_t t), or exp(-sigma_t D) alone, is not.
    // Bright light, sigma_t D = 104: the radiance (up to 1e-35) is a normal f32, but exp(-sigma_t d) *
    // exp(-sigma_t t), or exp(-sigma_t D) alone (7e-46), is below even f32's denormals.
    let bright = || {
        let mut s = floor_scene("thick-bright");
        s.light = point(Vec3::new(0.2, 3.0, 0.1), 1.0e9);
        s.medium.scattering = Vec3::splat(17.0);
        s.medium.absorption = Vec3::splat(0.1);
        s
    };
    v.push(
        C::new("medium", "thick-bright", bright())
            .about("sigma_t D = 104 with I0 = 1e9: the answer (~1e-35) is a normal f32, exp(-104) = 7e-46 is not even a denormal")
            .reason("the exponent and the log of the prefactor combined in one exp (before the fix: 681%, all 0)")
            .quick()
            .vsv(0.005)
            .done(),
    );
    v.push(
        C::new("medium", "thick-bright-baseline", bright())
            .about("medium/thick-bright through the ray-marching baseline")
            .reason("as medium/thick-bright: raymarch.wgsl evaluates exp(-sigma_t (d + t)) before the prefactor, so it flushes to 0")
            .march(0.05)
            .done(),
    );
    let mut s = floor_scene("clear");
    s.medium.scattering = Vec3::splat(1e-6);
    s.medium.absorption = Vec3::splat(1e-6);
    s.light = point(Vec3::new(0.2, 3.0, 0.1), 1e6);
    v.push(
        C::new("medium", "clear-1e-6", s)
            .about("sigma_s = sigma_a = 1e-6 (I0 = 1e6): the clear limit, 1 - exp(-x) with x ~ 1e-6")
            .reason("as the default: the 1 - exp(-x) forms keep full precision at x ~ 1e-6")
            .quick()
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("coloured");
    s.medium.scattering = Vec3::new(0.4, 4e-3, 4e-6);
    s.medium.absorption = Vec3::new(0.1, 1e-3, 1e-6);
    v.push(
        C::new("medium", "coloured", s)
            .about("channels five orders apart: sigma_t = (0.5, 5e-3, 5e-6)")
            .reason("relative RMSE per channel (worst reported): each channel must be as good as the default")
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("absorption-only");
    s.medium.scattering = Vec3::ZERO;
    s.medium.absorption = Vec3::new(0.3, 0.2, 0.1);
    v.push(
        C::new("medium", "absorption-only", s)
            .about("sigma_s = 0: no in-scattering; compares the final image (surfaces attenuated by the view path)")
            .reason("final image: the surface shading's shadow map (2048^2 per face) against exact shadow rays (0.07%)")
            .target(Target::Hdr)
            .vsv(0.005)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("scattering-only");
    s.medium.scattering = Vec3::new(0.15, 0.12, 0.1);
    s.medium.absorption = Vec3::ZERO;
    v.push(
        C::new("medium", "scattering-only", s)
            .about("sigma_a = 0")
            .reason("as the default")
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    v
}

fn phases() -> Vec<Case> {
    let mut v = Vec::new();
    // The light in front of the camera, on screen, above the caster: the forward peak is in view.
    let base = |name: &str, phase: Phase| {
        let mut s = floor_scene(name);
        s.light = point(Vec3::new(0.3, 1.8, -1.0), 10.0);
        s.medium.phase = phase;
        s
    };
    // (name, phase, vsv: rel RMSE outside the light's 3x3 / their sum, raymarch: the same, quick)
    type Row = (&'static str, Phase, (f64, f64), (f64, f64), bool);
    let list: [Row; 10] = [
        ("hg-0.999", Phase::HenyeyGreenstein { g: G_MAX }, (0.03, 0.02), (2.5, 1.7), true),
        ("hg-0", Phase::HenyeyGreenstein { g: 0.0 }, (0.04, 0.02), (0.005, 0.02), false),
        ("hg--0.999", Phase::HenyeyGreenstein { g: -G_MAX }, (0.01, 0.065), (3.5, 1.7), false),
        ("cs-0.999", Phase::CornetteShanks { g: G_MAX }, (0.03, 0.02), (2.5, 1.7), false),
        ("cs-0", Phase::CornetteShanks { g: 0.0 }, (0.04, 0.02), (0.005, 0.02), false),
        ("cs--0.999", Phase::CornetteShanks { g: -G_MAX }, (0.01, 0.065), (3.5, 1.7), true),
        // Schlick at the edge of its range (k = 0.9991: a lobe as narrow as HG's at g = 0.999).
        // Measured on llvmpipe: vsv 0.80% / 0.18%, raymarch 89% / 78%; bounds about 1.5x that.
        ("schlick-0.93", Phase::Schlick { g: 0.93 }, (0.012, 0.005), (1.3, 0.2), false),
        ("schlick--0.93", Phase::Schlick { g: -0.93 }, (0.005, 0.005), (1.2, 0.4), false),
        ("rayleigh", Phase::Rayleigh, (0.04, 0.02), (0.005, 0.02), false),
        ("isotropic", Phase::Isotropic, (0.04, 0.02), (0.005, 0.02), false),
    ];
    for (name, phase, (vsv, vsv_win), (march, march_win), quick) in list {
        let scene = base(name, phase);
        let window = light_window(&scene).unwrap_or(PixelWindow { x: 0, y: 0, radius: 0 });
        let mut c = C::new("phase", name, scene)
            .about("point light on screen in front of the camera, above the caster; the light's 3x3 pixels apart")
            .reason(if phase.g().abs() > 0.9 {
                "the lobe (1e-3 rad) puts 30x the mean into the light's pixel: its 3x3 sum is bounded apart; \
                 raymarch-256 cannot sample a lobe that narrow (its sampling, not its numerics)"
            } else {
                "the light is on screen close above the caster: shadow edges run radially through the bright epipole"
            })
            .run(Method::Vsv, Expect::rel_split(vsv, window, vsv_win))
            .run(RAYMARCH, Expect::rel_split(march, window, march_win));
        if quick {
            c = c.quick();
        }
        v.push(c.done());
    }
    // Directional sun on screen with the extreme lobes.
    for (name, g, vsv, march) in [("hg-0.999-sun", G_MAX, 0.1, 0.1), ("hg--0.999-sun", -G_MAX, 0.02, 0.006)] {
        let s = sun_scene(name, g);
        v.push(
            C::new("phase", name, s)
                .about(
                    "directional light on screen (in front), extreme HG lobe: the phase is constant along a view ray",
                )
                .reason(
                    "p(gamma) per pixel is exact, but near the epipole a bin (uniform in r) is dr / sin(gamma) long \
                         on the view ray, and the forward lobe puts the image's energy into exactly those pixels \
                         (sampled bins: 4.9% forward, 0.46% backward; the cell voxelizer had 24% and 2.2%)",
                )
                .vsv(vsv)
                .march(march)
                .done(),
        );
    }
    v
}

fn point_lights() -> Vec<Case> {
    let mut v = Vec::new();
    let cam = floor_scene("").camera;
    let (r, u, f, tw, th) = basis(&cam, 1.0);
    let eye = cam.eye.as_dvec3();
    let at = |p: DVec3| p.as_vec3();

    let mut s = floor_scene("behind-camera");
    s.light = point(Vec3::new(0.6, 2.6, 9.0), 10.0);
    v.push(
        C::new("light", "behind-camera", s)
            .about("point light behind the camera, off the view axis: the anti-epipole is off screen")
            .reason(
                "view rays run away from the light: the lit stretches past the caster's shadow span few bins (1.45%)",
            )
            .quick()
            .vsv(0.03)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("eye-plane");
    s.light = point(at(eye + r * 3.0 + u * 0.7), 10.0);
    v.push(
        C::new("light", "eye-plane", s)
            .about("point light exactly in the eye's plane (clip w = 0): epipolar lines parallel on screen")
            .reason("as the default: the planes are computed in 3-D, no division by w")
            .quick()
            .vsv(0.005)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("axis-front");
    s.light = point(at(eye + f * 4.0), 10.0);
    v.push(
        C::new("light", "axis-front", s)
            .about("point light exactly on the view axis in front: the epipole at the screen centre, every plane in view")
            .reason("as the default; planes converge at the centre, where the 4 image pixels around it straddle the epipole")
            .vsv(0.005)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("axis-behind");
    s.light = point(at(eye - f * 3.0), 10.0);
    v.push(
        C::new("light", "axis-behind", s)
            .about("point light exactly on the view axis behind the eye: the anti-epipole at the screen centre")
            .reason("rays near the anti-epipole (gamma -> pi) span few psi bins; the table is stored per (pi - gamma) (0.37%)")
            .vsv(0.01)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("screen-corner");
    s.light = point(at(eye + (f + r * tw + u * th).normalize() * 5.0), 10.0);
    v.push(
        C::new("light", "screen-corner", s)
            .about("point light exactly on the top-right corner ray of the frustum")
            .reason("as the default: the epipole on the image border")
            .vsv(0.006)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("far-off-screen");
    s.light = point(Vec3::new(2000.0, 600.0, 300.0), 10.0 * 2100.0 * 2100.0);
    // Thin enough that light arrives from 2 km: sigma_t D = 2.
    s.medium.scattering = Vec3::splat(8e-4);
    s.medium.absorption = Vec3::splat(2e-4);
    v.push(
        C::new("light", "far-off-screen", s)
            .about("point light 2 km off to the side (I0 x d^2): nearly parallel rays, a narrow wedge of planes")
            .reason("as the default; psi spans a tiny angle, bins cover only the casters' range")
            .vsv(0.005)
            .march(0.005)
            .done(),
    );
    let mut s = floor_scene("inside-open-box");
    s.light = point(Vec3::new(0.1, 1.1, 0.05), 10.0);
    s.meshes[1] = cuboid("lantern", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.4, 0.3, 0.4), true);
    v.push(
        C::new("light", "inside-open-box", s)
            .about("point light inside a box open at the top: a beam of light up through the opening")
            .reason(
                "the bins span all of psi (the light is inside the casters' bounds), 0.7 degrees each, and the \
                     beam's edge is the box rim seen edge-on: half a bin either way along it (3.8%; 9.3% when the \
                     cell voxelizer over-shadowed by a whole bin)",
            )
            .vsv(0.08)
            .march(0.08)
            .done(),
    );
    let mut s = floor_scene("inside-closed-box");
    s.light = point(Vec3::new(0.1, 1.1, 0.05), 10.0);
    s.meshes[1] = cuboid("closed box", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.4, 0.3, 0.4), false);
    // Exact answer: 0. Scale of an unshadowed pixel: sigma_s I0 / (4 pi D) ~ 0.016.
    v.push(
        C::new("light", "inside-closed-box", s)
            .about("point light inside a closed box: the exact in-scattering is 0 everywhere")
            .reason(
                "no light may leak: every value <= 1e-6 (1e-4 of an unshadowed pixel, sigma_s I0 / (4 pi D) = 0.016)",
            )
            .quick()
            .run(Method::Vsv, Expect::max_abs(1e-6))
            .run(RAYMARCH, Expect::max_abs(1e-6))
            .done(),
    );
    let mut s = floor_scene("at-eye");
    s.light = point(cam.eye, 10.0);
    v.push(
        C::new("light", "at-eye", s)
            .about("point light exactly at the eye (r = 0): the exact answer is infinite on every pixel")
            .reason("degenerate (no epipolar planes, infinite integral): the renderer must refuse with a message, never NaN")
            .quick()
            .run(Method::Vsv, Expect::Refused)
            .done(),
    );
    let mut s = floor_scene("near-eye");
    s.light = point(at(eye + (r * 0.6 - u * 0.3 + f * 0.2).normalize() * 1e-3), 10.0);
    v.push(
        C::new("light", "near-eye", s)
            .about("point light 1e-3 from the eye (r = 0): every view ray passes within 1e-3 of it")
            .reason(
                "pixels are ~1/h large but finite; the table is independent of D except through sigma_t D; \
                     raymarch-256 cannot follow the 1/d^2 peak 1e-3 from the eye (85%: its sampling)",
            )
            .vsv(0.005)
            .march(1.0)
            .done(),
    );
    // A view ray through the light, the radius shrinking toward 0.
    let (px, py) = (30u32, 17u32);
    let window = PixelWindow { x: px, y: py, radius: 1 };
    for (name, radius, win, quick) in [
        ("through-pixel-r0.1", 0.1f32, 0.02, false),
        ("through-pixel-r0.01", 0.01, 0.02, true),
        ("through-pixel-r0.001", 1e-3, 0.06, true),
    ] {
        let mut s = floor_scene(name);
        s.light = Light::Point { position: on_pixel_ray(&cam, px, py, 4.0), intensity: Vec3::splat(10.0), radius };
        let mut c = C::new("light", name, s)
            .about("the light exactly on the ray through a pixel centre, softening radius r: that pixel ~ 1/r")
            .reason("finite for r > 0: the light's 3x3 pixels must converge to the reference as r shrinks, the rest as the default")
            .run(Method::Vsv, Expect::rel_split(0.005, window, win))
            .run(RAYMARCH, Expect::rel_split(0.005, window, 0.02));
        if quick {
            c = c.quick();
        }
        v.push(c.done());
    }
    let mut s = floor_scene("through-pixel-r0");
    s.light = on_pixel_ray_light(&cam, px, py);
    v.push(
        C::new("light", "through-pixel-r0", s)
            .about("the light exactly on a pixel's ray, r = 0: that pixel's exact value is infinite")
            .reason(
                "degenerate at the light's pixel: it must be finite; the rest (outside a 3x3 window) as the default",
            )
            .quick()
            .run(Method::Vsv, Expect::rel_outside(0.005, window))
            .run(RAYMARCH, Expect::rel_outside(0.005, window))
            .done(),
    );
    v
}

fn on_pixel_ray_light(cam: &Camera, px: u32, py: u32) -> Light {
    Light::Point { position: on_pixel_ray(cam, px, py, 4.0), intensity: Vec3::splat(10.0), radius: 0.0 }
}

fn directional_lights() -> Vec<Case> {
    let mut v = Vec::new();
    // Along each world axis. The camera looks along -z with +x right and +y up: +-x and +-y are
    // screen axes (epipole at infinity, the Cartesian grid applies), +z is behind the camera on the
    // view axis, -z in front of it.
    // (name, direction, a screen axis, vsv bound, quick)
    let axes: [(&str, Vec3, bool, f64, bool); 6] = [
        ("+x", Vec3::X, true, 0.01, false),
        ("-x", Vec3::NEG_X, true, 0.01, false),
        ("+y", Vec3::Y, true, 0.01, true),
        ("-y", Vec3::NEG_Y, true, 0.01, false),
        ("+z", Vec3::Z, false, 0.01, false),
        ("-z", Vec3::NEG_Z, false, 0.03, true),
    ];
    for (name, d, screen_axis, bound, quick) in axes {
        let mut s = floating_scene(&format!("dir{name}"));
        s.light = directional(d);
        let mut c = C::new("light", &format!("dir{name}"), s)
            .about(if screen_axis {
                "directional light along a world axis that is a screen axis: parallel epipolar lines"
            } else {
                "directional light along the view axis (epipole or anti-epipole at the screen centre)"
            })
            .reason(if name == "-z" {
                "the sun straight ahead: near the epipole a bin (uniform in r) is dr / sin(gamma) long on the view ray"
            } else {
                "grid discretisation: the medium box's faces and the casters' shadows resolve to a bin"
            })
            .vsv(bound)
            .march(0.005);
        if screen_axis {
            c = c.cartesian(0.01);
        }
        if quick {
            c = c.quick();
        }
        v.push(c.done());
    }
    let mut s = floor_scene("dir-grazing");
    s.light = directional(Vec3::new(1.0, 0.03, 0.3));
    v.push(
        C::new("light", "dir-grazing", s)
            .about("directional light 1.7 degrees above the floor: shadows stretch across the whole floor")
            .reason("long shadow volumes through the whole view: many runs per ray")
            .vsv(0.03)
            .march(0.005)
            .done(),
    );
    v
}

/// The eye in a shade's shadow, the light behind the camera exactly on the view axis.
fn behind_axis_scene(name: &str) -> Scene {
    let mut s = floor_scene(name);
    s.camera.target = Vec3::new(0.0, 1.5, 0.0);
    s.light = point(Vec3::new(0.0, 1.5, 10.0), 10.0);
    s.meshes.push(quad("shade", Vec3::new(0.0, 1.5, 8.0), Vec3::X * 0.5, Vec3::Y * 0.5));
    s
}

/// The floating boxes with the sun on screen ahead and an HG lobe of asymmetry `g`.
fn sun_scene(name: &str, g: f32) -> Scene {
    let mut s = floating_scene(name);
    s.light = directional(Vec3::new(0.15, 0.1, -1.0));
    s.medium.phase = Phase::HenyeyGreenstein { g };
    s
}

fn eyes() -> Vec<Case> {
    let mut v = Vec::new();
    let mut s = floor_scene("in-shadow-above");
    s.light = point(Vec3::new(0.0, 4.0, 0.0), 10.0);
    s.camera.eye = Vec3::new(0.05, 1.0, 0.1);
    s.camera.target = Vec3::new(0.0, 0.8, -5.0);
    v.push(
        C::new("eye", "in-shadow-above", s)
            .about("the eye in the caster's shadow, the light above it: view rays start shadowed and leave the volume")
            .reason("grid discretisation as the default (0.97%)")
            .quick()
            .vsv(0.02)
            .march(0.005)
            .done(),
    );
    let s = behind_axis_scene("in-shadow-behind-axis");
    v.push(
        C::new("eye", "in-shadow-behind-axis", s)
            .about("the eye in a shade's shadow with the light behind the camera exactly on the view axis")
            .reason(
                "known weak spot: beyond the shade's shadow each view ray is lit over a few psi bins only and the \
                     lit weight sits in the first of them: a sampled edge is off by up to half a bin (3.7%; 15% with \
                     the cell voxelizer's whole-bin over-shadowing)",
            )
            .quick()
            .vsv(0.08)
            .march(0.12)
            .done(),
    );
    let mut s = floating_scene("outside-box");
    s.camera.eye = Vec3::new(0.0, 5.0, 14.0);
    s.camera.target = Vec3::new(0.0, 1.0, 0.0);
    v.push(
        C::new("eye", "outside-box", s)
            .about("directional light, the eye outside the medium's box: view rays enter it part-way")
            .reason("grid discretisation (1.7%); no extinction outside the box (the same model as the reference)")
            .vsv(0.035)
            .march(0.005)
            .done(),
    );
    // Thick box, the eye inside it near the top: the light's path inside the box is short there.
    let mut s = floating_scene("inside-thick-box");
    s.camera.eye = Vec3::new(0.0, 2.9, 6.0);
    s.camera.target = Vec3::new(0.0, 2.4, 0.0);
    s.light = directional(Vec3::new(0.2, 1.0, 0.1));
    s.medium.scattering = Vec3::splat(20.0);
    s.medium.absorption = Vec3::splat(5.0);
    v.push(
        C::new("eye", "inside-thick-box", s)
            .about("directional light into a thick box (sigma_t x box = 300), the eye inside near the top")
            .reason(
                "boundary layer 0.04 units deep: the closed-form run integral is exact (1e-6); raymarch-256 \
                     samples it coarsely (2%)",
            )
            .quick()
            .vsv(0.005)
            .march(0.05)
            .done(),
    );
    v
}

fn scales() -> Vec<Case> {
    let mut v = Vec::new();
    v.push(
        C::new("scale", "mm", scaled(floor_scene("mm"), 1e-3, Vec3::ZERO))
            .about("the default scene at millimetre size (x 1e-3; coefficients x 1e3, I0 x 1e-6)")
            .reason("the same radiance as the default: errors as the default (the GPU's arithmetic is eye-relative)")
            .quick()
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    v.push(
        C::new("scale", "km", scaled(floor_scene("km"), 1e3, Vec3::ZERO))
            .about("the default scene at kilometre size (x 1e3; coefficients x 1e-3, I0 x 1e6)")
            .reason("the same radiance as the default: errors as the default (the GPU's arithmetic is eye-relative)")
            .quick()
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    v.push(
        C::new("scale", "km-offset", scaled(floor_scene("km-offset"), 1e3, Vec3::new(2e5, 0.0, -3e5)))
            .about("kilometre size and 360 km from the origin: f32 positions keep 3 cm, 3e-6 of the scene")
            .reason("as the default: the GPU works relative to the eye, so f32 rounding adds nothing visible")
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    v.push(
        C::new("scale", "m-offset-1e5", scaled(floor_scene("m-offset"), 1.0, Vec3::new(1e5, 0.0, 1e5)))
            .about("the metre scene 141 km from the origin: f32 positions keep 8 mm, 1% of the caster")
            .reason(
                "both renderers see the same rounded vertices; the GPU's eye-relative f32 arithmetic must not add more",
            )
            .vsv(0.015)
            .march(0.025)
            .done(),
    );
    let mut s = floor_scene("near-far");
    s.camera.near = 1e-4;
    s.camera.far = 1e6;
    v.push(
        C::new("scale", "near-1e-4-far-1e6", s)
            .about("camera planes 1e-4 and 1e6: the depth buffer keeps 1e-10 of the range")
            .reason("as the default: distances come from world positions, not from the depth buffer")
            .quick()
            .vsv(0.015)
            .march(0.005)
            .done(),
    );
    v
}

fn grids(limits: &wgpu::Limits) -> Vec<Case> {
    let mut v = Vec::new();
    let mut s = floor_scene("smallest-grid");
    s.grid = Grid { planes: 8, rays: 8, bins: 32, ..Grid::default() };
    v.push(
        C::new("grid", "smallest", s)
            .about("8 x 8 x 32: a plane spans several degrees, a ray several pixels")
            .reason("shadow edges are blurred over ~6 pixels and 1/32 of the psi range: coarse but bounded (4.7%)")
            .quick()
            .vsv(0.1)
            .done(),
    );
    let mut s = floor_scene("cosine-bins");
    s.grid.spacing = crate::params::BinSpacing::UniformCosine;
    v.push(
        C::new("grid", "cosine-bins", s)
            .about("the default scene with bins uniform in cos(psi) (the paper's spacing)")
            .reason("grid discretisation as the default")
            .vsv(0.015)
            .done(),
    );
    let mut s = floor_scene("cosine-far-light");
    s.grid.spacing = crate::params::BinSpacing::UniformCosine;
    s.light = point(Vec3::new(2000.0, 600.0, 300.0), 10.0 * 2100.0 * 2100.0);
    s.medium.scattering = Vec3::splat(8e-4);
    s.medium.absorption = Vec3::splat(2e-4);
    v.push(
        C::new("grid", "cosine-far-light", s)
            .about("light/far-off-screen with cosine bins: psi spans 3e-3 rad around 0.3, cos(psi) only 1e-3")
            .reason("the bins' cosines differ by 4e-6 each, 30 f32 ulps: bin edges must not lose that")
            .vsv(0.015)
            .done(),
    );
    for (name, spacing) in [
        ("very-far-light", crate::params::BinSpacing::UniformAngle),
        ("cosine-very-far-light", crate::params::BinSpacing::UniformCosine),
    ] {
        let mut s = floor_scene(name);
        s.grid.spacing = spacing;
        s.light = point(Vec3::new(1.0e6, 3.0e5, 1.5e5), 1.0e9);
        s.medium.scattering = Vec3::splat(4e-6);
        s.medium.absorption = Vec3::splat(1e-6);
        v.push(
            C::new("grid", name, s)
                .about("a point light 1000 km away: the casters span 1e-5 rad of psi, below f32's resolution of cos(psi) near 1")
                .reason("grid discretisation as the default; the bins must stay finite and ordered")
                .vsv(0.015)
                .done(),
        );
    }
    let mut s = floor_scene("most-bins");
    s.grid = Grid { planes: 256, rays: 256, bins: Grid::BINS.max as u32, ..Grid::default() };
    v.push(
        C::new("grid", "most-bins", s)
            .about("256 x 256 x 2048: the most bins a grid may have (64 words per ray)")
            .reason("as the default or better: runs are found word by word (0.62%)")
            .vsv(0.015)
            .done(),
    );
    // The product's default grid (Grid::default) on the two scenes with casters pierced by the
    // eye-light axis: a finer grid must do at least as well as the 256 x 256 x 256 of the cases above.
    let mut s = behind_axis_scene("default-grid-behind-axis");
    s.grid = Grid::default();
    v.push(
        C::new("grid", "default-behind-axis", s)
            .about(&format!("eye/in-shadow-behind-axis at the default grid {} (thin cells around the axis)", Grid::default()))
            .reason("no worse than at 256^3 (3.7%): 1.0% at 2048 x 512 x 768 (1.4% at 1536 and 1024 x 512 x 512, 2.7% at 1024 x 1024 x 256; the cell voxelizer dropped the shade from 158 of row 0's planes: 8.1%)")
            .vsv(0.06)
            .done(),
    );
    let mut s = sun_scene("default-grid-sun-lobe", G_MAX);
    s.grid = Grid::default();
    v.push(
        C::new("grid", "default-sun-lobe", s)
            .about(&format!("phase/hg-0.999-sun at the default grid {} (thin cells around the axis)", Grid::default()))
            .reason("no worse than at 256^3 (4.9%): 2.8% at 2048 x 512 x 768; not monotonic in the planes near the epipole (x 512 x 512: 2.4% at 1280, 3.9% at 1024, 4.8% at 1536, 5.3% at 2048; 4.4% at 1024 x 1024 x 256; the cell voxelizer's spurious bits near the epipole: 22%)")
            .vsv(0.1)
            .done(),
    );
    let mut s = floor_scene("largest-grid");
    s.grid = largest_grid(limits);
    v.push(
        C::new("grid", "largest", s)
            .about("the largest grid the adapter allows (planes = rays = its largest side, bins to the buffer limit)")
            .reason("as the default or better; on lavapipe (128 MiB buffers) it is 8192 x 4096 x 32, so bins limit it")
            .vsv(0.02)
            .done(),
    );
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn largest_grid_fits_the_limits() {
        let mut l = wgpu::Limits { max_texture_dimension_2d: 8192, ..wgpu::Limits::default() };
        l.max_storage_buffer_binding_size = 128 << 20;
        l.max_buffer_size = 1 << 30;
        let g = largest_grid(&l);
        assert_eq!((g.planes, g.rays, g.bins), (8192, 4096, 32));
        l.max_storage_buffer_binding_size = 4 << 30;
        l.max_buffer_size = 4 << 30;
        let g = largest_grid(&l);
        assert_eq!((g.planes, g.rays, g.bins), (8192, 8192, 512));
        assert!(g.validate().is_ok() && g.bytes() <= 4 << 30);
    }

    #[test]
    fn a_light_on_a_pixel_ray_projects_into_that_pixel() {
        let cam = floor_scene("").camera;
        for (px, py) in [(30, 17), (0, 0), (47, 47), (24, 24)] {
            assert_eq!(pixel_of(&cam, on_pixel_ray(&cam, px, py, 4.0)), Some((px, py)));
        }
        assert_eq!(pixel_of(&cam, cam.eye + Vec3::Z), None, "behind the eye");
    }
}

//! Every user-facing parameter: its meaning, unit and valid range, in one place.
//!
//! UI sliders, preset and scene-file validation and the command line all read the ranges from the
//! [`Spec`] constants below; defaults live only in the `Default` impls.
//!
//! Units: lengths are *scene units* (metres for the shipped scenes); coefficients are per scene unit.
//! Radiometry is linear RGB: a point light has a radiant intensity (W/sr per channel), a directional
//! light an irradiance (W/m^2 per channel); the images hold radiance (W/(m^2 sr)).

use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The documentation and valid range of one scalar parameter (applies per channel for RGB ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spec {
    /// Field name as written in presets and scene files.
    pub name: &'static str,
    /// Unit shown next to the value.
    pub unit: &'static str,
    /// Inclusive lower bound.
    pub min: f64,
    /// Inclusive upper bound.
    pub max: f64,
    /// One sentence: what it means.
    pub doc: &'static str,
}

/// A value outside its [`Spec`], or a combination that cannot be rendered.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParamError {
    #[error("{name} = {value} is out of range [{min}, {max}] {unit}")]
    OutOfRange { name: &'static str, value: f64, min: f64, max: f64, unit: &'static str },
    #[error("{name} is not a finite number ({value})")]
    NotFinite { name: &'static str, value: f64 },
    #[error("{0}")]
    Invalid(String),
}

impl Spec {
    /// Checks one value against the range. The bounds are met to f32 precision: parameters are
    /// stored as f32, and `0.999f32` (0.99900001) must pass a documented maximum of 0.999. The slack
    /// is relative to each bound itself, so a minimum of 0 admits no negative value however large
    /// the maximum is.
    pub fn check(&self, value: f64) -> Result<(), ParamError> {
        if !value.is_finite() {
            return Err(ParamError::NotFinite { name: self.name, value });
        }
        let slack = |bound: f64| f32::EPSILON as f64 * bound.abs();
        if value < self.min - slack(self.min) || value > self.max + slack(self.max) {
            return Err(ParamError::OutOfRange {
                name: self.name,
                value,
                min: self.min,
                max: self.max,
                unit: self.unit,
            });
        }
        Ok(())
    }

    /// Checks the three channels of an RGB value.
    pub fn check_rgb(&self, value: Vec3) -> Result<(), ParamError> {
        for c in value.to_array() {
            self.check(c as f64)?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------------
// Medium
// ---------------------------------------------------------------------------------------------

/// Phase function: the angular distribution of single scattering, normalised so that its integral
/// over the sphere is 1 (unit 1/sr). `cos_theta` is the cosine of the deflection angle: 1 means the
/// light keeps going in its direction (forward scattering).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case")]
pub enum Phase {
    /// `1 / (4 pi)`.
    Isotropic,
    /// Henyey-Greenstein, `(1 - g^2) / (4 pi (1 + g^2 - 2 g cos)^(3/2))`.
    HenyeyGreenstein { g: f32 },
    /// Schlick's approximation of HG, `(1 - k^2) / (4 pi (1 - k cos)^2)` with `k = 1.55 g - 0.55 g^3`.
    Schlick { g: f32 },
    /// Cornette-Shanks, `3 (1 - g^2) (1 + cos^2) / (8 pi (2 + g^2) (1 + g^2 - 2 g cos)^(3/2))`.
    CornetteShanks { g: f32 },
    /// Rayleigh, `3 (1 + cos^2) / (16 pi)`.
    Rayleigh,
}

impl Phase {
    /// Asymmetry `g` of the lobed phase functions: -1 back, 0 isotropic, 1 forward.
    pub const G: Spec = Spec {
        name: "g",
        unit: "",
        min: -0.999,
        max: 0.999,
        doc: "Asymmetry of the lobe: negative scatters back toward the light, positive forward.",
    };

    /// `g` of Schlick's approximation: its `k = 1.55 g - 0.55 g^3` passes 1 in magnitude at
    /// |g| = 0.938, beyond which `(1 - k^2) / (1 - k cos)^2` is negative with a pole, so the range
    /// stops short of that.
    pub const SCHLICK_G: Spec = Spec {
        name: "g",
        unit: "",
        min: -0.93,
        max: 0.93,
        doc: "Asymmetry of Schlick's lobe: negative scatters back toward the light, positive forward \
              (|g| <= 0.93, where the approximation stays a positive function).",
    };

    /// The range of this kind's `g` ([`Phase::G`], or [`Phase::SCHLICK_G`] for Schlick).
    pub fn g_spec(&self) -> &'static Spec {
        match self {
            Phase::Schlick { .. } => &Self::SCHLICK_G,
            _ => &Self::G,
        }
    }

    /// All kinds, in UI order, with their file names.
    pub const KINDS: [&'static str; 5] = ["isotropic", "henyey-greenstein", "schlick", "cornette-shanks", "rayleigh"];

    /// The phase function of kind `id` ([`Phase::id`], the index in [`Phase::KINDS`]) with asymmetry
    /// `g` where the kind has one; `None` for an unknown id.
    pub fn of_kind(id: u32, g: f32) -> Option<Phase> {
        Some(match id {
            0 => Phase::Isotropic,
            1 => Phase::HenyeyGreenstein { g },
            2 => Phase::Schlick { g },
            3 => Phase::CornetteShanks { g },
            4 => Phase::Rayleigh,
            _ => return None,
        })
    }

    /// The kind's file name (`henyey-greenstein`), as in [`Phase::KINDS`].
    pub fn kind_name(&self) -> &'static str {
        Self::KINDS[self.id() as usize]
    }

    /// Whether the kind has an asymmetry parameter `g`.
    pub fn has_g(&self) -> bool {
        matches!(self, Phase::HenyeyGreenstein { .. } | Phase::Schlick { .. } | Phase::CornetteShanks { .. })
    }

    /// Stable small integer used by the shaders (`PHASE_*` in `common.wgsl`).
    pub fn id(&self) -> u32 {
        match self {
            Phase::Isotropic => 0,
            Phase::HenyeyGreenstein { .. } => 1,
            Phase::Schlick { .. } => 2,
            Phase::CornetteShanks { .. } => 3,
            Phase::Rayleigh => 4,
        }
    }

    /// The asymmetry parameter, 0 where the function has none.
    pub fn g(&self) -> f32 {
        match *self {
            Phase::HenyeyGreenstein { g } | Phase::Schlick { g } | Phase::CornetteShanks { g } => g,
            Phase::Isotropic | Phase::Rayleigh => 0.0,
        }
    }

    /// Evaluates the normalised phase function in `f64` (used by the reference and the tests).
    pub fn eval(&self, cos_theta: f64) -> f64 {
        let c = cos_theta.clamp(-1.0, 1.0);
        match *self {
            Phase::Isotropic => 1.0 / (4.0 * PI),
            Phase::HenyeyGreenstein { g } => {
                let g = g as f64;
                let den = 1.0 + g * g - 2.0 * g * c;
                (1.0 - g * g) / (4.0 * PI * den * den.sqrt())
            }
            Phase::Schlick { g } => {
                let g = g as f64;
                let k = 1.55 * g - 0.55 * g * g * g;
                let den = 1.0 - k * c;
                (1.0 - k * k) / (4.0 * PI * den * den)
            }
            Phase::CornetteShanks { g } => {
                let g = g as f64;
                let den = 1.0 + g * g - 2.0 * g * c;
                3.0 * (1.0 - g * g) * (1.0 + c * c) / (8.0 * PI * (2.0 + g * g) * den * den.sqrt())
            }
            Phase::Rayleigh => 3.0 * (1.0 + c * c) / (16.0 * PI),
        }
    }

    /// Checks `g` against its kind's range.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.g_spec().check(self.g() as f64)
    }
}

impl Default for Phase {
    fn default() -> Self {
        Phase::HenyeyGreenstein { g: 0.3 }
    }
}

/// A homogeneous participating medium (single scattering).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Medium {
    /// Scattering coefficient `sigma_s` per RGB channel.
    pub scattering: Vec3,
    /// Absorption coefficient `sigma_a` per RGB channel.
    pub absorption: Vec3,
    /// Multiplies both coefficients: a single knob for "thicker/thinner".
    pub density: f32,
    /// Angular distribution of scattering.
    pub phase: Phase,
}

impl Medium {
    pub const SCATTERING: Spec = Spec {
        name: "scattering",
        unit: "1/unit",
        min: 0.0,
        max: 1.0e4,
        doc: "Scattering coefficient sigma_s per channel: fraction of light scattered per unit length.",
    };
    pub const ABSORPTION: Spec = Spec {
        name: "absorption",
        unit: "1/unit",
        min: 0.0,
        max: 1.0e4,
        doc: "Absorption coefficient sigma_a per channel: fraction of light absorbed per unit length.",
    };
    pub const DENSITY: Spec =
        Spec { name: "density", unit: "x", min: 0.0, max: 1.0e3, doc: "Multiplier applied to both coefficients." };

    /// `sigma_s * density`.
    pub fn sigma_s(&self) -> Vec3 {
        self.scattering * self.density
    }
    /// `sigma_t = (sigma_s + sigma_a) * density`.
    pub fn sigma_t(&self) -> Vec3 {
        (self.scattering + self.absorption) * self.density
    }
    /// True when nothing scatters: the scattering passes have nothing to compute.
    pub fn is_clear(&self) -> bool {
        self.sigma_s().max_element() <= 0.0
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        Self::SCATTERING.check_rgb(self.scattering)?;
        Self::ABSORPTION.check_rgb(self.absorption)?;
        Self::DENSITY.check(self.density as f64)?;
        self.phase.validate()
    }
}

impl Default for Medium {
    fn default() -> Self {
        Medium { scattering: Vec3::splat(0.1), absorption: Vec3::splat(0.01), density: 1.0, phase: Phase::default() }
    }
}

// ---------------------------------------------------------------------------------------------
// Light
// ---------------------------------------------------------------------------------------------

/// The single light of a frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Light {
    /// A spherical light small enough to count as a point for visibility.
    Point {
        /// World position.
        position: Vec3,
        /// Radiant intensity per RGB channel.
        intensity: Vec3,
        /// Softening radius: `1/d^2` becomes `1/(d^2 + radius^2)`, which keeps a view ray through
        /// the light finite. 0 is an ideal point.
        radius: f32,
    },
    /// A light at infinity (the sun): parallel rays, no fall-off.
    Directional {
        /// Unit vector pointing *toward* the light (as in Mitsuba's `sunDirection`).
        direction: Vec3,
        /// Irradiance per RGB channel on a surface facing the light, outside the medium.
        irradiance: Vec3,
    },
}

impl Light {
    pub const POSITION: Spec =
        Spec { name: "position", unit: "unit", min: -1.0e7, max: 1.0e7, doc: "World position of the point light." };
    pub const INTENSITY: Spec = Spec {
        name: "intensity",
        unit: "W/sr",
        min: 0.0,
        max: 1.0e9,
        doc: "Radiant intensity of the point light per channel.",
    };
    pub const RADIUS: Spec = Spec {
        name: "radius",
        unit: "unit",
        min: 0.0,
        max: 1.0e4,
        doc: "Radius that softens 1/d^2 near the point light; 0 is an ideal point.",
    };
    pub const DIRECTION: Spec = Spec {
        name: "direction",
        unit: "",
        min: -1.0,
        max: 1.0,
        doc: "Unit vector toward the directional light (normalised on load).",
    };
    pub const IRRADIANCE: Spec = Spec {
        name: "irradiance",
        unit: "W/m^2",
        min: 0.0,
        max: 1.0e9,
        doc: "Irradiance of the directional light per channel.",
    };

    pub fn is_point(&self) -> bool {
        matches!(self, Light::Point { .. })
    }

    /// Radiant intensity or irradiance.
    pub fn power(&self) -> Vec3 {
        match *self {
            Light::Point { intensity, .. } => intensity,
            Light::Directional { irradiance, .. } => irradiance,
        }
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        match *self {
            Light::Point { position, intensity, radius } => {
                Self::POSITION.check_rgb(position)?;
                Self::INTENSITY.check_rgb(intensity)?;
                Self::RADIUS.check(radius as f64)
            }
            Light::Directional { direction, irradiance } => {
                Self::IRRADIANCE.check_rgb(irradiance)?;
                if !direction.is_finite() || direction.length() < 1e-6 {
                    return Err(ParamError::Invalid(format!(
                        "light direction {direction} must be a finite, non-zero vector"
                    )));
                }
                Ok(())
            }
        }
    }

    /// The same light with its direction normalised (directional) — loaders call this.
    pub fn normalized(self) -> Self {
        match self {
            Light::Directional { direction, irradiance } => {
                Light::Directional { direction: direction.normalize_or(Vec3::Y), irradiance }
            }
            l => l,
        }
    }
}

impl Default for Light {
    fn default() -> Self {
        Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::splat(20.0), radius: 0.0 }
    }
}

// ---------------------------------------------------------------------------------------------
// Grid
// ---------------------------------------------------------------------------------------------

/// How the z bins (light rays within a plane) are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum BinSpacing {
    /// Equal steps of the angle `psi` at the light: for a clear medium every bin carries the same
    /// in-scattering weight (DESIGN section 2).
    #[default]
    UniformAngle,
    /// Equal steps of `cos(psi)`, the paper's choice.
    UniformCosine,
}

/// Resolution of the epipolar voxel grid: `planes x rays x bins` bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Grid {
    /// Epipolar planes (x): half-lines around the epipole.
    pub planes: u32,
    /// View rays per plane (y), ordered by the angle `gamma` from the eye-light axis.
    pub rays: u32,
    /// Light rays per plane (z), as bits: a multiple of 32.
    pub bins: u32,
    /// Spacing of the bins for point lights (directional lights are always uniform in distance).
    pub spacing: BinSpacing,
}

impl Grid {
    pub const PLANES: Spec = Spec { name: "planes", unit: "", min: 8.0, max: 8192.0, doc: "Epipolar planes (x)." };
    pub const RAYS: Spec = Spec { name: "rays", unit: "", min: 8.0, max: 8192.0, doc: "View rays per plane (y)." };
    pub const BINS: Spec = Spec {
        name: "bins",
        unit: "bits",
        min: 32.0,
        max: 2048.0,
        doc: "Light rays per plane (z): depth resolution of the shadow volume, a multiple of 32.",
    };

    /// 32-bit words of bins per ray.
    pub fn words(&self) -> u32 {
        self.bins / 32
    }

    /// Whether every ray starts on four words (bins a multiple of 128): Scan and Integrate then
    /// read the grid four words at a time (`QUAD_RAYS` in common.wgsl). On llvmpipe a load is one
    /// instruction per lane whatever its width: Scan took 45% less time reading vectors, Integrate
    /// 20% (docs/results.md, session 15).
    pub fn quad_rays(&self) -> bool {
        self.words().is_multiple_of(4)
    }

    /// The index of the first word of grid ray (`plane`, `ray`) in the grid buffer
    /// ([`crate::render::Renderer::read_grid`]): plane-major, each ray [`Grid::words`] long
    /// (`ray_offset` in common.wgsl).
    pub fn ray_offset(&self, plane: u32, ray: u32) -> usize {
        (plane as usize * self.rays as usize + ray as usize) * self.words() as usize
    }

    /// Bytes of one grid buffer.
    pub fn bytes(&self) -> u64 {
        self.planes as u64 * self.rays as u64 * self.words() as u64 * 4
    }

    pub fn validate(&self) -> Result<(), ParamError> {
        Self::PLANES.check(self.planes as f64)?;
        Self::RAYS.check(self.rays as f64)?;
        Self::BINS.check(self.bins as f64)?;
        if !self.bins.is_multiple_of(32) {
            return Err(ParamError::Invalid(format!("bins = {} must be a multiple of 32", self.bins)));
        }
        Ok(())
    }

    /// Parses `PxRxB`, e.g. `1024x1024x256`.
    pub fn parse(text: &str) -> Result<Grid, ParamError> {
        let parts: Vec<&str> = text.split(['x', 'X']).collect();
        let bad = || ParamError::Invalid(format!("grid '{text}' is not PLANESxRAYSxBINS, e.g. 1024x1024x256"));
        if parts.len() != 3 {
            return Err(bad());
        }
        let n: Vec<u32> = parts.iter().map(|p| p.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| bad())?;
        let g = Grid { planes: n[0], rays: n[1], bins: n[2], ..Grid::default() };
        g.validate()?;
        Ok(g)
    }
}

impl std::fmt::Display for Grid {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}x{}", self.planes, self.rays, self.bins)
    }
}

/// 2048 x 256 x 1536: 2048 planes and 1536 bins of light rays (light space, where a shadow's
/// edge in the medium is placed) and 256 ray cells. VSV's default volume keeps each light ray's
/// first hit ([`crate::render::ShadowVolume::FirstHits`]: 12 MiB of keys and 2 of their words'
/// bounds, the rays only bound the cells the pixels read); the bits (grid surface shadows, the
/// Cartesian grid) take 96 MiB.
/// Measured on the classroom at 512x512 against the exact reference (relative RMSE of the
/// scattered light), llvmpipe, session 47 (docs/results.md):
///
/// | grid | first hits | bits | the frame, first hits |
/// |---|---:|---:|---:|
/// | 2048x512x768 (the default of sessions 13 to 46) | 0.92% | 0.985% | 338 ms (bits 297) |
/// | **2048x256x1536** | **0.74%** | 0.92% | **390 ms** |
/// | 2048x512x2048 / 4096x512x1536 | 0.75% / 0.62% | too large | 521 ms (4096 planes) |
///
/// At 0.74% the as-accurate march needs 2048 steps on the 4096 map (3.27 s): 8.4x, against the
/// old default's 7.1x at 0.985%. Doubling the bins halves a shadow edge's sampling error along
/// the light rays, which the bits could not afford (2048x512x1536 is 192 MiB, past llvmpipe's
/// storage binding). The plane count is not monotonic near the shaft edges (1536 planes: 1.10%).
/// Until session 46 the default was 2048 x 512 x 768 (from session 13; 1536 x 512 x 512 and
/// 1024 x 512 x 512 before, the paper's 1024 x 1024 x 256 first).
impl Default for Grid {
    fn default() -> Self {
        Grid { planes: 2048, rays: 256, bins: 1536, spacing: BinSpacing::UniformAngle }
    }
}

// ---------------------------------------------------------------------------------------------
// The ray-marching baseline
// ---------------------------------------------------------------------------------------------

/// Settings of the ray-marching baseline (`--method raymarch`, the editor's "ray march"): `steps`
/// samples per view ray, each with one lookup in a `shadow_map`-texel shadow map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Baseline {
    pub steps: u32,
    pub shadow_map: u32,
    /// Offset the steps by a per-pixel random fraction (noise instead of banding).
    pub jitter: bool,
}

impl Baseline {
    pub const STEPS: Spec = Spec {
        name: "steps",
        unit: "",
        min: 1.0,
        // As far as the bench's chase for VSV's error may go (bench::CHASE_MAX_STEPS).
        max: 32768.0,
        doc: "Samples per view ray of the ray-marching baseline, each with one shadow-map lookup.",
    };
    pub const SHADOW_MAP: Spec = Spec {
        name: "shadow-map",
        unit: "texels",
        min: 64.0,
        max: 16384.0,
        doc: "The shadow map's budget as texels per side of a square (surface shadows, and the baseline's visibility); VSV's sun map holds about as many texels, shaped to square texels over the rectangle it covers.",
    };

    pub fn validate(&self) -> Result<(), ParamError> {
        Self::STEPS.check(self.steps as f64)?;
        Self::SHADOW_MAP.check(self.shadow_map as f64)
    }
}

impl Default for Baseline {
    fn default() -> Self {
        Baseline { steps: 64, shadow_map: 2048, jitter: false }
    }
}

// ---------------------------------------------------------------------------------------------
// Image / tone mapping
// ---------------------------------------------------------------------------------------------

/// How the linear image becomes a PNG.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Exposure {
    /// Exposure in stops applied before tone mapping.
    pub stops: f32,
}

impl Exposure {
    pub const STOPS: Spec =
        Spec { name: "exposure", unit: "EV", min: -20.0, max: 20.0, doc: "Exposure before tone mapping." };
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure { stops: 0.0 }
    }
}

// ---------------------------------------------------------------------------------------------
// Surfaces, camera, image and measurement settings
// ---------------------------------------------------------------------------------------------

/// Ranges of a mesh's surface values (the meshes themselves live in `crate::scene`).
pub struct Surface;

impl Surface {
    pub const ALBEDO: Spec = Spec {
        name: "albedo",
        unit: "",
        min: 0.0,
        max: 1.0,
        doc: "Diffuse reflectance of a surface per channel: the fraction of light it reflects.",
    };
}

/// Ranges of the camera's scalar settings (the camera itself is `crate::scene::Camera`).
pub struct View;

impl View {
    pub const FOV_Y: Spec = Spec {
        name: "fov_y_deg",
        unit: "deg",
        min: 0.01,
        max: 178.0,
        doc: "Vertical field of view of the pinhole camera.",
    };
}

/// The size of a rendered image (`--size WIDTHxHEIGHT`).
pub struct ImageSize;

impl ImageSize {
    pub const SIDE: Spec =
        Spec { name: "size", unit: "pixels", min: 1.0, max: 16384.0, doc: "Width or height of a rendered image." };
}

/// Settings of the exact CPU reference a user may choose (`--samples`); its defaults are
/// `reference::ReferenceOptions::default()`.
pub struct ReferenceQuality;

impl ReferenceQuality {
    /// Below 2 the reference has no interval to bisect; beyond 65536 its per-thread buffers stop
    /// being small and the result no longer changes at any image size this tool renders.
    pub const SAMPLES: Spec = Spec {
        name: "samples",
        unit: "per view ray",
        min: 2.0,
        max: 65536.0,
        doc: "Visibility samples per view ray of the CPU reference: a shadow feature thinner than \
              1/(samples - 1) of the ray's light angle can be missed.",
    };
}

/// How `epivox bench` measures (`--frames`, `--warmup`, `--rounds`).
pub struct Measure;

impl Measure {
    pub const FRAMES: Spec = Spec {
        name: "frames",
        unit: "frames",
        min: 1.0,
        max: 1000.0,
        doc: "Frames timed per measured point; the report gives their median.",
    };
    pub const WARMUP: Spec = Spec {
        name: "warmup",
        unit: "frames",
        min: 0.0,
        max: 1000.0,
        doc: "Frames rendered before timing (pipeline compilation, caches).",
    };
    pub const ROUNDS: Spec = Spec {
        name: "rounds",
        unit: "rounds",
        min: 1.0,
        max: 100.0,
        doc: "Times the error sweep and the triangle sweep are timed, interleaved: each round times \
              every point once (after its warm-up), so a slow phase of a shared machine falls on all \
              points alike; a point's time is the median of its frames from all rounds.",
    };
    pub const VOXELIZE_RUN: Spec = Spec {
        name: "voxelize-run",
        unit: "items",
        min: 1.0,
        max: 1024.0,
        doc: "Voxelize's work items a thread takes, and Cull's triangles a thread culls (the renderer's \
              own choice: 64 on a CPU adapter, 1 on a GPU; Voxelize::items_per_thread).",
    };
    pub const ROOM: Spec = Spec {
        name: "room",
        unit: "triangles",
        min: 2000.0,
        max: 10_000_000.0,
        doc: "The bench's procedural room (64 spheres under a point light, the triangle sweep's scene) \
              tessellated to at least this many triangles.",
    };
}

impl Light {
    /// Radiance of an emissive surface that becomes a point light (Mitsuba's area emitters).
    pub const RADIANCE: Spec = Spec {
        name: "radiance",
        unit: "W/(m^2 sr)",
        min: 0.0,
        max: 1.0e9,
        doc: "Radiance of an emissive surface per channel.",
    };
}

/// A direction given by a user or a file, unit length. Zero, NaN and infinite vectors are refused
/// (never replaced by a default): `name` says which field it was.
pub fn unit_direction(name: &str, v: Vec3) -> Result<Vec3, ParamError> {
    match v.try_normalize() {
        Some(u) if v.is_finite() => Ok(u),
        _ => Err(ParamError::Invalid(format!("{name} = {v} must be a finite, non-zero vector"))),
    }
}

/// Strict deserializers for the files users write (presets, scene files): a vector is exactly
/// three numbers, and a phase function is one of [`Phase::KINDS`] with `g` exactly when the kind
/// has one and no other key.
pub mod de {
    use super::Phase;
    use glam::Vec3;
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::{Deserialize, Deserializer};

    struct Vec3Visitor;

    impl<'de> Visitor<'de> for Vec3Visitor {
        type Value = Vec3;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an array of 3 numbers")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec3, A::Error> {
            let mut v = [0.0f32; 3];
            let mut n = 0usize;
            while let Some(x) = seq.next_element::<f32>()? {
                if let Some(slot) = v.get_mut(n) {
                    *slot = x;
                }
                n += 1;
            }
            if n != 3 {
                return Err(A::Error::invalid_length(n, &self));
            }
            Ok(Vec3::from(v))
        }
    }

    /// Exactly three numbers.
    pub fn vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Vec3, D::Error> {
        d.deserialize_seq(Vec3Visitor)
    }

    /// [`vec3`] for an optional field (use with `#[serde(default)]`).
    pub fn opt_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec3>, D::Error> {
        vec3(d).map(Some)
    }

    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct PhaseFields {
        #[serde(rename = "type")]
        kind: String,
        g: Option<f32>,
    }

    /// `{ type = KIND, g = G }`: see [`Phase::from_fields`].
    pub fn phase<'de, D: Deserializer<'de>>(d: D) -> Result<Phase, D::Error> {
        let f = PhaseFields::deserialize(d)?;
        Phase::from_fields(&f.kind, f.g).map_err(D::Error::custom)
    }

    /// [`phase`] for an optional field (use with `#[serde(default)]`).
    pub fn opt_phase<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Phase>, D::Error> {
        phase(d).map(Some)
    }
}

impl Phase {
    /// The phase function a file names: `kind` one of [`Phase::KINDS`], `g` given exactly when the
    /// kind has one ([`Phase::has_g`]). The range of `g` is checked by [`Phase::validate`].
    pub fn from_fields(kind: &str, g: Option<f32>) -> Result<Phase, ParamError> {
        let Some(id) = Self::KINDS.iter().position(|k| *k == kind) else {
            return Err(ParamError::Invalid(format!(
                "unknown phase function type '{kind}' (expected one of: {})",
                Self::KINDS.join(", ")
            )));
        };
        let p = Self::of_kind(id as u32, g.unwrap_or(0.0))
            .ok_or_else(|| ParamError::Invalid(format!("unknown phase function type '{kind}'")))?;
        match (p.has_g(), g) {
            (true, None) => Err(ParamError::Invalid(format!("phase function '{kind}' needs `g`"))),
            (false, Some(_)) => Err(ParamError::Invalid(format!("phase function '{kind}' has no `g`"))),
            _ => Ok(p),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Schlick's range stops where the approximation stays positive; the documented maximum of
    /// every range is accepted in the f32 the parameters are stored in.
    #[test]
    fn schlick_range_keeps_the_phase_positive_and_bounds_pass_in_f32() {
        let edge = Phase::Schlick { g: Phase::SCHLICK_G.max as f32 };
        assert!(edge.validate().is_ok());
        for i in 0..=2000 {
            let c = -1.0 + i as f64 / 1000.0;
            assert!(edge.eval(c) > 0.0 && Phase::Schlick { g: -0.93 }.eval(c) > 0.0, "negative at cos {c}");
        }
        assert!(Phase::Schlick { g: 0.95 }.validate().is_err());
        assert!(Phase::Schlick { g: 0.95 }.eval(0.0) < 0.0, "the refused range is indeed negative");
        assert!(Phase::HenyeyGreenstein { g: 0.95 }.validate().is_ok());
        assert!(Phase::HenyeyGreenstein { g: 0.999 }.validate().is_ok(), "0.999f32 = 0.99900001");
        assert!(Phase::HenyeyGreenstein { g: -0.999 }.validate().is_ok());
        assert!(Phase::HenyeyGreenstein { g: 0.9991 }.validate().is_err());
    }

    /// Integrates a phase function over the sphere with a midpoint rule in cos(theta).
    fn sphere_integral(p: &Phase) -> f64 {
        let n = 200_000;
        (0..n)
            .map(|i| {
                let c = -1.0 + (i as f64 + 0.5) * 2.0 / n as f64;
                p.eval(c) * 2.0 * PI * 2.0 / n as f64
            })
            .sum()
    }

    #[test]
    fn phase_functions_are_normalised() {
        for p in [
            Phase::Isotropic,
            Phase::Rayleigh,
            Phase::HenyeyGreenstein { g: 0.7 },
            Phase::HenyeyGreenstein { g: -0.5 },
            Phase::Schlick { g: 0.8 },
            Phase::CornetteShanks { g: 0.6 },
            Phase::CornetteShanks { g: -0.3 },
        ] {
            let i = sphere_integral(&p);
            assert!((i - 1.0).abs() < 1e-4, "{p:?} integrates to {i}");
        }
    }

    #[test]
    fn phase_kinds_round_trip() {
        for (i, name) in Phase::KINDS.iter().enumerate() {
            let p = Phase::of_kind(i as u32, 0.25).unwrap();
            assert_eq!((p.id() as usize, p.kind_name()), (i, *name));
            assert_eq!(p.g(), if p.has_g() { 0.25 } else { 0.0 });
        }
        assert!(Phase::of_kind(Phase::KINDS.len() as u32, 0.0).is_none());
    }

    #[test]
    fn phase_from_fields_is_strict() {
        assert_eq!(Phase::from_fields("schlick", Some(0.5)).unwrap(), Phase::Schlick { g: 0.5 });
        assert_eq!(Phase::from_fields("rayleigh", None).unwrap(), Phase::Rayleigh);
        for (kind, g, needle) in [
            ("rayleigh", Some(0.1), "has no `g`"),
            ("henyey-greenstein", None, "needs `g`"),
            ("Isotropic", None, "unknown phase function type 'Isotropic'"),
        ] {
            let e = Phase::from_fields(kind, g).unwrap_err().to_string();
            assert!(e.contains(needle), "{kind}: {e}");
        }
        // The strict deserializers, through TOML as the files use them.
        #[derive(Deserialize)]
        struct T {
            #[serde(deserialize_with = "de::vec3")]
            v: Vec3,
            #[serde(default, deserialize_with = "de::opt_phase")]
            p: Option<Phase>,
        }
        let t: T = toml::from_str("v = [1, 2.5, 3]\np = { type = \"cornette-shanks\", g = -0.2 }").unwrap();
        assert_eq!((t.v, t.p), (Vec3::new(1.0, 2.5, 3.0), Some(Phase::CornetteShanks { g: -0.2 })));
        assert!(toml::from_str::<T>("v = [1, 2, 3, 4]").is_err());
        assert!(toml::from_str::<T>("v = [1, 2]").is_err());
        assert!(toml::from_str::<T>("v = [1, 2, 3]\np = { type = \"isotropic\", g = 0.0 }").is_err());
        assert!(toml::from_str::<T>("v = [1, 2, 3]\np = { type = \"isotropic\", k = 1 }").is_err());
    }

    #[test]
    fn unit_direction_refuses_instead_of_substituting() {
        assert_eq!(unit_direction("d", Vec3::new(0.0, 2.0, 0.0)).unwrap(), Vec3::Y);
        for v in [Vec3::ZERO, Vec3::new(f32::NAN, 1.0, 0.0), Vec3::new(f32::INFINITY, 0.0, 0.0)] {
            let e = unit_direction("light direction", v).unwrap_err().to_string();
            assert!(e.contains("light direction") && e.contains("non-zero"), "{e}");
        }
    }

    #[test]
    fn grid_parse_and_validate() {
        let g = Grid::parse("512x256x64").unwrap();
        assert_eq!((g.planes, g.rays, g.bins), (512, 256, 64));
        assert!(Grid::parse("512x256x60").is_err());
        assert!(Grid::parse("512x256").is_err());
        assert!(Grid::parse("axbxc").is_err());
        assert!(Grid::parse("4x256x64").is_err());
    }

    #[test]
    fn ranges_reject_bad_values() {
        // A wide range does not widen its lower bound: [0, 1e9] refuses -5 (it once had a slack of
        // 119 at both ends).
        assert!(Light::INTENSITY.check(-5.0).is_err());
        assert!(Light::INTENSITY.check(-1e-6).is_err());
        assert!(Light::INTENSITY.check(0.0).is_ok() && Light::INTENSITY.check(f64::from(1e9_f32)).is_ok());
        assert!(Medium::SCATTERING.check(-1.0).is_err());
        assert!(Medium::SCATTERING.check(f64::NAN).is_err());
        assert!(Medium::default().validate().is_ok());
        let m = Medium { phase: Phase::HenyeyGreenstein { g: 1.5 }, ..Medium::default() };
        assert!(m.validate().is_err());
    }
}

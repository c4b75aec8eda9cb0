//! The per-frame uniforms every pass reads (`Frame` in `shaders/common.wgsl`).

use crate::epipolar::{EpipolarFrame, GridMapping, LightGeom};
use crate::params::{BinSpacing, Light};
use crate::scene::{Aabb, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, UVec4, Vec4};

// Bits 1, 4 and 8 were the light type, cosine bins and the Cartesian grid: they are pipeline
// constants now (`render::Variant`), so no shader branches on them at run time.
pub const FLAG_PHI_WRAPS: u32 = 2;
/// Nothing scatters (no medium or a dark light): Integrate writes zeros and the voxel passes are skipped.
pub const FLAG_NO_SCATTER: u32 = 16;
/// The surfaces' shadows come from the shadow volume (Integrate writes them; no shadow map is
/// drawn): set by the renderer on VSV frames ([`super::Renderer::surface_shadows`]: grid). Read on the CPU
/// only, where it picks the passes' pipelines ([`super::Variant::grid_shadows`]): no shader
/// branches on it.
pub const FLAG_GRID_SHADOWS: u32 = 32;
/// Cull tests the blocks of a large triangle's planes against the sun's pyramid on their own and
/// Voxelize skips the hidden ones (cull.wgsl `hidden_blocks`): set by the renderer unless
/// [`super::Renderer::hidden_blocks`] is off.
pub const FLAG_HIDDEN_BLOCKS: u32 = 64;
/// The surfaces' sun shadows are tested against the triangles ([`super::ExactShadows`]), not
/// looked up in the shadow map: set by the renderer ([`super::Renderer::surface_shadows`]: exact). Read on
/// the CPU only, like [`FLAG_GRID_SHADOWS`].
pub const FLAG_EXACT_SHADOWS: u32 = 128;
/// The frame keeps its shadow volume as each light ray's first hit
/// ([`super::ShadowVolume::FirstHits`]): set by the renderer. Read on the CPU only, like
/// [`FLAG_GRID_SHADOWS`].
pub const FLAG_FIRST_HITS: u32 = 256;
/// Ranges wrote each plane's reach this frame ([`super::Ranges::reach`]), and Voxelize keeps no
/// first hit past it: set by the renderer on a first-hit frame that prunes and whose planes do
/// not wrap, unless [`super::Renderer::plane_reach`] is off.
pub const FLAG_PLANE_REACH: u32 = 512;

/// Mirrors `struct Frame` in `shaders/common.wgsl` field for field (checked by a layout test).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct FrameUniforms {
    /// Camera right, up and forward unit vectors; `w`: tan(half fov x), tan(half fov y), near.
    pub cam_right: Vec4,
    pub cam_up: Vec4,
    pub cam_fwd: Vec4,
    /// Eye position; `w`: far.
    pub eye: Vec4,
    pub view_proj: Mat4,
    /// Point light: its position, `w` = 1. Directional: the unit vector toward it, `w` = 0.
    pub light: Vec4,
    /// Intensity (W/sr) or irradiance (W/m^2); `w`: the point light's softening radius.
    pub light_power: Vec4,
    /// Unit axis from the eye toward the light; `w`: the eye-light distance D (0 for a sun).
    pub axis: Vec4,
    /// Basis around the axis; `b1.w`: the first plane's angle phi0, `b2.w`: the planes' span.
    pub b1: Vec4,
    pub b2: Vec4,
    /// sigma_s per channel; `w`: the phase function's asymmetry g.
    pub sigma_s: Vec4,
    /// sigma_t per channel; `w` unused.
    pub sigma_t: Vec4,
    /// gamma_lo, gamma_hi (the rays), z_lo, z_hi (the bins; Ranges overwrites `zw` on the GPU).
    pub ranges: Vec4,
    /// The box the medium fills for a directional light (`w` unused).
    pub medium_min: Vec4,
    pub medium_max: Vec4,
    /// planes, rays, bins, 32-bit words per ray.
    pub grid: UVec4,
    /// Image width and height, unused, flags (`FLAG_*`).
    pub image: UVec4,
    /// Scatter-table rows and columns, the Cartesian grid's light axis (0 +right, 1 -right, 2 +up,
    /// 3 -up); `w` unused.
    pub table: UVec4,
    /// Voxelize's work list: items per thread and 32-bit words of bins per item (the renderer sets
    /// them per adapter: [`super::Voxelize`]), and the coarsest shadow-pyramid level Cull reads to
    /// drop triangles hidden from the light (0: no such test; [`super::ShadowPyramid`]); `w` the
    /// coarsest level of the eye's depth pyramid Surface's culling reads (0: none;
    /// [`super::EyePyramid`]).
    pub work: UVec4,
    /// Where the axis toward the light meets the image, in pixel coordinates (the pixel convention
    /// of [`crate::scene::Camera::pixel_dir_f64`]: pixel p's centre is at p), computed in f64 and
    /// split into whole pixels (`xy`) and the fraction (`zw`, in [0, 1)), so that a pixel's offset
    /// from it keeps full precision (`gamma_of_pixel`, common.wgsl); `NO_EPIPOLE` in `x` when the
    /// light is not in front of the camera or its point lies too far out of the image.
    pub epipole: Vec4,
}

/// `FrameUniforms::epipole.x` when no pixel lies near the light's direction.
pub const NO_EPIPOLE: f32 = 3.0e38;

/// The epipole ([`FrameUniforms::epipole`]): the pixel whose ray is the light's axis `a` (unit,
/// from the eye), split into whole pixels and the fraction.
fn epipole(a: glam::DVec3, cam: &crate::scene::Camera, width: u32, height: u32) -> Vec4 {
    // Past 2^22 pixels the split would lose the fraction; no pixel is near such a point anyway.
    let far = 4_194_304.0;
    match cam.pixel_of_dir_f64(a, width, height) {
        Some((x, y)) if x.abs() < far && y.abs() < far => {
            let (xi, yi) = (x.floor(), y.floor());
            Vec4::new(xi as f32, yi as f32, (x - xi) as f32, (y - yi) as f32)
        }
        _ => Vec4::new(NO_EPIPOLE, 0.0, 0.0, 0.0),
    }
}

/// Everything derived from the scene for one frame on the CPU.
#[derive(Debug, Clone, Copy)]
pub struct FrameSetup {
    pub uniforms: FrameUniforms,
    pub frame: EpipolarFrame,
    pub mapping: GridMapping,
    pub width: u32,
    pub height: u32,
    pub method: Method,
}

/// Which shadow-volume grid a frame uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Voxelized Epipolar Shadow Volumes: planes around the eye-light axis (any light).
    #[default]
    Vsv,
    /// The paper's screen-space Cartesian grid (its section 2): only for a directional light along
    /// a screen axis, whose light rays then follow the grid's rows or columns.
    Cartesian,
    /// The baseline: `steps` samples per view ray with one shadow-map lookup each, optionally
    /// jittered per pixel (`raymarch.rs`). Its uniforms are those of `Vsv`; it uses no grid.
    Raymarch { steps: u32, jitter: bool },
}

/// Why a frame cannot be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrameError {
    #[error("the eye sits exactly on the point light; move one of them")]
    EyeOnLight,
    #[error(
        "the Cartesian method needs a directional light along the camera's x or y axis (it is {off_deg:.2} degrees off the nearest, {name}); for this camera use --light-dir {suggest}"
    )]
    NotAxisAligned { off_deg: f64, name: &'static str, suggest: String },
    #[error("the Cartesian method needs a directional light; use --light-dir or --method vsv")]
    NotDirectional,
}

/// Largest angle between a Cartesian light and its screen axis: the scan assumes light rays stay in
/// one grid row, so a tilt of `delta` shifts them by `delta * depth` — keep that below a texel.
pub const CARTESIAN_TOLERANCE_DEG: f64 = 0.05;

/// Rows and columns of the point-light scatter table (see `scatter_table.rs`).
pub const TABLE_ROWS: u32 = 256;
pub const TABLE_COLS: u32 = 512;

impl FrameSetup {
    /// Whether the frame's surface shadows come from the shadow volume ([`FLAG_GRID_SHADOWS`]):
    /// it draws no shadow map.
    pub fn grid_shadowed(&self) -> bool {
        self.uniforms.image.w & FLAG_GRID_SHADOWS != 0
    }

    /// Whether the frame's surfaces take the sun's shadow from [`super::ExactShadows`]
    /// ([`FLAG_EXACT_SHADOWS`]): its map is drawn only to make Cull's pyramid.
    pub fn exact_shadowed(&self) -> bool {
        self.uniforms.image.w & FLAG_EXACT_SHADOWS != 0
    }

    /// Whether the frame keeps its shadow volume as first hits ([`FLAG_FIRST_HITS`]).
    pub fn first_hits(&self) -> bool {
        self.uniforms.image.w & FLAG_FIRST_HITS != 0
    }

    /// The shader variant this frame's passes run as: its light, `phase`, medium, grid axes
    /// (cosine bins only where the method has bins) and surface shadows.
    pub fn variant(&self, phase: &crate::params::Phase) -> super::Variant {
        let cosine =
            self.mapping.spacing == BinSpacing::UniformCosine && !matches!(self.method, Method::Raymarch { .. });
        super::Variant::new(self.frame.is_point(), phase, self.uniforms.sigma_t.truncate().to_array())
            .with_grid(self.method == Method::Cartesian, cosine)
            .with_quad_rays(self.mapping.grid.quad_rays())
            .with_grid_shadows(self.grid_shadowed())
            .with_exact_shadows(self.exact_shadowed())
            .with_first_hits(self.first_hits())
    }

    pub fn new(scene: &Scene, width: u32, height: u32, method: Method) -> Result<FrameSetup, FrameError> {
        Self::with_pruning(scene, width, height, method, true)
    }

    /// With `prune == false` (`--no-prune`) the planes cover the full circle and the rays the full
    /// half-turn of gamma, whatever the frame sees (the bins keep the casters' range).
    pub fn with_pruning(
        scene: &Scene,
        width: u32,
        height: u32,
        method: Method,
        prune: bool,
    ) -> Result<FrameSetup, FrameError> {
        let cam = &scene.camera;
        let aspect = width as f64 / height as f64;
        let frame =
            EpipolarFrame::new(cam.eye.as_dvec3(), LightGeom::from(&scene.light)).ok_or(FrameError::EyeOnLight)?;
        let bounds: Aabb = scene.bounds();
        let mut mapping = GridMapping::fit(&frame, cam, aspect, &bounds, scene.grid);
        if !prune {
            mapping.phi0 = 0.0;
            mapping.phi_span = std::f64::consts::TAU;
            mapping.phi_wraps = true;
            mapping.gamma_lo = 0.0;
            mapping.gamma_hi = std::f64::consts::PI;
        }
        let [r, u, f] = cam.basis_f64();
        let mut cartesian_axis = 0u32;
        if method == Method::Cartesian {
            let LightGeom::Directional(w) = frame.light else { return Err(FrameError::NotDirectional) };
            let axes = [
                (glam::DVec3::from(r), "+x (right)"),
                (-glam::DVec3::from(r), "-x (left)"),
                (glam::DVec3::from(u), "+y (up)"),
                (-glam::DVec3::from(u), "-y (down)"),
            ];
            let (best, off) = (0..4)
                .map(|i| (i, crate::epipolar::angle_between(axes[i].0, w)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap_or((0, std::f64::consts::PI));
            if off.to_degrees() > CARTESIAN_TOLERANCE_DEG {
                let s = axes[best].0;
                return Err(FrameError::NotAxisAligned {
                    off_deg: off.to_degrees(),
                    name: axes[best].1,
                    suggest: format!("{:.6},{:.6},{:.6}", s.x, s.y, s.z),
                });
            }
            cartesian_axis = best as u32;
            // Bins: view depth over the casters' extent in front of the eye.
            let fwd = glam::DVec3::from(f);
            let c = bounds.center().as_dvec3() - frame.eye;
            let rho = bounds.radius() as f64 * 1.001;
            let depth = c.dot(fwd);
            mapping.z_lo = (depth - rho).max(cam.near as f64);
            mapping.z_hi = (depth + rho).max(mapping.z_lo * 1.001 + 1e-9);
            mapping.spacing = BinSpacing::UniformAngle;
        }
        let th = (cam.fov_y_deg.to_radians() * 0.5).tan();
        let tw = th * aspect as f32;
        let v3 = |a: [f64; 3], w: f32| Vec4::new(a[0] as f32, a[1] as f32, a[2] as f32, w);
        let (light, power) = match scene.light {
            Light::Point { position, intensity, radius } => (position.extend(1.0), intensity.extend(radius)),
            Light::Directional { direction, irradiance } => {
                (direction.normalize_or(glam::Vec3::Y).extend(0.0), irradiance.extend(0.0))
            }
        };
        let mut flags = 0;
        if mapping.phi_wraps {
            flags |= FLAG_PHI_WRAPS;
        }
        if !scene.needs_scattering() {
            flags |= FLAG_NO_SCATTER;
        }
        let mb = scene.medium_bounds();
        let m = &scene.medium;
        let dist = if frame.dist.is_finite() { frame.dist as f32 } else { 0.0 };
        let uniforms = FrameUniforms {
            cam_right: v3(r, tw),
            cam_up: v3(u, th),
            cam_fwd: v3(f, cam.near),
            eye: cam.eye.extend(cam.far),
            view_proj: cam.view_proj(aspect as f32),
            light,
            light_power: power,
            axis: frame.axis.as_vec3().extend(dist),
            b1: frame.b1.as_vec3().extend(mapping.phi0 as f32),
            b2: frame.b2.as_vec3().extend(mapping.phi_span as f32),
            sigma_s: m.sigma_s().extend(m.phase.g()),
            sigma_t: m.sigma_t().extend(0.0),
            ranges: Vec4::new(
                mapping.gamma_lo as f32,
                mapping.gamma_hi as f32,
                mapping.z_lo as f32,
                mapping.z_hi as f32,
            ),
            medium_min: mb.min.extend(0.0),
            medium_max: mb.max.extend(0.0),
            grid: UVec4::new(scene.grid.planes, scene.grid.rays, scene.grid.bins, scene.grid.words()),
            image: UVec4::new(width, height, 0, flags),
            table: UVec4::new(TABLE_ROWS, TABLE_COLS, cartesian_axis, 0),
            work: UVec4::new(1, 1, 0, 0),
            epipole: epipole(frame.axis, cam, width, height),
        };
        Ok(FrameSetup { uniforms, frame, mapping, width, height, method })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Light;

    /// The epipole is where the ray through that (fractional) pixel position is the axis toward
    /// the light, to f64's precision; its fraction lies in [0, 1); a light behind the eye has none.
    #[test]
    fn the_epipole_is_the_pixel_whose_ray_is_the_axis() {
        let mut scene = crate::scene::builtin_scene();
        let cam = scene.camera;
        let (w, h) = (640u32, 360u32);
        for (px, py) in [(100.3, 200.7), (0.0, 0.0), (639.999, 5.25), (-50.5, 400.0)] {
            let toward = cam.pixel_dir_f64(px, py, w, h);
            scene.light = Light::Point {
                position: (cam.eye.as_dvec3() + toward * 3.0).as_vec3(),
                intensity: glam::Vec3::ONE,
                radius: 0.0,
            };
            let setup = FrameSetup::new(&scene, w, h, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
            let e = setup.uniforms.epipole;
            assert!((0.0..1.0).contains(&e.z) && (0.0..1.0).contains(&e.w), "fraction {e}");
            let (x, y) = (e.x as f64 + e.z as f64, e.y as f64 + e.w as f64);
            // The light's f32 position limits the axis to ~1e-7 of 3 m: about 1e-4 pixel here.
            assert!((x - px).abs() < 1e-3 && (y - py).abs() < 1e-3, "({x}, {y}) for ({px}, {py})");
            let off = crate::epipolar::angle_between(cam.pixel_dir_f64(x, y, w, h), setup.frame.axis);
            assert!(off < 1e-9, "the ray through the epipole is {off:e} rad off the axis");
        }
        let behind = cam.eye.as_dvec3() - (cam.target - cam.eye).as_dvec3();
        scene.light = Light::Point { position: behind.as_vec3(), intensity: glam::Vec3::ONE, radius: 0.0 };
        let setup = FrameSetup::new(&scene, w, h, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(setup.uniforms.epipole.x, NO_EPIPOLE);
    }
}

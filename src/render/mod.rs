//! The GPU renderer: one struct per pass, each owning its pipelines, layout and bind groups, and
//! [`Renderer::render_frame`], the frame as the ordered list of pass calls:
//!
//! ```text
//! ShadowMap -> Surface -> Ranges -> (Cull -> Voxelize per chunk of triangles) -> Scan
//!           -> ScatterTable (point light) -> Integrate -> Composite                     (VSV, Cartesian)
//! ShadowMap -> Surface -> Raymarch -> Composite                                          (the baseline)
//! ```
//!
//! Resources (targets, grid, geometry, shadow map) are created when their inputs change, and every
//! pass's bind groups with them ([`Renderer::rebind`]): a frame of an unchanged scene, size and
//! grid creates nothing. A frame whose only changes are the medium's coefficients, its phase
//! function's asymmetry or the light's power (an artist tuning the medium) runs no pass before
//! Integrate (or Raymarch) at all: the shadow map, the surfaces and the shadow volume are the
//! previous frame's, bit for bit ([`Renderer::reuse_unchanged`]).

mod composite;
mod cull;
mod exact_shadows;
mod frame;
mod hit_bounds;
mod integrate;
mod pass;
mod ranges;
mod raymarch;
mod scan;
mod scatter_table;
mod scene_gpu;
mod shadow_fit;
mod shadow_map;
mod shadow_pyramid;
mod surface;
pub(crate) mod util;
mod variant;
mod voxelize;

pub use composite::{Composite, CompositeBindings};
pub use cull::{Cull, CullBindings, CullCounts, CullLists};
pub use exact_shadows::{ExactInputs, ExactParams, ExactShadows, ExactShadowsBindings, ExactStats};
pub use frame::{FrameError, FrameSetup, FrameUniforms, Method, CARTESIAN_TOLERANCE_DEG, TABLE_COLS, TABLE_ROWS};
pub use hit_bounds::{HitBounds, HitBoundsBindings, WordBounds};
pub use integrate::{Integrate, IntegrateBindings, IntegrateInputs};
pub use pass::{Pass, PassTiming};
pub use ranges::{Ranges, RangesBindings};
pub use raymarch::{Raymarch, RaymarchBindings, RaymarchUniforms};
pub use scan::{Scan, ScanBindings};
pub use scatter_table::{ScatterTable, ScatterTableBindings};
pub use scene_gpu::SceneGpu;
pub use shadow_fit::{fit_key, FitKey, FitResult, ShadowFit, ShadowFitBindings};
pub use shadow_map::{
    FaceUniforms, MapDrawing, ShadowCullBindings, ShadowCullUniforms, ShadowMap, ShadowMapBindings, ShadowUniforms,
};
pub use shadow_pyramid::{DepthPyramid, EyeInputs, EyePyramid, MapInputs, ShadowPyramid, ShadowPyramidBindings};
pub use surface::{EyeDrawing, Surface, SurfaceBindings, SurfaceCullBindings, SurfaceTargets};
pub use variant::{Specialised, Variant, VariantPipelines};
pub use voxelize::{Voxelize, VoxelizeBindings, VoxelizeInputs};

use crate::epipolar::GridMapping;
use crate::gpu::{GpuContext, GpuError, GpuTimer, ShaderLibrary};
use crate::image::Image;
use crate::params::{Baseline, Grid};
use crate::scene::Scene;
use std::ops::Range;
use std::sync::Arc;
use util::texture_2d;
use wgpu::util::DeviceExt;

/// Why a frame could not be rendered.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(transparent)]
    Frame(#[from] FrameError),
}

/// What one frame produced.
#[derive(Debug, Clone)]
pub struct RenderOutput {
    /// Final linear radiance.
    pub hdr: Image,
    /// In-scattered radiance alone.
    pub scatter: Image,
    /// GPU time per pass (empty when the adapter has no encoder timestamps).
    pub timings: Vec<PassTiming>,
    /// The frame's fitted grid ranges.
    pub setup: FrameSetup,
    /// The passes that ran, in order.
    pub passes: Vec<Pass>,
    /// The passes whose results came from the previous frame ([`FrameInfo::reused`]).
    pub reused: Vec<Pass>,
    /// The shader variant the passes ran as.
    pub variant: Variant,
    /// Whether Integrate took pixels from their neighbours ([`FrameInfo::adaptive_pixels`]).
    pub adaptive_pixels: bool,
}

/// What one frame produced on the GPU side (timings and the fitted grid), without images.
#[derive(Debug, Clone)]
pub struct FrameInfo {
    pub timings: Vec<PassTiming>,
    pub setup: FrameSetup,
    /// The passes that ran, in order (also without timestamps).
    pub passes: Vec<Pass>,
    /// The passes whose results this frame took from the previous one instead of running them
    /// (nothing they read had changed: [`Renderer::reuse_unchanged`]); empty for a whole frame,
    /// the shadow map alone when only the camera (or something else the map does not read)
    /// changed.
    pub reused: Vec<Pass>,
    /// The shader variant the passes ran as.
    pub variant: Variant,
    /// Whether Integrate took the pixels between from their neighbours
    /// ([`Renderer::adaptive_pixels`], where the image's buffers fit the adapter); false when it
    /// integrated every pixel or did not run.
    pub adaptive_pixels: bool,
}

impl FrameInfo {
    /// Whether the frame took everything before the volume's integration from the frame before
    /// (a medium edit): it ran Integrate (or Raymarch) and Composite alone.
    pub fn reused_all_before_volume(&self) -> bool {
        self.reused.contains(&Pass::Surface)
    }
}

/// What fitting the work to the frame kept (DESIGN section 6), for `--json` and the Stats panel.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PruneReport {
    pub enabled: bool,
    /// Angular span of the planes around the eye-light axis, of 360 degrees.
    pub planes_span_deg: f64,
    /// gamma range of the rays, within [0, 180] degrees.
    pub rays_gamma_deg: [f64; 2],
    /// z range of the bins (psi in degrees for a point light, distance otherwise), after fitting
    /// to the visible depth, and the casters' range it was cut from.
    pub bins_z: [f64; 2],
    pub bins_z_casters: [f64; 2],
    /// 32-bit words per ray (the bins' precision is spent on `bins_z`).
    pub words_per_ray: u32,
    /// The share of the grid's (plane, ray) cells that Voxelize and Scan keep: those the
    /// frame's pixels read ([`GridMapping::plane_rays`]; 1 when that is off).
    pub plane_ray_cells: f64,
    pub triangles_total: u32,
    /// Kept and dropped triangles, and Voxelize's work items (zero when no voxel pass ran).
    pub triangles: CullCounts,
    /// The passes that ran.
    pub passes: Vec<Pass>,
    /// The passes whose results the frame took from the previous one ([`FrameInfo::reused`]).
    pub reused: Vec<Pass>,
    /// The shader variant they ran as (`point light, henyey-greenstein`): the light type and phase
    /// function are compiled into the pipelines rather than branched on per pixel.
    pub variant: String,
}

impl RenderOutput {
    /// The frame's description without the images.
    pub fn info(&self) -> FrameInfo {
        FrameInfo {
            timings: self.timings.clone(),
            setup: self.setup,
            passes: self.passes.clone(),
            reused: self.reused.clone(),
            variant: self.variant,
            adaptive_pixels: self.adaptive_pixels,
        }
    }

    pub fn total_ms(&self) -> f64 {
        self.timings.iter().map(|t| t.ms).sum()
    }
}

/// Everything the passes before Integrate (or Raymarch) read: the shadow map, the surfaces, Ranges,
/// Cull, Voxelize and Scan. Two frames with the same inputs make the same map, surfaces and shadow
/// volume, bit for bit, so the second takes them from the first.
///
/// The frame's uniforms are compared whole but for the fields only Integrate, the scatter table,
/// Raymarch and Composite read (the medium's coefficients, the phase function's asymmetry, the
/// light's power and softening radius: `tests/reuse.rs` changes each and checks the image against
/// a fresh renderer's); anything else the earlier passes depend on is in the uniforms, the shadow
/// map's uniforms or the fields below, and a change of resources or pipelines (a new size, grid,
/// shadow map, shader reload or variant) forgets the key altogether.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct FrameKey {
    /// The shadow map's inputs, which the later passes read too.
    map: MapKey,
    uniforms: [u8; std::mem::size_of::<FrameUniforms>()],
    method: Method,
    /// Whether the medium scatters at all: without it no voxel pass runs.
    scatters: bool,
    /// prune, keep_geometry, prune_plane_rays.
    switches: [bool; 3],
}

impl FrameKey {
    /// `faces` and `lookup`: the shadow map's uniforms for `scene` (`ShadowMap::uniforms`, which
    /// the caller has already computed: it walks every vertex).
    fn new(
        r: &Renderer,
        scene: &Scene,
        setup: &FrameSetup,
        faces: &[FaceUniforms; 6],
        lookup: &ShadowUniforms,
    ) -> FrameKey {
        let mut u = setup.uniforms;
        // What only the passes from Integrate on read (common.wgsl's Frame).
        u.light_power = glam::Vec4::ZERO;
        // Whether Surface's culling reads the eye's pyramid: the targets are the same either way,
        // and the frame after a view's first (the first to read it) may take them over.
        u.work.w = 0;
        u.sigma_s = glam::Vec4::ZERO;
        u.sigma_t = glam::Vec4::ZERO;
        FrameKey {
            map: MapKey {
                faces: bytemuck::cast(*faces),
                lookup: bytemuck::cast(*lookup),
                geometry: r.geometry.as_ref().map_or(0, |g| g.fingerprint),
                hidden: setup.uniforms.work.z,
                view: fit_key(r.fits_map(setup), &setup.uniforms),
                switches: [r.shadow_face_culling, r.back_face_culling, r.occlusion_culling, r.fits_map(setup)],
            },
            uniforms: bytemuck::cast(u),
            method: setup.method,
            scatters: scene.needs_scattering(),
            switches: [r.prune, r.keep_geometry, r.prune_plane_rays],
        }
    }
}

/// What a frame's per-plane ray cells ([`GridMapping::plane_rays`]) are computed from, and
/// whether they are pruned at all.
#[derive(Debug, Clone, Copy, PartialEq)]
struct PlaneRaysKey {
    mapping: GridMapping,
    frame: crate::epipolar::EpipolarFrame,
    camera: crate::scene::Camera,
    size: [u32; 2],
    pruned: bool,
}

/// Everything the shadow map is drawn from: the light's faces and lookup uniforms (the light, the
/// map's size and the casters' fit), the geometry, the draw list's culling (which also depends on
/// the pyramid of hidden triangles being ready), the culling switches and, for a map fitted to the
/// view ([`ShadowFit`]: a directional light), the view. Under a point light the camera is not among
/// them: a frame whose camera alone moved takes the map from the frame before (and so does every
/// frame that changes only what the passes after the map read). A change of resources or
/// pipelines forgets it with the rest (`FrameKey`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct MapKey {
    faces: [u8; std::mem::size_of::<[FaceUniforms; 6]>()],
    lookup: [u8; std::mem::size_of::<ShadowUniforms>()],
    geometry: u64,
    /// The coarsest pyramid level Cull and the map's list test hidden triangles at (0: none).
    hidden: u32,
    /// What the fitted map's rectangle depends on (zero where it is not fitted).
    view: FitKey,
    /// shadow_face_culling, back_face_culling, occlusion_culling, and whether the map is fitted.
    switches: [bool; 4],
}

/// Where a frame's surface shadows come from ([`Renderer::surface_shadows`]): the CLI's
/// `--surface-shadows`, the editor's toolbar and the renderer's switches read this one list.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, clap::ValueEnum)]
pub enum SurfaceShadows {
    /// The shadow volume itself (integrate.wgsl, "surface shadows"; VSV only): no shadow map is
    /// drawn, and the shadows are as sharp as the grid's bins.
    Grid,
    /// The shadow map, like the baseline's surfaces.
    Map,
    /// Under a sun, each surface point tested against the triangles (exact_shadows.wgsl): the
    /// reference's shadows, and a map drawn only in the first frame of a still light, scene and
    /// view. Point lights use the map. The default: on the classroom the whole image is half as
    /// far from the reference as with the map, for a frame 2-5% longer on llvmpipe
    /// (docs/results.md, session 45).
    #[default]
    Exact,
}

impl SurfaceShadows {
    /// In the order a menu offers them.
    pub const ALL: [SurfaceShadows; 3] = [SurfaceShadows::Map, SurfaceShadows::Grid, SurfaceShadows::Exact];

    /// The short name (the CLI's value, the toolbar's item).
    pub fn label(self) -> &'static str {
        match self {
            SurfaceShadows::Map => "map",
            SurfaceShadows::Grid => "grid",
            SurfaceShadows::Exact => "exact",
        }
    }

    /// What it means, for a tooltip.
    pub fn doc(self) -> &'static str {
        match self {
            SurfaceShadows::Map => {
                "The surfaces' shadows from the shadow map's filtered texels, like the ray-marching baseline's"
            }
            SurfaceShadows::Grid => {
                "The surfaces' shadows from VSV's shadow volume itself: no shadow map is drawn (faster on a GPU), and \
                 the shadows are as sharp as the grid's bins"
            }
            SurfaceShadows::Exact => {
                "The surfaces' shadows under a sun: each surface point tested against the triangles themselves: the \
                 reference's shadows, and no shadow map after the first frame (the default). A point light keeps the \
                 map"
            }
        }
    }
}

/// How VSV keeps its shadow volume ([`Renderer::shadow_volume`]): the CLI's `--volume` and the
/// renderer read this one list.
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default, clap::ValueEnum)]
pub enum ShadowVolume {
    /// The paper's voxels: every hit of a light ray sets the bit of the ray cell that holds its
    /// angle, and Scan's prefix OR along the rays makes the volume (`planes x rays x bins` bits).
    /// A point's shadow is its ray cell's: up to one cell toward the light.
    Bits,
    /// Each light ray's first hit, as its angle: a view ray's point is shadowed where its light
    /// ray met a triangle at a smaller angle, compared with the pixel's own (no ray cells, no
    /// scan; `planes x bins` keys, common.wgsl "The first-hit volume"). Epipolar VSV frames whose
    /// surfaces do not take their shadows from the grid; the others keep the bits. The default
    /// since session 47: at the default grid the classroom's scattered light is 0.74% off the
    /// reference (the bits at that grid 0.92%), and the as-accurate march 8.4x the frame's time
    /// on llvmpipe (docs/results.md).
    #[default]
    FirstHits,
}

impl ShadowVolume {
    /// In the order a menu offers them.
    pub const ALL: [ShadowVolume; 2] = [ShadowVolume::FirstHits, ShadowVolume::Bits];

    /// The short name (the CLI's value, the toolbar's item).
    pub fn label(self) -> &'static str {
        match self {
            ShadowVolume::Bits => "bits",
            ShadowVolume::FirstHits => "first-hits",
        }
    }

    /// What it means, for a tooltip.
    pub fn doc(self) -> &'static str {
        match self {
            ShadowVolume::Bits => {
                "The paper's voxels: a bit per plane, ray cell and bin, scanned along the light rays; a point takes \
                 its ray cell's shadow (up to one cell toward the light). The inspector's geometry layer shows \
                 every surface a light ray meets"
            }
            ShadowVolume::FirstHits => {
                "Each light ray's first hit, as its angle from the eye: a point is shadowed where its light ray met \
                 a triangle before it, compared as angles (no ray cells, no scan, a seventh of the bits' memory at \
                 the default grid). Grid surface shadows and the Cartesian grid keep the bits"
            }
        }
    }

    /// The volume's bytes for `grid`.
    pub fn bytes(self, grid: &Grid) -> u64 {
        match self {
            ShadowVolume::Bits => grid.bytes(),
            ShadowVolume::FirstHits => HitBounds::volume_bytes(grid),
        }
    }
}

/// What `prepare` gives the frame: its setup, the variant its passes run as, what the passes
/// before Integrate read (`FrameKey`) and the shadow map's face uniforms (`ShadowMap::uniforms`,
/// the first `face_count` of them drawn).
struct Prepared {
    setup: FrameSetup,
    variant: Variant,
    key: FrameKey,
    faces: [FaceUniforms; 6],
    face_count: usize,
}

/// Size-dependent targets.
struct Targets {
    width: u32,
    height: u32,
    material: wgpu::TextureView,
    /// Kept for [`Renderer::read_view_distances`].
    distance_texture: wgpu::Texture,
    distance: wgpu::TextureView,
    depth: wgpu::TextureView,
    /// The same depth as an array of one layer, for the eye's pyramid.
    depth_layers: wgpu::TextureView,
    scatter: wgpu::Texture,
    scatter_view: wgpu::TextureView,
    hdr: wgpu::Texture,
    hdr_view: wgpu::TextureView,
}

/// Every pass, created together so that a reload either replaces all of them or none.
struct Passes {
    surface: Surface,
    shadow_fit: ShadowFit,
    shadow_map: ShadowMap,
    exact_shadows: ExactShadows,
    ranges: Ranges,
    shadow_pyramid: ShadowPyramid,
    eye_pyramid: EyePyramid,
    cull: Cull,
    voxelize: Voxelize,
    scan: Scan,
    hit_bounds: HitBounds,
    scatter_table: ScatterTable,
    integrate: Integrate,
    raymarch: Raymarch,
    composite: Composite,
}

impl Passes {
    fn new(ctx: &GpuContext, lib: &ShaderLibrary, shadow_map_size: u32) -> Result<Passes, GpuError> {
        let d = &ctx.device;
        ctx.scoped("creating the pipelines", || -> Result<Passes, GpuError> {
            Ok(Passes {
                surface: Surface::new(d, lib)?,
                shadow_fit: ShadowFit::new(d, lib)?,
                shadow_map: ShadowMap::new(d, lib, shadow_map_size)?,
                exact_shadows: ExactShadows::new(d, lib)?,
                ranges: Ranges::new(d, lib)?,
                shadow_pyramid: ShadowPyramid::new(d, lib, "ShadowPyramid", false)?,
                eye_pyramid: EyePyramid::new(d, lib, "EyePyramid", true)?,
                cull: Cull::new(d, lib)?,
                voxelize: Voxelize::new(d, lib, ctx.info.device_type)?,
                scan: Scan::new(d, lib)?,
                hit_bounds: HitBounds::new(d, lib)?,
                scatter_table: ScatterTable::new(d, lib)?,
                integrate: Integrate::new(d, lib, ctx.info.device_type == wgpu::DeviceType::Cpu)?,
                raymarch: Raymarch::new(d, lib)?,
                composite: Composite::new(d, lib)?,
            })
        })?
    }

    /// Builds the pipelines specialised to `variant` that are not built yet, in every pass that
    /// depends on it. Cheap when they exist (a lookup per pass); a new light type or phase function
    /// costs one pipeline build per pass, once.
    fn prepare(&mut self, ctx: &GpuContext, variant: Variant) -> Result<(), GpuError> {
        let d = &ctx.device;
        ctx.scoped(&format!("creating the pipelines for a {variant}"), || {
            self.surface.prepare(d, variant);
            self.shadow_fit.prepare(d, variant);
            self.shadow_map.prepare(d, variant);
            self.exact_shadows.prepare(d, variant);
            self.ranges.prepare(d, variant);
            self.cull.prepare(d, variant);
            self.voxelize.prepare(d, variant);
            self.scatter_table.prepare(d, variant);
            self.integrate.prepare(d, variant);
            self.raymarch.prepare(d, variant);
            self.composite.prepare(d, variant);
        })
    }
}

/// The scene's geometry on the GPU and the fingerprint of the meshes it was uploaded from.
struct Geometry {
    gpu: SceneGpu,
    fingerprint: u64,
}

/// The frame being recorded: its encoder, the passes that ran and their timestamps.
struct FrameRecorder<'a> {
    enc: wgpu::CommandEncoder,
    timer: Option<&'a mut GpuTimer<Pass>>,
    ran: Vec<Pass>,
}

impl FrameRecorder<'_> {
    /// Marks the end of `pass`.
    fn mark(&mut self, pass: Pass) {
        self.ran.push(pass);
        if let Some(t) = self.timer.as_deref_mut() {
            t.mark(&mut self.enc, pass);
        }
    }
}

/// Owns the passes and the resources of the current scene, size and grid.
pub struct Renderer {
    pub ctx: GpuContext,
    passes: Passes,
    /// Fit the frame's work to what it needs (DESIGN section 6); `false` is `--no-prune`.
    pub prune: bool,
    /// Point lights: each cube face draws only the triangles that can reach it (on by default;
    /// off only to compare, `tests/shadow_faces.rs`).
    pub shadow_face_culling: bool,
    /// Solids (closed meshes, `crate::scene::solid`) seen from outside draw and voxelize only
    /// their faces toward the eye or the light (on by default; off only to compare,
    /// `tests/solids.rs`).
    pub back_face_culling: bool,
    /// Surface leaves out the triangles that would draw nothing (they cover no pixel centre, or
    /// they are solids' faces turned away from the eye) and draws the others in their order,
    /// skipping the left-out ones' vertex work and primitive assembly (on by default; the targets
    /// are the same either way, off only to compare, `tests/surface_cull.rs`).
    pub surface_culling: bool,
    /// Scan the grid's columns (a plane's four words of bins each) with a workgroup per plane
    /// instead of one thread per column (`scan_columns.wgsl`; grids whose rays start on four
    /// words): the same bits. On by default on hardware GPUs, where one thread per column leaves
    /// most of the chip idle (on an H200 the paper's grid's Scan 0.50 -> 0.05 ms, the default
    /// grid's 0.20 -> 0.12 ms from session 25's workgroup per plane, docs/results.md); off on CPU
    /// adapters (llvmpipe), whose few threads are all busy either way and where it reads the grid
    /// twice (classroom frame 261-285 -> 353-398 ms). `--scan threads|columns` overrides it.
    pub scan_columns: bool,
    /// Directional lights: Cull drops the triangles the shadow map shows behind nearer surfaces
    /// all around them ([`ShadowPyramid`]; on by default, part of pruning: off with `prune`, and
    /// on its own only to compare, `tests/occlusion.rs`). It reads the pyramid of an earlier frame
    /// whose map had the same inputs (the light, the geometry, the map's size and the view the map
    /// is fitted to): the frame after a change runs without it and reduces its own map at its end.
    pub occlusion_culling: bool,
    /// Directional lights, with [`Renderer::occlusion_culling`]: Cull also tests each large
    /// triangle's planes in blocks of 64 against the same pyramid, trims the hidden blocks at either
    /// end of its range from its work and has Voxelize skip the others (cull.wgsl `hidden_blocks`;
    /// on the classroom a sixth of Voxelize's items, the shadow volume the same word for word). On
    /// by default; off only to compare, `tests/occlusion.rs`.
    pub hidden_blocks: bool,
    /// Surface leaves out the triangles behind the depth an earlier frame of the same view left
    /// at every pixel they cover ([`EyePyramid`], surface_cull.wgsl; needs
    /// [`Renderer::surface_culling`]). The targets are the same, bit for bit; a frame of a new
    /// view (camera, image size, geometry) runs without it and reduces its depth at the end of
    /// Surface for the frames after it. On by default; off only to compare, `tests/surface_cull.rs`.
    pub eye_occlusion_culling: bool,
    /// Directional lights: narrow the shadow map to the rectangle the frame's view segments cover
    /// ([`ShadowFit`]; on by default, off only to compare, `tests/shadow_fit.rs`). The camera then
    /// joins the map's inputs: a camera move draws the sun's map again.
    pub fit_shadow_map: bool,
    /// Directional lights, frames whose volume does not read the map (VSV's, the Cartesian
    /// grid's): draw the map at a width and height that make its texels about square over the
    /// rectangle it covers, for about as many texels as the budget's square
    /// ([`ShadowMap::wanted_dims`]). On by default; off only to compare.
    pub shape_shadow_map: bool,
    /// VSV frames clear only the grid's cells their passes write (each plane's kept ray cells,
    /// [`GridMapping::plane_rays`], neighbouring runs merged) instead of the whole grid. Where the
    /// adapter is a CPU a clear is a `memset` on one thread at memory speed (the classroom's
    /// 100 MB grid ~10 ms on a 2-core Xeon, its kept 61% of the cells ~7;
    /// docs/results.md, session 43); on a GPU every clear is a dispatch of its own, and a plane's
    /// worth of them would cost more than the whole grid's. On for CPU adapters.
    pub clear_kept_cells: bool,
    /// Where the surfaces' shadows come from (the default: [`SurfaceShadows::Exact`]).
    ///
    /// - [`SurfaceShadows::Exact`]: frames under a sun (VSV and Cartesian; the march keeps its
    ///   map) test the sun's shadow on each visible surface point against the triangles
    ///   themselves ([`ExactShadows`]): the surfaces' shadows of the reference's shadow rays, and
    ///   no map drawn but to make Cull's pyramid of hidden triangles, in the first frame of a still
    ///   light, scene and view (or a renderer's first frame): a frame of a moving sun draws none,
    ///   nor one of a moving camera while Cull has a pyramid of this light. Point lights keep the
    ///   cube map; so do scenes whose triangles or planes do not fit one storage binding
    ///   ([`SceneGpu::whole_triangles`], [`ExactShadows::fits`]). On the classroom the whole image
    ///   is 21% off the reference against the map's 45%, for a frame 2-5% longer on llvmpipe
    ///   (docs/results.md, session 45).
    /// - [`SurfaceShadows::Map`]: the shadow map's filtered texels, like the baseline's.
    /// - [`SurfaceShadows::Grid`]: VSV frames take them from the shadow volume (Integrate reads
    ///   them from the same bits: `integrate.wgsl`, "surface shadows") and draw no shadow map at
    ///   all: no fit, no map, no pyramid, so Cull skips its hidden-triangle test. The scattered
    ///   light is the same; the surfaces' shadows are as sharp as the grid's bins (the
    ///   classroom's whole image at 512x512 and the default grid: 60.9% relative RMSE against
    ///   the reference, where the 2048 map gives 50.8% and a 1024 map 78%; docs/results.md,
    ///   sessions 25 and 27): for a GPU that rasterizes on few units. A frame with nothing to
    ///   scatter has no shadow volume and uses the map.
    pub surface_shadows: SurfaceShadows,
    /// How VSV frames keep their shadow volume ([`ShadowVolume`]; the Cartesian grid's frames
    /// and those with grid surface shadows always keep bits).
    pub shadow_volume: ShadowVolume,
    /// The list capacity [`ExactShadows`] needs, grown when a frame's triangles overflowed it (0:
    /// none asked yet).
    exact_capacity: u32,
    /// The exact shadows' first list capacity in entries, instead of [`ExactShadows::first_capacity`]'s
    /// guess: for tests of the list's growth.
    pub exact_first_capacity: Option<u32>,
    /// Integrate every fourth pixel along the epipolar lines (the shafts run along them), then
    /// the pixels between, coarse to fine, from their two neighbours on the line where they lie
    /// on its surface and agree within 1% or lie on a straight stretch, and integrate only the
    /// rest ([`Integrate`], `integrate.wgsl`, "pixels from their neighbours"). On by default: on
    /// the classroom it integrates 43% of the pixels (Integrate ~30% faster on llvmpipe), and the
    /// scattered light's error against the reference is lower, not higher (0.992% -> 0.985%;
    /// docs/results.md, session 30). Off (`--pixels all`) integrates every pixel.
    pub adaptive_pixels: bool,
    /// Voxelize and Scan keep, per plane, only the ray cells its pixels read
    /// ([`GridMapping::plane_rays`]; part of pruning: off with `prune`, and on its own only to
    /// compare, `tests/pruning.rs`; frames with grid surface shadows ([`Renderer::surface_shadows`]) keep every cell).
    /// The image is the same to the bit; on the classroom 14% of the grid's non-zero words lay
    /// past a plane's last read cell and 23% before its first, where they now fold into one
    /// (docs/results.md, session 33).
    pub prune_plane_rays: bool,
    /// Voxelize keeps, per plane, no first hit past the farthest point its pixels' view rays reach
    /// (which Ranges takes from the depth: [`Ranges::reach`]; frames whose planes wrap round the
    /// circle keep every bin; part of pruning: off with `prune`, and on its own only to compare,
    /// `tests/pruning.rs`). The image is the same to the bit (docs/results.md, session 49).
    pub plane_reach: bool,
    /// Whether the last frame's map was fitted ([`Renderer::read_shadow_fit`]).
    last_fitted: bool,
    /// The fitted rectangle's aspect, from a frame's fit to the next frames' map
    /// ([`ShadowMap::dims`]), and the last one read (`None` before any: the casters' rectangle's).
    fit_readback: shadow_fit::AspectReadback,
    fit_aspect: Option<f32>,
    /// The inputs of this frame's shadow map when the frame is to reduce it into the pyramid
    /// for the frames after it (set by `prepare`).
    pyramid_to_build: Option<MapInputs>,
    /// The geometry, the sun's direction and the view a fitted map follows in the last prepared
    /// frame (`None` before any, or under a point light): how a frame under exact shadows tells a
    /// still sun, scene and camera from ones that change from frame to frame. (Not the pyramid's
    /// `MapInputs`: those hold the map's size too, which the first fit's aspect reshapes in a
    /// still view.)
    last_sun: Option<(u64, glam::Vec3, FitKey)>,
    /// The inputs of this frame's eye depth when Surface is to reduce it into the eye's pyramid
    /// for the frames after it (set by `prepare`).
    eye_pyramid_to_build: Option<EyeInputs>,
    /// Take the shadow map, the surfaces and the shadow volume from the previous frame when
    /// nothing they depend on changed (`FrameKey`): a frame that only changes the medium's
    /// coefficients, its phase asymmetry or the light's power runs Integrate (or Raymarch) and
    /// Composite alone. A frame whose changes leave the map's inputs alone (a camera move:
    /// `MapKey`) takes the map only. On by default; `epivox bench` turns it off to time whole
    /// frames.
    pub reuse_unchanged: bool,
    /// The inputs of the last frame that ran the passes before Integrate (or Raymarch) and
    /// completed, and which of them it ran; `None` after anything that may change their results
    /// without showing in the key: new resources or pipelines (whatever marks the bind groups
    /// stale: a new size, grid, geometry or shadow map, a shader reload), a new variant, a failed
    /// frame.
    drawn: Option<(FrameKey, Vec<Pass>)>,
    /// The library the passes were built from, kept to rebuild the shadow map at a new size.
    lib: ShaderLibrary,
    frame_buffer: wgpu::Buffer,
    shadow_uniforms: wgpu::Buffer,
    timer: Option<GpuTimer<Pass>>,
    geometry: Option<Geometry>,
    targets: Option<Targets>,
    /// The shadow volume's buffer: of the grid's bits or its first hits ([`ShadowVolume`]).
    grid: Option<(Grid, ShadowVolume, wgpu::Buffer)>,
    /// Per plane of the grid, the ray cells its pixels read ([`GridMapping::plane_rays`]), which
    /// bound Voxelize and Scan; made with the grid, written when what it is computed from
    /// changes: what it holds was computed from that key, and keeps that share of the cells
    /// ([`PruneReport::plane_ray_cells`]).
    plane_rays: Option<(wgpu::Buffer, Option<(PlaneRaysKey, f64)>)>,
    /// The grid's bytes that the cells in `plane_rays` take ([`kept_byte_ranges`]), which a frame
    /// clears when [`Renderer::clear_kept_cells`] is on.
    kept_bytes: Arc<[Range<u64>]>,
    /// The bytes the last frame that voxelized cleared and its passes wrote (Voxelize and Scan
    /// never leave the kept cells): [`Renderer::read_grid`] reads the rest as zero, what was left
    /// there by earlier frames is no part of this one.
    grid_written: Arc<[Range<u64>]>,
    /// A copy of the grid taken between voxelize and scan (the geometry voxels), kept only while
    /// [`Renderer::set_keep_geometry_grid`] asks for it (the editor's inspector).
    geometry_copy: Option<wgpu::Buffer>,
    keep_geometry: bool,
    /// The variant of the last frame: every pass holds its pipelines (a reload or a new shadow map
    /// builds them before replacing the old ones), so frames of the same variant build nothing.
    variant: Option<Variant>,
    /// A resource or the passes changed since the bind groups were made.
    stale_bindings: bool,
}

impl Renderer {
    /// A renderer with the default shadow map ([`Baseline`]'s), or the adapter's largest if smaller.
    pub fn new(ctx: GpuContext, lib: &ShaderLibrary) -> Result<Renderer, GpuError> {
        let shadow_map_size = Baseline::default().shadow_map.min(ctx.device.limits().max_texture_dimension_2d);
        let passes = Passes::new(&ctx, lib, shadow_map_size)?;
        // Read-only storage, not uniform buffers: lavapipe (Mesa's software Vulkan) compiles a new
        // variant of a shader for every distinct value of the uniforms that steer its control flow
        // (uniform inlining), 0.1-0.7 s per pass for every camera or light move; it never inlines
        // storage buffers. GPUs read both alike (docs/results.md, "The first frame").
        let uniform = |label: &str, size: usize, usage: wgpu::BufferUsages| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | usage,
                mapped_at_creation: false,
            })
        };
        let frame_buffer =
            uniform("Renderer::frame_uniforms", std::mem::size_of::<FrameUniforms>(), wgpu::BufferUsages::empty());
        // The pyramid keeps a copy of the matrix its map was drawn with (ShadowPyramid::record).
        let shadow_uniforms =
            uniform("Renderer::shadow_uniforms", std::mem::size_of::<ShadowUniforms>(), wgpu::BufferUsages::COPY_SRC);
        let timer = GpuTimer::new(&ctx);
        let fit_readback = shadow_fit::AspectReadback::new(&ctx.device);
        let scan_columns = ctx.info.device_type != wgpu::DeviceType::Cpu;
        let clear_kept_cells = ctx.info.device_type == wgpu::DeviceType::Cpu;
        Ok(Renderer {
            ctx,
            passes,
            prune: true,
            shadow_face_culling: true,
            back_face_culling: true,
            surface_culling: true,
            scan_columns,
            occlusion_culling: true,
            hidden_blocks: true,
            eye_occlusion_culling: true,
            fit_shadow_map: true,
            shape_shadow_map: true,
            clear_kept_cells,
            surface_shadows: SurfaceShadows::default(),
            shadow_volume: ShadowVolume::default(),
            exact_capacity: 0,
            exact_first_capacity: None,
            adaptive_pixels: true,
            prune_plane_rays: true,
            plane_reach: true,
            last_fitted: false,
            fit_readback,
            fit_aspect: None,
            pyramid_to_build: None,
            last_sun: None,
            eye_pyramid_to_build: None,
            reuse_unchanged: true,
            drawn: None,
            lib: lib.clone(),
            frame_buffer,
            shadow_uniforms,
            timer,
            geometry: None,
            targets: None,
            grid: None,
            plane_rays: None,
            kept_bytes: Arc::from([]),
            grid_written: Arc::from([]),
            geometry_copy: None,
            keep_geometry: false,
            variant: None,
            stale_bindings: true,
        })
    }

    /// Rebuilds every pipeline from `lib` (after a shader edit). On any error — WGSL that does not
    /// parse or validate, or a pipeline wgpu refuses — the old pipelines stay and keep rendering.
    pub fn reload(&mut self, lib: &ShaderLibrary) -> Result<(), GpuError> {
        let mut passes = Passes::new(&self.ctx, lib, self.passes.shadow_map.size)?;
        // The work list's shape set with set_voxelize_work survives the reload.
        passes.voxelize.items_per_thread = self.passes.voxelize.items_per_thread;
        passes.voxelize.words_per_item = self.passes.voxelize.words_per_item;
        // Build what the current picture needs now, so that a shader wgpu refuses for this variant
        // fails here, with the old pipelines still in place.
        if let Some(v) = self.variant {
            passes.prepare(&self.ctx, v)?;
        }
        self.passes = passes;
        self.lib = lib.clone();
        self.stale_bindings = true;
        Ok(())
    }

    /// The folder the shaders were loaded from (`None`: the ones built into the binary).
    pub fn shader_dir(&self) -> Option<&std::path::Path> {
        self.lib.dir()
    }

    /// Whether the last frame's geometry could have its cube faces culled (see
    /// [`Renderer::shadow_face_culling`]).
    pub fn shadow_face_lists(&self) -> bool {
        self.passes.shadow_map.has_face_lists()
    }

    /// Whether VSV's frames at the bound size take the adaptive pixels: [`Renderer::adaptive_pixels`],
    /// and the size's buffers fit the adapter (past its largest binding Integrate integrates every
    /// pixel). Frames report it ([`FrameInfo::adaptive_pixels`]).
    fn adaptive_pixels_in_use(&self) -> bool {
        self.adaptive_pixels && self.passes.integrate.adaptive_available()
    }

    /// The shadow map's budget: texels per side of a square ([`ShadowMap::size`]).
    pub fn shadow_map_size(&self) -> u32 {
        self.passes.shadow_map.size
    }

    /// Each shadow-map layer's width and height as the last frame drew it ([`ShadowMap::dims`]).
    pub fn shadow_map_dims(&self) -> (u32, u32) {
        self.passes.shadow_map.dims
    }

    /// Rebuilds the shadow map at `size` texels per side (the ray-marching baseline's quality knob;
    /// the surface pass uses it too). Refused, keeping the old map, when the adapter cannot hold it.
    pub fn set_shadow_map_size(&mut self, size: u32) -> Result<(), GpuError> {
        if size == self.passes.shadow_map.size {
            return Ok(());
        }
        self.ctx.check_texture("the shadow map", size, size)?;
        Baseline::SHADOW_MAP.check(size as f64).map_err(|e| GpuError::Validation {
            during: "setting the shadow-map size".into(),
            message: e.to_string(),
        })?;
        let map = self.ctx.scoped("creating the shadow map", || -> Result<ShadowMap, GpuError> {
            let mut map = ShadowMap::new(&self.ctx.device, &self.lib, size)?;
            if let Some(v) = self.variant {
                map.prepare(&self.ctx.device, v);
            }
            Ok(map)
        })??;
        self.passes.shadow_map = map;
        self.stale_bindings = true;
        Ok(())
    }

    /// The bins' z range the last frame used after fitting it to the visible depth (`None` when
    /// pruning was off or the method has no bins). Blocks on a 16-byte readback.
    pub fn pruned_z_range(&self) -> Result<Option<(f32, f32)>, GpuError> {
        if !self.prune {
            return Ok(None);
        }
        let bytes = self.ctx.read_buffer(&self.passes.ranges.result)?;
        let v: &[f32] = bytemuck::cast_slice(&bytes);
        Ok(Some((v[1], v[2])).filter(|(lo, hi)| hi > lo))
    }

    /// What pruning kept of the frame `info` describes (the last one). Blocks on two tiny readbacks.
    pub fn prune_report(&self, info: &FrameInfo) -> Result<PruneReport, GpuError> {
        let m = &info.setup.mapping;
        let point = info.setup.frame.is_point() && info.setup.method != Method::Cartesian;
        let z = |v: f64| if point { v.to_degrees() } else { v };
        // A frame that reused the last frame's shadow volume reports the Cull pass that made it.
        let voxels_ran = info.passes.contains(&Pass::Voxelize) || info.reused.contains(&Pass::Voxelize);
        let fitted = if voxels_ran { self.pruned_z_range()? } else { None };
        let bins = fitted.map(|(lo, hi)| [z(lo as f64), z(hi as f64)]).unwrap_or([z(m.z_lo), z(m.z_hi)]);
        Ok(PruneReport {
            enabled: self.prune,
            planes_span_deg: m.phi_span.to_degrees(),
            rays_gamma_deg: [m.gamma_lo.to_degrees(), m.gamma_hi.to_degrees()],
            bins_z: bins,
            bins_z_casters: [z(m.z_lo), z(m.z_hi)],
            words_per_ray: m.grid.words(),
            plane_ray_cells: self.plane_rays.as_ref().and_then(|(_, w)| *w).map_or(1.0, |(_, kept)| kept),
            triangles_total: self.geometry.as_ref().map_or(0, |g| g.gpu.triangle_count),
            triangles: if voxels_ran { self.cull_counts()? } else { CullCounts::default() },
            passes: info.passes.clone(),
            reused: info.reused.clone(),
            variant: info.variant.to_string(),
        })
    }

    /// What the last frame's Cull pass kept and dropped. Blocks on a 16-byte readback.
    pub fn cull_counts(&self) -> Result<CullCounts, GpuError> {
        let bytes = self.ctx.read_buffer(&self.passes.cull.counters)?;
        let v: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(CullCounts {
            kept: v[4],
            culled_depth: v[1],
            culled_view: v[2],
            culled_back: v[7],
            culled_hidden: v[8],
            items: v[5] as u64,
        })
    }

    /// The final linear image of the last frame (RGBA32Float), e.g. for an editor to display.
    pub fn hdr_texture(&self) -> Option<&wgpu::Texture> {
        self.targets.as_ref().map(|t| &t.hdr)
    }

    /// The in-scattered light of the last frame (RGBA32Float).
    pub fn scatter_texture(&self) -> Option<&wgpu::Texture> {
        self.targets.as_ref().map(|t| &t.scatter)
    }

    /// Uploads the scene's geometry. [`Renderer::render_frame`] does this by itself whenever the
    /// meshes differ from the last upload (a fingerprint of their content), so calling it is only
    /// a way to pay for the upload ahead of the frame.
    pub fn set_scene(&mut self, scene: &Scene) {
        let gpu = SceneGpu::new(&self.ctx.device, scene, self.ctx.max_binding());
        self.geometry = Some(Geometry { gpu, fingerprint: scene.geometry_fingerprint() });
        self.stale_bindings = true;
    }

    fn ensure_geometry(&mut self, scene: &Scene) -> Result<(), GpuError> {
        if self.geometry.as_ref().is_some_and(|g| g.fingerprint == scene.geometry_fingerprint()) {
            return Ok(());
        }
        // The lists Cull fills (CullLists::BYTES_PER_TRIANGLE per triangle of a chunk): past the
        // adapter's largest buffer the scene cannot be voxelized at all.
        let n = scene.triangle_count() as u64;
        let per_chunk = self.ctx.max_binding() / SceneGpu::TRIANGLE_BYTES;
        self.ctx.check_buffer(
            &format!("the work lists of {n} triangles"),
            n.min(per_chunk) * CullLists::BYTES_PER_TRIANGLE,
            "use a scene with fewer triangles",
        )?;
        let during = match &scene.source {
            Some(path) => format!("uploading the {n} triangles of {}", path.display()),
            None => format!("uploading the {n} triangles of the scene"),
        };
        let ctx = self.ctx.clone();
        ctx.scoped(&during, || self.set_scene(scene))?;
        self.ctx.take_uncaptured(&during)
    }

    fn ensure_targets(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        if self.targets.as_ref().is_some_and(|t| t.width == width && t.height == height) {
            return Ok(());
        }
        self.ctx.check_texture("the image", width, height)?;
        let d = &self.ctx.device;
        use wgpu::TextureUsages as U;
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let target = |label, format, usage| texture_2d(d, label, width, height, 1, format, usage);
        let material =
            target("Renderer::surface_material", Surface::MATERIAL, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let distance = target(
            "Renderer::surface_distance",
            Surface::DISTANCE,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        // (TEXTURE_BINDING: the eye's pyramid reads it, as an array of one layer.)
        let depth = target("Renderer::depth", Surface::DEPTH, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let written = U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC;
        let scatter = target("Renderer::scatter", Integrate::OUTPUT, written);
        let hdr = target("Renderer::hdr", Composite::OUTPUT, written);
        self.targets = Some(Targets {
            width,
            height,
            material: view(&material),
            distance: view(&distance),
            distance_texture: distance,
            depth: view(&depth),
            depth_layers: depth.create_view(&wgpu::TextureViewDescriptor {
                label: Some("Renderer::depth_layers"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                ..Default::default()
            }),
            scatter_view: view(&scatter),
            scatter,
            hdr_view: view(&hdr),
            hdr,
        });
        self.stale_bindings = true;
        Ok(())
    }

    fn ensure_grid(&mut self, grid: Grid, volume: ShadowVolume) -> Result<(), GpuError> {
        if self.grid.as_ref().is_some_and(|(g, v, _)| *g == grid && *v == volume) {
            return Ok(());
        }
        let (what, fix) = match volume {
            ShadowVolume::Bits => (format!("the {grid} grid"), "use fewer planes, rays or bins"),
            ShadowVolume::FirstHits => (format!("the {grid} grid's first hits"), "use fewer planes or bins"),
        };
        self.ctx.check_buffer(&what, volume.bytes(&grid), fix)?;
        let bits = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(match volume {
                ShadowVolume::Bits => "Renderer::grid_bits",
                ShadowVolume::FirstHits => "Renderer::grid_first_hits",
            }),
            size: volume.bytes(&grid),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let plane_rays = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::plane_rays"),
            size: grid.planes as u64 * 8,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.grid_written = whole_range(bits.size());
        self.grid = Some((grid, volume, bits));
        self.plane_rays = Some((plane_rays, None));
        // (A new buffer is all zeros: nothing is left to hide.)
        self.geometry_copy = None;
        self.stale_bindings = true;
        Ok(())
    }

    /// Makes every pass's bind groups for the current resources (after any of them changed).
    fn rebind(&mut self) {
        let (Some(geometry), Some(t), Some((_, _, bits)), Some((plane_rays, _))) =
            (&self.geometry, &self.targets, &self.grid, &self.plane_rays)
        else {
            return;
        };
        let d = &self.ctx.device;
        let p = &mut self.passes;
        use wgpu::BindingResource as R;
        let frame = || self.frame_buffer.as_entire_binding();
        let shadow = || self.shadow_uniforms.as_entire_binding();
        p.shadow_pyramid.bind(d, &p.shadow_map.map_view, p.shadow_map.dims);
        let Some(pyramid) = &p.shadow_pyramid.pyramid else { return };
        p.shadow_map.bind(d, &geometry.gpu, pyramid);
        let shadow_map = R::TextureView(&p.shadow_map.map_view);
        p.eye_pyramid.bind(d, &t.depth_layers, (t.width, t.height));
        let Some(eye_pyramid) = &p.eye_pyramid.pyramid else { return };
        p.surface.bind(d, &self.frame_buffer, &geometry.gpu, eye_pyramid);
        p.shadow_fit.bind(d, &self.frame_buffer, &self.shadow_uniforms, &t.distance);
        let exact = ExactInputs {
            frame: &self.frame_buffer,
            shadow: &self.shadow_uniforms,
            distance: &t.distance,
            material: &t.material,
            pyramid,
        };
        p.exact_shadows.bind(d, &geometry.gpu, exact);
        p.ranges.bind(d, &self.frame_buffer, &t.distance);
        p.cull.bind(d, &self.frame_buffer, &geometry.gpu, &self.shadow_uniforms, pyramid);
        let voxelize =
            VoxelizeInputs { frame: &self.frame_buffer, grid: bits, plane_rays, reach: &p.ranges.reach, cull: &p.cull };
        p.voxelize.bind(d, &geometry.gpu, voxelize);
        let scan = ScanBindings {
            frame_in: frame(),
            grid: bits.as_entire_binding(),
            plane_rays: plane_rays.as_entire_binding(),
        };
        p.scan.bind(d, scan);
        p.hit_bounds.bind(d, HitBoundsBindings { frame_in: frame(), volume: bits.as_entire_binding() });
        p.scatter_table.bind(d, &self.frame_buffer);
        let integrate = IntegrateInputs {
            frame_in: frame(),
            grid: bits.as_entire_binding(),
            table: p.scatter_table.table.as_entire_binding(),
            distance: &t.distance,
            scatter_out: &t.scatter_view,
            material: &t.material,
            width: t.width,
            height: t.height,
        };
        p.integrate.bind(d, integrate);
        let march = p.raymarch.uniforms.clone();
        let raymarch = RaymarchBindings {
            frame_in: frame(),
            shadow_in: shadow(),
            shadow_map: shadow_map.clone(),
            distance: R::TextureView(&t.distance),
            scatter_out: R::TextureView(&t.scatter_view),
            march_in: march.as_entire_binding(),
        };
        p.raymarch.bind(d, raymarch);
        let samplers = p.composite.samplers.clone();
        let composite = CompositeBindings {
            frame_in: frame(),
            shadow_in: shadow(),
            shadow_map,
            shadow_sun: R::Sampler(&samplers[0]),
            shadow_cube: R::Sampler(&samplers[1]),
            material: R::TextureView(&t.material),
            distance: R::TextureView(&t.distance),
            scatter: R::TextureView(&t.scatter_view),
            hdr: R::TextureView(&t.hdr_view),
            // (Read only by exact-shadow frames; any buffer binds in the others.)
            exact_vis: p.exact_shadows.vis.as_ref().unwrap_or(&self.frame_buffer).as_entire_binding(),
        };
        p.composite.bind(d, composite);
        self.stale_bindings = false;
    }

    /// Everything a frame needs before its passes are recorded: resources, pipelines of the variant,
    /// bind groups and this frame's uniforms ([`Prepared`]).
    fn prepare(&mut self, scene: &Scene, width: u32, height: u32, method: Method) -> Result<Prepared, RenderError> {
        self.ensure_geometry(scene)?;
        self.ensure_targets(width, height)?;
        let volume = self.volume_of(scene, method);
        self.ensure_grid(scene.grid, volume)?;
        if self.keep_geometry && self.geometry_copy.as_ref().is_none_or(|c| c.size() != volume.bytes(&scene.grid)) {
            self.geometry_copy = Some(self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Renderer::geometry_copy"),
                size: volume.bytes(&scene.grid),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
        }
        let mut setup = FrameSetup::with_pruning(scene, width, height, method, self.prune)?;
        self.set_frame_flags(scene, &mut setup);
        // The map's texels square over the rectangle it covers: the last fit's (a view moves by
        // small steps), else the casters' (ShadowMap::dims).
        if let Some(aspect) = self.fit_readback.take(&self.ctx.device) {
            self.fit_aspect = Some(aspect);
        }
        let dims = self.map_dims(scene, method, self.fits_map(&setup), self.fit_aspect);
        if self.passes.shadow_map.set_dims(&self.ctx.device, dims) {
            self.stale_bindings = true;
        }
        if setup.exact_shadowed() {
            let triangles = self.geometry.as_ref().map_or(0, |g| g.gpu.triangle_count);
            let dims = ExactShadows::tile_dims(self.fit_aspect.unwrap_or(1.0));
            let pixels = width as u64 * height as u64;
            if self.exact_capacity == 0 {
                self.exact_capacity = self
                    .exact_first_capacity
                    .unwrap_or_else(|| ExactShadows::first_capacity(triangles, dims, self.ctx.max_binding()));
            }
            if self.passes.exact_shadows.ensure(&self.ctx.device, triangles, pixels, dims, self.exact_capacity) {
                self.stale_bindings = true;
            }
        }
        let variant = self.frame_variant(&setup, &scene.medium.phase);
        // Every pass holds `self.variant`'s pipelines (reload and set_shadow_map_size keep it so):
        // only a new light type, phase function or work list builds, and checks, anything.
        if self.variant != Some(variant) {
            self.passes.prepare(&self.ctx, variant)?;
            self.variant = Some(variant);
            self.drawn = None;
        }
        if self.stale_bindings {
            // New resources: nothing drawn into the old ones carries over.
            self.drawn = None;
            let ctx = self.ctx.clone();
            ctx.scoped("binding the passes", || self.rebind())?;
        }
        let (faces, shadow_lookup, face_count) = self.passes.shadow_map.uniforms(scene);
        let (work, build, eye_build) = self.frame_work(&setup, &shadow_lookup);
        setup.uniforms.work = work;
        // Under exact shadows the map is drawn only for Cull's pyramid, which serves the frames
        // after this one in the same light. Where the light or the casters changed since the last
        // frame (a light dragged, a scene edited), or only the view while Cull has a pyramid of
        // this light (an orbit: Cull projects with the matrix of the view it was made in), the
        // next frame is likely to change them again: no map and no pyramid then. The frame culls
        // as it would anyway (with no pyramid in a new light). The first frame of a still light,
        // scene and view makes it.
        let sun = match (&scene.light, &self.geometry) {
            (crate::params::Light::Directional { direction, .. }, Some(g)) => {
                Some((g.fingerprint, *direction, fit_key(self.fits_map(&setup), &setup.uniforms)))
            }
            _ => None,
        };
        let moving = setup.exact_shadowed()
            && match (&self.last_sun, &sun) {
                (Some((g0, d0, v0)), Some((g1, d1, v1))) => (g0, d0) != (g1, d1) || (v0 != v1 && work.z > 0),
                _ => false,
            };
        self.pyramid_to_build = build.filter(|_| !moving);
        self.last_sun = sun;
        self.eye_pyramid_to_build = eye_build;
        self.ctx.queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&setup.uniforms));
        self.ctx.queue.write_buffer(&self.shadow_uniforms, 0, bytemuck::bytes_of(&shadow_lookup));
        self.write_plane_rays(scene, &setup);
        let key = FrameKey::new(self, scene, &setup, &faces, &shadow_lookup);
        Ok(Prepared { setup, variant, key, faces, face_count })
    }

    /// Writes the frame's per-plane ray cells ([`GridMapping::plane_rays`]) unless the buffer
    /// holds them: a VSV frame's with pruning, every cell otherwise (the Cartesian grid's rows,
    /// `--no-prune`, surface shadows from the grid).
    fn write_plane_rays(&mut self, scene: &Scene, setup: &FrameSetup) {
        let Some((buffer, written)) = &mut self.plane_rays else { return };
        let key = PlaneRaysKey {
            mapping: setup.mapping,
            frame: setup.frame,
            camera: scene.camera,
            size: [setup.width, setup.height],
            // The grid's surface shadows read cells around each surface point's reach, which
            // moves away from the pixel's own cell with the surface's slope to the light
            // (integrate.wgsl, `sample_lit`): their frames keep every cell.
            pruned: self.prune && self.prune_plane_rays && setup.method == Method::Vsv && !setup.grid_shadowed(),
        };
        if written.is_some_and(|(k, _)| k == key) {
            return;
        }
        let grid = setup.mapping.grid;
        let cells = if key.pruned {
            let aspect = setup.width as f64 / setup.height as f64;
            setup.mapping.plane_rays(&setup.frame, &scene.camera, aspect)
        } else {
            vec![[0, grid.rays]; grid.planes as usize]
        };
        self.ctx.queue.write_buffer(buffer, 0, bytemuck::cast_slice(&cells));
        self.kept_bytes = kept_byte_ranges(&grid, &cells).into();
        let kept: u64 = cells.iter().map(|c| u64::from(c[1] - c[0])).sum();
        *written = Some((key, kept as f64 / (grid.planes as f64 * grid.rays as f64)));
    }

    /// The frame's `work` uniforms (Voxelize's list shape, the coarsest pyramid level Cull reads
    /// and the coarsest eye-pyramid level Surface's culling reads, 0 for none) and, when the frame
    /// is to reduce its shadow map or its eye's depth into a pyramid, their inputs.
    ///
    /// The test of hidden triangles (a directional light's map, pruning on) reads the pyramid a
    /// frame with the same casters and light left, whatever view its map was fitted to: the frame
    /// after the light or the geometry changed runs without it, and every frame whose map's inputs
    /// changed reduces its map at its end, when the map is long drawn (reading it before Cull
    /// would make the frame wait for its rasterization). Cull and the map's own list (every
    /// method's; only from a pyramid of the same matrix) leave the hidden triangles out.
    fn frame_work(
        &self,
        setup: &FrameSetup,
        shadow: &ShadowUniforms,
    ) -> (glam::UVec4, Option<MapInputs>, Option<EyeInputs>) {
        // (A frame that draws no map has no pyramid to make.)
        let occlusion = self.prune && self.occlusion_culling && !setup.frame.is_point() && !setup.grid_shadowed();
        let key = match (&self.geometry, occlusion) {
            (Some(g), true) => Some(MapInputs::new(
                g.fingerprint,
                shadow,
                fit_key(self.fits_map(setup), &setup.uniforms),
                self.back_face_culling,
            )),
            _ => None,
        };
        let pyramid = &self.passes.shadow_pyramid;
        // A pyramid of the same casters in the same light serves whatever view its map was fitted
        // to (Cull projects with the matrix it holds; the map's list only reads one of this very
        // matrix); one made from other inputs in any way is made anew at this frame's end.
        let usable = matches!((&pyramid.built_from, &key), (Some(b), Some(k)) if b.same_but_view(k));
        let levels = if usable { pyramid.bound_coarsest() } else { 0 };
        let v = &self.passes.voxelize;
        let build = if pyramid.built_from == key { None } else { key };
        // The eye's: only from a frame of this very view (EyeInputs), made at the end of Surface
        // in a frame of any other.
        let eye_key = match &self.geometry {
            Some(g) if self.surface_culling && self.eye_occlusion_culling => {
                Some(EyeInputs::new(&setup.uniforms, g.fingerprint, self.back_face_culling))
            }
            _ => None,
        };
        let eye = &self.passes.eye_pyramid;
        let eye_levels = if eye_key.is_some() && eye.built_from == eye_key { eye.bound_coarsest() } else { 0 };
        let eye_build = if eye.built_from == eye_key { None } else { eye_key };
        (glam::UVec4::new(v.run_for(&setup.mapping.grid), v.words_per_item, levels, eye_levels), build, eye_build)
    }

    /// The shader variant of a frame set up as `setup` ([`FrameSetup::variant`]), with this
    /// renderer's work list: whether each of Voxelize's items holds all of a ray's words.
    fn frame_variant(&self, setup: &FrameSetup, phase: &crate::params::Phase) -> Variant {
        let whole = self.passes.voxelize.words_per_item >= setup.mapping.grid.words();
        setup.variant(phase).with_whole_ray_items(whole)
    }

    /// Whether the frame's shadow map is fitted to its view ([`ShadowFit`]): a directional light,
    /// with [`Renderer::fit_shadow_map`] on.
    fn fits_map(&self, setup: &FrameSetup) -> bool {
        self.fit_shadow_map && !setup.frame.is_point() && !setup.grid_shadowed()
    }

    /// Marks a VSV frame that scatters to take its surface shadows from the shadow volume
    /// (grid surface shadows, [`Renderer::surface_shadows`]), and a frame whose Cull tests large triangles' blocks of planes
    /// ([`Renderer::hidden_blocks`]).
    fn set_frame_flags(&self, scene: &Scene, setup: &mut FrameSetup) {
        if self.surface_shadows == SurfaceShadows::Grid && setup.method == Method::Vsv && scene.needs_scattering() {
            setup.uniforms.image.w |= frame::FLAG_GRID_SHADOWS;
        }
        if self.hidden_blocks {
            setup.uniforms.image.w |= frame::FLAG_HIDDEN_BLOCKS;
        }
        // Scenes past one buffer of triangles, or of the test's planes, keep the map.
        let fits = self.geometry.as_ref().is_some_and(|g| {
            g.gpu.whole_triangles().is_some() && ExactShadows::fits(g.gpu.triangle_count, self.ctx.max_binding())
        });
        let voxels = setup.method == Method::Vsv && scene.needs_scattering();
        if voxels && self.volume_of(scene, setup.method) == ShadowVolume::FirstHits {
            setup.uniforms.image.w |= frame::FLAG_FIRST_HITS;
            // Ranges runs where the frame prunes, and takes the planes' reach there, where they do
            // not wrap round the circle (no epipole in the image: ranges.wgsl).
            let wraps = setup.uniforms.image.w & frame::FLAG_PHI_WRAPS != 0;
            if self.prune && self.plane_reach && !wraps {
                setup.uniforms.image.w |= frame::FLAG_PLANE_REACH;
            }
        }
        if self.surface_shadows == SurfaceShadows::Exact
            && fits
            && !setup.frame.is_point()
            && !setup.grid_shadowed()
            && matches!(setup.method, Method::Vsv | Method::Cartesian)
        {
            setup.uniforms.image.w |= frame::FLAG_EXACT_SHADOWS;
        }
    }

    /// The shadow volume's buffer a frame of `scene` with `method` binds: the bits for the
    /// Cartesian grid and for VSV with grid surface shadows (Integrate's surface test reads ray
    /// cells), else [`Renderer::shadow_volume`]'s (a frame with no volume to make, the march's or
    /// one with nothing to scatter, keeps it too, so that switching methods allocates nothing).
    fn volume_of(&self, scene: &Scene, method: Method) -> ShadowVolume {
        let grid_shadows =
            method == Method::Vsv && scene.needs_scattering() && self.surface_shadows == SurfaceShadows::Grid;
        if method == Method::Cartesian || grid_shadows {
            ShadowVolume::Bits
        } else {
            self.shadow_volume
        }
    }

    /// Whether a frame of `scene` at `width x height` with `method` would take the shadow map, the
    /// surfaces and the shadow volume from the last frame ([`Renderer::reuse_unchanged`]), decided
    /// without rendering or touching anything: the editor renders such a frame at full quality
    /// at once instead of a preview first.
    pub fn would_reuse(&self, scene: &Scene, width: u32, height: u32, method: Method) -> bool {
        let Some((drawn, _)) = &self.drawn else { return false };
        let fingerprint = scene.geometry_fingerprint();
        // Anything prepare would make anew (and then forget the last frame for).
        let same_resources = !self.stale_bindings
            && self.geometry.as_ref().is_some_and(|g| g.fingerprint == fingerprint)
            && self.targets.as_ref().is_some_and(|t| (t.width, t.height) == (width, height))
            && self.grid.as_ref().is_some_and(|(g, v, _)| *g == scene.grid && *v == self.volume_of(scene, method))
            && (!self.keep_geometry || self.geometry_copy.is_some());
        if !self.reuse_unchanged || !same_resources {
            return false;
        }
        let Ok(mut setup) = FrameSetup::with_pruning(scene, width, height, method, self.prune) else { return false };
        self.set_frame_flags(scene, &mut setup);
        if self.variant != Some(self.frame_variant(&setup, &scene.medium.phase)) {
            return false;
        }
        // A map to be remade in another shape (the last fit's aspect, maybe still on its way).
        let aspect = match self.fit_readback.peek(&self.ctx.device) {
            shadow_fit::AspectPeek::Pending => return false,
            shadow_fit::AspectPeek::Ready(a) => a.or(self.fit_aspect),
            shadow_fit::AspectPeek::Nothing => self.fit_aspect,
        };
        if self.map_dims(scene, method, self.fits_map(&setup), aspect) != self.passes.shadow_map.dims {
            return false;
        }
        let (faces, shadow, _) = self.passes.shadow_map.uniforms(scene);
        setup.uniforms.work = self.frame_work(&setup, &shadow).0;
        // (same_resources: the uploaded geometry is this scene's.)
        FrameKey::new(self, scene, &setup, &faces, &shadow) == *drawn
    }

    /// Renders one frame of `scene` at `width x height` into the GPU targets
    /// ([`Renderer::hdr_texture`], [`Renderer::scatter_texture`]) without reading the images back:
    /// what an interactive viewer calls every frame.
    pub fn render_frame(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        method: Method,
    ) -> Result<FrameInfo, RenderError> {
        let Prepared { setup, variant: v, key, faces, face_count } = self.prepare(scene, width, height, method)?;
        let fitted = self.fits_map(&setup);
        // Exact surface shadows need the map only to make Cull's pyramid of hidden triangles.
        let exact = setup.exact_shadowed();
        let draws_map = !setup.grid_shadowed() && (!exact || self.pyramid_to_build.is_some());
        // The passes before Integrate (or Raymarch) ran in the last frame with these inputs: their
        // results are still in the targets, the shadow map and the grid. Or only the map's inputs
        // are the same (the camera moved): the map is still in its texture.
        let drawn = self.drawn.take().filter(|_| self.reuse_unchanged);
        let reuse = drawn.as_ref().is_some_and(|(d, _)| *d == key);
        // (A frame that takes the surfaces over draws no depth to reduce.)
        let eye_build = self.eye_pyramid_to_build.take().filter(|_| !reuse);
        let map_reused = draws_map
            && !reuse
            && drawn.as_ref().is_some_and(|(d, ran)| d.map == key.map && ran.contains(&Pass::ShadowMap));
        let reused = match drawn {
            Some((_, ran)) if reuse => ran,
            // (A fitted map's fit is one of its inputs, taken over with it.)
            _ if map_reused && fitted => vec![Pass::ShadowFit, Pass::ShadowMap],
            _ if map_reused => vec![Pass::ShadowMap],
            _ => Vec::new(),
        };
        // Solids seen from outside are drawn and voxelized by their faces toward the viewpoint.
        let u = &setup.uniforms;
        let (eye, forward, near) = (u.eye.truncate(), u.cam_fwd.truncate(), u.cam_fwd.w);
        let near_corner = near * (1.0 + u.cam_right.w.powi(2) + u.cam_up.w.powi(2)).sqrt();
        let mut eye_runs = Vec::new();
        if let Some(g) = self.geometry.as_mut() {
            g.gpu.update_light_facing(&self.ctx.queue, &scene.light, self.back_face_culling);
            let eye_facing = g.gpu.eye_facing(eye, near_corner, self.back_face_culling);
            g.gpu.update_eye_sides(&self.ctx.queue, &eye_facing);
            eye_runs = g.gpu.draw_runs(&eye_facing);
            self.passes.surface.update_runs(&self.ctx.queue, &eye_runs);
        }
        let (Some(geometry), Some(t), Some((grid, _, bits))) = (&self.geometry, &self.targets, &self.grid) else {
            unreachable!("prepare made them")
        };
        let (p, queue, size) = (&self.passes, &self.ctx.queue, (width, height));
        let enc =
            self.ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("Renderer::frame") });
        let mut timer = self.timer.take();
        let mut f = FrameRecorder { enc, timer: timer.as_mut(), ran: Vec::new() };
        if let Some(t) = f.timer.as_deref_mut() {
            t.begin(&mut f.enc);
        }
        let g = &geometry.gpu;
        // The frame: an ordered list of passes.
        if !reuse {
            let ahead = 2.0 * near.max(1e-4);
            let eye_ccw = util::toward_is_ccw(u.view_proj, eye + forward * ahead, -forward * ahead);
            let drawing = MapDrawing {
                matrices: &faces[..face_count],
                faces: self.shadow_face_culling,
                hidden: u.work.z,
                light_facing: g.light_facing(),
                fit: fitted.then_some(&p.shadow_fit),
            };
            let targets = SurfaceTargets { material: &t.material, distance: &t.distance, depth: &t.depth };
            let eye = EyeDrawing { runs: &eye_runs, toward_ccw: eye_ccw, cull: self.surface_culling };
            p.surface.record(&mut f.enc, v, g, targets, eye);
            if eye_build.is_some() {
                p.eye_pyramid.record(&mut f.enc, None);
            }
            f.mark(Pass::Surface);
            // The map follows the view when it is fitted: never reused across a camera move (MapKey).
            // Exact shadows take their rectangle from the fit too.
            if fitted && (exact || draws_map && !map_reused) {
                p.shadow_fit.record(&mut f.enc, v, &self.shadow_uniforms, width, height);
                self.fit_readback.record(&mut f.enc, &p.shadow_fit);
                f.mark(Pass::ShadowFit);
            }
            if draws_map && !map_reused {
                p.shadow_map.record(queue, &mut f.enc, v, scene, g, drawing);
                p.surface.rebind_targets(&mut f.enc, &t.material, &t.distance);
                f.mark(Pass::ShadowMap);
            }
            if exact {
                let largest = g.largest_coordinate.max(scene.camera.eye.abs().max_element());
                p.exact_shadows.record(queue, &mut f.enc, v, (width, height), largest);
                f.mark(Pass::ExactShadows);
            }
        }
        if fitted && (reuse || map_reused) {
            // prepare wrote the casters' fit: the map in place was drawn with this frame's fit.
            p.shadow_fit.copy_lookup(&mut f.enc, &self.shadow_uniforms);
        }
        match method {
            Method::Raymarch { steps, jitter } => {
                p.raymarch.record(queue, &mut f.enc, v, size, steps, jitter);
                f.mark(Pass::Raymarch);
            }
            // Nothing scatters: no voxel pass has anything to compute; Integrate writes zeros.
            _ if !scene.needs_scattering() => {
                p.integrate.record(&mut f.enc, v, width, height, self.adaptive_pixels);
                f.mark(Pass::Integrate);
            }
            _ => {
                if reuse {
                    // The uniforms were written anew: the bins' range is the one the grid was made with.
                    if self.prune {
                        p.ranges.copy_range(&mut f.enc, &self.frame_buffer);
                    }
                } else {
                    if self.prune {
                        p.ranges.record(&mut f.enc, v, &self.frame_buffer, width, height);
                        f.mark(Pass::Ranges);
                    }
                    let first_hits = setup.first_hits();
                    if first_hits {
                        // The keys only: HitBounds writes every bound.
                        f.enc.clear_buffer(bits, 0, Some(HitBounds::key_bytes(grid)));
                        self.grid_written = whole_range(bits.size());
                    } else if self.clear_kept_cells {
                        for r in self.kept_bytes.iter() {
                            f.enc.clear_buffer(bits, r.start, Some(r.end - r.start));
                        }
                        self.grid_written = self.kept_bytes.clone();
                    } else {
                        f.enc.clear_buffer(bits, 0, None);
                        self.grid_written = whole_range(bits.size());
                    }
                    p.cull.begin_frame(&mut f.enc);
                    // Chunks of triangles (one unless the mesh is huge) share the Cull pass's lists.
                    for chunk in 0..p.cull.chunks() {
                        p.cull.record(&mut f.enc, v, chunk, setup.uniforms.work.x);
                        f.mark(Pass::Cull);
                        p.voxelize.record(&mut f.enc, v, chunk, &p.cull.dispatch);
                        f.mark(Pass::Voxelize);
                    }
                    if let (true, Some(copy)) = (self.keep_geometry, &self.geometry_copy) {
                        f.enc.copy_buffer_to_buffer(bits, 0, copy, 0, bits.size());
                    }
                    if first_hits {
                        p.hit_bounds.record(&mut f.enc, grid);
                        f.mark(Pass::HitBounds);
                    } else {
                        // (The frame's own grid: planes in x; Scan uses it on quad grids.)
                        let planes = self.scan_columns.then_some(setup.uniforms.grid.x);
                        p.scan.record(&mut f.enc, &p.cull.dispatch, Cull::SCAN_ARGS, v.quad_rays, planes);
                        f.mark(Pass::Scan);
                    }
                }
                if setup.frame.is_point() && method == Method::Vsv {
                    p.scatter_table.record(&mut f.enc, v);
                    f.mark(Pass::ScatterTable);
                }
                p.integrate.record(&mut f.enc, v, width, height, self.adaptive_pixels);
                f.mark(Pass::Integrate);
            }
        }
        p.composite.record(&mut f.enc, v, width, height);
        f.mark(Pass::Composite);
        // For the frames after this one, while its map's inputs stay the same.
        let build = self.pyramid_to_build.take();
        if build.is_some() {
            p.shadow_pyramid.record(&mut f.enc, Some((&self.shadow_uniforms, 0)));
            f.mark(Pass::ShadowPyramid);
        }
        let done = self.finish(f, setup, v, reused);
        self.timer = timer;
        self.last_fitted = fitted && done.is_ok();
        if let Ok(info) = &done {
            if build.is_some() {
                self.passes.shadow_pyramid.built_from = build;
            }
            if eye_build.is_some() {
                self.passes.eye_pyramid.built_from = eye_build;
            }
            let drawn = Pass::BEFORE_VOLUME
                .into_iter()
                .filter(|p| info.passes.contains(p) || info.reused.contains(p))
                .collect();
            self.drawn = Some((key, drawn));
        }
        // A list too short for this frame's triangles left some pixels lit: the frame again, with
        // room for them (the same inputs ask for the same entries).
        if exact && !reuse && done.is_ok() {
            if let Some(needed) = self.passes.exact_shadows.overflowed(&self.ctx)? {
                let entries = needed.saturating_mul(5) / 4;
                self.ctx.check_buffer(
                    "the exact shadows' list",
                    entries * ExactShadows::RECORDED_BYTES,
                    "use --surface-shadows map",
                )?;
                if entries > self.exact_capacity as u64 {
                    self.exact_capacity = entries.min(u32::MAX as u64) as u32;
                    self.drawn = None;
                    return self.render_frame(scene, width, height, method);
                }
            }
        }
        done
    }

    /// Submits the frame and reads its timestamps back.
    fn finish(
        &self,
        f: FrameRecorder,
        setup: FrameSetup,
        variant: Variant,
        reused: Vec<Pass>,
    ) -> Result<FrameInfo, RenderError> {
        let FrameRecorder { mut enc, timer, ran } = f;
        if let Some(t) = timer.as_deref() {
            t.resolve(&mut enc);
        }
        self.ctx.queue.submit([enc.finish()]);
        self.fit_readback.submitted();
        self.ctx.take_uncaptured("rendering the frame")?;
        let mut timings: Vec<PassTiming> = Vec::new();
        for (pass, ms) in timer.map(|t| t.read(&self.ctx)).transpose()?.unwrap_or_default() {
            // A pass that ran once per chunk is reported once, with the sum.
            match timings.iter_mut().find(|t| t.pass == pass) {
                Some(t) => t.ms += ms,
                None => timings.push(PassTiming { pass, ms }),
            }
        }
        let mut passes = ran;
        passes.dedup();
        let adaptive_pixels = passes.contains(&Pass::Integrate) && self.adaptive_pixels_in_use();
        Ok(FrameInfo { timings, setup, passes, reused, variant, adaptive_pixels })
    }

    /// Renders one frame and reads the final and the scattered image back to the CPU. A view's
    /// first frame under a sun draws its map shaped to the casters' rectangle, not yet to the
    /// rectangle it fits ([`ShadowMap::dims`]): when that frame's fit asks for another shape, the
    /// frame is rendered again with it, so that a one-off image has the map a second frame would.
    pub fn render(
        &mut self,
        scene: &Scene,
        width: u32,
        height: u32,
        method: Method,
    ) -> Result<RenderOutput, RenderError> {
        let mut info = self.render_frame(scene, width, height, method)?;
        if self.map_reshapes(scene, method) {
            info = self.render_frame(scene, width, height, method)?;
        }
        self.read_output(info)
    }

    /// Whether the last frame's fit (read back now, waiting for it) gives `scene`'s next frame a
    /// map of another shape.
    fn map_reshapes(&mut self, scene: &Scene, method: Method) -> bool {
        if !self.last_fitted {
            return false;
        }
        if self.fit_readback.in_flight() {
            // The frame's own timestamps were read with a wait; without them, wait here.
            let _ = self.ctx.wait();
        }
        if let Some(aspect) = self.fit_readback.take(&self.ctx.device) {
            self.fit_aspect = Some(aspect);
        }
        self.map_dims(scene, method, true, self.fit_aspect) != self.passes.shadow_map.dims
    }

    /// Whether `method`'s frames shape a sun's map to its rectangle ([`ShadowMap::wanted_dims`]):
    /// those whose volume does not read the map.
    fn shapes_map(&self, method: Method) -> bool {
        self.shape_shadow_map && !matches!(method, Method::Raymarch { .. })
    }

    /// The map's width and height for a frame of `scene` with `method` whose map is `fitted` or
    /// not, given the last fit's `aspect` (the casters' rectangle's where the map is not fitted or
    /// none was read): the one rule `prepare`, `render`'s second frame and `would_reuse` share.
    fn map_dims(&self, scene: &Scene, method: Method, fitted: bool, aspect: Option<f32>) -> (u32, u32) {
        let max_side = self.ctx.device.limits().max_texture_dimension_2d;
        let aspect = aspect.filter(|_| fitted);
        self.passes.shadow_map.wanted_dims(scene, self.shapes_map(method), aspect, max_side)
    }

    /// Reads back the final and the scattered image that the frame `info` (the last one
    /// [`Renderer::render_frame`] returned) left in the targets: what [`Renderer::render`] returns.
    pub fn read_output(&self, info: FrameInfo) -> Result<RenderOutput, RenderError> {
        let FrameInfo { timings, setup, passes, reused, variant, adaptive_pixels } = info;
        let (width, height) = (setup.width, setup.height);
        let t = self.targets.as_ref().ok_or_else(|| GpuError::Readback("no targets".into()))?;
        let to_image = |data: Vec<f32>| {
            let mut img = Image::new(width, height);
            for (p, c) in img.pixels.iter_mut().zip(data.chunks_exact(4)) {
                *p = [c[0], c[1], c[2]];
            }
            img
        };
        let hdr = to_image(self.ctx.read_texture_rgba32f(&t.hdr)?);
        let scatter = to_image(self.ctx.read_texture_rgba32f(&t.scatter)?);
        Ok(RenderOutput { hdr, scatter, timings, setup, passes, reused, variant, adaptive_pixels })
    }

    /// Where the last frame's view rays end: the distance along each pixel's unit view ray to the
    /// surface the rasterizer kept there (`f32::INFINITY` for the sky), rows top to bottom. Every
    /// GPU method ends its rays there; the reference's own first hits are
    /// [`crate::reference::ReferenceImage::depth`], and
    /// [`crate::reference::ViewEnds::Given`] integrates along these instead.
    pub fn read_view_distances(&self) -> Result<Vec<f32>, GpuError> {
        let t = self.targets.as_ref().ok_or_else(|| GpuError::Readback("no frame rendered yet".into()))?;
        // The surface pass writes the distance in the first channel, negative for the sky.
        Ok(self
            .ctx
            .read_texture_f32(&t.distance_texture, 2)?
            .chunks_exact(2)
            .map(|c| if c[0] >= 0.0 { c[0] } else { f32::INFINITY })
            .collect())
    }

    /// The last frame's fit of its directional shadow map ([`ShadowFit`]: the view-projection the
    /// map was drawn and looked up with, its texel size and its rectangle in the casters' map
    /// coordinates), or `None` when that frame's map was not fitted (a point light, or
    /// [`Renderer::fit_shadow_map`] off).
    pub fn read_shadow_fit(&self) -> Result<Option<FitResult>, GpuError> {
        if !self.last_fitted {
            return Ok(None);
        }
        let bytes = self.ctx.read_buffer(&self.passes.shadow_fit.result)?;
        Ok(Some(bytemuck::pod_read_unaligned(&bytes[..std::mem::size_of::<FitResult>()])))
    }

    /// The indices Surface drew in the last frame with [`Renderer::surface_culling`]: the scene's,
    /// in their order, without the triangles that would draw nothing (they cover no pixel centre,
    /// or they are a solid's faces the pipeline culls) (`None` when no list was made: no scene, or
    /// one too large for a storage binding), for tests.
    pub fn read_eye_list(&self) -> Result<Option<Vec<u32>>, GpuError> {
        let Some((list, blocks)) = self.passes.surface.eye_list() else { return Ok(None) };
        let blocks: Vec<u32> = bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(blocks)?);
        let mut list: Vec<u32> = bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(list)?);
        list.truncate(3 * blocks.last().copied().unwrap_or(0) as usize);
        Ok(Some(list))
    }

    /// The point light's scatter table as the last frame left it: `TABLE_ROWS x (TABLE_COLS + 1)`
    /// cumulative values of `G / (pi - gamma)` (RGB, then 0), row by row (scatter_table.wgsl), for
    /// tests.
    pub fn read_scatter_table(&self) -> Result<Vec<[f32; 4]>, GpuError> {
        Ok(bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(&self.passes.scatter_table.table)?))
    }

    /// Voxelize's work items per thread and 32-bit words of bins per item (each at least 1; the
    /// adapter's choice until set: [`Voxelize::items_per_thread`], [`Voxelize::words_per_item`];
    /// kept across [`Renderer::reload`]). Any values give the same grid; tests compare them.
    pub fn set_voxelize_work(&mut self, items_per_thread: u32, words_per_item: u32) {
        self.passes.voxelize.items_per_thread = items_per_thread.max(1);
        self.passes.voxelize.words_per_item = words_per_item.max(1);
    }

    /// Voxelize's work items per thread and words of bins per item ([`Renderer::set_voxelize_work`]).
    pub fn voxelize_work(&self) -> (u32, u32) {
        (self.passes.voxelize.items_per_thread, self.passes.voxelize.words_per_item)
    }

    /// What the last exact-shadow frame's test needed (`None` before any).
    pub fn read_exact_stats(&self) -> Result<Option<ExactStats>, GpuError> {
        self.passes.exact_shadows.read_stats(&self.ctx)
    }

    /// The shadow volume of the last frame, `planes x rays x words` words (plane-major: ray
    /// (`plane`, `ray`) starts at [`Grid::ray_offset`]), for the inspector and tests.
    /// A first-hit frame's volume reads as the layers it stands for
    /// ([`hit_bounds::first_hits_as_bits`]).
    pub fn read_grid(&self) -> Result<Vec<u32>, GpuError> {
        let (grid, volume, bits) =
            self.grid.as_ref().ok_or_else(|| GpuError::Readback("no frame rendered yet".into()))?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(bits)?);
        match volume {
            ShadowVolume::Bits => Ok(self.zero_unwritten(words)),
            ShadowVolume::FirstHits => self.first_hits_as_bits(&words, grid, false),
        }
    }

    /// The last frame's shadow volume as its buffer holds it, with its grid and form: the bits as
    /// they are (words no frame cleared read as whatever they held), or the first hits' keys and
    /// then their bounds ([`WordBounds::read`]). For tests of the passes' layouts.
    pub fn read_volume(&self) -> Result<(Grid, ShadowVolume, Vec<u32>), GpuError> {
        let (grid, volume, buffer) =
            self.grid.as_ref().ok_or_else(|| GpuError::Readback("no frame rendered yet".into()))?;
        Ok((*grid, *volume, bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(buffer)?)))
    }

    /// A first-hit volume's keys as the bits' layers, under the last frame's mapping.
    fn first_hits_as_bits(&self, keys: &[u32], grid: &Grid, geometry: bool) -> Result<Vec<u32>, GpuError> {
        let Some((_, Some((key, _)))) = &self.plane_rays else {
            return Err(GpuError::Readback("no frame rendered yet".into()));
        };
        Ok(hit_bounds::first_hits_as_bits(keys, grid, &key.mapping, geometry))
    }

    /// `words` (the grid or its geometry copy) with every word outside the last voxelizing frame's
    /// cleared cells set to zero: what a clear of the whole grid would have left there.
    fn zero_unwritten(&self, mut words: Vec<u32>) -> Vec<u32> {
        let len = words.len();
        let word = |byte: u64| ((byte / 4) as usize).min(len);
        // The ranges are in order and apart: zero each gap before one, then the tail.
        let mut from = 0;
        for r in self.grid_written.iter() {
            let (start, end) = (word(r.start), word(r.end));
            words[from.min(start)..start].fill(0);
            from = end;
        }
        words[from..].fill(0);
        words
    }

    /// Keep a copy of the geometry voxels (the grid before the scan) of every following frame, for
    /// [`Renderer::read_geometry_grid`]; off by default (it costs one grid copy per frame).
    pub fn set_keep_geometry_grid(&mut self, keep: bool) {
        self.keep_geometry = keep;
        if !keep {
            self.geometry_copy = None;
        }
    }

    /// The geometry voxels of the last frame (before the scan), laid out as [`Renderer::read_grid`]
    /// (of a first-hit frame, each light ray's first hit alone); needs
    /// [`Renderer::set_keep_geometry_grid`] before that frame.
    pub fn read_geometry_grid(&self) -> Result<Vec<u32>, GpuError> {
        let b = self.geometry_copy.as_ref().filter(|_| self.keep_geometry).ok_or_else(|| {
            GpuError::Readback("the geometry grid is not kept (Renderer::set_keep_geometry_grid)".into())
        })?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&self.ctx.read_buffer(b)?);
        match &self.grid {
            Some((grid, ShadowVolume::FirstHits, _)) => self.first_hits_as_bits(&words, grid, true),
            _ => Ok(self.zero_unwritten(words)),
        }
    }

    /// Uploads raw grid words (tests use it to check the scan in isolation).
    pub fn debug_upload_buffer(&self, data: &[u32]) -> wgpu::Buffer {
        self.ctx.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("Renderer::debug_upload"),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        })
    }
}

/// One range over all of a buffer's `bytes`.
fn whole_range(bytes: u64) -> Arc<[Range<u64>]> {
    std::iter::once(0..bytes).collect()
}

/// The grid's byte ranges that per-plane ray cells `cells` ([`GridMapping::plane_rays`]: plane
/// `p` keeps cells `cells[p][0]..cells[p][1]`) take in its plane-major layout
/// ([`Grid::ray_offset`]), in order, with runs that touch merged into one.
fn kept_byte_ranges(grid: &Grid, cells: &[[u32; 2]]) -> Vec<Range<u64>> {
    let mut ranges: Vec<Range<u64>> = Vec::new();
    for (plane, c) in cells.iter().enumerate() {
        if c[1] <= c[0] {
            continue;
        }
        let start = grid.ray_offset(plane as u32, c[0]) as u64 * 4;
        let end = grid.ray_offset(plane as u32, c[1]) as u64 * 4;
        match ranges.last_mut() {
            Some(last) if last.end == start => last.end = end,
            _ => ranges.push(start..end),
        }
    }
    ranges
}

#[cfg(test)]
mod kept_byte_ranges_tests {
    use super::*;

    #[test]
    fn ranges_follow_the_plane_major_layout_and_merge_where_they_touch() {
        let grid = Grid { planes: 4, rays: 8, bins: 64, ..Grid::default() };
        // A ray is two words of four bytes. Plane 0 keeps its last cells and plane 1 its first:
        // one run across the boundary. Plane 2 keeps none; plane 3 keeps cells 2..5.
        let ray = 2 * 4;
        let cells = [[5, 8], [0, 3], [4, 4], [2, 5]];
        let r = kept_byte_ranges(&grid, &cells);
        assert_eq!(r, vec![5 * ray..11 * ray, (3 * 8 + 2) * ray..(3 * 8 + 5) * ray]);
        let all = kept_byte_ranges(&grid, &[[0, 8]; 4]);
        assert_eq!(all, vec![0..grid.bytes()]);
        assert!(kept_byte_ranges(&grid, &[[0, 0]; 4]).is_empty());
    }
}

#[cfg(test)]
mod layout_tests {
    //! The Rust mirrors of the WGSL uniform structs must match byte for byte: naga computes the
    //! WGSL layout, `offset_of!` the Rust one.
    use super::*;
    use std::mem::{offset_of, size_of};

    fn wgsl_struct(file: &str, name: &str) -> (Vec<(String, u32)>, u32) {
        let (module, _) = ShaderLibrary::embedded().validate(file).unwrap_or_else(|e| panic!("{e}"));
        for (_, ty) in module.types.iter() {
            if ty.name.as_deref() == Some(name) {
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    return (members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect(), *span);
                }
            }
        }
        panic!("struct {name} not found in {file}");
    }

    fn check(file: &str, name: &str, rust: &[(&str, usize)], size: usize) {
        let (members, span) = wgsl_struct(file, name);
        let wgsl: Vec<(String, u32)> = members;
        let rust: Vec<(String, u32)> = rust.iter().map(|(n, o)| (n.to_string(), *o as u32)).collect();
        assert_eq!(wgsl, rust, "{name}: WGSL members (left) differ from Rust (right)");
        assert_eq!(span as usize, size, "{name}: WGSL size {span} != Rust size {size}");
    }

    macro_rules! fields {
        ($t:ty: $($f:ident),*) => { &[$((stringify!($f), offset_of!($t, $f))),*] };
    }

    #[test]
    fn frame_uniforms_match_wgsl() {
        check(
            "scan.wgsl",
            "Frame",
            fields!(FrameUniforms: cam_right, cam_up, cam_fwd, eye, view_proj, light, light_power, axis, b1, b2,
                sigma_s, sigma_t, ranges, medium_min, medium_max, grid, image, table, work, epipole),
            size_of::<FrameUniforms>(),
        );
    }

    /// The value of `const name: u32` in `file`.
    fn wgsl_u32(file: &str, name: &str) -> u32 {
        let (module, _) = ShaderLibrary::embedded().validate(file).unwrap_or_else(|e| panic!("{e}"));
        let (_, c) = module
            .constants
            .iter()
            .find(|(_, c)| c.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("const {name} not found in {file}"));
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => v,
            ref e => panic!("const {name} in {file} is not a u32 literal: {e:?}"),
        }
    }

    /// Constants the Rust side sizes dispatches and buffers by.
    #[test]
    fn dispatch_constants_match_wgsl() {
        assert_eq!(wgsl_u32("ranges.wgsl", "ROWS"), Ranges::ROWS);
        assert_eq!(wgsl_u32("ranges.wgsl", "REACH_GROUP") as u64, Ranges::REACH_GROUP);
        assert_eq!(wgsl_u32("ranges.wgsl", "REACH_PLANES_AT") as u64, Ranges::REACH_PLANES_AT);
        assert_eq!(wgsl_u32("shadow_fit.wgsl", "ROWS"), ShadowFit::ROWS);
        assert_eq!(wgsl_u32("cull.wgsl", "BLOCK"), Cull::BLOCK);
        assert_eq!(wgsl_u32("cull.wgsl", "PYRAMID_FIRST_LEVEL"), ShadowPyramid::FIRST_LEVEL);
        assert_eq!(wgsl_u32("cull.wgsl", "PYRAMID_MATRIX_FLOATS"), ShadowPyramid::MATRIX_FLOATS);
        assert_eq!(wgsl_u32("surface_cull.wgsl", "BLOCK"), Surface::CULL_BLOCK);
        assert_eq!(wgsl_u32("exact_shadows.wgsl", "BLOCK"), ExactShadows::BLOCK);
    }

    #[test]
    fn shadow_uniforms_match_wgsl() {
        check(
            "shadow_fit.wgsl",
            "Fit",
            fields!(FitResult: extremes, view_proj, texel, aspect, rect),
            size_of::<FitResult>(),
        );
        check("shadow_map.wgsl", "Face", fields!(FaceUniforms: view_proj, light, origin), size_of::<FaceUniforms>());
        check(
            "shadow_pyramid.wgsl",
            "Level",
            fields!(shadow_pyramid::Level: src_size, dst_size, src_offset, dst_offset),
            size_of::<shadow_pyramid::Level>(),
        );
        check(
            "shadow_cull.wgsl",
            "ShadowCull",
            fields!(ShadowCullUniforms: light, counts, view_proj, map_size),
            size_of::<ShadowCullUniforms>(),
        );
        check(
            "exact_shadows.wgsl",
            "ExactParams",
            fields!(ExactParams: tiles, eps, rounding),
            size_of::<ExactParams>(),
        );
        check(
            "composite.wgsl",
            "ShadowFaces",
            fields!(ShadowUniforms: view_proj, params, origin, size),
            size_of::<ShadowUniforms>(),
        );
    }
}

#[cfg(test)]
mod binding_tests {
    //! Each pass declares its bind group once (`util::bindings!`): here naga checks that binding i
    //! of the WGSL is the variable of that name and kind, so the Rust list, the layout built from
    //! it and the shader cannot drift apart.
    use super::util::Kind;
    use super::*;

    fn check(file: &str, slots: &[(&str, Kind)]) {
        let (module, _) = ShaderLibrary::embedded().validate(file).unwrap_or_else(|e| panic!("{e}"));
        let mut found: Vec<(u32, String, Kind)> = Vec::new();
        for (_, var) in module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            assert_eq!(rb.group, 0, "{file}: only group 0 is used");
            let kind = match (var.space, &module.types[var.ty].inner) {
                (naga::AddressSpace::Uniform, _) => Kind::Uniform,
                (naga::AddressSpace::Storage { access }, _) if access.contains(naga::StorageAccess::STORE) => {
                    Kind::StorageRw
                }
                (naga::AddressSpace::Storage { .. }, _) => Kind::Storage,
                (_, naga::TypeInner::Image { class: naga::ImageClass::Storage { format, .. }, .. }) => {
                    let format = match format {
                        naga::StorageFormat::Rgba32Float => wgpu::TextureFormat::Rgba32Float,
                        other => panic!("{file}: storage format {other:?} not mapped in this test"),
                    };
                    Kind::StorageTexture(format)
                }
                (_, naga::TypeInner::Image { class: naga::ImageClass::Depth { multi: false }, arrayed: true, .. }) => {
                    Kind::DepthArray
                }
                (_, naga::TypeInner::Image { arrayed: true, .. }) => Kind::TextureArray,
                (_, naga::TypeInner::Sampler { comparison: true }) => Kind::ComparisonSampler,
                (_, naga::TypeInner::Image { .. }) => Kind::Texture,
                (space, inner) => panic!("{file}: binding {} has an unexpected kind {space:?} {inner:?}", rb.binding),
            };
            found.push((rb.binding, var.name.clone().unwrap_or_default(), kind));
        }
        found.sort_by_key(|f| f.0);
        let want: Vec<(u32, String, Kind)> =
            slots.iter().enumerate().map(|(i, (name, kind))| (i as u32, name.to_string(), *kind)).collect();
        assert_eq!(found, want, "{file}: WGSL bindings (left) differ from the pass's declaration (right)");
    }

    #[test]
    fn every_pass_declares_the_bindings_of_its_shader() {
        check("shadow_map.wgsl", ShadowMapBindings::SLOTS);
        check("shadow_cull.wgsl", ShadowCullBindings::SLOTS);
        check("surface.wgsl", SurfaceBindings::SLOTS);
        check("surface_cull.wgsl", SurfaceCullBindings::SLOTS);
        check("ranges.wgsl", RangesBindings::SLOTS);
        check("shadow_fit.wgsl", ShadowFitBindings::SLOTS);
        check("shadow_pyramid.wgsl", ShadowPyramidBindings::SLOTS);
        check("cull.wgsl", CullBindings::SLOTS);
        check("voxelize.wgsl", VoxelizeBindings::SLOTS);
        check("scan.wgsl", ScanBindings::SLOTS);
        check("scan_words.wgsl", ScanBindings::SLOTS);
        check("scan_columns.wgsl", ScanBindings::SLOTS);
        check("hit_bounds.wgsl", HitBoundsBindings::SLOTS);
        check("scatter_table.wgsl", ScatterTableBindings::SLOTS);
        check("integrate.wgsl", IntegrateBindings::SLOTS);
        check("raymarch.wgsl", RaymarchBindings::SLOTS);
        check("composite.wgsl", CompositeBindings::SLOTS);
        check("exact_shadows.wgsl", ExactShadowsBindings::SLOTS);
    }

    /// The frame's parameters reach the passes through read-only storage buffers: on lavapipe a
    /// uniform buffer whose values steer control flow gets the shader recompiled for every new
    /// value (0.1-0.7 s per pass: every camera move in the editor, the first frame of every
    /// `render`). Only the shadow map's per-face matrices stay uniform (they steer nothing).
    #[test]
    fn only_the_shadow_map_faces_are_uniform_buffers() {
        let passes: [(&str, &[(&str, Kind)]); 17] = [
            ("shadow_map.wgsl", ShadowMapBindings::SLOTS),
            ("shadow_cull.wgsl", ShadowCullBindings::SLOTS),
            ("surface.wgsl", SurfaceBindings::SLOTS),
            ("surface_cull.wgsl", SurfaceCullBindings::SLOTS),
            ("ranges.wgsl", RangesBindings::SLOTS),
            ("shadow_pyramid.wgsl", ShadowPyramidBindings::SLOTS),
            ("cull.wgsl", CullBindings::SLOTS),
            ("voxelize.wgsl", VoxelizeBindings::SLOTS),
            ("scan.wgsl", ScanBindings::SLOTS),
            ("scan_words.wgsl", ScanBindings::SLOTS),
            ("scan_columns.wgsl", ScanBindings::SLOTS),
            ("hit_bounds.wgsl", HitBoundsBindings::SLOTS),
            ("scatter_table.wgsl", ScatterTableBindings::SLOTS),
            ("integrate.wgsl", IntegrateBindings::SLOTS),
            ("raymarch.wgsl", RaymarchBindings::SLOTS),
            ("composite.wgsl", CompositeBindings::SLOTS),
            ("exact_shadows.wgsl", ExactShadowsBindings::SLOTS),
        ];
        let uniform: Vec<String> = passes
            .iter()
            .flat_map(|(file, slots)| {
                slots.iter().filter(|(_, k)| *k == Kind::Uniform).map(move |(name, _)| format!("{file}: {name}"))
            })
            .collect();
        assert_eq!(uniform, ["shadow_map.wgsl: face"]);
    }
}

#[cfg(test)]
mod private_array_tests {
    //! The per-item and per-pixel shaders hold no array in private or function memory
    //! (docs/architecture.md, "No private arrays in the hot shaders"): on llvmpipe one indexed per
    //! lane is a gather through memory, and Voxelize and Integrate ran two to three times slower
    //! with them. Arrays in storage and workgroup memory are fine.
    use crate::gpu::ShaderLibrary;

    fn holds_array(module: &naga::Module, ty: naga::Handle<naga::Type>) -> bool {
        match &module.types[ty].inner {
            naga::TypeInner::Array { .. } | naga::TypeInner::BindingArray { .. } => true,
            naga::TypeInner::Struct { members, .. } => members.iter().any(|m| holds_array(module, m.ty)),
            _ => false,
        }
    }

    /// `file`'s private globals and function locals that hold an array, by name.
    fn private_arrays(file: &str) -> Vec<String> {
        let (module, _) = ShaderLibrary::embedded().validate(file).unwrap_or_else(|e| panic!("{e}"));
        let mut found: Vec<String> = module
            .global_variables
            .iter()
            .filter(|(_, v)| v.space == naga::AddressSpace::Private && holds_array(&module, v.ty))
            .map(|(_, v)| format!("var<private> {}", v.name.clone().unwrap_or_default()))
            .collect();
        let functions = module.functions.iter().map(|(_, f)| f).chain(module.entry_points.iter().map(|e| &e.function));
        for func in functions {
            for (_, local) in func.local_variables.iter() {
                if holds_array(&module, local.ty) {
                    found.push(format!(
                        "{}: var {}",
                        func.name.clone().unwrap_or_default(),
                        local.name.clone().unwrap_or_default()
                    ));
                }
            }
        }
        found
    }

    #[test]
    fn the_hot_shaders_hold_no_private_array() {
        for file in
            ["cull.wgsl", "voxelize.wgsl", "scan.wgsl", "scan_words.wgsl", "scan_columns.wgsl", "integrate.wgsl"]
        {
            let found = private_arrays(file);
            assert!(found.is_empty(), "{file} holds arrays in private or function memory: {found:?}");
        }
    }

    /// The check itself finds one: the march's private copy of the shadow-map faces holds the six
    /// matrices (picked with constant indices only, raymarch.wgsl's `face_matrix`).
    #[test]
    fn a_private_array_is_found() {
        assert!(!private_arrays("raymarch.wgsl").is_empty(), "raymarch.wgsl's `shadow` holds an array");
    }
}

//! The GPU renderer: one struct per pass, and [`Renderer::render`], the ordered list of pass calls.
//!
//! ```text
//! ShadowMap -> Surface -> Voxelize -> Scan -> ScatterTable (point light) -> Integrate -> Composite
//! ShadowMap -> Surface -> Raymarch -> Composite                      (Method::Raymarch, the baseline)
//! ```

mod composite;
mod cull;
mod frame;
mod integrate;
mod ranges;
mod raymarch;
mod scan;
mod scatter_table;
mod scene_gpu;
mod shadow_map;
mod surface;
mod util;
mod variant;
mod voxelize;

pub use composite::Composite;
pub use cull::{Cull, CullCounts};
pub use frame::{FrameError, FrameSetup, FrameUniforms, Method, CARTESIAN_TOLERANCE_DEG, TABLE_COLS, TABLE_ROWS};
pub use integrate::Integrate;
pub use ranges::Ranges;
pub use raymarch::{Raymarch, RaymarchUniforms};
pub use scan::Scan;
pub use scatter_table::ScatterTable;
pub use scene_gpu::SceneGpu;
pub use shadow_map::{FaceUniforms, ShadowMap, ShadowUniforms};
pub use surface::Surface;
pub use variant::{Specialised, Variant, VariantPipelines};
pub use voxelize::Voxelize;

use crate::gpu::{GpuContext, GpuError, GpuTimer, PassTiming, ShaderLibrary};
use crate::image::Image;
use crate::params::Grid;
use crate::scene::Scene;
use util::texture_2d;
use wgpu::util::DeviceExt;

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
    pub passes: Vec<&'static str>,
    /// The shader variant the passes ran as.
    pub variant: Variant,
}

/// What one frame produced on the GPU side (timings and the fitted grid), without images.
#[derive(Debug, Clone)]
pub struct FrameInfo {
    pub timings: Vec<PassTiming>,
    pub setup: FrameSetup,
    /// The passes that ran, in order (also without timestamps).
    pub passes: Vec<&'static str>,
    /// The shader variant the passes ran as.
    pub variant: Variant,
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
    pub triangles_total: u32,
    /// Kept and dropped triangles (zero when no voxel pass ran).
    pub triangles: CullCounts,
    /// The passes that ran.
    pub passes: Vec<&'static str>,
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
            variant: self.variant,
        }
    }

    pub fn total_ms(&self) -> f64 {
        self.timings.iter().map(|t| t.ms).sum()
    }
}

/// Size-dependent targets.
struct Targets {
    width: u32,
    height: u32,
    radiance: wgpu::TextureView,
    distance: wgpu::TextureView,
    depth: wgpu::TextureView,
    scatter: wgpu::Texture,
    scatter_view: wgpu::TextureView,
    hdr: wgpu::Texture,
    hdr_view: wgpu::TextureView,
}

/// Grid-dependent resources.
struct GridResources {
    grid: Grid,
    bits: wgpu::Buffer,
}

/// Every pass, created together so that a reload either replaces all of them or none.
struct Passes {
    shadow_map: ShadowMap,
    surface: Surface,
    voxelize: Voxelize,
    scan: Scan,
    scatter_table: ScatterTable,
    integrate: Integrate,
    composite: Composite,
    raymarch: Raymarch,
    ranges: Ranges,
    cull: Cull,
}

impl Passes {
    fn new(ctx: &GpuContext, lib: &ShaderLibrary, shadow_map_size: u32) -> Result<Passes, GpuError> {
        let d = &ctx.device;
        ctx.scoped("creating the pipelines", || -> Result<Passes, GpuError> {
            Ok(Passes {
                shadow_map: ShadowMap::new(d, lib, shadow_map_size)?,
                surface: Surface::new(d, lib)?,
                voxelize: Voxelize::new(d, lib)?,
                scan: Scan::new(d, lib)?,
                scatter_table: ScatterTable::new(d, lib)?,
                integrate: Integrate::new(d, lib)?,
                composite: Composite::new(d, lib)?,
                raymarch: Raymarch::new(d, lib)?,
                ranges: Ranges::new(d, lib)?,
                cull: Cull::new(d, lib)?,
            })
        })?
    }

    /// Builds the pipelines specialised to `variant` that are not built yet, in every pass that
    /// depends on it. Cheap when they exist (a lookup per pass); a new light type or phase function
    /// costs one pipeline build per pass, once.
    fn prepare(&mut self, ctx: &GpuContext, variant: Variant) -> Result<(), GpuError> {
        let d = &ctx.device;
        ctx.scoped(&format!("creating the pipelines for a {variant}"), || {
            self.shadow_map.prepare(d, variant);
            self.surface.prepare(d, variant);
            self.ranges.prepare(d, variant);
            self.cull.prepare(d, variant);
            self.voxelize.prepare(d, variant);
            self.scatter_table.prepare(d, variant);
            self.integrate.prepare(d, variant);
            self.composite.prepare(d, variant);
            self.raymarch.prepare(d, variant);
        })
    }
}

/// Owns the passes and the resources of the current scene, size and grid.
pub struct Renderer {
    pub ctx: GpuContext,
    passes: Passes,
    /// Fit the frame's work to what it needs (DESIGN section 6); `false` is `--no-prune`.
    pub prune: bool,
    /// The library the passes were built from, kept to rebuild the shadow map at a new size.
    lib: ShaderLibrary,
    frame_buffer: wgpu::Buffer,
    shadow_uniforms: wgpu::Buffer,
    table: wgpu::Buffer,
    timer: Option<GpuTimer>,
    geometry: Option<(SceneGpu, usize)>,
    targets: Option<Targets>,
    grid: Option<GridResources>,
    /// A copy of the grid taken between voxelize and scan (the geometry voxels), kept only while
    /// [`Renderer::set_keep_geometry_grid`] asks for it (the editor's inspector).
    geometry_copy: Option<wgpu::Buffer>,
    keep_geometry: bool,
    /// The variant of the last frame: every pass holds its pipelines (a reload or a new shadow map
    /// builds them before replacing the old ones), so frames of the same variant build nothing.
    variant: Option<Variant>,
}

impl Renderer {
    /// Shadow-map texels per side.
    pub const SHADOW_MAP_SIZE: u32 = 2048;

    pub fn new(ctx: GpuContext, lib: &ShaderLibrary) -> Result<Renderer, GpuError> {
        let shadow_map_size = Self::SHADOW_MAP_SIZE.min(ctx.device.limits().max_texture_dimension_2d);
        let passes = Passes::new(&ctx, lib, shadow_map_size)?;
        let d = &ctx.device;
        let frame_buffer = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::frame_uniforms"),
            size: std::mem::size_of::<FrameUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let shadow_uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::shadow_uniforms"),
            size: std::mem::size_of::<ShadowUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let table = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::scatter_table"),
            size: ScatterTable::BYTES,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let timer = GpuTimer::new(&ctx);
        Ok(Renderer {
            ctx,
            passes,
            prune: true,
            lib: lib.clone(),
            frame_buffer,
            shadow_uniforms,
            table,
            timer,
            geometry: None,
            targets: None,
            grid: None,
            geometry_copy: None,
            keep_geometry: false,
            variant: None,
        })
    }

    /// Rebuilds every pipeline from `lib` (after a shader edit). On any error — WGSL that does not
    /// parse or validate, or a pipeline wgpu refuses — the old pipelines stay and keep rendering.
    pub fn reload(&mut self, lib: &ShaderLibrary) -> Result<(), GpuError> {
        let mut passes = Passes::new(&self.ctx, lib, self.passes.shadow_map.size)?;
        // Build what the current picture needs now, so that a shader wgpu refuses for this variant
        // fails here, with the old pipelines still in place.
        if let Some(v) = self.variant {
            passes.prepare(&self.ctx, v)?;
        }
        self.passes = passes;
        self.lib = lib.clone();
        Ok(())
    }

    /// Texels per side of each shadow-map layer.
    pub fn shadow_map_size(&self) -> u32 {
        self.passes.shadow_map.size
    }

    /// Rebuilds the shadow map at `size` texels per side (the ray-marching baseline's quality knob;
    /// the surface pass uses it too). Refused, keeping the old map, when the adapter cannot hold it.
    pub fn set_shadow_map_size(&mut self, size: u32) -> Result<(), GpuError> {
        if size == self.passes.shadow_map.size {
            return Ok(());
        }
        if size == 0 {
            return Err(GpuError::Validation {
                during: "setting the shadow-map size".into(),
                message: "the shadow map needs at least one texel per side".into(),
            });
        }
        self.ctx.check_texture("the shadow map", size, size)?;
        let map = self.ctx.scoped("creating the shadow map", || -> Result<ShadowMap, GpuError> {
            let mut map = ShadowMap::new(&self.ctx.device, &self.lib, size)?;
            if let Some(v) = self.variant {
                map.prepare(&self.ctx.device, v);
            }
            Ok(map)
        })??;
        self.passes.shadow_map = map;
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
        let voxels_ran = info.passes.contains(&"voxelize");
        let fitted = if voxels_ran { self.pruned_z_range()? } else { None };
        let bins = fitted.map(|(lo, hi)| [z(lo as f64), z(hi as f64)]).unwrap_or([z(m.z_lo), z(m.z_hi)]);
        Ok(PruneReport {
            enabled: self.prune,
            planes_span_deg: m.phi_span.to_degrees(),
            rays_gamma_deg: [m.gamma_lo.to_degrees(), m.gamma_hi.to_degrees()],
            bins_z: bins,
            bins_z_casters: [z(m.z_lo), z(m.z_hi)],
            words_per_ray: m.grid.words(),
            triangles_total: self.geometry.as_ref().map_or(0, |(g, _)| g.triangle_count),
            triangles: if voxels_ran { self.cull_counts()? } else { CullCounts::default() },
            passes: info.passes.clone(),
            variant: info.variant.to_string(),
        })
    }

    /// What the last frame's Cull pass kept and dropped. Blocks on a 16-byte readback.
    pub fn cull_counts(&self) -> Result<CullCounts, GpuError> {
        let bytes = self.ctx.read_buffer(&self.passes.cull.counters)?;
        let v: &[u32] = bytemuck::cast_slice(&bytes);
        Ok(CullCounts { kept: v[4], culled_depth: v[1], culled_view: v[2], items: v[5] as u64 })
    }

    /// The final linear image of the last frame (RGBA32Float), e.g. for an editor to display.
    pub fn hdr_texture(&self) -> Option<&wgpu::Texture> {
        self.targets.as_ref().map(|t| &t.hdr)
    }

    /// The in-scattered light of the last frame (RGBA32Float).
    pub fn scatter_texture(&self) -> Option<&wgpu::Texture> {
        self.targets.as_ref().map(|t| &t.scatter)
    }

    /// Uploads the scene's geometry (call again when the geometry changes).
    pub fn set_scene(&mut self, scene: &Scene) {
        let l = self.ctx.device.limits();
        let max_binding = (l.max_storage_buffer_binding_size as u64).min(l.max_buffer_size);
        self.geometry = Some((SceneGpu::new(&self.ctx.device, scene, max_binding), scene.triangle_count()));
    }

    fn ensure_targets(&mut self, width: u32, height: u32) -> Result<(), GpuError> {
        if self.targets.as_ref().is_some_and(|t| t.width == width && t.height == height) {
            return Ok(());
        }
        self.ctx.check_texture("the image", width, height)?;
        let d = &self.ctx.device;
        use wgpu::TextureUsages as U;
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let radiance = texture_2d(
            d,
            "Renderer::surface_radiance",
            width,
            height,
            1,
            Surface::RADIANCE,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING,
        );
        let distance = texture_2d(
            d,
            "Renderer::surface_distance",
            width,
            height,
            1,
            Surface::DISTANCE,
            U::RENDER_ATTACHMENT | U::TEXTURE_BINDING,
        );
        let depth = texture_2d(d, "Renderer::depth", width, height, 1, Surface::DEPTH, U::RENDER_ATTACHMENT);
        let scatter = texture_2d(
            d,
            "Renderer::scatter",
            width,
            height,
            1,
            Integrate::OUTPUT,
            U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        let hdr = texture_2d(
            d,
            "Renderer::hdr",
            width,
            height,
            1,
            Composite::OUTPUT,
            U::STORAGE_BINDING | U::TEXTURE_BINDING | U::COPY_SRC,
        );
        self.targets = Some(Targets {
            width,
            height,
            radiance: view(&radiance),
            distance: view(&distance),
            depth: view(&depth),
            scatter_view: view(&scatter),
            scatter,
            hdr_view: view(&hdr),
            hdr,
        });
        Ok(())
    }

    fn ensure_grid(&mut self, grid: Grid) -> Result<(), GpuError> {
        if self.grid.as_ref().is_some_and(|g| g.grid == grid) {
            return Ok(());
        }
        self.ctx.check_buffer(&format!("the {grid} grid"), grid.bytes())?;
        self.ctx.check_texture(&format!("the {grid} grid's planes x rays"), grid.planes, grid.rays)?;
        let d = &self.ctx.device;
        let bits = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Renderer::grid_bits"),
            size: grid.bytes(),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        self.grid = Some(GridResources { grid, bits });
        Ok(())
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
    ) -> Result<FrameInfo, GpuError> {
        if self.geometry.as_ref().is_none_or(|(_, n)| *n != scene.triangle_count()) {
            self.set_scene(scene);
        }
        self.ensure_targets(width, height)?;
        self.ensure_grid(scene.grid)?;
        if self.keep_geometry && self.geometry_copy.as_ref().is_none_or(|b| b.size() != scene.grid.bytes()) {
            self.geometry_copy = Some(self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("Renderer::geometry_copy"),
                size: scene.grid.bytes(),
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            }));
        }
        let setup = FrameSetup::with_pruning(scene, width, height, method, self.prune)?;
        let variant = Variant::new(setup.frame.is_point(), &scene.medium.phase);
        // Every pass holds `self.variant`'s pipelines (reload and set_shadow_map_size keep it so):
        // only a new light type or phase function builds, and checks, anything.
        if self.variant != Some(variant) {
            self.passes.prepare(&self.ctx, variant)?;
            self.variant = Some(variant);
        }
        let (Some((geometry, _)), Some(t), Some(g)) = (&self.geometry, &self.targets, &self.grid) else {
            unreachable!("ensured above")
        };
        let ctx = &self.ctx;
        let d = &ctx.device;
        ctx.queue.write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&setup.uniforms));
        let (_, shadow_lookup, _) = self.passes.shadow_map.uniforms(scene);
        ctx.queue.write_buffer(&self.shadow_uniforms, 0, bytemuck::bytes_of(&shadow_lookup));

        let bind = |label: &str, layout: &wgpu::BindGroupLayout, resources: &[wgpu::BindingResource]| {
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout,
                entries: &resources
                    .iter()
                    .enumerate()
                    .map(|(i, r)| wgpu::BindGroupEntry { binding: i as u32, resource: r.clone() })
                    .collect::<Vec<_>>(),
            })
        };
        use wgpu::BindingResource as R;
        let frame = self.frame_buffer.as_entire_binding();
        let surface_bg = bind(
            "Surface::bind_group",
            &self.passes.surface.layout,
            &[
                frame.clone(),
                self.shadow_uniforms.as_entire_binding(),
                R::TextureView(&self.passes.shadow_map.map_view),
            ],
        );
        let cull = &self.passes.cull;
        // One Cull and one Voxelize bind group per chunk of triangles (one chunk unless the mesh
        // is larger than the adapter's largest storage binding).
        let chunk_groups: Vec<(wgpu::BindGroup, wgpu::BindGroup, u32)> = geometry
            .chunks
            .iter()
            .filter(|(_, n)| *n > 0)
            .map(|(tris, n)| {
                let l = &geometry.lists;
                let cull_bg = bind(
                    "Cull::bind_group",
                    &cull.layout,
                    &[
                        frame.clone(),
                        tris.as_entire_binding(),
                        l.records.as_entire_binding(),
                        l.offsets.as_entire_binding(),
                        l.blocks.as_entire_binding(),
                        cull.counters.as_entire_binding(),
                        cull.dispatch.as_entire_binding(),
                    ],
                );
                let voxelize_bg = bind(
                    "Voxelize::bind_group",
                    &self.passes.voxelize.layout,
                    &[
                        frame.clone(),
                        tris.as_entire_binding(),
                        g.bits.as_entire_binding(),
                        l.records.as_entire_binding(),
                        l.offsets.as_entire_binding(),
                        l.blocks.as_entire_binding(),
                        cull.counters.as_entire_binding(),
                    ],
                );
                (cull_bg, voxelize_bg, *n)
            })
            .collect();
        let scan_bg = bind("Scan::bind_group", &self.passes.scan.layout, &[frame.clone(), g.bits.as_entire_binding()]);
        let table_bg = bind(
            "ScatterTable::bind_group",
            &self.passes.scatter_table.layout,
            &[frame.clone(), self.table.as_entire_binding()],
        );
        let integrate_bg = bind(
            "Integrate::bind_group",
            &self.passes.integrate.layout,
            &[
                frame.clone(),
                g.bits.as_entire_binding(),
                self.table.as_entire_binding(),
                R::TextureView(&t.distance),
                R::TextureView(&t.scatter_view),
            ],
        );
        let raymarch_bg = bind(
            "Raymarch::bind_group",
            &self.passes.raymarch.layout,
            &[
                frame.clone(),
                self.shadow_uniforms.as_entire_binding(),
                R::TextureView(&self.passes.shadow_map.map_view),
                R::TextureView(&t.distance),
                R::TextureView(&t.scatter_view),
                self.passes.raymarch.uniforms.as_entire_binding(),
            ],
        );
        let ranges_bg = bind(
            "Ranges::bind_group",
            &self.passes.ranges.layout,
            &[frame.clone(), R::TextureView(&t.distance), self.passes.ranges.result.as_entire_binding()],
        );
        let composite_bg = bind(
            "Composite::bind_group",
            &self.passes.composite.layout,
            &[
                frame,
                R::TextureView(&t.radiance),
                R::TextureView(&t.distance),
                R::TextureView(&t.scatter_view),
                R::TextureView(&t.hdr_view),
            ],
        );

        let mut enc = d.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("Renderer::frame") });
        let mut timer = self.timer.take();
        if let Some(tm) = timer.as_mut() {
            tm.begin(&mut enc);
        }
        let mut ran: Vec<&'static str> = Vec::new();
        let mut mark = |enc: &mut wgpu::CommandEncoder, pass: &'static str| {
            ran.push(pass);
            if let Some(tm) = timer.as_mut() {
                tm.mark(enc, pass);
            }
        };
        // The frame: an ordered list of passes.
        self.passes.shadow_map.record(&ctx.queue, &mut enc, variant, scene, geometry);
        mark(&mut enc, "shadow_map");
        self.passes.surface.record(&mut enc, variant, &surface_bg, geometry, &t.radiance, &t.distance, &t.depth);
        mark(&mut enc, "surface");
        if let Method::Raymarch { steps, jitter } = method {
            self.passes.raymarch.record(&ctx.queue, &mut enc, variant, &raymarch_bg, width, height, steps, jitter);
            mark(&mut enc, "raymarch");
        } else if !scene.needs_scattering() {
            // Nothing scatters: no voxel pass has anything to compute; Integrate writes zeros.
            enc.clear_buffer(&g.bits, 0, None);
            self.passes.integrate.record(&mut enc, variant, &integrate_bg, width, height);
            mark(&mut enc, "integrate");
        } else {
            if self.prune {
                self.passes.ranges.record(&mut enc, variant, &ranges_bg, &self.frame_buffer, width, height);
                mark(&mut enc, "ranges");
            }
            enc.clear_buffer(&g.bits, 0, None);
            self.passes.cull.begin_frame(&mut enc);
            // Chunks are culled and voxelized in turn: they share the Cull pass's lists.
            for (cull_bg, voxelize_bg, n) in &chunk_groups {
                self.passes.cull.record(&mut enc, variant, cull_bg, *n);
                mark(&mut enc, "cull");
                self.passes.voxelize.record(&mut enc, variant, voxelize_bg, &self.passes.cull.dispatch);
                mark(&mut enc, "voxelize");
            }
            if let (true, Some(copy)) = (self.keep_geometry, &self.geometry_copy) {
                enc.copy_buffer_to_buffer(&g.bits, 0, copy, 0, g.bits.size());
            }
            self.passes.scan.record(&mut enc, &scan_bg, &self.passes.cull.dispatch, Cull::SCAN_ARGS);
            mark(&mut enc, "scan");
            if scene.light.is_point() && method == Method::Vsv {
                self.passes.scatter_table.record(&mut enc, variant, &table_bg);
                mark(&mut enc, "scatter_table");
            }
            self.passes.integrate.record(&mut enc, variant, &integrate_bg, width, height);
            mark(&mut enc, "integrate");
        }
        self.passes.composite.record(&mut enc, variant, &composite_bg, width, height);
        mark(&mut enc, "composite");
        if let Some(tm) = timer.as_ref() {
            tm.resolve(&mut enc);
        }
        ctx.queue.submit([enc.finish()]);
        let timings = match timer.as_ref() {
            Some(tm) => tm.read(ctx)?,
            None => Vec::new(),
        };
        self.timer = timer;

        Ok(FrameInfo { timings, setup, passes: ran, variant })
    }

    /// Renders one frame and reads the final and the scattered image back to the CPU.
    pub fn render(&mut self, scene: &Scene, width: u32, height: u32, method: Method) -> Result<RenderOutput, GpuError> {
        let FrameInfo { timings, setup, passes, variant } = self.render_frame(scene, width, height, method)?;
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
        Ok(RenderOutput { hdr, scatter, timings, setup, passes, variant })
    }

    /// The shadow volume of the last frame, `rays x planes x words` words (ray-major), for the
    /// inspector and tests.
    pub fn read_grid(&self) -> Result<Vec<u32>, GpuError> {
        let g = self.grid.as_ref().ok_or_else(|| GpuError::Readback("no frame rendered yet".into()))?;
        Ok(bytemuck::cast_slice(&self.ctx.read_buffer(&g.bits)?).to_vec())
    }

    /// Keep a copy of the geometry voxels (the grid before the scan) of every following frame, for
    /// [`Renderer::read_geometry_grid`]; off by default (it costs one grid copy per frame).
    pub fn set_keep_geometry_grid(&mut self, keep: bool) {
        self.keep_geometry = keep;
        if !keep {
            self.geometry_copy = None;
        }
    }

    /// The geometry voxels of the last frame (before the scan), laid out as [`Renderer::read_grid`];
    /// needs [`Renderer::set_keep_geometry_grid`] before that frame.
    pub fn read_geometry_grid(&self) -> Result<Vec<u32>, GpuError> {
        let b = self.geometry_copy.as_ref().filter(|_| self.keep_geometry).ok_or_else(|| {
            GpuError::Readback("the geometry grid is not kept (Renderer::set_keep_geometry_grid)".into())
        })?;
        Ok(bytemuck::cast_slice(&self.ctx.read_buffer(b)?).to_vec())
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
                sigma_s, sigma_t, ranges, medium_min, medium_max, grid, image, table),
            size_of::<FrameUniforms>(),
        );
    }

    #[test]
    fn shadow_uniforms_match_wgsl() {
        check("shadow_map.wgsl", "Face", fields!(FaceUniforms: view_proj, light, origin), size_of::<FaceUniforms>());
        check(
            "surface.wgsl",
            "ShadowFaces",
            fields!(ShadowUniforms: view_proj, params, origin),
            size_of::<ShadowUniforms>(),
        );
    }
}

//! The viewport: our pipeline drawn inside egui's render pass through an `egui_wgpu` paint callback.
//!
//! The [`Renderer`] lives in egui_wgpu's callback resources ([`ViewportResources`]). Each frame the
//! UI hands a [`FrameRequest`] to a [`ViewportCallback`]; `prepare` runs
//! [`Renderer::render_frame`] only when the request's generation differs from the one drawn last
//! (something changed: look, size, method, scene, shaders), and `paint` draws the HDR (or scattered)
//! texture through `shaders/display.wgsl` (exposure, ACES fit, sRGB).

use crate::gpu::{GpuContext, GpuError, ShaderLibrary};
use crate::render::{FrameInfo, Method, PruneReport, Renderer};
use crate::scene::{Camera, Scene};
use eframe::egui_wgpu::{CallbackResources, CallbackTrait, ScreenDescriptor};
use std::sync::Arc;
use std::time::Instant;

/// Which of the renderer's images the viewport shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    Hdr,
    Scatter,
}

/// Everything one viewport frame needs; `generation` changes whenever the picture must be redrawn.
#[derive(Debug, Clone)]
pub struct FrameRequest {
    pub generation: u64,
    /// Changes when the geometry must be uploaded again (another scene was opened).
    pub scene_generation: u64,
    pub scene: Arc<Scene>,
    pub width: u32,
    pub height: u32,
    pub method: Method,
    pub shown: Shown,
    /// Exposure in stops (applied at display time: changing it does not re-render).
    pub exposure: f32,
}

/// What the last render produced, for the Stats panel, the inspector and the hover linking.
#[derive(Debug, Clone)]
pub struct FrameReport {
    pub generation: u64,
    /// The frame's timings and fitted grid, or why it failed (the previous picture stays).
    pub result: Result<FrameInfo, String>,
    /// Wall time of `render_frame`: recording, submission and waiting for the timestamps (ms).
    pub render_ms: f64,
    pub width: u32,
    pub height: u32,
    pub method: Method,
    /// The last frame that succeeded (what is on screen).
    pub last_good: Option<GoodFrame>,
    /// What fitting the work to the frame kept and dropped (for the Stats panel).
    pub prune: Option<PruneReport>,
}

/// A frame that rendered: what the viewport shows, and how its pixels map to the grid.
#[derive(Debug, Clone)]
pub struct GoodFrame {
    pub generation: u64,
    pub info: FrameInfo,
    pub width: u32,
    pub height: u32,
    pub method: Method,
    pub camera: Camera,
}

/// The pipeline that puts a linear image on screen.
struct DisplayPipeline {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayUniforms {
    exposure: f32,
    linear_target: u32,
    _pad: [u32; 2],
}

impl DisplayPipeline {
    fn new(ctx: &GpuContext, lib: &ShaderLibrary, format: wgpu::TextureFormat) -> Result<DisplayPipeline, GpuError> {
        let d = &ctx.device;
        ctx.scoped("creating the display pipeline", || -> Result<DisplayPipeline, GpuError> {
            let module = lib.module(d, "display.wgsl")?;
            let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("editor::Display::layout"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 0,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Buffer {
                            ty: wgpu::BufferBindingType::Uniform,
                            has_dynamic_offset: false,
                            min_binding_size: None,
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 1,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: false },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                        count: None,
                    },
                ],
            });
            let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("editor::Display::pipeline_layout"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            });
            let pipeline = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("editor::Display::pipeline"),
                layout: Some(&pl),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                primitive: wgpu::PrimitiveState::default(),
                // egui's pass: no depth attachment and one sample (eframe is started that way).
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                multiview_mask: None,
                cache: None,
            });
            Ok(DisplayPipeline { pipeline, layout })
        })?
    }
}

/// The renderer and the display pipeline, stored in egui_wgpu's callback resources.
pub struct ViewportResources {
    pub renderer: Renderer,
    display: DisplayPipeline,
    format: wgpu::TextureFormat,
    uniforms: wgpu::Buffer,
    bind_group: Option<wgpu::BindGroup>,
    /// (generation of the last good frame, image) the bind group points at.
    bound: Option<(u64, Shown)>,
    rendered_generation: Option<u64>,
    uploaded_scene: Option<u64>,
    last_good_generation: Option<u64>,
    pub report: Option<FrameReport>,
    /// Frames rendered so far (for tests and the run summary).
    pub frames_rendered: u64,
    keep_geometry: bool,
}

impl ViewportResources {
    pub fn new(
        ctx: GpuContext,
        lib: &ShaderLibrary,
        format: wgpu::TextureFormat,
    ) -> Result<ViewportResources, GpuError> {
        let display = DisplayPipeline::new(&ctx, lib, format)?;
        let uniforms = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("editor::Display::uniforms"),
            size: std::mem::size_of::<DisplayUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let renderer = Renderer::new(ctx, lib)?;
        Ok(ViewportResources {
            renderer,
            display,
            format,
            uniforms,
            bind_group: None,
            bound: None,
            rendered_generation: None,
            uploaded_scene: None,
            last_good_generation: None,
            report: None,
            frames_rendered: 0,
            keep_geometry: false,
        })
    }

    /// Rebuilds every pipeline (ours and the renderer's) from `lib`; on error the old ones stay.
    pub fn reload(&mut self, lib: &ShaderLibrary) -> Result<(), GpuError> {
        // Validate both before swapping either, so a broken display.wgsl leaves everything as it was.
        let display = DisplayPipeline::new(&self.renderer.ctx, lib, self.format)?;
        self.renderer.reload(lib)?;
        self.display = display;
        self.bind_group = None;
        self.bound = None;
        // The new shaders may draw differently: render again.
        self.rendered_generation = None;
        Ok(())
    }

    /// Whether the renderer keeps the geometry grid (the grid before the scan) of each frame.
    pub fn renderer_keeps_geometry(&self) -> bool {
        self.keep_geometry
    }

    /// Makes the renderer keep (or stop keeping) the geometry grid; the next frame renders again
    /// so that the grid shown matches it.
    pub fn set_keep_geometry(&mut self, keep: bool) {
        self.keep_geometry = keep;
        self.renderer.set_keep_geometry_grid(keep);
        self.rendered_generation = None;
    }

    /// Forces the next request to render even if its generation was drawn already.
    pub fn invalidate(&mut self) {
        self.rendered_generation = None;
    }

    /// Has a picture to show.
    pub fn has_picture(&self) -> bool {
        self.last_good_generation.is_some()
    }

    fn render(&mut self, req: &FrameRequest) {
        if self.uploaded_scene != Some(req.scene_generation) {
            self.renderer.set_scene(&req.scene);
            self.uploaded_scene = Some(req.scene_generation);
        }
        let t0 = Instant::now();
        let result = self.renderer.render_frame(&req.scene, req.width, req.height, req.method);
        let render_ms = t0.elapsed().as_secs_f64() * 1e3;
        self.rendered_generation = Some(req.generation);
        let mut last_good = self.report.as_ref().and_then(|r| r.last_good.clone());
        let mut prune = self.report.as_ref().and_then(|r| r.prune.clone());
        let result = match result {
            Ok(info) => {
                // Two tiny readbacks (the fitted bin range, the cull counters).
                prune = self.renderer.prune_report(&info).ok();
                self.frames_rendered += 1;
                self.last_good_generation = Some(req.generation);
                last_good = Some(GoodFrame {
                    generation: req.generation,
                    info: info.clone(),
                    width: req.width,
                    height: req.height,
                    method: req.method,
                    camera: req.scene.camera,
                });
                Ok(info)
            }
            Err(e) => Err(e.to_string()),
        };
        self.report = Some(FrameReport {
            generation: req.generation,
            result,
            render_ms,
            width: req.width,
            height: req.height,
            method: req.method,
            last_good,
            prune,
        });
    }

    fn update_bind_group(&mut self, shown: Shown) {
        let Some(good) = self.last_good_generation else { return };
        if self.bound == Some((good, shown)) && self.bind_group.is_some() {
            return;
        }
        let texture = match shown {
            Shown::Hdr => self.renderer.hdr_texture(),
            Shown::Scatter => self.renderer.scatter_texture(),
        };
        let Some(texture) = texture else { return };
        let view = texture
            .create_view(&wgpu::TextureViewDescriptor { label: Some("editor::Display::image"), ..Default::default() });
        self.bind_group = Some(self.renderer.ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("editor::Display::bind_group"),
            layout: &self.display.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: self.uniforms.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
            ],
        }));
        self.bound = Some((good, shown));
    }

    /// Renders `req` now if needed (what `prepare` does; also used outside a paint, e.g. by the
    /// accuracy job before it changes the renderer's size).
    pub fn prepare(&mut self, queue: &wgpu::Queue, req: &FrameRequest) {
        if self.rendered_generation != Some(req.generation) {
            self.render(req);
        }
        let u = DisplayUniforms {
            exposure: 2f32.powf(req.exposure),
            linear_target: self.format.is_srgb() as u32,
            _pad: [0; 2],
        };
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        self.update_bind_group(req.shown);
    }
}

/// The paint callback of one viewport frame.
pub struct ViewportCallback(pub Arc<FrameRequest>);

impl CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        _device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(res) = resources.get_mut::<ViewportResources>() {
            res.prepare(queue, &self.0);
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: eframe::egui::epaint::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else { return };
        if let Some(bg) = &res.bind_group {
            pass.set_pipeline(&res.display.pipeline);
            pass.set_bind_group(0, bg, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

//! Putting a finished picture on screen: `shaders/display.wgsl` drawn inside egui's render pass
//! through an `egui_wgpu` paint callback.
//!
//! The render worker (its own device) reads each frame back and writes the final and the
//! scattered image into two textures on the *window's* device ([`DisplayImages::upload`], called
//! on the worker thread: wgpu queues are shared between threads). The UI thread only binds them:
//! a paint callback never renders, waits or copies pixels.

use crate::gpu::{GpuContext, GpuError, ShaderLibrary};
use crate::image::Image;
use eframe::egui_wgpu::{CallbackResources, CallbackTrait, ScreenDescriptor};
use std::sync::Arc;

/// Which of the two images the viewport shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    Hdr,
    Scatter,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayUniforms {
    exposure: f32,
    linear_target: u32,
    _pad: [u32; 2],
}

/// The display shader's bind group layout. Written here, not reflected, so a reloaded
/// `display.wgsl` must match it (a mismatch is a reload error, and the old pipeline stays).
pub fn display_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
    })
}

/// The pipeline that puts a linear image on screen (exposure, ACES fit, sRGB).
pub struct DisplayPipeline {
    pipeline: wgpu::RenderPipeline,
}

impl DisplayPipeline {
    /// Builds the pipeline from `lib`'s `display.wgsl` inside an error scope (error scopes are per
    /// thread, so this may run on the worker).
    pub fn new(
        ctx: &GpuContext,
        lib: &ShaderLibrary,
        layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
    ) -> Result<DisplayPipeline, GpuError> {
        let d = &ctx.device;
        ctx.scoped("creating the display pipeline", || -> Result<DisplayPipeline, GpuError> {
            let module = lib.module(d, "display.wgsl")?;
            let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("editor::Display::pipeline_layout"),
                bind_group_layouts: &[Some(layout)],
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
            Ok(DisplayPipeline { pipeline })
        })?
    }
}

/// One picture's images on the window's device, with the bind groups that show them.
pub struct DisplayImages {
    uniforms: wgpu::Buffer,
    hdr: wgpu::BindGroup,
    scatter: wgpu::BindGroup,
}

impl std::fmt::Debug for DisplayImages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("DisplayImages")
    }
}

impl DisplayImages {
    /// Creates the textures on `ui` (the window's device) and queues the pixels' upload; the
    /// window's next submission carries it, before the frame that shows them.
    pub fn upload(ui: &GpuContext, layout: &wgpu::BindGroupLayout, hdr: &Image, scatter: &Image) -> DisplayImages {
        let d = &ui.device;
        let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("editor::Display::uniforms"),
            size: std::mem::size_of::<DisplayUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = |img: &Image, label: &'static str| {
            let size = wgpu::Extent3d { width: img.width, height: img.height, depth_or_array_layers: 1 };
            let texture = d.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            let rgba: Vec<f32> = img.pixels.iter().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect();
            ui.queue.write_texture(
                texture.as_image_copy(),
                bytemuck::cast_slice(&rgba),
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(img.width * 16), rows_per_image: None },
                size,
            );
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("editor::Display::image_view"),
                ..Default::default()
            });
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("editor::Display::bind_group"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                ],
            })
        };
        let hdr = bind(hdr, "editor::Display::hdr");
        let scatter = bind(scatter, "editor::Display::scatter");
        DisplayImages { uniforms, hdr, scatter }
    }
}

/// What the window keeps in egui_wgpu's callback resources: the display pipeline (replaced by a
/// successful reload) and whether the target stores linear values.
pub struct ViewportResources {
    pub display: DisplayPipeline,
    pub format: wgpu::TextureFormat,
}

/// The paint callback of one viewport frame: the picture to show, which image, at what exposure.
pub struct ViewportCallback {
    pub images: Arc<DisplayImages>,
    pub shown: Shown,
    /// In stops.
    pub exposure: f32,
}

impl CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        _device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get::<ViewportResources>() else { return Vec::new() };
        let u = DisplayUniforms {
            exposure: 2f32.powf(self.exposure),
            linear_target: res.format.is_srgb() as u32,
            _pad: [0; 2],
        };
        queue.write_buffer(&self.images.uniforms, 0, bytemuck::bytes_of(&u));
        Vec::new()
    }

    fn paint(
        &self,
        _info: eframe::egui::epaint::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else { return };
        pass.set_pipeline(&res.display.pipeline);
        pass.set_bind_group(
            0,
            match self.shown {
                Shown::Hdr => &self.images.hdr,
                Shown::Scatter => &self.images.scatter,
            },
            &[],
        );
        pass.draw(0..3, 0..1);
    }
}

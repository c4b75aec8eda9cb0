//! Voxelize: the geometry bits of the epipolar grid (`shaders/voxelize.wgsl`).
//!
//! Each triangle the Cull pass kept is drawn as its bounding rectangles in (plane, ray) texels (an
//! indirect draw); each fragment clips the
//! triangle to its texel's cell (the pyramid of four view rays from the eye) and sets the bits of
//! the z bins the clipped polygon spans: `grid[x, y, k] |= 1` for `k` in `[bin(z_min), bin(z_max)]`.
//! A render pass needs one attachment on Mesa 22, so a write-masked R8 target of the grid's size
//! stands in.

use super::util::{storage_entry, texture_2d, uniform_entry};
use super::variant::{Specialised, Variant, VariantPipelines};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct Voxelize {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: VariantPipelines<wgpu::RenderPipeline>,
    pub layout: wgpu::BindGroupLayout,
}

impl Voxelize {
    const DUMMY: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;
    /// Vertices drawn per triangle: two rectangles (the second past the seam at phi = 0).
    pub const VERTICES_PER_TRIANGLE: u32 = 12;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Voxelize, GpuError> {
        let module = lib.module(device, "voxelize.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Voxelize::layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT),
                storage_entry(1, wgpu::ShaderStages::VERTEX_FRAGMENT, true),
                storage_entry(2, wgpu::ShaderStages::FRAGMENT, false),
                storage_entry(3, wgpu::ShaderStages::VERTEX, true),
                storage_entry(4, wgpu::ShaderStages::VERTEX, true),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Voxelize::pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        Ok(Voxelize { module, pipeline_layout: pl, pipelines: VariantPipelines::new(Specialised::Light), layout })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        let (module, pl) = (&self.module, &self.pipeline_layout);
        self.pipelines.prepare(variant, |constants, v| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(&format!("Voxelize::pipeline{v}")),
                layout: Some(pl),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_main"),
                    compilation_options: super::util::options(constants),
                    buffers: &[],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
                    entry_point: Some("fs_main"),
                    compilation_options: super::util::options(constants),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: Self::DUMMY,
                        blend: None,
                        write_mask: wgpu::ColorWrites::empty(),
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        });
    }

    /// The stand-in attachment, `planes x rays`.
    pub fn dummy_target(device: &wgpu::Device, planes: u32, rays: u32) -> wgpu::Texture {
        texture_2d(
            device,
            "Voxelize::dummy_target",
            planes,
            rays,
            1,
            Self::DUMMY,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        dummy: &wgpu::TextureView,
        draw_args: &wgpu::Buffer,
    ) {
        // Renderer::render_frame prepares every variant it records.
        let Some(pipeline) = self.pipelines.get(variant) else {
            return;
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Voxelize::pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: dummy,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::BLACK), store: wgpu::StoreOp::Discard },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        // The Cull pass wrote the vertex count: 12 per kept triangle.
        pass.draw_indirect(draw_args, 0);
    }
}

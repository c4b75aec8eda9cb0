//! Surface: what the eye sees of the surfaces, per pixel (`shaders/surface.wgsl`): the nearest
//! surface's albedo, `cos theta_i` toward the light and distance `t` from the eye.
//!
//! Lighting is deferred to Composite, which evaluates
//! `L_surface = albedo / pi * max(cos theta_i, 0) * V * E_in` once per pixel at `P = eye + t v`:
//! shading every rasterized fragment cost as much as the rest of the pass on llvmpipe, most of it
//! for fragments a nearer surface then covered.
//!
//! The solids the eye lies outside of draw only their faces toward it (`crate::scene::solid`):
//! the scene is drawn as runs of consecutive meshes that cull the same faces.

use super::scene_gpu::{Facing, SceneGpu};
use super::util::{bindings, cull_mode, scene_vertex_layout, Kind};
use super::variant::{Specialised, Variant, VariantPipelines};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Surface's bind group (surface.wgsl).
    SurfaceBindings { frame_in: Kind::Storage }
}

/// The pass's render targets, `width x height`.
pub struct SurfaceTargets<'a> {
    pub material: &'a wgpu::TextureView,
    pub distance: &'a wgpu::TextureView,
    pub depth: &'a wgpu::TextureView,
}

pub struct Surface {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    /// Per variant, one pipeline per cull mode ([`super::util::facing_pipelines`]).
    pipelines: VariantPipelines<Vec<wgpu::RenderPipeline>>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
}

impl Surface {
    /// Albedo (rgb) and the cosine of the light's incidence on the eye's side of the surface (a;
    /// negative when the light is behind it).
    pub const MATERIAL: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
    /// Eye distance (negative for the sky) and, for a surface lit from behind, the cosine between the
    /// view ray and its normal (0 when lit from the front).
    pub const DISTANCE: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
    pub const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Surface, GpuError> {
        let module = lib.module(device, "surface.wgsl")?;
        let layout = SurfaceBindings::layout(device, "Surface::layout", wgpu::ShaderStages::VERTEX_FRAGMENT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Surface::pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        Ok(Surface {
            module,
            pipeline_layout: pl,
            pipelines: VariantPipelines::new(Specialised::Light),
            layout,
            bind_group: None,
        })
    }

    /// (Re)binds the inputs; called when the resources change.
    pub fn bind(&mut self, device: &wgpu::Device, b: SurfaceBindings) {
        self.bind_group = Some(b.bind(device, "Surface::bind_group", &self.layout));
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        let (module, pl) = (&self.module, &self.pipeline_layout);
        self.pipelines.prepare(variant, |constants, v| {
            super::util::facing_pipelines(|cull, name| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(&format!("Surface::pipeline{v}{name}")),
                    layout: Some(pl),
                    vertex: wgpu::VertexState {
                        module,
                        entry_point: Some("vs_main"),
                        compilation_options: super::util::options(constants),
                        buffers: &[Some(scene_vertex_layout())],
                    },
                    primitive: wgpu::PrimitiveState { cull_mode: cull, ..Default::default() },
                    depth_stencil: Some(wgpu::DepthStencilState {
                        format: Self::DEPTH,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(wgpu::CompareFunction::Less),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: Default::default(),
                    fragment: Some(wgpu::FragmentState {
                        module,
                        entry_point: Some("fs_main"),
                        compilation_options: super::util::options(constants),
                        targets: &[Some(Self::MATERIAL.into()), Some(Self::DISTANCE.into())],
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            })
        });
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        geometry: &SceneGpu,
        targets: SurfaceTargets,
        runs: &[(std::ops::Range<u32>, Facing)],
        toward_ccw: bool,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some(pipelines), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let SurfaceTargets { material, distance, depth } = targets;
        let color = |view, clear: f64| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r: clear, g: 0.0, b: 0.0, a: 0.0 }),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Surface::pass"),
            // Distance -1 marks the sky.
            color_attachments: &[color(material, 0.0), color(distance, -1.0)],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, bind_group, &[]);
        pass.set_vertex_buffer(0, geometry.vertices.slice(..));
        pass.set_index_buffer(geometry.indices.slice(..), wgpu::IndexFormat::Uint32);
        for (range, facing) in runs {
            pass.set_pipeline(&pipelines[cull_mode(*facing, toward_ccw).0]);
            pass.draw_indexed(range.clone(), 0, 0..1);
        }
    }

    /// An empty pass over the surface targets (loaded and stored, nothing drawn), recorded after
    /// the shadow map. On llvmpipe (Mesa 22.3) the encoder timestamps of the compute passes after
    /// a frame's last render pass land late when that pass was the shadow map's: Scan's took in
    /// Integrate's time (Integrate 0.2 ms against its 60–80) and, with other targets bound last,
    /// Integrate's Composite's. With the surface targets bound last, as when the map came before
    /// Surface, every pass gets its own time; the pass costs nothing measurable on the classroom
    /// (docs/results.md, session 20), and on a GPU it is a load and a store of two small targets.
    pub fn rebind_targets(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        material: &wgpu::TextureView,
        distance: &wgpu::TextureView,
    ) {
        let keep = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
            })
        };
        let _pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("Surface::rebind_pass"),
            color_attachments: &[keep(material), keep(distance)],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
    }
}

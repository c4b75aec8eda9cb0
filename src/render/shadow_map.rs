//! ShadowMap: distance from the light to the nearest surface (`shaders/shadow_map.wgsl`).
//!
//! Point light: a cube of six 90-degree faces around the light storing `|P - L|`. Directional
//! light: one orthographic view along `-w` over the scene's bounding sphere storing the distance
//! from a plane beyond the scene. The surface pass compares against it with a small bias.

use super::scene_gpu::SceneGpu;
use super::util::{bindings, scene_vertex_layout, texture_2d, Kind};
use super::variant::{Specialised, Variant, VariantPipelines};
use crate::gpu::{GpuError, ShaderLibrary};
use crate::params::Light;
use crate::scene::Scene;
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

bindings! {
    /// One face's bind group (shadow_map.wgsl).
    ShadowMapBindings { face: Kind::Uniform }
}

/// One face's uniforms (`struct Face` in the WGSL).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct FaceUniforms {
    pub view_proj: Mat4,
    pub light: Vec4,
    pub origin: Vec4,
}

/// What the surface pass needs to look the map up (`struct ShadowFaces` in surface.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ShadowUniforms {
    pub view_proj: [Mat4; 6],
    /// x: texels per side, y: texel size (directional: scene units; point: per unit distance),
    /// z: 1 point / 0 directional (informational: shaders take the light type from `Variant`).
    pub params: Vec4,
    pub origin: Vec4,
}

pub struct ShadowMap {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    pipelines: VariantPipelines<wgpu::RenderPipeline>,
    pub size: u32,
    /// R32Float, six layers.
    pub map: wgpu::Texture,
    pub map_view: wgpu::TextureView,
    depth: wgpu::TextureView,
    /// Per face: its uniforms, their bind group and the map layer it renders into.
    faces: Vec<(wgpu::Buffer, wgpu::BindGroup, wgpu::TextureView)>,
}

impl ShadowMap {
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary, size: u32) -> Result<ShadowMap, GpuError> {
        let module = lib.module(device, "shadow_map.wgsl")?;
        let layout = ShadowMapBindings::layout(device, "ShadowMap::layout", wgpu::ShaderStages::VERTEX_FRAGMENT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ShadowMap::pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let map = texture_2d(
            device,
            "ShadowMap::map",
            size,
            size,
            6,
            Self::FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let map_view = map.create_view(&wgpu::TextureViewDescriptor {
            label: Some("ShadowMap::map_view"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let depth = texture_2d(
            device,
            "ShadowMap::depth",
            size,
            size,
            1,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
        .create_view(&Default::default());
        let faces = (0..6)
            .map(|i| {
                let buf = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(&format!("ShadowMap::face{i}")),
                    size: std::mem::size_of::<FaceUniforms>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let bg = ShadowMapBindings { face: buf.as_entire_binding() }.bind(
                    device,
                    &format!("ShadowMap::face{i}_bind_group"),
                    &layout,
                );
                let view = map.create_view(&wgpu::TextureViewDescriptor {
                    label: Some(&format!("ShadowMap::face{i}_view")),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: i,
                    array_layer_count: Some(1),
                    ..Default::default()
                });
                (buf, bg, view)
            })
            .collect();
        Ok(ShadowMap {
            module,
            pipeline_layout: pl,
            pipelines: VariantPipelines::new(Specialised::Light),
            size,
            map,
            map_view,
            depth,
            faces,
        })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        let (module, pl) = (&self.module, &self.pipeline_layout);
        self.pipelines.prepare(variant, |constants, v| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(&format!("ShadowMap::pipeline{v}")),
                layout: Some(pl),
                vertex: wgpu::VertexState {
                    module,
                    entry_point: Some("vs_main"),
                    compilation_options: super::util::options(constants),
                    buffers: &[Some(scene_vertex_layout())],
                },
                primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
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
                    targets: &[Some(Self::FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        });
    }

    /// The faces' matrices for this scene's light, and the lookup uniforms for the surface pass.
    pub fn uniforms(&self, scene: &Scene) -> ([FaceUniforms; 6], ShadowUniforms, usize) {
        let b = scene.bounds();
        let (c, r) = (b.center(), b.radius().max(1e-6));
        let mut faces = [FaceUniforms { view_proj: Mat4::IDENTITY, light: Vec4::ZERO, origin: Vec4::ZERO }; 6];
        let texel;
        let count;
        match scene.light {
            Light::Point { position: l, .. } => {
                let far = (l - c).length() + r * 2.0;
                let near = (far * 1e-5).max(1e-6);
                let proj = glam::camera::rh::proj::directx::perspective(std::f32::consts::FRAC_PI_2, 1.0, near, far);
                let dirs = [
                    (Vec3::X, -Vec3::Y),
                    (-Vec3::X, -Vec3::Y),
                    (Vec3::Y, Vec3::Z),
                    (-Vec3::Y, -Vec3::Z),
                    (Vec3::Z, -Vec3::Y),
                    (-Vec3::Z, -Vec3::Y),
                ];
                for (i, (d, up)) in dirs.into_iter().enumerate() {
                    let view = glam::camera::rh::view::look_to_mat4(l, d, up);
                    faces[i] = FaceUniforms { view_proj: proj * view, light: l.extend(1.0), origin: Vec4::ZERO };
                }
                // A 90-degree face: a texel spans 2 / size per unit of distance from the light.
                texel = 2.0 / self.size as f32;
                count = 6;
            }
            Light::Directional { direction, .. } => {
                // Across the light, cover the scene without its backdrops (texel density); along it,
                // the whole scene (every caster on the light's side counts).
                let core = scene.core_bounds();
                let (cc, cr) = (core.center(), core.radius().max(1e-6));
                let w = direction.normalize_or(Vec3::Y);
                let origin = cc + w * ((c - cc).dot(w) + 2.0 * r);
                let up = if w.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
                let view = glam::camera::rh::view::look_to_mat4(origin, -w, up);
                let depth = (origin - c).dot(w) + 2.0 * r;
                let proj = glam::camera::rh::proj::directx::orthographic(-cr, cr, -cr, cr, 0.0, depth);
                let r = cr;
                faces[0] = FaceUniforms { view_proj: proj * view, light: w.extend(0.0), origin: origin.extend(1.0) };
                texel = 2.0 * r / self.size as f32;
                count = 1;
            }
        }
        let lookup = ShadowUniforms {
            view_proj: faces.map(|f| f.view_proj),
            params: Vec4::new(self.size as f32, texel, if count == 6 { 1.0 } else { 0.0 }, 0.0),
            origin: faces[0].origin,
        };
        (faces, lookup, count)
    }

    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        scene: &Scene,
        geometry: &SceneGpu,
    ) {
        // Renderer::render_frame prepares every variant it records.
        let Some(pipeline) = self.pipelines.get(variant) else { return };
        let (faces, _, count) = self.uniforms(scene);
        for (i, face) in faces.iter().enumerate().take(count) {
            let (uniforms, bind_group, view) = &self.faces[i];
            queue.write_buffer(uniforms, 0, bytemuck::bytes_of(face));
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ShadowMap::pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color { r: 3.0e38, g: 0.0, b: 0.0, a: 0.0 }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_vertex_buffer(0, geometry.vertices.slice(..));
            pass.set_index_buffer(geometry.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..geometry.index_count, 0, 0..1);
        }
    }
}

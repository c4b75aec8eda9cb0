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
//!
//! Before drawing, a compute pass (`shaders/surface_cull.wgsl`) leaves out the triangles whose
//! bounding box in pixels holds no pixel centre, and the solids' faces turned away from the eye
//! (which the pipeline's cull mode would drop after their vertex work): they would draw nothing.
//! The draw list keeps the other triangles in their order (a prefix sum places them), and each
//! run draws its part of it through indirect arguments the pass writes, so the targets are the
//! same, bit for bit; on a million-triangle scene most triangles are such, and llvmpipe's vertex
//! work and primitive assembly, which run on one thread, shrink with them.

use super::scene_gpu::{Facing, SceneGpu};
use super::util::{bindings, compute_pipeline, cull_mode, scene_vertex_layout, Kind};
use super::variant::{Specialised, Variant, VariantPipelines};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Surface's bind group (surface.wgsl).
    SurfaceBindings { frame_in: Kind::Storage }
}

bindings! {
    /// The culling's bind group (surface_cull.wgsl).
    SurfaceCullBindings {
        frame_in: Kind::Storage,
        tris: Kind::Storage,
        indices: Kind::Storage,
        lists: Kind::StorageRw,
        sides: Kind::Storage,
        threads: Kind::StorageRw,
        blocks: Kind::StorageRw,
        runs: Kind::Storage,
        args: Kind::StorageRw,
        pyramid: Kind::Storage,
    }
}

/// How [`Surface::record`] draws the scene.
pub struct EyeDrawing<'a> {
    /// Runs of consecutive meshes that keep the same faces ([`SceneGpu::draw_runs`]).
    pub runs: &'a [(std::ops::Range<u32>, Facing)],
    /// Whether faces toward the eye come out counter-clockwise ([`super::util::toward_is_ccw`]).
    pub toward_ccw: bool,
    /// Empty the triangles that would draw nothing first ([`super::Renderer::surface_culling`]).
    pub cull: bool,
}

/// The eye's draw list for one scene's geometry (surface_cull.wgsl).
struct EyeList {
    /// The scene index buffer and the frame parameters it was made from (remade when they change),
    /// and the eye's depth pyramid its bind group reads (rebound when it changes: a new image size).
    source: wgpu::Buffer,
    frame: wgpu::Buffer,
    pyramid: wgpu::Buffer,
    /// The culling's per-thread words (`mark`, `compact`).
    threads: wgpu::Buffer,
    /// The scene's indices without the triangles that would draw nothing, in their order.
    lists: wgpu::Buffer,
    /// Per block of [`Surface::CULL_BLOCK`] triangles, the kept ones before it, then the total.
    blocks: wgpu::Buffer,
    /// The runs: their count, then each one's triangles (written when they change,
    /// [`Surface::update_runs`]).
    runs: wgpu::Buffer,
    /// The runs `runs` holds, as triangle ranges (`None` until written).
    written_runs: Option<Vec<[u32; 2]>>,
    /// Each run's `DrawIndexedIndirect` arguments, written by the pass.
    args: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    triangles: u32,
    /// Meshes: no frame draws more runs than that.
    meshes: u32,
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
    cull_layout: wgpu::BindGroupLayout,
    /// surface_cull.wgsl's `mark`, `places` and `compact`.
    cull_pipelines: [wgpu::ComputePipeline; 3],
    /// `None` until bound, or when the list would not fit a storage binding or the triangles one
    /// chunk ([`SceneGpu::whole_triangles`]; then every triangle is drawn as it is).
    eye_list: Option<EyeList>,
}

impl Surface {
    /// Albedo (rgb) and the cosine of the light's incidence on the eye's side of the surface (a;
    /// negative when the light is behind it).
    pub const MATERIAL: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
    /// Eye distance (negative for the sky) and, for a surface lit from behind, the cosine between the
    /// view ray and its normal (0 when lit from the front).
    pub const DISTANCE: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;
    pub const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
    /// Triangles per workgroup of the culling's `mark` and `compact` (64 threads of 16).
    pub const CULL_BLOCK: u32 = 1024;
    /// Bytes of one run's `DrawIndexedIndirect` arguments.
    const ARGS_BYTES: u64 = 20;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Surface, GpuError> {
        let module = lib.module(device, "surface.wgsl")?;
        let layout = SurfaceBindings::layout(device, "Surface::layout", wgpu::ShaderStages::VERTEX_FRAGMENT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("Surface::pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let cull_module = lib.module(device, "surface_cull.wgsl")?;
        let cull_layout = SurfaceCullBindings::layout(device, "Surface::cull_layout", wgpu::ShaderStages::COMPUTE);
        let cull_pipelines = ["mark", "places", "compact"].map(|entry| {
            compute_pipeline(device, &format!("Surface::cull_pipeline_{entry}"), &cull_module, entry, &cull_layout)
        });
        Ok(Surface {
            module,
            pipeline_layout: pl,
            pipelines: VariantPipelines::new(Specialised::Light),
            layout,
            bind_group: None,
            cull_layout,
            cull_pipelines,
            eye_list: None,
        })
    }

    /// (Re)binds the inputs; called when the resources change. The eye's draw list is remade
    /// only for another scene (or frame buffer), and its culling rebound for another eye pyramid
    /// ([`super::EyePyramid`], which it reads: one per image size).
    pub fn bind(&mut self, device: &wgpu::Device, frame: &wgpu::Buffer, geometry: &SceneGpu, pyramid: &wgpu::Buffer) {
        let b = SurfaceBindings { frame_in: frame.as_entire_binding() };
        self.bind_group = Some(b.bind(device, "Surface::bind_group", &self.layout));
        let layout = &self.cull_layout;
        if let Some(l) = self.eye_list.as_mut().filter(|l| l.source == geometry.indices && l.frame == *frame) {
            if l.pyramid != *pyramid {
                if let Some(tris) = geometry.whole_triangles() {
                    let buffers = [&l.lists, &l.threads, &l.blocks, &l.runs, &l.args];
                    l.bind_group = Self::cull_bind_group(device, layout, frame, geometry, tris, buffers, pyramid);
                    l.pyramid = pyramid.clone();
                }
            }
            return;
        }
        self.eye_list = None;
        let limit = crate::gpu::max_binding(&device.limits());
        let bytes = geometry.index_count as u64 * 4;
        let Some(tris) = geometry.whole_triangles().filter(|_| geometry.index_count > 0 && bytes <= limit) else {
            return;
        };
        let triangles = geometry.index_count / 3;
        let meshes = geometry.meshes.len() as u32;
        // COPY_SRC: Renderer::read_eye_list, for tests.
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: usage | wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let lists = buffer("Surface::eye_list", bytes, wgpu::BufferUsages::INDEX);
        // Per `mark` thread (64 a block, the last block's too) two words; per block one, and the total.
        let block_count = triangles.div_ceil(Self::CULL_BLOCK) as u64;
        let threads = buffer("Surface::cull_threads", block_count * 64 * 8, wgpu::BufferUsages::empty());
        let blocks = buffer("Surface::cull_blocks", (block_count + 1) * 4, wgpu::BufferUsages::empty());
        let runs = buffer("Surface::cull_runs", (meshes as u64 + 1) * 8, wgpu::BufferUsages::COPY_DST);
        let args = buffer("Surface::cull_args", meshes.max(1) as u64 * Self::ARGS_BYTES, wgpu::BufferUsages::INDIRECT);
        let buffers = [&lists, &threads, &blocks, &runs, &args];
        let bind_group = Self::cull_bind_group(device, layout, frame, geometry, tris, buffers, pyramid);
        self.eye_list = Some(EyeList {
            source: geometry.indices.clone(),
            frame: frame.clone(),
            pyramid: pyramid.clone(),
            threads,
            lists,
            blocks,
            runs,
            written_runs: None,
            args,
            bind_group,
            triangles,
            meshes,
        });
    }

    /// The culling's bind group over a list's buffers (lists, threads, blocks, runs, args).
    fn cull_bind_group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        frame: &wgpu::Buffer,
        geometry: &SceneGpu,
        tris: &wgpu::Buffer,
        [lists, threads, blocks, runs, args]: [&wgpu::Buffer; 5],
        pyramid: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let b = SurfaceCullBindings {
            frame_in: frame.as_entire_binding(),
            tris: tris.as_entire_binding(),
            indices: geometry.indices.as_entire_binding(),
            lists: lists.as_entire_binding(),
            sides: geometry.eye_sides.as_entire_binding(),
            threads: threads.as_entire_binding(),
            blocks: blocks.as_entire_binding(),
            runs: runs.as_entire_binding(),
            args: args.as_entire_binding(),
            pyramid: pyramid.as_entire_binding(),
        };
        b.bind(device, "Surface::cull_bind_group", layout)
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

    /// Uploads the runs the culling writes draw arguments for (`places`) unless the list already
    /// holds them: they change only with the meshes' facing, so a camera move within it uploads
    /// nothing.
    pub fn update_runs(&mut self, queue: &wgpu::Queue, runs: &[(std::ops::Range<u32>, Facing)]) {
        let Some(list) = self.eye_list.as_mut() else { return };
        let ranges = runs.iter().map(|(r, _)| [r.start / 3, r.end / 3]);
        if runs.len() > list.meshes as usize
            || list.written_runs.as_ref().is_some_and(|w| w.iter().copied().eq(ranges.clone()))
        {
            return;
        }
        let written: Vec<[u32; 2]> = ranges.collect();
        let mut data = vec![[written.len() as u32, 0]];
        data.extend_from_slice(&written);
        queue.write_buffer(&list.runs, 0, bytemuck::cast_slice(&data));
        list.written_runs = Some(written);
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        geometry: &SceneGpu,
        targets: SurfaceTargets,
        drawing: EyeDrawing,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some(pipelines), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let EyeDrawing { runs, toward_ccw, cull } = drawing;
        // Only with this frame's runs in the list's buffer (Renderer::render_frame updates them first).
        let current = |l: &&EyeList| {
            let ranges = runs.iter().map(|(r, _)| [r.start / 3, r.end / 3]);
            l.written_runs.as_ref().is_some_and(|w| w.iter().copied().eq(ranges))
        };
        let list = self.eye_list.as_ref().filter(|l| cull && current(l));
        if let Some(list) = list {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("Surface::cull_pass"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &list.bind_group, &[]);
            // One workgroup per block of triangles, spread over y past the 65 535 limit on x.
            let groups = list.triangles.div_ceil(Self::CULL_BLOCK).max(1);
            let x = groups.min(65_535);
            let [mark, places, compact] = &self.cull_pipelines;
            pass.set_pipeline(mark);
            pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
            pass.set_pipeline(places);
            pass.dispatch_workgroups(1, 1, 1);
            pass.set_pipeline(compact);
            pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
        }
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
                // Stored: the eye's pyramid reduces it for the frames after this one.
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, bind_group, &[]);
        pass.set_vertex_buffer(0, geometry.vertices.slice(..));
        let indices = list.map_or(&geometry.indices, |l| &l.lists);
        pass.set_index_buffer(indices.slice(..), wgpu::IndexFormat::Uint32);
        for (i, (range, facing)) in runs.iter().enumerate() {
            pass.set_pipeline(&pipelines[cull_mode(*facing, toward_ccw).0]);
            match list {
                Some(l) => pass.draw_indexed_indirect(&l.args, i as u64 * Self::ARGS_BYTES),
                None => pass.draw_indexed(range.clone(), 0, 0..1),
            }
        }
    }

    /// The draw list of the last culled frame ([`Surface::record`] with `cull`; `None` without a
    /// list) and the buffer whose last word holds its triangle count, for tests.
    pub fn eye_list(&self) -> Option<(&wgpu::Buffer, &wgpu::Buffer)> {
        self.eye_list.as_ref().map(|l| (&l.lists, &l.blocks))
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

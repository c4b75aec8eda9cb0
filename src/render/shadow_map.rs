//! ShadowMap: the depth of the nearest surface seen from the light (`shaders/shadow_map.wgsl`).
//!
//! Point light: a cube of six 90-degree faces around the light, reversed infinite perspective
//! (`depth = near / a`, `a` the distance along the face's axis). Directional light: one
//! orthographic view along `-w` over the rectangle the casters' box projects to across the light
//! (`depth = s / far`, `s` the distance from a plane beyond the scene), narrowed on the GPU to the
//! part of it the frame looks up ([`super::ShadowFit`], which runs after Surface: the face's matrix
//! and the lookups' are copied from its result). Depth only: no fragment
//! shader and no colour target, which on llvmpipe took six 2048² faces over 100 000 triangles
//! from 190–215 to 136–145 ms (docs/results.md). The lookups
//! (`shaders/shadow_lookup.wgsl`) turn a stored depth back into a distance along the point's own
//! direction and compare it with the point's, with a small bias.
//!
//! Face culling (point light): a compute pass (`shaders/shadow_cull.wgsl`) first lists, per face,
//! the triangles that can reach its 90-degree pyramid, and each face draws only its list
//! (`draw_indexed_indirect`). Without it every face draws every triangle: six times the vertex
//! work, which on llvmpipe is single-threaded and was the largest cost of big scenes under a
//! point light. Skipped (every face draws all) when the lists would not fit a storage binding
//! (or the triangles one chunk, [`SceneGpu::whole_triangles`], which the culling reads).
//! The sun's map draws a list the same way (`sun` in shadow_cull.wgsl): the solids' faces toward
//! the light, less the triangles an earlier frame's pyramid of the same map shows hidden, which
//! could not win its depth test ([`super::ShadowPyramid`]; the same map, bit for bit).
//!
//! Size: `size` is a budget, texels per side of a square. A cube's faces are that square; a sun's
//! map for a frame whose volume does not read it (VSV's) holds about `size²` texels shaped so
//! that they are square over the rectangle it covers ([`ShadowMap::dims`], [`sun_dims`]; the
//! rectangle's aspect comes from the last frame's fit, [`super::shadow_fit::AspectReadback`]).

use super::scene_gpu::{Facing, SceneGpu};
use super::util::{bindings, compute_pipeline, cull_mode, scene_vertex_layout, texture_2d, toward_is_ccw, Kind};
use super::variant::{Specialised, Variant, VariantPipelines};
use crate::gpu::{GpuError, ShaderLibrary};
use crate::params::Light;
use crate::scene::{Aabb, Scene};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3, Vec4};

bindings! {
    /// One face's bind group (shadow_map.wgsl).
    ShadowMapBindings { face: Kind::Uniform }
}

bindings! {
    /// The face culling's bind group (shadow_cull.wgsl).
    ShadowCullBindings {
        cull_in: Kind::Storage,
        tris: Kind::Storage,
        indices: Kind::Storage,
        lists: Kind::StorageRw,
        args: Kind::StorageRw,
        sides: Kind::Storage,
        pyramid: Kind::Storage,
    }
}

/// The face culling's parameters (`struct ShadowCull` in shadow_cull.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct ShadowCullUniforms {
    /// xyz: the light's position (point) or the direction toward it (sun).
    pub light: Vec4,
    /// x: triangles, y: indices per face region (the scene's index count), z: the pyramid's
    /// coarsest level the sun list may read (0: none), w: unused.
    pub counts: [u32; 4],
    /// The sun map's view-projection.
    pub view_proj: Mat4,
    /// The sun map's width and height in texels ([`ShadowMap::dims`]); zw unused.
    pub map_size: [u32; 4],
}

/// What face culling holds for one scene's geometry.
struct FaceLists {
    /// The scene index buffer the lists were made for (they are remade only when it changes,
    /// not when the image or the grid does), and the sun's pyramid they read.
    source: wgpu::Buffer,
    pyramid: wgpu::Buffer,
    /// Six regions of the scene's index count; face k's starts at `k * index_count`.
    lists: wgpu::Buffer,
    /// Six DrawIndexedIndirect arguments, reset from `args_init` each frame.
    args: wgpu::Buffer,
    args_init: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    triangles: u32,
    index_count: u32,
}

/// How [`ShadowMap::record`] draws the map: its faces, what it leaves out, and the fit it draws
/// with.
pub struct MapDrawing<'a> {
    /// The faces to draw (six for a point light, one for a sun): [`ShadowMap::uniforms`] as the
    /// frame's `prepare` computed them (it walks every vertex; once per frame is enough).
    pub matrices: &'a [FaceUniforms],
    /// Point light: each cube face draws only the triangles that can reach it. Sun: the map draws
    /// a list of the triangles it needs (solids' faces toward the light, and not hidden).
    pub faces: bool,
    /// Sun: the coarsest level of a pyramid made from a map with this frame's inputs, whose hidden
    /// triangles the list leaves out (0: none; [`super::ShadowPyramid`]).
    pub hidden: u32,
    /// Per mesh: the faces the light can see first ([`SceneGpu::update_light_facing`]).
    pub light_facing: &'a [Facing],
    /// A directional map fitted to the view: the pass whose result replaces the casters' fit in
    /// the face's matrix and the draw list's parameters (`None`: the casters' fit, or a cube).
    pub fit: Option<&'a super::ShadowFit>,
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
    /// x: the budget's texels per side ([`ShadowMap::size`]), y: texel size (directional: the
    /// longer side, scene units; point: per unit distance), z: 1 point / 0 directional
    /// (informational: shaders take the light type from `Variant`), w: the cube's near distance
    /// (point) or the orthographic depth range (directional).
    pub params: Vec4,
    pub origin: Vec4,
    /// Each layer's width and height in texels ([`ShadowMap::dims`]) and their reciprocals.
    pub size: Vec4,
}

pub struct ShadowMap {
    module: wgpu::ShaderModule,
    pipeline_layout: wgpu::PipelineLayout,
    /// Per variant, one pipeline per cull mode ([`super::util::facing_pipelines`]).
    pipelines: VariantPipelines<Vec<wgpu::RenderPipeline>>,
    /// The budget, as texels per side of a square (`--shadow-map`, the editor's size): a cube
    /// face is that square, a sun's map holds about its square's texels ([`ShadowMap::dims`]).
    pub size: u32,
    /// Each layer's width and height in texels: `size` square for a point light's cube; for a
    /// sun, shaped to the rectangle the map covers so that its texels are about square
    /// ([`sun_dims`]). Texels 2.4 times longer one way than the other (the square map over the
    /// classroom's 13.6 x 5.7 m) waste the budget along the short side and size the surfaces'
    /// slope bias to the long one: shaped, the classroom's whole image is ~15% closer to the
    /// reference for the same texels (docs/results.md, session 41).
    pub dims: (u32, u32),
    /// [`ShadowMap::FORMAT`], six layers of `dims`.
    pub map: wgpu::Texture,
    pub map_view: wgpu::TextureView,
    /// Per face: its uniforms and their bind group.
    faces: Vec<(wgpu::Buffer, wgpu::BindGroup)>,
    /// Per face: the map layer it renders into.
    face_views: Vec<wgpu::TextureView>,
    cull_layout: wgpu::BindGroupLayout,
    cull_pipeline: wgpu::ComputePipeline,
    /// The sun's list (`sun` in shadow_cull.wgsl).
    sun_pipeline: wgpu::ComputePipeline,
    cull_uniforms: wgpu::Buffer,
    /// `None` until bound, or when the lists would not fit a storage binding (or the triangles
    /// one chunk).
    face_lists: Option<FaceLists>,
}

impl ShadowMap {
    pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary, size: u32) -> Result<ShadowMap, GpuError> {
        let module = lib.module(device, "shadow_map.wgsl")?;
        let layout = ShadowMapBindings::layout(device, "ShadowMap::layout", wgpu::ShaderStages::VERTEX_FRAGMENT);
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("ShadowMap::pipeline_layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let (map, map_view, face_views) = Self::texture(device, (size, size));
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
                (buf, bg)
            })
            .collect();
        let cull_module = lib.module(device, "shadow_cull.wgsl")?;
        let cull_layout = ShadowCullBindings::layout(device, "ShadowMap::cull_layout", wgpu::ShaderStages::COMPUTE);
        let cull_pipeline = compute_pipeline(device, "ShadowMap::cull_pipeline", &cull_module, "main", &cull_layout);
        let sun_pipeline = compute_pipeline(device, "ShadowMap::sun_pipeline", &cull_module, "sun", &cull_layout);
        let cull_uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ShadowMap::cull_uniforms"),
            size: std::mem::size_of::<ShadowCullUniforms>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(ShadowMap {
            module,
            pipeline_layout: pl,
            pipelines: VariantPipelines::new(Specialised::Light),
            size,
            dims: (size, size),
            map,
            map_view,
            faces,
            face_views,
            cull_layout,
            cull_pipeline,
            sun_pipeline,
            cull_uniforms,
            face_lists: None,
        })
    }

    /// The map's texture of six `dims` layers, its array view (the lookups') and one view per layer
    /// (the faces' render targets).
    fn texture(device: &wgpu::Device, dims: (u32, u32)) -> (wgpu::Texture, wgpu::TextureView, Vec<wgpu::TextureView>) {
        let map = texture_2d(
            device,
            "ShadowMap::map",
            dims.0,
            dims.1,
            6,
            Self::FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let map_view = map.create_view(&wgpu::TextureViewDescriptor {
            label: Some("ShadowMap::map_view"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let face_views = (0..6)
            .map(|i| {
                map.create_view(&wgpu::TextureViewDescriptor {
                    label: Some(&format!("ShadowMap::face{i}_view")),
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: i,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        (map, map_view, face_views)
    }

    /// Remakes the texture at `dims` unless it has them; true when it did (the lookups' and the
    /// pyramid's bind groups then need the new view).
    pub fn set_dims(&mut self, device: &wgpu::Device, dims: (u32, u32)) -> bool {
        if dims == self.dims {
            return false;
        }
        (self.map, self.map_view, self.face_views) = Self::texture(device, dims);
        self.dims = dims;
        true
    }

    /// The layers' width and height a frame under `scene`'s light wants: the budget's square for
    /// a point light and for a map that is not `shaped`; else, for a sun, [`sun_dims`] for the
    /// rectangle's `aspect` (width over height in scene units; `None`: the casters' rectangle,
    /// [`ShadowMap::uniforms`]'s unfitted one), no side past `max_side`.
    ///
    /// Only maps that serve the surfaces alone are shaped (VSV's, whose volume is the grid's):
    /// the march also samples its volume in the map, and there the shape trades the other way.
    /// On the classroom square texels took the 1024-step march on the 4096 map from 0.764% to
    /// 0.89% off the reference's scattered light (its shaft's long upper edge runs across the
    /// map's short side, which the square map resolves 1.5 times finer; docs/results.md,
    /// session 41), so the march keeps the square.
    pub fn wanted_dims(&self, scene: &Scene, shaped: bool, aspect: Option<f32>, max_side: u32) -> (u32, u32) {
        let Light::Directional { direction, .. } = scene.light else { return (self.size, self.size) };
        if !shaped {
            return (self.size, self.size);
        }
        let aspect = aspect.unwrap_or_else(|| {
            // (Margins of a huge map's half texel: none to speak of.)
            let core = scene.core_bounds();
            let view = Self::sun_view(&scene.bounds(), &core, direction).0;
            let (lo, hi) = light_rectangle(&core, view, (u32::MAX, u32::MAX));
            let d = hi - lo;
            d.x / d.y
        });
        sun_dims(self.size, aspect, self.dims, max_side)
    }

    /// Whether the faces can be culled for the bound geometry (the lists fit a storage binding).
    pub fn has_face_lists(&self) -> bool {
        self.face_lists.is_some()
    }

    /// Makes the face lists for `geometry` unless they were made for it and `pyramid` (the sun's,
    /// [`super::ShadowPyramid`]). Without room for them in one storage binding (or for the
    /// triangles in one chunk, [`SceneGpu::whole_triangles`]) the faces draw every triangle.
    pub fn bind(&mut self, device: &wgpu::Device, geometry: &SceneGpu, pyramid: &wgpu::Buffer) {
        let limit = crate::gpu::max_binding(&device.limits());
        if self.face_lists.as_ref().is_some_and(|fl| fl.source == geometry.indices && fl.pyramid == *pyramid) {
            return;
        }
        let index_bytes = geometry.index_count as u64 * 4;
        self.face_lists = None;
        let Some(tris) = geometry.whole_triangles().filter(|_| geometry.index_count > 0 && 6 * index_bytes <= limit)
        else {
            return;
        };
        let lists = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ShadowMap::face_lists"),
            size: 6 * index_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDEX,
            mapped_at_creation: false,
        });
        let init: Vec<u32> = (0..6u32).flat_map(|k| [0, 1, k * geometry.index_count, 0, 0]).collect();
        use wgpu::util::DeviceExt;
        let args_init = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ShadowMap::face_args_init"),
            contents: bytemuck::cast_slice(&init),
            usage: wgpu::BufferUsages::COPY_SRC,
        });
        let args = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ShadowMap::face_args"),
            size: args_init.size(),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = ShadowCullBindings {
            cull_in: self.cull_uniforms.as_entire_binding(),
            tris: tris.as_entire_binding(),
            indices: geometry.indices.as_entire_binding(),
            lists: lists.as_entire_binding(),
            args: args.as_entire_binding(),
            sides: geometry.light_sides.as_entire_binding(),
            pyramid: pyramid.as_entire_binding(),
        }
        .bind(device, "ShadowMap::cull_bind_group", &self.cull_layout);
        self.face_lists = Some(FaceLists {
            source: geometry.indices.clone(),
            pyramid: pyramid.clone(),
            lists,
            args,
            args_init,
            bind_group,
            triangles: geometry.index_count / 3,
            index_count: geometry.index_count,
        });
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        let (module, pl) = (&self.module, &self.pipeline_layout);
        self.pipelines.prepare(variant, |constants, v| {
            super::util::facing_pipelines(|cull, name| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(&format!("ShadowMap::pipeline{v}{name}")),
                    layout: Some(pl),
                    vertex: wgpu::VertexState {
                        module,
                        entry_point: Some("vs_main"),
                        compilation_options: super::util::options(constants),
                        buffers: &[Some(scene_vertex_layout())],
                    },
                    primitive: wgpu::PrimitiveState { cull_mode: cull, ..Default::default() },
                    depth_stencil: Some(wgpu::DepthStencilState {
                        format: Self::FORMAT,
                        depth_write_enabled: Some(true),
                        depth_compare: Some(Self::compare(variant.point_light)),
                        stencil: Default::default(),
                        bias: Default::default(),
                    }),
                    multisample: Default::default(),
                    fragment: None,
                    multiview_mask: None,
                    cache: None,
                })
            })
        });
    }

    /// Nearer is larger under the cube's reversed depth, smaller under the orthographic one.
    fn compare(point_light: bool) -> wgpu::CompareFunction {
        if point_light {
            wgpu::CompareFunction::Greater
        } else {
            wgpu::CompareFunction::Less
        }
    }

    /// The depth of an empty texel: the farthest value under [`ShadowMap::compare`].
    fn empty(point_light: bool) -> f32 {
        if point_light {
            0.0
        } else {
            1.0
        }
    }

    /// The faces' matrices for this scene's light, and the lookup uniforms for the surface pass.
    pub fn uniforms(&self, scene: &Scene) -> ([FaceUniforms; 6], ShadowUniforms, usize) {
        let b = scene.bounds();
        let (c, r) = (b.center(), b.radius().max(1e-6));
        let mut faces = [FaceUniforms { view_proj: Mat4::IDENTITY, light: Vec4::ZERO, origin: Vec4::ZERO }; 6];
        let texel;
        let count;
        let near_or_range;
        match scene.light {
            Light::Point { position: l, .. } => {
                let far = (l - c).length() + r * 2.0;
                near_or_range = (far * 1e-5).max(1e-6);
                // Reversed and infinite: depth = near / a keeps f32's relative precision at every
                // distance (a forward projection keeps it only near the light).
                let proj = glam::camera::rh::proj::directx::perspective_infinite_reverse(
                    std::f32::consts::FRAC_PI_2,
                    1.0,
                    near_or_range,
                );
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
                texel = 2.0 / self.dims.0 as f32;
                count = 6;
            }
            Light::Directional { direction, .. } => {
                // Across the light, the rectangle the scene without its backdrops projects to (its
                // box's corners in light space: texel density where the casters are, a square
                // around its bounding sphere wasted up to 3.5x in one axis on the classroom);
                // along it, the whole scene (every caster on the light's side counts).
                let core = scene.core_bounds();
                let (view, origin, w) = Self::sun_view(&b, &core, direction);
                let depth = (origin - c).dot(w) + 2.0 * r;
                near_or_range = depth;
                let (lo, hi) = light_rectangle(&core, view, self.dims);
                let proj = glam::camera::rh::proj::directx::orthographic(lo.x, hi.x, lo.y, hi.y, 0.0, depth);
                faces[0] = FaceUniforms { view_proj: proj * view, light: w.extend(0.0), origin: origin.extend(1.0) };
                // The bias works in the coarser of the two texel sides.
                texel = ((hi - lo) / glam::Vec2::new(self.dims.0 as f32, self.dims.1 as f32)).max_element();
                count = 1;
            }
        }
        let (width, height) = (self.dims.0 as f32, self.dims.1 as f32);
        let lookup = ShadowUniforms {
            view_proj: faces.map(|f| f.view_proj),
            params: Vec4::new(self.size as f32, texel, if count == 6 { 1.0 } else { 0.0 }, near_or_range),
            origin: faces[0].origin,
            size: Vec4::new(width, height, 1.0 / width, 1.0 / height),
        };
        (faces, lookup, count)
    }

    /// A sun's light view: from a point far on the light's side of the scene's core (`core`, its
    /// box without backdrops; `bounds` the whole scene's: both walk every vertex, so the caller
    /// passes them), looking along the light; and that point and the unit direction toward the
    /// light.
    fn sun_view(bounds: &Aabb, core: &Aabb, direction: Vec3) -> (Mat4, Vec3, Vec3) {
        let (c, r) = (bounds.center(), bounds.radius().max(1e-6));
        let cc = core.center();
        let w = direction.normalize_or(Vec3::Y);
        let origin = cc + w * ((c - cc).dot(w) + 2.0 * r);
        let up = if w.y.abs() > 0.9 { Vec3::Z } else { Vec3::Y };
        (glam::camera::rh::view::look_to_mat4(origin, -w, up), origin, w)
    }

    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        scene: &Scene,
        geometry: &SceneGpu,
        drawing: MapDrawing,
    ) {
        // Renderer::render_frame prepares every variant it records.
        let Some(pipelines) = self.pipelines.get(variant) else { return };
        let faces = drawing.matrices;
        let culled = match (&self.face_lists, scene.light) {
            (Some(fl), light) if drawing.faces => {
                let (light, pipeline) = match light {
                    Light::Point { position, .. } => (position.extend(1.0), &self.cull_pipeline),
                    Light::Directional { direction, .. } => (direction.extend(0.0), &self.sun_pipeline),
                };
                let u = ShadowCullUniforms {
                    light,
                    counts: [fl.triangles, fl.index_count, drawing.hidden, 0],
                    view_proj: faces[0].view_proj,
                    map_size: [self.dims.0, self.dims.1, 0, 0],
                };
                queue.write_buffer(&self.cull_uniforms, 0, bytemuck::bytes_of(&u));
                if let Some(fit) = drawing.fit {
                    fit.copy_matrix(
                        encoder,
                        &self.cull_uniforms,
                        std::mem::offset_of!(ShadowCullUniforms, view_proj) as u64,
                    );
                }
                encoder.copy_buffer_to_buffer(&fl.args_init, 0, &fl.args, 0, fl.args_init.size());
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: Some("ShadowMap::cull_pass"),
                    timestamp_writes: None,
                });
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &fl.bind_group, &[]);
                // 64 triangles a workgroup, spread over y past the 65 535 limit on x.
                let groups = fl.triangles.div_ceil(64).max(1);
                let x = groups.min(65_535);
                pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
                Some(fl)
            }
            _ => None,
        };
        // Without face lists the solids the light lies outside of draw only their faces toward
        // it, mesh runs at a time (the face lists already left the others out).
        let runs = if culled.is_none() { geometry.draw_runs(drawing.light_facing) } else { Vec::new() };
        for (i, face) in faces.iter().enumerate() {
            let (uniforms, bind_group) = &self.faces[i];
            let view = &self.face_views[i];
            queue.write_buffer(uniforms, 0, bytemuck::bytes_of(face));
            // A directional map fitted to the view (one face): ShadowFit's matrix replaces the
            // casters' fit (the queue's write lands before the frame's commands).
            if let Some(fit) = drawing.fit {
                fit.copy_matrix(encoder, uniforms, std::mem::offset_of!(FaceUniforms, view_proj) as u64);
            }
            let clear = Self::empty(variant.point_light);
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("ShadowMap::pass"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, bind_group, &[]);
            pass.set_vertex_buffer(0, geometry.vertices.slice(..));
            match culled {
                Some(fl) => {
                    pass.set_pipeline(&pipelines[0]);
                    pass.set_index_buffer(fl.lists.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed_indirect(&fl.args, 20 * i as u64);
                }
                None => {
                    // A point in front of the face and the way back to the light (a point light's
                    // position, or the direction toward the sun).
                    let at = face.view_proj.inverse().project_point3(Vec3::new(0.0, 0.0, 0.5));
                    let toward = face.light.truncate() - face.light.w * at;
                    let ccw = toward_is_ccw(face.view_proj, at, toward);
                    pass.set_index_buffer(geometry.indices.slice(..), wgpu::IndexFormat::Uint32);
                    for (range, facing) in &runs {
                        pass.set_pipeline(&pipelines[cull_mode(*facing, ccw).0]);
                        pass.draw_indexed(range.clone(), 0, 0..1);
                    }
                }
            }
        }
    }
}

/// The rectangle of the directional map in light view space: the box's eight corners under
/// `view`, with half a texel of margin and never a zero-width side (a flat scene seen edge-on).
fn light_rectangle(core: &crate::scene::Aabb, view: Mat4, dims: (u32, u32)) -> (glam::Vec2, glam::Vec2) {
    let (mut lo, mut hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
    for corner in core.corners() {
        let p = view.transform_point3(corner).truncate();
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let pad = ((hi - lo) * 0.5 / glam::Vec2::new(dims.0 as f32, dims.1 as f32)).max(glam::Vec2::splat(1e-6));
    (lo - pad, hi + pad)
}

/// The width and height of a sun's map of about `size²` texels whose texels are square over a
/// rectangle `aspect` times as wide as high (scene units). The aspect goes in steps of 2^(1/4)
/// within [1/4, 4] (texels at most 2^(1/8) from square), and `current`'s step stays while the
/// aspect lies within 3/4 of a step of it, so that a moving view seldom remakes the texture;
/// sides are multiples of size / 32 (64 texels, llvmpipe's tile, from a 2048 budget on) and at
/// most `max_side`; a side held at `max_side` leaves the other what the budget gives it (an
/// adapter whose largest texture is the budget's side keeps the square). A non-finite or
/// non-positive aspect keeps `current`'s step.
pub fn sun_dims(size: u32, aspect: f32, current: (u32, u32), max_side: u32) -> (u32, u32) {
    const STEPS: f32 = 4.0;
    let step = |w: u32, h: u32| (STEPS * (w as f32 / h.max(1) as f32).log2()).round().clamp(-8.0, 8.0);
    let at = step(current.0, current.1);
    let want = if aspect.is_finite() && aspect > 0.0 { (STEPS * aspect.log2()).clamp(-8.0, 8.0) } else { at };
    let k = if (want - at).abs() <= 0.75 { at } else { want.round() };
    let r = 2f32.powf(k / (2.0 * STEPS));
    let grain = (size / 32).clamp(1, 64);
    let side = |x: f32| (((x / grain as f32).round() as u32).max(1) * grain).min(max_side.max(1));
    let (cap, budget) = (max_side.max(1) as f32, size as f32 * size as f32);
    let (w, h) = match (size as f32 * r, size as f32 / r) {
        (w, _) if w > cap => (cap, (budget / cap).min(cap)),
        (_, h) if h > cap => ((budget / cap).min(cap), cap),
        wh => wh,
    };
    (side(w), side(h))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A long, low box under a slanting sun: the map's rectangle holds every corner, touches the
    /// outermost ones within a texel on both axes, and is much narrower than the bounding sphere's
    /// square across the box (the classroom's case: 13.9 m against 48.4 m).
    #[test]
    fn the_directional_map_fits_the_casters_rectangle() {
        let core = Aabb { min: Vec3::new(-4.5, -0.2, -23.3), max: Vec3::new(8.2, 3.1, 23.2) };
        let w = Vec3::new(-0.866, 0.417, -0.277).normalize();
        let view = glam::camera::rh::view::look_to_mat4(core.center() + w * 100.0, -w, Vec3::Y);
        let size = 2048;
        let (lo, hi) = light_rectangle(&core, view, (size, size));
        let texel = (hi - lo) / size as f32;
        let (mut seen_lo, mut seen_hi) = (glam::Vec2::splat(f32::INFINITY), glam::Vec2::splat(f32::NEG_INFINITY));
        for c in core.corners() {
            let p = view.transform_point3(c).truncate();
            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "corner {c} at {p} outside {lo}..{hi}");
            seen_lo = seen_lo.min(p);
            seen_hi = seen_hi.max(p);
        }
        assert!((seen_lo - lo).cmple(texel).all() && (hi - seen_hi).cmple(texel).all(), "not tight");
        let diameter = 2.0 * core.radius();
        let (wide, narrow) = ((hi - lo).max_element(), (hi - lo).min_element());
        assert!(wide <= diameter * 1.01 && narrow < diameter / 3.0, "{wide} x {narrow} against {diameter}");
    }

    /// A sun's map holds about its budget's texels, with texels within 2^(1/8) of square (and
    /// the sides' rounding to 64 texels) over the rectangle; it keeps its step while the aspect
    /// wavers within 3/4 of a step, stops at 4:1 and at the adapter's side, and keeps its shape
    /// for an aspect that is no number.
    #[test]
    fn a_sun_map_is_shaped_to_its_rectangle() {
        let square = (2048, 2048);
        for aspect in [1.0f32, 1.3, 2.39, 3.4, 0.42, 4.0, 0.25] {
            let (w, h) = sun_dims(2048, aspect, square, 16384);
            assert!(w % 64 == 0 && h % 64 == 0, "{aspect}: {w} x {h}");
            // A texel's width over its height: (aspect / w) / (1 / h).
            let texel = aspect * h as f32 / w as f32;
            assert!(texel.log2().abs() <= 0.125 + 0.03, "{aspect}: {w} x {h}, texels {texel}:1");
            let count = w as f64 * h as f64 / (2048.0 * 2048.0);
            assert!((count - 1.0).abs() < 0.03, "{aspect}: {w} x {h} holds {count} of the budget");
        }
        assert_eq!(sun_dims(2048, 50.0, square, 16384), (4096, 1024));
        assert_eq!(sun_dims(2048, 0.01, square, 16384), (1024, 4096));
        let classroom = sun_dims(2048, 2.39, square, 16384);
        assert_eq!(classroom, (3136, 1344));
        assert_eq!(sun_dims(2048, 2.39 * 2f32.powf(0.15), classroom, 16384), classroom);
        assert_eq!(sun_dims(2048, 2.39 / 2f32.powf(0.15), classroom, 16384), classroom);
        assert_ne!(sun_dims(2048, 2.39 * 2f32.powf(0.25), classroom, 16384), classroom);
        assert_eq!(sun_dims(2048, f32::NAN, classroom, 16384), classroom);
        assert_eq!(sun_dims(2048, -1.0, classroom, 16384), classroom);
        assert_eq!(sun_dims(8192, 4.0, (8192, 8192), 16384), (16384, 4096));
        // At the adapter's limit the other side takes the rest of the budget.
        assert_eq!(sun_dims(8192, 4.0, (8192, 8192), 8192), (8192, 8192));
        assert_eq!(sun_dims(2048, 2.39, square, 2048), square);
        assert_eq!(sun_dims(2048, 2.39, square, 2560), (2560, 1664));
        // A small budget rounds to a finer grain.
        let (w, h) = sun_dims(64, 2.39, (64, 64), 16384);
        assert!((w * h) as f64 / 4096.0 > 0.9 && w > h, "{w} x {h}");
    }
}

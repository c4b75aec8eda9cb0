//! Small constructors shared by the passes (bind groups, textures, pipelines).

/// What one binding of a pass's bind group holds (its layout entry's type).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Uniform,
    /// `var<storage, read>`.
    Storage,
    /// `var<storage, read_write>`.
    StorageRw,
    /// `texture_2d<f32>`, not filterable (loaded, never sampled).
    Texture,
    /// `texture_2d_array<f32>`, not filterable.
    TextureArray,
    /// `texture_depth_2d_array` (loaded, or sampled with a comparison sampler).
    DepthArray,
    /// `sampler_comparison`.
    ComparisonSampler,
    /// `texture_storage_2d<format, write>`.
    StorageTexture(wgpu::TextureFormat),
}

impl Kind {
    pub fn entry(self, binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
        match self {
            Kind::Uniform => uniform_entry(binding, visibility),
            Kind::Storage => storage_entry(binding, visibility, true),
            Kind::StorageRw => storage_entry(binding, visibility, false),
            Kind::Texture => texture_entry(binding, visibility, wgpu::TextureViewDimension::D2),
            Kind::TextureArray => texture_entry(binding, visibility, wgpu::TextureViewDimension::D2Array),
            Kind::DepthArray => wgpu::BindGroupLayoutEntry {
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Depth,
                    view_dimension: wgpu::TextureViewDimension::D2Array,
                    multisampled: false,
                },
                ..texture_entry(binding, visibility, wgpu::TextureViewDimension::D2Array)
            },
            Kind::ComparisonSampler => wgpu::BindGroupLayoutEntry {
                binding,
                visibility,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                count: None,
            },
            Kind::StorageTexture(format) => {
                wgpu::BindGroupLayoutEntry { visibility, ..storage_texture_entry(binding, format) }
            }
        }
    }
}

/// Declares a pass's bind group once: a struct with one field per binding, in binding order and
/// named as the WGSL variable, with the layout and the bind group built from that one list (a
/// test checks the names and kinds against the WGSL, `render::binding_tests`).
macro_rules! bindings {
    ($(#[$doc:meta])* $name:ident { $($field:ident: $kind:expr),* $(,)? }) => {
        $(#[$doc])*
        pub struct $name<'a> {
            $(pub $field: wgpu::BindingResource<'a>,)*
        }

        impl $name<'_> {
            /// The WGSL variable name and kind of each binding, in binding order.
            pub const SLOTS: &'static [(&'static str, $crate::render::util::Kind)] = &[$((stringify!($field), $kind)),*];

            /// The bind-group layout, every binding visible to `visibility`.
            pub fn layout(device: &wgpu::Device, label: &str, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayout {
                let entries: Vec<wgpu::BindGroupLayoutEntry> =
                    Self::SLOTS.iter().enumerate().map(|(i, (_, kind))| kind.entry(i as u32, visibility)).collect();
                device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(label), entries: &entries })
            }

            pub fn bind(self, device: &wgpu::Device, label: &str, layout: &wgpu::BindGroupLayout) -> wgpu::BindGroup {
                let resources = [$(self.$field),*];
                let entries: Vec<wgpu::BindGroupEntry> = resources
                    .into_iter()
                    .enumerate()
                    .map(|(i, resource)| wgpu::BindGroupEntry { binding: i as u32, resource })
                    .collect();
                device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout, entries: &entries })
            }
        }
    };
}
pub(crate) use bindings;

pub fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub fn storage_entry(binding: u32, visibility: wgpu::ShaderStages, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub fn texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    dim: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: dim,
            multisampled: false,
        },
        count: None,
    }
}

pub fn storage_texture_entry(binding: u32, format: wgpu::TextureFormat) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    layers: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: layers },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// Compilation options carrying the WGSL `override` values of a [`super::Variant`].
pub fn options<'a>(constants: &'a [(&'a str, f64)]) -> wgpu::PipelineCompilationOptions<'a> {
    wgpu::PipelineCompilationOptions { constants, ..Default::default() }
}

/// An unspecialised compute pipeline with one bind group, of `module`'s entry point `entry` (the
/// passes whose shaders read neither the light type nor the phase; the others use
/// `variant::SpecialisedCompute`).
pub fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    entry: &str,
    layout: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pl),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Vertex layout of the scene's vertex buffer: position and albedo, both `vec3<f32>`.
pub const SCENE_VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

/// Workgroups `(x, y)` for `groups` of them in one dispatch: two dimensions past the 65535 one
/// dimension allows (the shaders take `id.x + id.y * num_workgroups.x * size`).
pub fn split_groups(groups: u32) -> (u32, u32) {
    let groups = groups.max(1);
    if groups > 65535 {
        (65535, groups.div_ceil(65535))
    } else {
        (groups, 1)
    }
}

/// Records a reduction over the image's pixels in one compute pass: `reduce` with a thread per
/// column of `rows` pixels and 64 columns a workgroup, then `finish` on one thread (Ranges,
/// ShadowFit).
pub fn record_reduction(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    [reduce, finish]: &[wgpu::ComputePipeline; 2],
    bind_group: &wgpu::BindGroup,
    (width, height, rows): (u32, u32, u32),
) {
    let mut pass =
        encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(label), timestamp_writes: None });
    pass.set_bind_group(0, bind_group, &[]);
    pass.set_pipeline(reduce);
    pass.dispatch_workgroups(width.div_ceil(64), height.div_ceil(rows), 1);
    pass.set_pipeline(finish);
    pass.dispatch_workgroups(1, 1, 1);
}

pub fn scene_vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 24,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &SCENE_VERTEX_ATTRIBUTES,
    }
}

/// Cull modes of the pipelines [`facing_pipelines`] builds, in order.
const CULL_MODES: [(Option<wgpu::Face>, &str); 3] =
    [(None, ""), (Some(wgpu::Face::Back), "[cull back]"), (Some(wgpu::Face::Front), "[cull front]")];

/// One raster pipeline per cull mode (none, back, front), for passes that draw solids one-sided
/// ([`super::scene_gpu::Facing`]); `build` gets the mode and a label suffix.
pub fn facing_pipelines<P>(mut build: impl FnMut(Option<wgpu::Face>, &str) -> P) -> Vec<P> {
    CULL_MODES.iter().map(|&(cull, name)| build(cull, name)).collect()
}

/// The pipeline of [`facing_pipelines`] (its index and cull mode) that keeps `facing`'s faces,
/// given whether faces toward the viewpoint come out counter-clockwise ([`toward_is_ccw`]).
pub fn cull_mode(facing: super::scene_gpu::Facing, toward_ccw: bool) -> (usize, Option<wgpu::Face>) {
    use super::scene_gpu::Facing;
    // wgpu's default front face is counter-clockwise.
    let keep_ccw = match facing {
        Facing::Both => return (0, None),
        Facing::Toward => toward_ccw,
        Facing::Away => !toward_ccw,
    };
    if keep_ccw {
        (1, CULL_MODES[1].0)
    } else {
        (2, CULL_MODES[2].0)
    }
}

/// Whether a triangle whose winding normal `(b - a) x (c - a)` faces the viewpoint comes out
/// counter-clockwise in `view_proj`'s normalized device coordinates. `at` is a point in front of
/// the view and `toward` the way from it to the viewpoint (its length the distance, for a
/// perspective view): rather than trusting a handedness convention, a small triangle there facing
/// the viewpoint is projected and its signed area read.
pub fn toward_is_ccw(view_proj: glam::Mat4, at: glam::Vec3, toward: glam::Vec3) -> bool {
    let n = toward.normalize_or(glam::Vec3::Z);
    // Two directions across n with u x v = n, a tenth of the distance long: the triangle stays in
    // front of a perspective viewpoint.
    let u = n.any_orthonormal_vector();
    let v = n.cross(u);
    let s = 0.1 * toward.length();
    let ndc = |p: glam::Vec3| view_proj.project_point3(p).truncate();
    let (a, b, c) = (ndc(at), ndc(at + u * s), ndc(at + v * s));
    (b - a).perp_dot(c - a) > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec3};

    /// wgpu's front faces are counter-clockwise in normalized device coordinates (y up), and the
    /// usual right-handed views put a face toward the viewpoint there: the probe must agree for
    /// the camera's perspective, a cube face's reversed infinite one and the sun's orthographic
    /// one, and flip under a mirrored view.
    #[test]
    fn faces_toward_the_viewpoint_come_out_counter_clockwise() {
        let eye = Vec3::new(1.0, 2.0, 3.0);
        let view = glam::camera::rh::view::look_to_mat4(eye, Vec3::new(0.3, -0.2, -1.0).normalize(), Vec3::Y);
        let at = |vp: Mat4| vp.inverse().project_point3(Vec3::new(0.0, 0.0, 0.5));
        let persp = glam::camera::rh::proj::directx::perspective(1.0, 1.5, 0.05, 100.0);
        let vp = persp * view;
        assert!(toward_is_ccw(vp, at(vp), eye - at(vp)));
        let cube =
            glam::camera::rh::proj::directx::perspective_infinite_reverse(std::f32::consts::FRAC_PI_2, 1.0, 1e-3);
        let vp = cube * view;
        assert!(toward_is_ccw(vp, at(vp), eye - at(vp)));
        let ortho = glam::camera::rh::proj::directx::orthographic(-2.0, 3.0, -1.0, 4.0, 0.0, 50.0);
        let vp = ortho * view;
        assert!(toward_is_ccw(vp, at(vp), Vec3::new(-0.3, 0.2, 1.0)));
        let mirrored = persp * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * view;
        assert!(!toward_is_ccw(mirrored, at(mirrored), eye - at(mirrored)));
    }

    #[test]
    fn cull_modes_keep_the_asked_faces() {
        use super::super::scene_gpu::Facing;
        assert_eq!(cull_mode(Facing::Both, true), (0, None));
        assert_eq!(cull_mode(Facing::Toward, true), (1, Some(wgpu::Face::Back)));
        assert_eq!(cull_mode(Facing::Away, true), (2, Some(wgpu::Face::Front)));
        assert_eq!(cull_mode(Facing::Toward, false), (2, Some(wgpu::Face::Front)));
    }
}

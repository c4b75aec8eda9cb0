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
    /// `texture_depth_2d_array` (loaded, never sampled or compared).
    DepthArray,
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

/// An unspecialised compute pipeline with one bind group and entry point `main` (the passes whose
/// shaders read neither the light type nor the phase; the others use `variant::SpecialisedCompute`).
pub fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
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
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Vertex layout of the scene's vertex buffer: position and albedo, both `vec3<f32>`.
pub const SCENE_VERTEX_ATTRIBUTES: [wgpu::VertexAttribute; 2] =
    wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];

pub fn scene_vertex_layout() -> wgpu::VertexBufferLayout<'static> {
    wgpu::VertexBufferLayout {
        array_stride: 24,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &SCENE_VERTEX_ATTRIBUTES,
    }
}

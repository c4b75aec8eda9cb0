//! Composite: lights the surfaces and gives the final linear radiance of each pixel
//! (`shaders/composite.wgsl`):
//!
//!   L_pixel = L_surface * T_view + L_scatter,   T_view = exp(-sigma_t * (the view path's length in the medium))
//!   L_surface = albedo / pi * max(cos theta_i, 0) * V * E_in
//!
//! (V: the shadow map's filtered test, or the shadow volume's ([`super::Renderer::surface_shadows`]: grid),
//! or under a sun the test against the triangles [`super::ExactShadows`].)
//!
//! Deferred lighting: Surface wrote the nearest surface's albedo, `cos theta_i` and distance, and
//! each pixel is lit once here at `P = eye + t v`. (The medium is unbounded for a point light and
//! fills the scene's box for a directional one; tone mapping for display happens when the image is
//! written.)

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Composite's bind group (composite.wgsl).
    CompositeBindings {
        frame_in: Kind::Storage,
        shadow_in: Kind::Storage,
        shadow_map: Kind::DepthArray,
        shadow_sun: Kind::ComparisonSampler,
        shadow_cube: Kind::ComparisonSampler,
        material: Kind::Texture,
        distance: Kind::Texture,
        scatter: Kind::Texture,
        hdr: Kind::StorageTexture(Composite::OUTPUT),
        exact_vis: Kind::Storage,
    }
}

pub struct Composite {
    pipelines: SpecialisedCompute<1>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// The shadow map's 2x2 filtered test as one comparison sample (clamped to the edge, linear):
    /// `shadow_sun` passes where the reference is at most the texel's depth (the sun's map stores
    /// the distance from a plane beyond the scene), `shadow_cube` where it is at least (the cube's
    /// reversed depth). One sample where four texel loads cost llvmpipe ~1.6 ms of the classroom's
    /// Composite (session 36).
    pub samplers: [wgpu::Sampler; 2],
}

impl Composite {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Composite, GpuError> {
        let module = lib.module(device, "composite.wgsl")?;
        let layout = CompositeBindings::layout(device, "Composite::layout", wgpu::ShaderStages::COMPUTE);
        let pipelines = SpecialisedCompute::new(
            device,
            "Composite",
            module,
            &layout,
            ["main"],
            Specialised::LightAndSurfaceShadows,
        );
        let sampler = |label: &str, compare: wgpu::CompareFunction| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some(label),
                address_mode_u: wgpu::AddressMode::ClampToEdge,
                address_mode_v: wgpu::AddressMode::ClampToEdge,
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                compare: Some(compare),
                ..Default::default()
            })
        };
        let samplers = [
            sampler("Composite::shadow_sun", wgpu::CompareFunction::LessEqual),
            sampler("Composite::shadow_cube", wgpu::CompareFunction::GreaterEqual),
        ];
        Ok(Composite { pipelines, layout, bind_group: None, samplers })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// (Re)binds the inputs; called when the targets or the shadow map change.
    pub fn bind(&mut self, device: &wgpu::Device, b: CompositeBindings) {
        self.bind_group = Some(b.bind(device, "Composite::bind_group", &self.layout));
    }

    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant, width: u32, height: u32) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([pipeline]), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("Composite::pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

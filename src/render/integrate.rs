//! Integrate: per-pixel single scattering over the lit stretches of the shadow volume
//! (`shaders/integrate.wgsl`):
//!
//!   L_scatter = sum_j C(z_j) (q_{j-1} - q_j),   C(z) = U(clamp(z, z_start, z_end))
//!
//! with U the cumulative unshadowed in-scattering along the view ray (point light: the scatter
//! table, `sigma_s I0 / h G`; directional: closed-form pieces of `exp(-sigma_t (l + m))`) and `q_j`
//! bin j's lit fraction blended between the two planes around the pixel, on its own ray cell. Only
//! the bins where `q` changes are visited.
//!
//! In a VSV frame it also reads the surfaces' shadows from the same bits (the pipeline constant
//! `GRID_SHADOWS`, [`super::Renderer::grid_shadows`]): the lit fraction of the bins around the
//! surface point, a slope-scaled bias toward the light before it, into the output's alpha for
//! Composite.

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Integrate's bind group (integrate.wgsl).
    IntegrateBindings {
        frame_in: Kind::Storage,
        grid: Kind::Storage,
        table: Kind::Storage,
        distance: Kind::Texture,
        scatter_out: Kind::StorageTexture(Integrate::OUTPUT),
        material: Kind::Texture,
    }
}

pub struct Integrate {
    pipelines: SpecialisedCompute<1>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
}

impl Integrate {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Integrate, GpuError> {
        let module = lib.module(device, "integrate.wgsl")?;
        let layout = IntegrateBindings::layout(device, "Integrate::layout", wgpu::ShaderStages::COMPUTE);
        let pipelines = SpecialisedCompute::new(device, "Integrate", module, &layout, ["main"], Specialised::All);
        Ok(Integrate { pipelines, layout, bind_group: None })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// (Re)binds the inputs; called when the targets or the grid change.
    pub fn bind(&mut self, device: &wgpu::Device, b: IntegrateBindings) {
        self.bind_group = Some(b.bind(device, "Integrate::bind_group", &self.layout));
    }

    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant, width: u32, height: u32) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([pipeline]), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("Integrate::pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

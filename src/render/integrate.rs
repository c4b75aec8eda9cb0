//! Integrate: per-pixel single scattering over the lit runs of the shadow volume
//! (`shaders/integrate.wgsl`). Point light: `sigma_s I0 / h (G(psi_s) - sum_runs dG)` with the
//! scatter table; directional light: the closed-form integral of `exp(-sigma_t (l + m))` over
//! piecewise-linear path lengths. Bilinear over the four grid rays around the pixel.

use super::util::{storage_entry, storage_texture_entry, texture_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct Integrate {
    pipelines: SpecialisedCompute<1>,
    pub layout: wgpu::BindGroupLayout,
}

impl Integrate {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Integrate, GpuError> {
        let module = lib.module(device, "integrate.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Integrate::layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, wgpu::ShaderStages::COMPUTE, true),
                storage_entry(2, wgpu::ShaderStages::COMPUTE, true),
                texture_entry(3, wgpu::ShaderStages::COMPUTE, wgpu::TextureViewDimension::D2),
                storage_texture_entry(4, Self::OUTPUT),
            ],
        });
        Ok(Integrate {
            pipelines: SpecialisedCompute::new(
                device,
                "Integrate",
                module,
                &layout,
                ["main"],
                Specialised::LightAndPhase,
            ),
            layout,
        })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        width: u32,
        height: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("Integrate::pass"),
            timestamp_writes: None,
        });
        // Renderer::render_frame prepares every variant it records.
        let Some([pipeline]) = self.pipelines.get(variant) else {
            return;
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

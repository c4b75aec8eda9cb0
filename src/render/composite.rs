//! Composite: `L_pixel = L_surface * T_view + L_scatter` in linear radiance
//! (`shaders/composite.wgsl`); tone mapping for display happens when the image is written.

use super::util::{storage_texture_entry, texture_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct Composite {
    pipelines: SpecialisedCompute<1>,
    pub layout: wgpu::BindGroupLayout,
}

impl Composite {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Composite, GpuError> {
        let module = lib.module(device, "composite.wgsl")?;
        let d2 = wgpu::TextureViewDimension::D2;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Composite::layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                texture_entry(1, wgpu::ShaderStages::COMPUTE, d2),
                texture_entry(2, wgpu::ShaderStages::COMPUTE, d2),
                texture_entry(3, wgpu::ShaderStages::COMPUTE, d2),
                storage_texture_entry(4, Self::OUTPUT),
            ],
        });
        Ok(Composite {
            pipelines: SpecialisedCompute::new(device, "Composite", module, &layout, ["main"], Specialised::Light),
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
            label: Some("Composite::pass"),
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

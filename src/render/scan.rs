//! Scan: the shadow volume as an inclusive prefix-OR of the geometry bits along each light ray,
//! in increasing gamma (`shaders/scan.wgsl`): `shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]`.

use super::util::{compute_pipeline, storage_entry, uniform_entry};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct Scan {
    pipeline: wgpu::ComputePipeline,
    pub layout: wgpu::BindGroupLayout,
}

impl Scan {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Scan, GpuError> {
        let module = lib.module(device, "scan.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Scan::layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, wgpu::ShaderStages::COMPUTE, false),
            ],
        });
        let pipeline = compute_pipeline(device, "Scan::pipeline", &module, &layout);
        Ok(Scan { pipeline, layout })
    }

    /// `args`: the Cull pass's DispatchIndirect arguments (no workgroups when nothing was kept).
    /// `args` holds the indirect dispatch at byte `offset` (empty when no caster was kept).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        args: &wgpu::Buffer,
        offset: u64,
    ) {
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Scan::pass"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups_indirect(args, offset);
    }
}

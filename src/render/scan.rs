//! Scan: the shadow volume as an inclusive prefix-OR of the geometry bits along each light ray,
//! in increasing gamma (`shaders/scan.wgsl`):
//!
//!   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]

use super::util::{bindings, compute_pipeline, Kind};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Scan's bind group (scan.wgsl).
    ScanBindings { frame_in: Kind::Storage, grid: Kind::StorageRw }
}

pub struct Scan {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
}

impl Scan {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Scan, GpuError> {
        let module = lib.module(device, "scan.wgsl")?;
        let layout = ScanBindings::layout(device, "Scan::layout", wgpu::ShaderStages::COMPUTE);
        let pipeline = compute_pipeline(device, "Scan::pipeline", &module, &layout);
        Ok(Scan { pipeline, layout, bind_group: None })
    }

    /// (Re)binds the inputs; called when the grid changes.
    pub fn bind(&mut self, device: &wgpu::Device, b: ScanBindings) {
        self.bind_group = Some(b.bind(device, "Scan::bind_group", &self.layout));
    }

    /// `args` holds the indirect dispatch at byte `offset` (no workgroups when no caster was kept).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, args: &wgpu::Buffer, offset: u64) {
        let Some(bind_group) = &self.bind_group else { return };
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Scan::pass"), timestamp_writes: None });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups_indirect(args, offset);
    }
}

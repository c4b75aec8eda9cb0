//! Voxelize: the geometry bits of the epipolar grid by point-sampled light rays
//! (`shaders/voxelize.wgsl`).
//!
//! Plane `x` and bin `k` are sample positions: the light ray at the plane's centre angle and the
//! bin's centre `z`. A triangle sets `geometry[x, y, k]` where that light ray meets it at an angle
//! `gamma` inside ray cell `y`. One compute thread per item of the Cull pass's work list (one
//! triangle x one plane x one 32-bit word of bins), dispatched indirectly, so the work follows the
//! light-space samples each triangle covers and a large triangle is spread over many threads.
//! Crossings of shared edges are computed in a canonical vertex order, which makes the sampling
//! watertight: no light ray slips between two triangles that share an edge or a vertex.

use super::util::{storage_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct Voxelize {
    pipelines: SpecialisedCompute<1>,
    pub layout: wgpu::BindGroupLayout,
}

impl Voxelize {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Voxelize, GpuError> {
        let module = lib.module(device, "voxelize.wgsl")?;
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Voxelize::layout"),
            entries: &[
                uniform_entry(0, c),
                storage_entry(1, c, true),  // triangles (this chunk)
                storage_entry(2, c, false), // grid bits
                storage_entry(3, c, true),  // Cull: records
                storage_entry(4, c, true),  // Cull: offsets
                storage_entry(5, c, true),  // Cull: block offsets
                storage_entry(6, c, true),  // Cull: counters
            ],
        });
        Ok(Voxelize {
            pipelines: SpecialisedCompute::new(device, "Voxelize", module, &layout, ["main"], Specialised::Light),
            layout,
        })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// One thread per work item; `dispatch` holds the Cull pass's indirect arguments (Voxelize's
    /// at [`super::Cull::VOXELIZE_ARGS`]).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        dispatch: &wgpu::Buffer,
    ) {
        // Renderer::render_frame prepares every variant it records.
        let Some([pipeline]) = self.pipelines.get(variant) else {
            return;
        };
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Voxelize::pass"), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups_indirect(dispatch, super::Cull::VOXELIZE_ARGS);
    }
}

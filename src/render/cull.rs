//! Cull: the triangles that can shadow a visible point, and their epipolar rectangles
//! (`shaders/cull.wgsl`). A triangle outside the visible wedge of planes, past the last visible
//! ray, or outside the bins' z range is dropped; the kept ones are listed for Voxelize's indirect
//! draw, and Scan's indirect dispatch is empty when none is kept, so an empty frame costs nothing.

use super::util::{storage_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

/// What the last cull found (read back on demand).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct CullCounts {
    /// Triangles voxelized.
    pub kept: u32,
    /// Dropped: outside the bins' z range (beyond the farthest visible depth, or not a caster).
    pub culled_depth: u32,
    /// Dropped: outside the visible wedge of planes or past the last visible ray.
    pub culled_view: u32,
}

pub struct Cull {
    pipelines: SpecialisedCompute<2>,
    pub layout: wgpu::BindGroupLayout,
    /// `[kept, culled by depth, culled by view, unused]`.
    pub counters: wgpu::Buffer,
    /// DrawIndirect arguments for Voxelize.
    pub draw_args: wgpu::Buffer,
    /// DispatchIndirect arguments for Scan.
    pub scan_args: wgpu::Buffer,
}

impl Cull {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Cull, GpuError> {
        let module = lib.module(device, "cull.wgsl")?;
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Cull::layout"),
            entries: &[
                uniform_entry(0, c),
                storage_entry(1, c, true),
                storage_entry(2, c, false),
                storage_entry(3, c, false),
                storage_entry(4, c, false),
                storage_entry(5, c, false),
                storage_entry(6, c, false),
            ],
        });
        let buffer = |label: &str, size: u64, extra: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE
                    | wgpu::BufferUsages::COPY_DST
                    | wgpu::BufferUsages::COPY_SRC
                    | extra,
                mapped_at_creation: false,
            })
        };
        Ok(Cull {
            pipelines: SpecialisedCompute::new(
                device,
                "Cull",
                module,
                &layout,
                ["cull", "cull_finish"],
                Specialised::Light,
            ),
            layout,
            counters: buffer("Cull::counters", 16, wgpu::BufferUsages::empty()),
            draw_args: buffer("Cull::draw_args", 16, wgpu::BufferUsages::INDIRECT),
            scan_args: buffer("Cull::scan_args", 12, wgpu::BufferUsages::INDIRECT),
        })
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        triangles: u32,
    ) {
        // Renderer::render_frame prepares every variant it records.
        let Some([cull, finish]) = self.pipelines.get(variant) else {
            return;
        };
        for b in [&self.counters, &self.draw_args, &self.scan_args] {
            encoder.clear_buffer(b, 0, None);
        }
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Cull::pass"), timestamp_writes: None });
        pass.set_bind_group(0, bind_group, &[]);
        pass.set_pipeline(cull);
        // Two dimensions past 65535 workgroups (4M triangles).
        let groups = triangles.div_ceil(64).max(1);
        let (gx, gy) = if groups > 65535 { (65535, groups.div_ceil(65535)) } else { (groups, 1) };
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(finish);
        pass.dispatch_workgroups(1, 1, 1);
    }
}

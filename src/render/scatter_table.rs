//! ScatterTable: the cumulative unshadowed in-scattering `G(gamma, psi)` along view rays of a
//! point light, with the phase function and the medium baked in (`shaders/scatter_table.wgsl`):
//!
//!   G(gamma, psi) = integral_0^psi p(cos(gamma + s)) exp(-sigma_t D (sin s + sin gamma) / sin(gamma + s))
//!                   * h^2 / (h^2 + r^2 sin^2(gamma + s)) ds,   h = D sin gamma
//!
//! so that a lit run `[psi_a, psi_b]` contributes `sigma_s I0 / h (G(psi_b) - G(psi_a))`.

use super::frame::{TABLE_COLS, TABLE_ROWS};
use super::util::{storage_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

pub struct ScatterTable {
    pipelines: SpecialisedCompute<1>,
    pub layout: wgpu::BindGroupLayout,
}

impl ScatterTable {
    /// Bytes of the table buffer: `rows x (cols + 1)` `vec4<f32>`.
    pub const BYTES: u64 = TABLE_ROWS as u64 * (TABLE_COLS as u64 + 1) * 16;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<ScatterTable, GpuError> {
        let module = lib.module(device, "scatter_table.wgsl")?;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("ScatterTable::layout"),
            entries: &[
                uniform_entry(0, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, wgpu::ShaderStages::COMPUTE, false),
            ],
        });
        Ok(ScatterTable {
            pipelines: SpecialisedCompute::new(
                device,
                "ScatterTable",
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

    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant, bind_group: &wgpu::BindGroup) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("ScatterTable::pass"),
            timestamp_writes: None,
        });
        // Renderer::render_frame prepares every variant it records.
        let Some([pipeline]) = self.pipelines.get(variant) else {
            return;
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(TABLE_ROWS.div_ceil(64), 1, 1);
    }
}

//! ScatterTable: the cumulative unshadowed in-scattering `G(gamma, psi)` along view rays of a
//! point light, with the phase function and the medium baked in (`shaders/scatter_table.wgsl`):
//!
//!   G(gamma, psi) = integral_0^psi p(cos(gamma + s)) exp(-sigma_t D (sin s + sin gamma) / sin(gamma + s))
//!                   * h^2 / (h^2 + r^2 sin^2(gamma + s)) ds,   h = D sin gamma
//!
//! so that a lit run `[psi_a, psi_b]` contributes `sigma_s I0 / h (G(psi_b) - G(psi_a))`.

use super::frame::{TABLE_COLS, TABLE_ROWS};
use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// ScatterTable's bind group (scatter_table.wgsl).
    ScatterTableBindings { frame_in: Kind::Storage, table: Kind::StorageRw }
}

pub struct ScatterTable {
    pipelines: SpecialisedCompute<1>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// `rows x (cols + 1)` `vec4<f32>`: G / (pi - gamma) per row.
    pub table: wgpu::Buffer,
}

impl ScatterTable {
    /// Bytes of the table buffer.
    pub const BYTES: u64 = TABLE_ROWS as u64 * (TABLE_COLS as u64 + 1) * 16;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<ScatterTable, GpuError> {
        let module = lib.module(device, "scatter_table.wgsl")?;
        let layout = ScatterTableBindings::layout(device, "ScatterTable::layout", wgpu::ShaderStages::COMPUTE);
        let pipelines =
            SpecialisedCompute::new(device, "ScatterTable", module, &layout, ["main"], Specialised::LightAndPhase);
        let table = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ScatterTable::table"),
            size: Self::BYTES,
            // COPY_SRC: Renderer::read_scatter_table (tests).
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Ok(ScatterTable { pipelines, layout, bind_group: None, table })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// Binds the frame uniforms and its own table (once).
    pub fn bind(&mut self, device: &wgpu::Device, frame: &wgpu::Buffer) {
        let b = ScatterTableBindings { frame_in: frame.as_entire_binding(), table: self.table.as_entire_binding() };
        self.bind_group = Some(b.bind(device, "ScatterTable::bind_group", &self.layout));
    }

    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([pipeline]), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("ScatterTable::pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        // A workgroup per row (scatter_table.wgsl).
        pass.dispatch_workgroups(TABLE_ROWS, 1, 1);
    }
}

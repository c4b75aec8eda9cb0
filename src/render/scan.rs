//! Scan: the shadow volume as an inclusive prefix-OR of the geometry bits along each light ray,
//! in increasing gamma (`shaders/scan.wgsl`):
//!
//!   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]
//!
//! A thread per column (a plane's four words of bins) walks its rays in turn; or, with
//! `Renderer::scan_columns`, a workgroup per plane splits its columns' rays into runs
//! (`scan_columns.wgsl`). Each plane's walk covers only the ray cells its pixels read
//! ([`crate::epipolar::GridMapping::plane_rays`]), into which Voxelize clamped every caster
//! before them.

use super::util::{bindings, compute_pipeline, Kind};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Scan's bind group (scan.wgsl).
    ScanBindings { frame_in: Kind::Storage, grid: Kind::StorageRw, plane_rays: Kind::Storage }
}

pub struct Scan {
    /// For grids whose rays start on four words (`scan.wgsl`, four words as one vector).
    quads: wgpu::ComputePipeline,
    /// For the others (`scan_words.wgsl`, a word at a time).
    words: wgpu::ComputePipeline,
    /// A workgroup per plane (`scan_columns.wgsl`).
    columns: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
}

impl Scan {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Scan, GpuError> {
        let layout = ScanBindings::layout(device, "Scan::layout", wgpu::ShaderStages::COMPUTE);
        let quads = compute_pipeline(device, "Scan::pipeline", &lib.module(device, "scan.wgsl")?, "main", &layout);
        let words =
            compute_pipeline(device, "Scan::pipeline_words", &lib.module(device, "scan_words.wgsl")?, "main", &layout);
        let columns = compute_pipeline(
            device,
            "Scan::pipeline_columns",
            &lib.module(device, "scan_columns.wgsl")?,
            "main",
            &layout,
        );
        Ok(Scan { quads, words, columns, layout, bind_group: None })
    }

    /// (Re)binds the inputs; called when the grid changes.
    pub fn bind(&mut self, device: &wgpu::Device, b: ScanBindings) {
        self.bind_group = Some(b.bind(device, "Scan::bind_group", &self.layout));
    }

    /// `args` holds the indirect dispatch at byte `offset` (no workgroups when no caster was kept);
    /// `quad_rays`: [`crate::params::Grid::quad_rays`]. `planes`: on a quad grid, scan with a
    /// workgroup per plane instead, this many planes (a direct dispatch, which scans the cleared
    /// grid too when no caster was kept); other grids ignore it.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        args: &wgpu::Buffer,
        offset: u64,
        quad_rays: bool,
        planes: Option<u32>,
    ) {
        let Some(bind_group) = &self.bind_group else { return };
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Scan::pass"), timestamp_writes: None });
        pass.set_bind_group(0, bind_group, &[]);
        match planes {
            Some(n) if quad_rays => {
                pass.set_pipeline(&self.columns);
                // scan_columns.wgsl: plane = wg.y * 65535 + wg.x.
                pass.dispatch_workgroups(n.clamp(1, 65535), n.div_ceil(65535).max(1), 1);
            }
            _ => {
                pass.set_pipeline(if quad_rays { &self.quads } else { &self.words });
                pass.dispatch_workgroups_indirect(args, offset);
            }
        }
    }
}

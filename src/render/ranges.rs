//! Ranges: fits the bins' z range to what this frame can see (`shaders/ranges.wgsl`):
//! `z_hi = min(casters' z_hi, max over pixels of the surface's z)`, computed on the GPU and copied
//! into the frame uniforms before voxelization, so far-away geometry does not dilute the bins.
//! Under a first-hit volume whose planes do not wrap it also takes the planes' reach, the greatest
//! `z_s` of the pixels that blend each group of 8 planes, and turns it into each plane's last bin,
//! where Voxelize stops the plane's first hits ([`Ranges::reach`]).

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};
use crate::params::Grid;

bindings! {
    /// Ranges' bind group (ranges.wgsl; `out` is the pass's own result buffer).
    RangesBindings { frame_in: Kind::Storage, distance: Kind::Texture, out: Kind::StorageRw, reach: Kind::StorageRw }
}

pub struct Ranges {
    pipelines: SpecialisedCompute<2>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// `[max visible z, z_lo, z_hi, unused]` as float bits.
    pub result: wgpu::Buffer,
    /// The planes' reach, for a first-hit frame whose planes do not wrap (the frame then has
    /// [`super::frame::FLAG_PLANE_REACH`]): per group of [`Ranges::REACH_GROUP`] planes the
    /// greatest z of the surfaces of the pixels that blend them (float bits, `reduce`), then from
    /// [`Ranges::REACH_PLANES_AT`] per plane the last bin Voxelize keeps (an i32, `finish`).
    pub reach: wgpu::Buffer,
}

impl Ranges {
    /// Pixels per thread of `reduce`, a column (ranges.wgsl's `ROWS`, checked by a test).
    pub const ROWS: u32 = 16;

    /// Planes a group of [`Ranges::reach`] (common.wgsl `REACH_GROUP`).
    pub const REACH_GROUP: u64 = 8;
    /// Where the planes' last bins start in [`Ranges::reach`], in words: past the groups of the
    /// most planes a grid has (common.wgsl `REACH_PLANES_AT`).
    pub const REACH_PLANES_AT: u64 = Grid::PLANES.max as u64 / Self::REACH_GROUP;

    /// Byte offset of `ranges.z` in [`super::FrameUniforms`]; `z_lo, z_hi` are copied there.
    pub const UNIFORM_OFFSET: u64 = std::mem::offset_of!(super::FrameUniforms, ranges) as u64 + 8;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Ranges, GpuError> {
        let module = lib.module(device, "ranges.wgsl")?;
        let layout = RangesBindings::layout(device, "Ranges::layout", wgpu::ShaderStages::COMPUTE);
        let result = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Ranges::result"),
            size: 16,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let reach = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Ranges::reach"),
            size: (Self::REACH_PLANES_AT + Grid::PLANES.max as u64) * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Ranges {
            pipelines: SpecialisedCompute::new(
                device,
                "Ranges",
                module,
                &layout,
                ["reduce", "finish"],
                Specialised::LightAndGrid,
            ),
            layout,
            bind_group: None,
            result,
            reach,
        })
    }

    /// (Re)binds the inputs; called when the targets change.
    pub fn bind(&mut self, device: &wgpu::Device, frame: &wgpu::Buffer, distance: &wgpu::TextureView) {
        let b = RangesBindings {
            frame_in: frame.as_entire_binding(),
            distance: wgpu::BindingResource::TextureView(distance),
            out: self.result.as_entire_binding(),
            reach: self.reach.as_entire_binding(),
        };
        self.bind_group = Some(b.bind(device, "Ranges::bind_group", &self.layout));
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// Reduces, then copies `[z_lo, z_hi]` into `frame_uniforms`.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        frame_uniforms: &wgpu::Buffer,
        width: u32,
        height: u32,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some(pipelines), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        encoder.clear_buffer(&self.result, 0, None);
        if variant.first_hits {
            encoder.clear_buffer(&self.reach, 0, Some(Self::REACH_PLANES_AT * 4));
        }
        // A thread per column of `ROWS` pixels (ranges.wgsl), 64 columns per workgroup.
        let size = (width, height, Self::ROWS);
        super::util::record_reduction(encoder, "Ranges::pass", pipelines, bind_group, size);
        self.copy_range(encoder, frame_uniforms);
    }

    /// Copies the last reduction's `[z_lo, z_hi]` into `frame_uniforms` (whose CPU copy holds the
    /// unfitted range): also for a frame that reuses the shadow volume of the frame that ran it.
    pub fn copy_range(&self, encoder: &mut wgpu::CommandEncoder, frame_uniforms: &wgpu::Buffer) {
        encoder.copy_buffer_to_buffer(&self.result, 4, frame_uniforms, Self::UNIFORM_OFFSET, 8);
    }
}

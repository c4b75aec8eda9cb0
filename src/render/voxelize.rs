//! Voxelize: the geometry bits of the epipolar grid by point-sampled light rays
//! (`shaders/voxelize.wgsl`).
//!
//! Plane `x` and bin `k` are sample positions: the light ray at the plane's centre angle and the
//! bin's centre `z`. A triangle sets `geometry[x, y, k]` where that light ray meets it at an angle
//! `gamma` inside ray cell `y`. One compute thread per item of the Cull pass's work list (one
//! triangle x one plane x a group of [`Voxelize::words_per_item`] 32-bit words of bins), dispatched
//! indirectly, so the work follows the light-space samples each triangle covers and, on a GPU, a
//! large triangle is spread over many threads.
//! Crossings of shared edges are computed in a canonical vertex order, which makes the sampling
//! watertight: no light ray slips between two triangles that share an edge or a vertex.
//!
//! A thread takes a run of items ([`Voxelize::items_per_thread`], in the frame uniforms' `work.x`,
//! which Cull also reads to size the dispatch): it searches the list for the first only. The
//! threads of a SIMD group (8 on llvmpipe) share a stretch of the list and take every 8th item of
//! it, so that at each step their lanes hold neighbouring items (mostly neighbouring planes of one
//! triangle) and finish their walks over bins together. Even workgroups take the first half of the
//! list, odd ones the second (voxelize.wgsl `stretch`), so that a CPU adapter's cores, which run
//! consecutive workgroups at once, do not OR into the same lines of the grid.
//!
//! With [`super::ShadowVolume::FirstHits`] (the default) an item keeps, per light ray, the least
//! angle at which its triangle meets it (an atomic max of the angle's key, `first_hits` in the
//! shader) instead of setting the bits of ray cells.
//!
//! Per plane only the ray cells its pixels read are kept
//! ([`crate::epipolar::GridMapping::plane_rays`]): a hit past them sets nothing, a caster before
//! them goes into the first (the scan carries it forward from there).

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

/// What Voxelize reads and writes besides the scene's chunks and work list.
pub struct VoxelizeInputs<'a> {
    pub frame: &'a wgpu::Buffer,
    /// The shadow volume it writes.
    pub grid: &'a wgpu::Buffer,
    /// Per plane, the ray cells its pixels read (`GridMapping::plane_rays`).
    pub plane_rays: &'a wgpu::Buffer,
    /// Per plane, the last bin its pixels reach ([`super::Ranges::reach`]).
    pub reach: &'a wgpu::Buffer,
    /// Cull's counters (the work list's length).
    pub cull: &'a super::Cull,
}

bindings! {
    /// Voxelize's bind group for one chunk of triangles (voxelize.wgsl).
    VoxelizeBindings {
        frame_in: Kind::Storage,
        tris: Kind::Storage,
        grid: Kind::StorageRw,
        records: Kind::Storage,
        offsets: Kind::Storage,
        blocks: Kind::Storage,
        counters: Kind::Storage,
        plane_rays: Kind::Storage,
        hidden: Kind::Storage,
        reach: Kind::Storage,
    }
}

pub struct Voxelize {
    /// Work items per thread (interleaved with its SIMD group's, voxelize.wgsl `main`), and Cull's
    /// triangles per thread (cull.wgsl). On a CPU adapter (llvmpipe, which runs 8 lanes per core)
    /// the search for an item's triangle and the triangle's reads were a quarter of the pass: runs
    /// of 16 took the classroom's Voxelize from ~190 to ~150 ms (session 16), and runs of 64
    /// another 10% (session 35: 37.8 to 34.0 ms, faster in 8 of 8 rounds, and faster in every
    /// round on the built-in room and the bench's rooms of 100 000 and a million triangles; 32,
    /// 40, 96, 128 and 256 measured no better than 16). A GPU keeps one item per thread, the
    /// balanced list this pass was designed around: a run of 64 would leave most of a large GPU
    /// idle on the classroom's 1.3 M items (not measured there).
    pub items_per_thread: u32,
    /// 32-bit words of bins per work item: the words of one plane's segment that one item walks.
    /// A GPU takes one (a wall's segment spread over many threads). On a CPU adapter an item's
    /// set-up (the plane's segment of the triangle) cost more than its bins, and most of a
    /// triangle's words in a plane hold none of its segment: one item per plane, walking only the
    /// segment's own words, halved the classroom's items (2.18 M to 1.27 M) and took its Voxelize
    /// 10-20% lower (more at more bins), session 13.
    pub words_per_item: u32,
    pipelines: SpecialisedCompute<1>,
    layout: wgpu::BindGroupLayout,
    /// One per chunk of triangles.
    bind_groups: Vec<wgpu::BindGroup>,
}

impl Voxelize {
    /// [`Voxelize::items_per_thread`] on a CPU adapter.
    pub const CPU_ITEMS_PER_THREAD: u32 = 64;

    /// llvmpipe ends every loop of a shader invocation once the invocation has run this many loop
    /// iterations, all its loops together (Mesa's gallivm, `LP_MAX_TGSI_LOOP_ITERATIONS`: a guard
    /// against endless loops, "shared between every loop"): the rest of its work is silently
    /// dropped. A thread's run of items must stay inside it.
    pub const LOOP_LIMIT: u32 = 65_535;

    /// The run of items a thread takes for `grid` (in the frame's `work.x`, which Cull reads too):
    /// [`Voxelize::items_per_thread`], cut so that a run's loop iterations stay inside
    /// [`Voxelize::LOOP_LIMIT`]. An item walks at most its words' bins once (the first hits) or
    /// its words once more (the bits' fills), plus its step in the run and the walk to its
    /// triangle; the search for the run's first item takes ~20 more. With runs of 64 at 1536 bins
    /// llvmpipe dropped the last items of long runs: the built-in room's scattered light was 40%
    /// off the reference, bits and first hits alike (session 47; 768 bins stayed inside).
    pub fn run_for(&self, grid: &crate::params::Grid) -> u32 {
        let words = self.words_per_item.min(grid.words()).max(1);
        let per_item = words * 32 + words + 4;
        self.items_per_thread.min((Self::LOOP_LIMIT - 64) / per_item).max(1)
    }

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary, adapter: wgpu::DeviceType) -> Result<Voxelize, GpuError> {
        let module = lib.module(device, "voxelize.wgsl")?;
        let layout = VoxelizeBindings::layout(device, "Voxelize::layout", wgpu::ShaderStages::COMPUTE);
        Ok(Voxelize {
            items_per_thread: if adapter == wgpu::DeviceType::Cpu { Self::CPU_ITEMS_PER_THREAD } else { 1 },
            words_per_item: if adapter == wgpu::DeviceType::Cpu {
                crate::params::Grid::BINS.max as u32 / 32
            } else {
                1
            },
            pipelines: SpecialisedCompute::new(
                device,
                "Voxelize",
                module,
                &layout,
                ["main"],
                // (Grid shadows too: Cull tests no blocks in their frames, `hidden_of`.)
                Specialised::LightGridAndSurfaceShadows,
            ),
            layout,
            bind_groups: Vec::new(),
        })
    }

    /// (Re)binds the scene's chunks and the grid; called when either changes.
    pub fn bind(&mut self, device: &wgpu::Device, geometry: &super::SceneGpu, inputs: VoxelizeInputs) {
        let VoxelizeInputs { frame, grid, plane_rays, reach, cull } = inputs;
        let l = &geometry.lists;
        self.bind_groups = geometry
            .nonempty_chunks()
            .map(|(i, tris, _)| {
                let b = VoxelizeBindings {
                    frame_in: frame.as_entire_binding(),
                    tris: tris.as_entire_binding(),
                    grid: grid.as_entire_binding(),
                    records: l.records.as_entire_binding(),
                    offsets: l.offsets.as_entire_binding(),
                    blocks: l.blocks.as_entire_binding(),
                    counters: cull.counters.as_entire_binding(),
                    plane_rays: plane_rays.as_entire_binding(),
                    hidden: l.hidden.as_entire_binding(),
                    reach: reach.as_entire_binding(),
                };
                b.bind(device, &format!("Voxelize::bind_group[{i}]"), &self.layout)
            })
            .collect();
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// One thread per work item of chunk `chunk`; `dispatch` holds the Cull pass's indirect
    /// arguments (Voxelize's at [`super::Cull::VOXELIZE_ARGS`]).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant, chunk: usize, dispatch: &wgpu::Buffer) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([pipeline]), Some(bind_group)) = (self.pipelines.get(variant), self.bind_groups.get(chunk)) else {
            return;
        };
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Voxelize::pass"), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups_indirect(dispatch, super::Cull::VOXELIZE_ARGS);
    }
}

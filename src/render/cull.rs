//! Cull: the triangles that can shadow a visible point, and the balanced work list Voxelize runs
//! (`shaders/cull.wgsl`).
//!
//! A triangle outside the visible wedge of planes, past the last visible ray, or outside the bins'
//! z range is dropped, and so is a closed mesh's face turned away from a light outside it (its
//! light rays enter the solid through a face toward the light first, and the scan shadows all
//! behind that), and, for a directional light, one the shadow map shows behind nearer surfaces at
//! every texel around it ([`super::ShadowPyramid`]). A kept one gets a record and `items = planes x ceil(words / words per item)`,
//! the light-space samples it may cover in units of one plane x a group of 32-bit words of bins
//! ([`super::Voxelize::words_per_item`]: one on a GPU, all on a CPU; where an item holds all of
//! a ray's words, [`Variant::whole_ray_items`], a point light's z range is the triangle's
//! bounding ball's, one angle where its edges take six, since extra words then cost no item);
//! an exclusive prefix sum
//! over the items (1024 per workgroup, then the blocks) lets Voxelize give every item its own
//! thread through an indirect dispatch. Scan's indirect dispatch is empty when nothing is kept, so
//! an empty frame costs nothing.

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Cull's bind group for one chunk of triangles (cull.wgsl).
    CullBindings {
        frame_in: Kind::Storage,
        tris: Kind::Storage,
        records: Kind::StorageRw,
        offsets: Kind::StorageRw,
        blocks: Kind::StorageRw,
        counters: Kind::StorageRw,
        dispatch: Kind::StorageRw,
        sides: Kind::Storage,
        shadow: Kind::Storage,
        pyramid: Kind::Storage,
        hidden: Kind::StorageRw,
        pairs: Kind::StorageRw,
    }
}

/// What the last cull found (read back on demand).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct CullCounts {
    /// Triangles voxelized.
    pub kept: u32,
    /// Dropped: outside the bins' z range (beyond the farthest visible depth, or not a caster).
    pub culled_depth: u32,
    /// Dropped: outside the visible wedge of planes, past the last visible ray, or of zero area.
    pub culled_view: u32,
    /// Dropped: a face of a closed mesh turned away from the light, which lies outside it
    /// (`crate::scene::solid`); the light meets that solid through its faces toward it first.
    pub culled_back: u32,
    /// Dropped: behind nearer surfaces at every shadow-map texel around it (directional lights;
    /// [`super::ShadowPyramid`]); its bits would change nothing after the scan.
    pub culled_hidden: u32,
    /// Voxelize's work items (one triangle x one plane x a group of 32-bit words of bins).
    pub items: u64,
}

/// The per-scene buffers the Cull pass fills for each chunk of triangles, sized for the largest.
pub struct CullLists {
    /// Per kept triangle: (triangle, first plane, planes, first word | words << 16).
    pub records: wgpu::Buffer,
    /// Per kept triangle: the exclusive prefix sum of the items within its block of 1024.
    pub offsets: wgpu::Buffer,
    /// Per block of 1024 kept triangles: the exclusive prefix sum of the blocks' items.
    pub blocks: wgpu::Buffer,
    /// Per kept triangle: bit i set where block i of its planes (64 each, from its record's first
    /// plane) is hidden from the sun (cull.wgsl `hidden_blocks`); Voxelize skips those items.
    pub hidden: wgpu::Buffer,
    /// Per block of 1024 kept triangles, the (triangle, block of planes) pairs Cull tests for
    /// `hidden` ([`Cull::PAIRS_PER_BLOCK`] at most).
    pub pairs: wgpu::Buffer,
}

impl CullLists {
    pub fn new(device: &wgpu::Device, max_triangles: u32) -> CullLists {
        let n = max_triangles.max(1) as u64;
        let storage = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        CullLists {
            records: storage("CullLists::records", n * 16),
            offsets: storage("CullLists::offsets", n * 4),
            blocks: storage("CullLists::blocks", n.div_ceil(Cull::BLOCK as u64) * 4),
            hidden: storage("CullLists::hidden", n * 4),
            pairs: storage("CullLists::pairs", n.div_ceil(Cull::BLOCK as u64) * Cull::PAIRS_PER_BLOCK * 4),
        }
    }

    /// Bytes per triangle of all the lists together (records, offsets, hidden blocks and the
    /// blocks' pairs; `blocks` is a word per 1024), for the adapter's limits.
    pub const BYTES_PER_TRIANGLE: u64 = 16 + 4 + 4 + Cull::PAIRS_PER_BLOCK * 4 / Cull::BLOCK as u64;
}

pub struct Cull {
    pipelines: SpecialisedCompute<4>,
    layout: wgpu::BindGroupLayout,
    /// One per chunk of triangles, with the chunk's triangle count.
    bind_groups: Vec<(wgpu::BindGroup, u32)>,
    /// `[kept (chunk), culled by depth, culled by view, items (chunk), kept (all), items (all),
    /// overflowed lists, culled as back faces, culled as hidden from the light, 3 unused]`.
    pub counters: wgpu::Buffer,
    /// DispatchIndirect arguments: Voxelize at 12, Scan at 24.
    pub dispatch: wgpu::Buffer,
}

impl Cull {
    /// Kept triangles per prefix-sum workgroup.
    pub const BLOCK: u32 = 1024;
    /// (Triangle, block of planes) pairs tested per block of kept triangles (cull.wgsl `PAIRS`).
    pub const PAIRS_PER_BLOCK: u64 = 2048;
    /// Byte offsets of the indirect arguments in [`Cull::dispatch`].
    pub const VOXELIZE_ARGS: u64 = 12;
    pub const SCAN_ARGS: u64 = 24;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Cull, GpuError> {
        let module = lib.module(device, "cull.wgsl")?;
        let layout = CullBindings::layout(device, "Cull::layout", wgpu::ShaderStages::COMPUTE);
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
                ["cull", "cull_finish", "offsets_local", "offsets_blocks"],
                Specialised::LightGridAndSurfaceShadows,
            ),
            layout,
            bind_groups: Vec::new(),
            counters: buffer("Cull::counters", 48, wgpu::BufferUsages::empty()),
            dispatch: buffer("Cull::dispatch", 48, wgpu::BufferUsages::INDIRECT),
        })
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// (Re)binds the scene's chunks of triangles and lists, the shadow map's uniforms and its
    /// pyramid; called when any of them changes.
    pub fn bind(
        &mut self,
        device: &wgpu::Device,
        frame: &wgpu::Buffer,
        geometry: &super::SceneGpu,
        shadow: &wgpu::Buffer,
        pyramid: &wgpu::Buffer,
    ) {
        let l = &geometry.lists;
        self.bind_groups = geometry
            .nonempty_chunks()
            .map(|(i, tris, n)| {
                let b = CullBindings {
                    frame_in: frame.as_entire_binding(),
                    tris: tris.as_entire_binding(),
                    records: l.records.as_entire_binding(),
                    offsets: l.offsets.as_entire_binding(),
                    blocks: l.blocks.as_entire_binding(),
                    counters: self.counters.as_entire_binding(),
                    dispatch: self.dispatch.as_entire_binding(),
                    sides: geometry.light_sides.as_entire_binding(),
                    shadow: shadow.as_entire_binding(),
                    pyramid: pyramid.as_entire_binding(),
                    hidden: l.hidden.as_entire_binding(),
                    pairs: l.pairs.as_entire_binding(),
                };
                (b.bind(device, &format!("Cull::bind_group[{i}]"), &self.layout), n)
            })
            .collect();
    }

    /// The chunks of triangles bound (one unless the scene is larger than a storage binding).
    pub fn chunks(&self) -> usize {
        self.bind_groups.len()
    }

    /// Clears the frame's totals; call once per frame before the first chunk.
    pub fn begin_frame(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.clear_buffer(&self.counters, 0, None);
        encoder.clear_buffer(&self.dispatch, 0, None);
    }

    /// Culls chunk `chunk` of the scene's triangles and builds its work list; each thread takes
    /// `per_thread` consecutive triangles (the frame uniforms' `work.x`, Voxelize's run).
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, variant: Variant, chunk: usize, per_thread: u32) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([cull, finish, local, blocks]), Some((bind_group, triangles))) =
            (self.pipelines.get(variant), self.bind_groups.get(chunk))
        else {
            return;
        };
        let triangles = *triangles;
        // This chunk's kept count and items (the frame's totals accumulate in the other counters).
        encoder.clear_buffer(&self.counters, 0, Some(4));
        encoder.clear_buffer(&self.counters, 12, Some(4));
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Cull::pass"), timestamp_writes: None });
        pass.set_bind_group(0, bind_group, &[]);
        pass.set_pipeline(cull);
        // Two dimensions past 65535 workgroups (4M threads).
        let (gx, gy) = super::util::split_groups(triangles.div_ceil(64 * per_thread.max(1)));
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(finish);
        pass.dispatch_workgroups(1, 1, 1);
        // For every triangle of the chunk, kept or not (the dispatch buffer is bound here, so it
        // cannot also be this dispatch's indirect arguments); blocks past the kept ones return early.
        pass.set_pipeline(local);
        pass.dispatch_workgroups(triangles.div_ceil(Self::BLOCK).max(1), 1, 1);
        pass.set_pipeline(blocks);
        pass.dispatch_workgroups(1, 1, 1);
    }
}

//! ExactShadows: the sun's shadow on each visible surface point, tested against the triangles
//! themselves instead of a shadow map's texels (`shaders/exact_shadows.wgsl`):
//!
//!   V(P) = 0  where the ray from P toward the light meets a triangle nearer the light, else 1
//!
//! An irregular z-buffer: light space over the fitted map's rectangle ([`super::ShadowFit`]) is cut
//! into tiles, each triangle is listed in the tiles its projection overlaps, and each pixel tests
//! its point against its tile's triangles. The surfaces' shadows are then those of the reference's
//! shadow rays (src/reference), with no texels, filtering or bias: the classroom's whole image at
//! 512x512 goes from 45% relative RMSE against the reference with the map to 21%, the rest in
//! isolated pixels, many of them silhouettes the rasterizer and the reference's ray see apart
//! (docs/results.md, session 44). And a frame needs no shadow map at all once the sun's
//! pyramid of hidden triangles is made (Cull's test; `Renderer::render_frame` draws the map only
//! to make it). Directional lights only: a point light's surfaces keep the cube map. That pyramid
//! also keeps the triangles it shows hidden out of the lists, as Cull keeps them out of the
//! volume: a nearer surface, which is listed, meets every ray toward the sun through them first.
//!
//! Each list entry holds, beside its triangle, the part of its tile the triangle's box covers, in
//! one word: a point reads the planes of only the entries whose box holds it (most of a tile's
//! entries for a lit point do not), and `count` records each entry with its place in its tile, so
//! that `fill` only moves them. On the classroom at 512x512 on llvmpipe the pass went from ~108
//! to ~68-77 ms with these, a frame 2-5% longer than the map's, for a whole image half as far
//! from the reference: the default under a sun (docs/results.md, session 45).
//!
//! The list's capacity is a guess that grows: a frame whose triangles need more entries than it
//! holds tests some points against incomplete lists, and reports it ([`ExactShadows::overflowed`]);
//! `Renderer::render_frame` then grows the list and renders the frame again, so such a frame is
//! never returned.

use super::scene_gpu::SceneGpu;
use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};
use bytemuck::{Pod, Zeroable};
use glam::{UVec4, Vec4};

bindings! {
    /// ExactShadows' bind group (exact_shadows.wgsl).
    ExactShadowsBindings {
        frame_in: Kind::Storage,
        shadow_in: Kind::Storage,
        params_in: Kind::Storage,
        tris: Kind::Storage,
        tiles: Kind::StorageRw,
        planes: Kind::StorageRw,
        list: Kind::StorageRw,
        vis: Kind::StorageRw,
        distance: Kind::Texture,
        material: Kind::Texture,
        sides: Kind::Storage,
        recorded: Kind::StorageRw,
        pyramid: Kind::Storage,
    }
}

/// What ExactShadows reads besides the scene's triangles and its own buffers.
pub struct ExactInputs<'a> {
    pub frame: &'a wgpu::Buffer,
    /// The shadow map's uniforms (the fitted rectangle's matrix).
    pub shadow: &'a wgpu::Buffer,
    /// Surface's targets: the distance to the nearest surface and (albedo, cos theta_i).
    pub distance: &'a wgpu::TextureView,
    pub material: &'a wgpu::TextureView,
    /// The sun's pyramid of block maxima (Cull's: a triangle it shows hidden is not listed).
    pub pyramid: &'a wgpu::Buffer,
}

/// Mirrors `struct ExactParams` in exact_shadows.wgsl (checked by a layout test).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct ExactParams {
    /// Tiles across and down the fitted rectangle, their number, and the list's capacity (entries).
    pub tiles: UVec4,
    /// `EPS_FLOOR` (scene units), `EPS_PER_DISTANCE`, `MIN_COS`, `TOL` (tiles): see the shader.
    pub eps: Vec4,
    /// x: the positions' rounding ([`ExactShadows::rounding`], scene units); yzw unused.
    pub rounding: Vec4,
}

/// The test's tolerances (exact_shadows.wgsl). The depth offset is along the light, the point's
/// own triangle being a few f32 steps of its view distance away (the distance texture is f32):
/// 2e-5 of it, divided by `cos theta_i` (an offset along the light clears the plane by that times
/// the cosine), with a floor for points next to the eye. On the classroom 4e-6 left acne and 4e-4
/// let light in at contacts; 1.5e-5 to 4e-5 gave the same error (docs/tried.md, session 44).
const EPS_FLOOR: f32 = 1e-5;
const EPS_PER_DISTANCE: f32 = 2e-5;
const MIN_COS: f32 = 0.02;
/// A millionth of a tile: neighbouring triangles overlap at their shared edge.
const TOL: f32 = 1e-6;
/// f32 steps of the largest coordinate in the depth offset: the rasterizer places a point from
/// world positions, so far from the origin it lies off its plane by their spacing. The check's
/// scene 141 km out (8 mm steps) under a sun: the whole image 87% off the reference with none
/// (the floor shadowed itself in bands), 34% with a quarter step, 8.25% from half a step on, as
/// the map's 8.6% (`tests/exact_shadows.rs`, `exact_shadows_hold_at_every_scale`; session 45).
/// Near the origin it is far below EPS_FLOOR.
const EPS_PER_ULP: f32 = 2.0;

/// What a frame's test needed ([`ExactShadows::read_stats`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub struct ExactStats {
    /// List entries the triangles asked for, and those past the capacity.
    pub entries: u64,
    pub overflow: u32,
    /// Tiles, those with a surface point, and those one triangle darkens whole.
    pub tiles: usize,
    pub tiles_with_points: usize,
    pub dark_tiles: usize,
}

pub struct ExactShadows {
    pipelines: SpecialisedCompute<6>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// An [`ExactParams`].
    params: wgpu::Buffer,
    /// Per tile its entries, then its first entry; the entries recorded and past the capacity;
    /// the tiles' and blocks' bounds (exact_shadows.wgsl).
    tiles: Option<wgpu::Buffer>,
    /// Per triangle its edges, depth plane and projection's box (four `vec4<f32>`).
    planes: Option<wgpu::Buffer>,
    list: Option<wgpu::Buffer>,
    /// The entries as `count` made them (tile, place, list entry), for `fill`.
    recorded: Option<wgpu::Buffer>,
    /// Per pixel 1 lit, 0 shadowed (`u32`): what Composite reads.
    pub vis: Option<wgpu::Buffer>,
    /// The last frame's list entries and those past the capacity, copied out for the renderer.
    readback: wgpu::Buffer,
    /// Tiles across and down, the list's capacity and the triangles the buffers hold.
    tile_dims: (u32, u32),
    capacity: u32,
    triangles: u32,
    pixels: u64,
}

impl ExactShadows {
    /// Tiles over the fitted rectangle: about `TILE_BUDGET` of them, square in scene units.
    pub const TILE_BUDGET: u32 = 8192;
    /// A list entry: the triangle and its box within the tile (`vec2<u32>`).
    const ENTRY_BYTES: u64 = 8;
    /// A recorded entry: its tile and place there, and the list entry (`vec4<u32>`): the larger
    /// of the two buffers an entry takes.
    pub const RECORDED_BYTES: u64 = 16;
    /// A triangle's planes: its edges, depth plane and projection's box (four `vec4<f32>`).
    const PLANE_BYTES: u64 = 64;
    /// The list's first capacity: entries per triangle, and per tile.
    const ENTRIES_PER_TRIANGLE: u32 = 4;
    const ENTRIES_PER_TILE: u32 = 16;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<ExactShadows, GpuError> {
        let module = lib.module(device, "exact_shadows.wgsl")?;
        let layout = ExactShadowsBindings::layout(device, "ExactShadows::layout", wgpu::ShaderStages::COMPUTE);
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ExactShadows::params"),
            size: std::mem::size_of::<ExactParams>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ExactShadows::readback"),
            size: 8,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(ExactShadows {
            readback,
            pipelines: SpecialisedCompute::new(
                device,
                "ExactShadows",
                module,
                &layout,
                ["points", "block_bounds", "count", "offsets", "fill", "test"],
                Specialised::Light,
            ),
            layout,
            bind_group: None,
            params,
            tiles: None,
            planes: None,
            list: None,
            recorded: None,
            vis: None,
            tile_dims: (0, 0),
            capacity: 0,
            triangles: 0,
            pixels: 0,
        })
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// Workgroups of `fill`, whose threads stride over the recorded entries.
    const FILL_GROUPS: u32 = 1024;

    /// Tiles per side of a block (exact_shadows.wgsl's `BLOCK`).
    pub const BLOCK: u32 = 8;

    /// Words of the tiles' buffer for `w x h` tiles (exact_shadows.wgsl, `tiles`).
    fn tile_words((w, h): (u32, u32)) -> u64 {
        let blocks = (w.div_ceil(Self::BLOCK) * h.div_ceil(Self::BLOCK)) as u64;
        4 * (w * h) as u64 + 3 + 2 * blocks
    }

    /// Tiles across and down for a rectangle `aspect` times as wide as high (scene units).
    pub fn tile_dims(aspect: f32) -> (u32, u32) {
        let aspect = if aspect.is_finite() && aspect > 0.0 { aspect.clamp(1.0 / 64.0, 64.0) } else { 1.0 };
        let budget = Self::TILE_BUDGET as f32;
        let w = (budget * aspect).sqrt().round().max(1.0);
        let h = (budget / w).round().max(1.0);
        (w as u32, h as u32)
    }

    /// Makes the buffers for `triangles` triangles, `pixels` pixels and `tile_dims` tiles, with at
    /// least `capacity` list entries; true when any buffer was made anew (the bind group must be
    /// made again).
    pub fn ensure(
        &mut self,
        device: &wgpu::Device,
        triangles: u32,
        pixels: u64,
        tile_dims: (u32, u32),
        capacity: u32,
    ) -> bool {
        let mut changed = false;
        let buffer = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size.max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        if self.tiles.as_ref().is_none_or(|b| b.size() < Self::tile_words(tile_dims) * 4) {
            self.tiles = Some(buffer("ExactShadows::tiles", Self::tile_words(tile_dims) * 4));
            changed = true;
        }
        self.tile_dims = tile_dims;
        if self.planes.is_none() || self.triangles != triangles {
            self.planes = Some(buffer("ExactShadows::planes", triangles as u64 * Self::PLANE_BYTES));
            self.triangles = triangles;
            changed = true;
        }
        let wanted = capacity.max(1);
        if self.list.is_none() || self.capacity < wanted {
            self.list = Some(buffer("ExactShadows::list", wanted as u64 * Self::ENTRY_BYTES));
            self.recorded = Some(buffer("ExactShadows::recorded", wanted as u64 * Self::RECORDED_BYTES));
            self.capacity = wanted;
            changed = true;
        }
        if self.vis.is_none() || self.pixels != pixels {
            self.vis = Some(buffer("ExactShadows::vis", pixels * 4));
            self.pixels = pixels;
            changed = true;
        }
        changed
    }

    /// The list's first capacity for `triangles` triangles over `tile_dims` tiles, within a
    /// binding of `max_binding` bytes: a guess (the classroom's 104 000 triangles over 8 192 tiles
    /// ask for ~123 000 entries), grown when a frame asks for more.
    pub fn first_capacity(triangles: u32, (w, h): (u32, u32), max_binding: u64) -> u32 {
        let guess =
            triangles.saturating_mul(Self::ENTRIES_PER_TRIANGLE).max((w * h).saturating_mul(Self::ENTRIES_PER_TILE));
        guess.min((max_binding / Self::RECORDED_BYTES).min(u32::MAX as u64) as u32)
    }

    /// Whether the per-triangle planes of `triangles` triangles fit a binding of `max_binding`
    /// bytes (a larger scene keeps the map).
    pub fn fits(triangles: u32, max_binding: u64) -> bool {
        triangles as u64 * Self::PLANE_BYTES <= max_binding
    }

    /// What the last frame left in the tiles' buffer.
    pub fn read_stats(&self, ctx: &crate::gpu::GpuContext) -> Result<Option<ExactStats>, GpuError> {
        let Some(tiles) = &self.tiles else { return Ok(None) };
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.read_buffer(tiles)?);
        let n = (self.tile_dims.0 * self.tile_dims.1) as usize;
        let at = |i: usize| words.get(i).copied().unwrap_or(0);
        // The non-zero words of the stretch of n from `from`.
        let nonzero = |from: usize| (from..from + n).filter(|&i| at(i) != 0).count();
        Ok(Some(ExactStats {
            entries: at(n) as u64,
            overflow: at(n + 2),
            tiles: n,
            tiles_with_points: nonzero(n + 3),
            dark_tiles: nonzero(3 * n + 3),
        }))
    }

    /// Binds `inputs` and `geometry`'s triangles (in one chunk: [`SceneGpu::whole_triangles`]; else
    /// no bind group, and the renderer keeps the map).
    pub fn bind(&mut self, device: &wgpu::Device, geometry: &SceneGpu, inputs: ExactInputs) {
        let ExactInputs { frame, shadow, distance, material, pyramid } = inputs;
        let (Some(tiles), Some(planes), Some(list), Some(recorded), Some(vis), Some(tris)) =
            (&self.tiles, &self.planes, &self.list, &self.recorded, &self.vis, geometry.whole_triangles())
        else {
            return;
        };
        use wgpu::BindingResource as R;
        let b = ExactShadowsBindings {
            frame_in: frame.as_entire_binding(),
            shadow_in: shadow.as_entire_binding(),
            params_in: self.params.as_entire_binding(),
            tris: tris.as_entire_binding(),
            tiles: tiles.as_entire_binding(),
            planes: planes.as_entire_binding(),
            list: list.as_entire_binding(),
            vis: vis.as_entire_binding(),
            distance: R::TextureView(distance),
            material: R::TextureView(material),
            sides: geometry.light_sides.as_entire_binding(),
            recorded: recorded.as_entire_binding(),
            pyramid: pyramid.as_entire_binding(),
        };
        self.bind_group = Some(b.bind(device, "ExactShadows::bind_group", &self.layout));
    }

    /// The depth offset's share for the rounding of positions whose largest coordinate is
    /// `largest` (scene units): `EPS_PER_ULP` f32 steps there.
    pub fn rounding(largest: f32) -> f32 {
        EPS_PER_ULP * largest.abs() * f32::EPSILON
    }

    /// Records the six dispatches for a `width x height` image (after Surface and ShadowFit); the
    /// scene's largest coordinate, of the eye and its box, is `largest`.
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        (width, height): (u32, u32),
        largest: f32,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([points, block_bounds, count, offsets, fill, test]), Some(bind_group), Some(tiles)) =
            (self.pipelines.get(variant), &self.bind_group, &self.tiles)
        else {
            return;
        };
        let (w, h) = self.tile_dims;
        let params = ExactParams {
            tiles: UVec4::new(w, h, w * h, self.capacity),
            eps: Vec4::new(EPS_FLOOR, EPS_PER_DISTANCE, MIN_COS, TOL),
            rounding: Vec4::new(Self::rounding(largest), 0.0, 0.0, 0.0),
        };
        queue.write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        encoder.clear_buffer(tiles, 0, Some(Self::tile_words((w, h)) * 4));
        // (Two dimensions past 65535 workgroups: exact_shadows.wgsl's `thread_index`.)
        let per_triangle = super::util::split_groups(self.triangles.div_ceil(64));
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("ExactShadows::pass"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, bind_group, &[]);
        pass.set_pipeline(points);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        pass.set_pipeline(block_bounds);
        pass.dispatch_workgroups((w.div_ceil(Self::BLOCK) * h.div_ceil(Self::BLOCK)).div_ceil(64), 1, 1);
        pass.set_pipeline(count);
        pass.dispatch_workgroups(per_triangle.0, per_triangle.1, 1);
        pass.set_pipeline(offsets);
        pass.dispatch_workgroups(1, 1, 1);
        pass.set_pipeline(fill);
        pass.dispatch_workgroups(self.capacity.div_ceil(64).clamp(1, Self::FILL_GROUPS), 1, 1);
        pass.set_pipeline(test);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
        drop(pass);
        // The total and the entries past the capacity: words T and T + 2.
        let n = (w * h) as u64;
        encoder.copy_buffer_to_buffer(tiles, n * 4, &self.readback, 0, 4);
        encoder.copy_buffer_to_buffer(tiles, (n + 2) * 4, &self.readback, 4, 4);
    }

    /// The list entries the last recorded frame's triangles asked for, when they were more than
    /// its capacity (its test then missed some of them): waits for that frame.
    pub fn overflowed(&self, ctx: &crate::gpu::GpuContext) -> Result<Option<u64>, GpuError> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&ctx.map_read(&self.readback)?);
        let (total, over) = (words.first().copied().unwrap_or(0), words.get(1).copied().unwrap_or(0));
        // The total counts every entry asked for, those past the capacity too.
        Ok((over > 0).then_some(total as u64))
    }
}

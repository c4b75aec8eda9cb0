//! HitBounds: the least and the greatest key of each word of the first-hit volume's bins
//! (`shaders/hit_bounds.wgsl`; [`super::ShadowVolume::FirstHits`]):
//!
//!   bounds[x * words + j] = (min, max) over bins 32 j .. 32 j + 31 of plane x's first-hit keys
//!
//! stored by fours (four words' least, then their greatest). Integrate reads a word whose keys all
//! lie on one side of a pixel's angle from its two bounds alone. In a first-hit frame it runs
//! where Scan runs in a bit-grid frame.

use super::util::{bindings, compute_pipeline, Kind};
use crate::epipolar::GridMapping;
use crate::gpu::{GpuError, ShaderLibrary};
use crate::params::Grid;

bindings! {
    /// HitBounds' bind group (hit_bounds.wgsl).
    HitBoundsBindings { frame_in: Kind::Storage, volume: Kind::StorageRw }
}

/// Threads per workgroup (hit_bounds.wgsl's `@workgroup_size`).
const WORKGROUP: u32 = 64;

pub struct HitBounds {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
}

impl HitBounds {
    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<HitBounds, GpuError> {
        let layout = HitBoundsBindings::layout(device, "HitBounds::layout", wgpu::ShaderStages::COMPUTE);
        let module = lib.module(device, "hit_bounds.wgsl")?;
        let pipeline = compute_pipeline(device, "HitBounds::pipeline", &module, "main", &layout);
        Ok(HitBounds { pipeline, layout, bind_group: None })
    }

    /// The first-hit volume's bytes for `grid`: a key per plane and bin, two per word of bins (by
    /// fours), and 1 KiB of slack (Integrate reads up to three words past a plane's last, which it
    /// masks: past the last plane's, they stay inside the buffer).
    pub fn volume_bytes(grid: &Grid) -> u64 {
        let words = grid.planes as u64 * grid.words() as u64;
        Self::key_bytes(grid) + (8 * words.div_ceil(4) + 256) * 4
    }

    /// The bytes of the keys alone (the part a frame clears before Voxelize).
    pub fn key_bytes(grid: &Grid) -> u64 {
        grid.planes as u64 * grid.bins as u64 * 4
    }

    /// (Re)binds the volume; called when it changes.
    pub fn bind(&mut self, device: &wgpu::Device, b: HitBoundsBindings) {
        self.bind_group = Some(b.bind(device, "HitBounds::bind_group", &self.layout));
    }

    /// A thread per word of bins of every plane of `grid`.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, grid: &Grid) {
        let Some(bind_group) = &self.bind_group else { return };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("HitBounds::pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        // At most 8192 planes x 64 words (Grid's limits): 8192 workgroups, one dimension.
        pass.dispatch_workgroups((grid.planes * grid.words()).div_ceil(WORKGROUP), 1, 1);
    }
}

/// The first-hit volume's `keys` (`planes x bins`, as the buffer starts) as the bit grid's layers
/// (`planes x rays x words`, [`Grid::ray_offset`]'s layout), for the inspector and tests: each hit
/// binned to the ray cell that holds its angle under `mapping`, as the bits' Voxelize bins it.
/// `geometry`: the bit of each light ray's first hit alone (the bits' geometry layer shows every
/// hit; the first hits keep only the first); else the shadow volume, set from the hit's cell on
/// (the bits' scan).
pub fn first_hits_as_bits(keys: &[u32], grid: &Grid, mapping: &GridMapping, geometry: bool) -> Vec<u32> {
    let (rays, words) = (grid.rays as usize, grid.words() as usize);
    let mut out = vec![0u32; grid.planes as usize * rays * words];
    let per_radian = rays as f64 / (mapping.gamma_hi - mapping.gamma_lo);
    // Per plane and word: the bits whose hit lies in each cell, then (the shadow) ORed on along
    // the cells: a pass over the cells per word, not one per hit.
    let mut enter = vec![0u32; rays];
    for (x, row) in keys.chunks_exact(grid.bins as usize).take(grid.planes as usize).enumerate() {
        for (w, word_keys) in row.chunks_exact(32).enumerate() {
            enter.fill(0);
            for (b, &key) in word_keys.iter().enumerate() {
                let cell = ((f32::from_bits(!key) as f64 - mapping.gamma_lo) * per_radian).floor().max(0.0);
                if key != 0 && cell < rays as f64 {
                    enter[cell as usize] |= 1 << b;
                }
            }
            let mut shadow = 0u32;
            for (y, &bits) in enter.iter().enumerate() {
                shadow = if geometry { bits } else { shadow | bits };
                out[(x * rays + y) * words + w] = shadow;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A key as Voxelize writes it (common.wgsl `hit_key`).
    fn key(gamma: f32) -> u32 {
        !gamma.max(0.0).to_bits()
    }

    #[test]
    fn keys_order_angles_backward_and_no_hit_is_zero() {
        assert!(key(0.1) > key(0.2) && key(0.2) > key(3.1));
        assert!(key(std::f32::consts::PI) > 0 && key(0.0) == u32::MAX);
    }

    #[test]
    fn first_hits_become_the_bits_layers() {
        let grid = Grid { planes: 2, rays: 4, bins: 64, ..Grid::default() };
        let mapping = GridMapping {
            grid,
            phi0: 0.0,
            phi_span: 1.0,
            phi_wraps: false,
            gamma_lo: 0.0,
            gamma_hi: 4.0,
            z_lo: 0.0,
            z_hi: 1.0,
            spacing: grid.spacing,
        };
        let mut keys = vec![0u32; 2 * 64];
        keys[3] = key(1.5); // plane 0, bin 3: cell 1
        keys[64 + 40] = key(0.2); // plane 1, bin 40 (word 1, bit 8): cell 0
        keys[64 + 41] = key(9.0); // past the last cell: no bit
        let at = |g: &[u32], x: usize, y: usize, w: usize| g[(x * 4 + y) * 2 + w];
        let shadow = first_hits_as_bits(&keys, &grid, &mapping, false);
        assert_eq!([0, 1, 2, 3].map(|y| at(&shadow, 0, y, 0)), [0, 8, 8, 8]);
        assert_eq!([0, 1, 2, 3].map(|y| at(&shadow, 1, y, 1)), [256; 4]);
        assert_eq!(shadow.iter().filter(|&&w| w != 0).count(), 7);
        let hits = first_hits_as_bits(&keys, &grid, &mapping, true);
        assert_eq!((at(&hits, 0, 1, 0), at(&hits, 1, 0, 1)), (8, 256));
        assert_eq!(hits.iter().filter(|&&w| w != 0).count(), 2);
    }
}

//! HitBounds: the bounds of each word of the first-hit volume's bins
//! (`shaders/hit_bounds.wgsl`; [`super::ShadowVolume::FirstHits`]): over the keys k_b of plane x's
//! bins 32 j .. 32 j + 31, split at the middle key m = lo + (hi - lo) / 2,
//!
//!   lo = min k_b,  hi = max k_b,  below = max { k_b <= m },  above = min { k_b > m },
//!   mask = the bits b with k_b > m,  wide = above - below > (hi - lo) / 4
//!
//! stored by fours ([`WordBounds::read`]). Integrate reads a word whose keys all lie on one side of
//! a pixel's from lo and hi alone, one whose keys the pixel's splits at a wide gap (below, above)
//! from its mask, and compares the 32 keys of the others only. In a first-hit frame it runs where
//! Scan runs in a bit-grid frame.

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

    /// The first-hit volume's bytes for `grid`: a key per plane and bin, five per word of bins
    /// ([`WordBounds`], by fours), and 1 KiB of slack (Integrate reads up to three words past a
    /// plane's last, which it masks: past the last plane's, they stay inside the buffer).
    pub fn volume_bytes(grid: &Grid) -> u64 {
        let words = grid.planes as u64 * grid.words() as u64;
        Self::key_bytes(grid) + (WordBounds::PER_FOUR * words.div_ceil(4) + 256) * 4
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

/// One word's bounds (hit_bounds.wgsl): its least key (rounded down to even, its lowest bit holding
/// `wide`) and greatest key, and the gap around the middle key between them, `below` and `above`,
/// with `mask` the bits whose keys lie above it; `wide`: the gap spans more than a quarter of the
/// keys' span (a shadow's edge), the only gap Integrate reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WordBounds {
    pub lo: u32,
    pub hi: u32,
    pub below: u32,
    pub above: u32,
    pub mask: u32,
    pub wide: bool,
}

impl WordBounds {
    /// Words of bounds per group of four words of bins: five vectors, each a field of four words.
    pub const PER_FOUR: u64 = 20;

    /// The bounds HitBounds writes for a word's 32 keys.
    pub fn of(keys: &[u32; 32]) -> WordBounds {
        let lo = keys.iter().copied().min().unwrap_or(0);
        let hi = keys.iter().copied().max().unwrap_or(0);
        let mid = lo + (hi - lo) / 2;
        let (mut below, mut above, mut mask) = (lo, hi, 0);
        for (b, &k) in keys.iter().enumerate() {
            if k > mid {
                above = above.min(k);
                mask |= 1 << b;
            } else {
                below = below.max(k);
            }
        }
        let wide = above - below > (hi - lo) / 4;
        WordBounds { lo: lo & !1, hi, below, above, mask, wide }
    }

    /// Word `i`'s bounds (`i = plane * words + word`) in a first-hit volume for `grid`, as read
    /// back (the keys, then the bounds by fours).
    pub fn read(volume: &[u32], grid: &Grid, i: usize) -> WordBounds {
        let at = grid.planes as usize * grid.bins as usize + Self::PER_FOUR as usize * (i / 4) + i % 4;
        let [lo, hi, below, above, mask] = [0, 4, 8, 12, 16].map(|o| volume[at + o]);
        WordBounds { lo: lo & !1, hi, below, above, mask, wide: lo & 1 == 1 }
    }

    /// The word's shadow bits for a pixel's `key` where its bounds settle them, as Integrate
    /// settles them (bit b: bin b's first hit comes before the pixel, its key greater), or `None`
    /// where only its keys do.
    pub fn settle(&self, key: u32) -> Option<u32> {
        if self.hi <= key {
            Some(0)
        } else if self.lo > key {
            Some(!0)
        } else if self.wide && self.below <= key && key < self.above {
            Some(self.mask)
        } else {
            None
        }
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
    use proptest::strategy::Just;

    /// A key as Voxelize writes it (common.wgsl `hit_key`).
    fn key(gamma: f32) -> u32 {
        !gamma.max(0.0).to_bits()
    }

    #[test]
    fn keys_order_angles_backward_and_no_hit_is_zero() {
        assert!(key(0.1) > key(0.2) && key(0.2) > key(3.1));
        assert!(key(std::f32::consts::PI) > 0 && key(0.0) == u32::MAX);
    }

    /// The bits a word's keys give a pixel's key (bin b shadowed where its key is greater).
    fn exact_bits(keys: &[u32; 32], key: u32) -> u32 {
        keys.iter().enumerate().filter(|(_, &k)| k > key).fold(0, |m, (b, _)| m | 1 << b)
    }

    proptest::proptest! {
        /// Whatever the keys (clusters, a slope, misses), a word its bounds settle is the word its
        /// keys give, at every pixel key near theirs.
        #[test]
        fn bounds_settle_a_word_only_as_its_keys_would(
            keys in proptest::array::uniform32(proptest::prop_oneof![
                Just(0u32), 1000u32..1100, 5000u32..5100, 0u32..=u32::MAX
            ])
        ) {
            let w = WordBounds::of(&keys);
            let probes = keys.iter().flat_map(|&k| [k.wrapping_sub(1), k, k.wrapping_add(1)]);
            for key in probes.chain([0, u32::MAX, w.lo + (w.hi - w.lo) / 2]) {
                if let Some(bits) = w.settle(key) {
                    proptest::prop_assert_eq!(bits, exact_bits(&keys, key), "key {}", key);
                }
            }
        }
    }

    #[test]
    fn a_word_across_a_shadow_edge_settles_between_its_two_groups() {
        // Light rays 0..12 meet a near caster (large keys: small angles), the rest a far wall.
        let keys: [u32; 32] = std::array::from_fn(|b| if b < 12 { key(0.30 + b as f32 * 1e-3) } else { key(0.9) });
        let w = WordBounds::of(&keys);
        assert!(w.wide);
        for gamma in [0.35f32, 0.5, 0.7, 0.89] {
            assert_eq!(w.settle(key(gamma)), Some(0xfff), "gamma {gamma}");
        }
        // Past the wall every bin is shadowed, before the caster none; inside the caster's own
        // spread of angles only the keys tell.
        assert_eq!((w.settle(key(0.95)), w.settle(key(0.2))), (Some(!0), Some(0)));
        assert_eq!(w.settle(key(0.305)), None);
        // All alike: no gap, only the bounds.
        let flat = WordBounds::of(&[key(0.5); 32]);
        assert!(!flat.wide);
        assert_eq!((flat.settle(key(0.4)), flat.settle(key(0.6))), (Some(0), Some(!0)));
        // A slope of keys (a surface the light rays meet one after another): its middle gap is
        // one step of 31, too narrow to be worth reading; its bounds still settle.
        let slope: [u32; 32] = std::array::from_fn(|b| key(0.5 + b as f32 * 1e-3));
        let w = WordBounds::of(&slope);
        assert!(!w.wide && w.settle(key(0.5155)).is_none());
        assert_eq!((w.settle(key(0.45)), w.settle(key(0.6))), (Some(0), Some(!0)));
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

// hit_bounds.wgsl: the bounds of the first-hit volume's words, which Integrate reads before their
// keys (common.wgsl, "The first-hit volume"; Renderer::shadow_volume: first-hits).
//
// For plane x and word j of its bins (word i = x * words + j of the volume), over the keys k_b of
// bins 32 j + b (b = 0..31), split at the middle key m = lo + (hi - lo) / 2:
//
//   lo = min k_b,   hi = max k_b,
//   below = max { k_b : k_b <= m },   above = min { k_b : k_b > m },   mask = bits b with k_b > m,
//   wide = above - below > (hi - lo) / 4   (stored as lo's lowest bit: lo rounded down to even),
//
// stored by fours past the planes x bins keys, five vectors a group of four words (words 4g to
// 4g + 3, component c = i % 4):
//
//   bounds[20 g + c] = lo,  [20 g + 4 + c] = hi,  [20 g + 8 + c] = below,  [20 g + 12 + c] = above,
//   [20 g + 16 + c] = mask,
//
// so that Integrate reads a plane's four words' bounds as vectors. A pixel with key K (its
// angle's) reads a word as all lit where hi <= K (no light ray of it meets a triangle before the
// pixel's angle), as all shadowed where lo > K, as `mask` where the gap is wide and
// below <= K < above (no key lies between the two, so a bin's key is greater than K exactly where
// it is greater than m), and only otherwise compares its 32 keys. The gap at the middle is the one
// a word across a shadow's edge has: its light rays meet a near caster on one side and a far
// surface (or nothing) on the other, and a pixel whose view ray crosses that edge has its key
// between the two (docs/results.md, session 48: the classroom's Integrate 10-22% shorter). This
// pass takes the place of Scan: first hits need no prefix OR.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> volume: array<u32>;

// (A thread per word of bins, of every plane: the dispatch is planes x words / 64 workgroups.)
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    let grid = frame_in.grid;
    let i = id.x;
    if (i >= grid.x * grid.w) { return; }
    var lo = ~0u;
    var hi = 0u;
    for (var b = 0u; b < 32u; b++) {
        let key = volume[32u * i + b];
        lo = min(lo, key);
        hi = max(hi, key);
    }
    // (hi - lo) / 2 first: lo + hi can overflow.
    let mid = lo + (hi - lo) / 2u;
    var below = lo;
    var above = hi;
    var mask = 0u;
    for (var b = 0u; b < 32u; b++) {
        let key = volume[32u * i + b];
        let up = key > mid;
        below = select(max(below, key), below, up);
        above = select(above, min(above, key), up);
        mask |= select(0u, 1u << b, up);
    }
    // Only a gap wider than a quarter of the keys' span is worth Integrate's three loads (a
    // shadow's edge); in a slope of keys (a surface the light rays meet one after another) a pixel
    // seldom falls between two neighbouring keys. The flag takes lo's lowest bit, which leaves lo
    // rounded down by at most one: lo > K only where the true least key is (never a wrong word).
    let wide = above - below > (hi - lo) / 4u;
    let at = grid.x * grid.z + 20u * (i / 4u) + i % 4u;
    volume[at] = (lo & ~1u) | select(0u, 1u, wide);
    volume[at + 4u] = hi;
    volume[at + 8u] = below;
    volume[at + 12u] = above;
    volume[at + 16u] = mask;
}

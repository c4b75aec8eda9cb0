// hit_bounds.wgsl: the bounds of the first-hit volume's words, which Integrate reads before their
// keys (common.wgsl, "The first-hit volume"; Renderer::shadow_volume: first-hits).
//
// For plane x and word j of its bins (word i = x * words + j of the volume), the least and the
// greatest key of bins 32 j to 32 j + 31, stored by fours past the planes x bins keys: the four
// least of words 4g to 4g + 3, then their four greatest,
//
//   bounds[8 g + c] = min of volume[32 i .. 32 i + 31],   bounds[8 g + 4 + c] = max,   i = 4 g + c
//
// so that Integrate reads a plane's four words' bounds as two vectors. A pixel with key K (its
// angle's) reads a word as all lit where max <= K (no light ray of it meets a triangle before the
// pixel's angle), as all shadowed where min > K, and only otherwise compares its 32 keys. This
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
    let at = grid.x * grid.z + 8u * (i / 4u) + i % 4u;
    volume[at] = lo;
    volume[at + 4u] = hi;
}

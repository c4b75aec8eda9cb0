// scan_words.wgsl: scan.wgsl for grids whose rays do not start on four words (bins not a multiple of
// 128), a word at a time: the shadow volume, an inclusive prefix-OR of the geometry bits along each
// light ray.
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]
//
// Along a light ray (fixed plane x and bin k) gamma grows with y, so after the scan a set bit means
// "some caster lies between this voxel and the light". One thread per plane and group of four
// 32-bit words (the light rays of 128 bins); the grid is plane-major ((plane * rays + ray) * words
// + word, common.wgsl), so a thread streams down its light rays `words` words at a time, and the
// threads of one plane touch neighbouring words at every step. Read once, written once. Four words
// per thread rather than one took a tenth off the pass on llvmpipe (docs/results.md, session 14).
// (Not scan.wgsl's vectors: where a ray's words straddle them, a store to one word of a vector
// writes the whole vector, and the threads of neighbouring words would overwrite each other's.)

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<u32>;
// Per plane, the ray cells [first, end) the frame's pixels can read (scan.wgsl).
@group(0) @binding(2) var<storage, read> plane_rays: array<vec2u>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// Words per thread (cull.wgsl sizes the dispatch by it).
const GROUP: u32 = 4u;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    let words = f.grid.w;
    let groups = (words + GROUP - 1u) / GROUP;
    let column = id.x; // plane * groups + group
    if (column >= f.grid.x * groups) { return; }
    let w0 = (column % groups) * GROUP;
    let base = ray_offset(f, column / groups, 0u) + w0;
    let cells = plane_rays[column / groups];
    if (w0 + GROUP <= words) {
        var acc = vec4u(0u);
        for (var y = cells.x; y < cells.y; y++) {
            let i = base + y * words;
            acc |= vec4u(grid[i], grid[i + 1u], grid[i + 2u], grid[i + 3u]);
            grid[i] = acc.x;
            grid[i + 1u] = acc.y;
            grid[i + 2u] = acc.z;
            grid[i + 3u] = acc.w;
        }
        return;
    }
    // The last group of a ray whose words are not a multiple of four.
    for (var w = 0u; w0 + w < words; w++) {
        var acc = 0u;
        for (var y = cells.x; y < cells.y; y++) {
            let i = base + w + y * words;
            acc |= grid[i];
            grid[i] = acc;
        }
    }
}

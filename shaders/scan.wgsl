// scan.wgsl: the shadow volume, an inclusive prefix-OR of the geometry bits along each light ray.
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]
//
// Along a light ray (fixed plane x and bin k) gamma grows with y, so after the scan a set bit means
// "some caster lies between this voxel and the light". One thread per (plane, 32-bit word); the grid
// is plane-major ((plane * rays + ray) * words + word, common.wgsl), so a thread streams down its
// light rays `words` words at a time, and the threads of one plane touch neighbouring words at
// every step. Read once, written once: bandwidth bound.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<u32>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    let planes = f.grid.x;
    let rays = f.grid.y;
    let words = f.grid.w;
    let column = id.x; // plane * words + word
    if (column >= planes * words) { return; }
    let base = ray_offset(f, column / words, 0u) + column % words;
    var acc = 0u;
    for (var y = 0u; y < rays; y++) {
        let i = base + y * words;
        acc = acc | grid[i];
        grid[i] = acc;
    }
}

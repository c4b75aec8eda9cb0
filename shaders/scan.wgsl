// scan.wgsl: the shadow volume, an inclusive prefix-OR of the geometry bits along each light ray.
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]
//
// Along a light ray (fixed plane x and bin k) gamma grows with y, so after the scan a set bit means
// "some caster lies between this voxel and the light". One thread per plane and group of four
// 32-bit words (the light rays of 128 bins); the grid is plane-major ((plane * rays + ray) * stride
// + word, common.wgsl), so a thread streams down its light rays four words at a time, and the
// threads of one plane touch neighbouring words at every step. Read once, written once. The words
// are read and written as one vec4u: every ray starts on 16 bytes (Grid::stride), and on llvmpipe a
// load costs one instruction per lane whatever its width, so the vector took the pass from ~63 to
// ~35 ms on the classroom (docs/results.md, session 15).

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<vec4u>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    // Vectors per ray (f.grid.w, the stride in words, is a multiple of four).
    let quads = f.grid.w / 4u;
    let column = id.x; // plane * quads + quad
    if (column >= f.grid.x * quads) { return; }
    let start = ray_offset(f, column / quads, 0u) / 4u + column % quads;
    var acc = vec4u(0u);
    for (var y = 0u; y < f.grid.y; y++) {
        let i = start + y * quads;
        acc |= grid[i];
        grid[i] = acc;
    }
}

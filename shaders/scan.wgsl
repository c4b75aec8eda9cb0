// scan.wgsl: the shadow volume, an inclusive prefix-OR of the geometry bits along each light ray.
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k]
//
// Along a light ray (fixed plane x and bin k) gamma grows with y, so after the scan a set bit means
// "some caster lies between this voxel and the light". The grid is plane-major ((plane * rays +
// ray) * words + word, common.wgsl), so a thread streams down its light rays one ray's words at a
// time, and the threads of one plane touch neighbouring words at every step. Read once, written
// once, and once all four words are full (every light ray of them shadowed) the rest of the column
// is only written: the classroom's words fill up at ray cell 211 of 512 on average. One loop over
// the rays with the read skipped once full, not a loop up to the fill and a write-only loop after
// it: a SIMD group runs each loop for as long as its slowest lane, so with two loops it stepped
// through the latest fill plus the longest tail, up to twice the rays (session 32: Scan 8-10%
// faster on the classroom and the built-in room, the same bits). For grids
// whose rays start on four words (bins a multiple of 128, Grid::quad_rays; the others take
// scan_words.wgsl): a thread takes four words as one vec4u, and on llvmpipe a load costs one
// instruction per lane whatever its width: the vector took the pass from ~60 to ~35 ms on the
// classroom (docs/results.md, session 15).

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<vec4u>;
// Per plane, the ray cells [first, end) the frame's pixels can read (GridMapping::plane_rays):
// Voxelize put every caster before `first` into it, so the scan starts there and stops at `end`.
@group(0) @binding(2) var<storage, read> plane_rays: array<vec2u>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// (cull.wgsl sizes the dispatch: a thread per plane and vector of four words.)
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    let words = f.grid.w;
    let column = id.x;
    let quads = words / 4u;
    if (column >= f.grid.x * quads) { return; }
    let plane = column / quads;
    let start = ray_offset(f, plane, 0u) / 4u + column % quads;
    let cells = plane_rays[plane];
    var acc = vec4u(0u);
    for (var y = cells.x; y < cells.y; y++) {
        let i = start + y * quads;
        if (any(acc != vec4u(0xffffffffu))) { acc |= grid[i]; }
        grid[i] = acc;
    }
}

// scan_columns.wgsl: scan.wgsl with a workgroup per column, for hardware GPUs: the shadow volume,
// an inclusive prefix-OR of the geometry bits along each light ray,
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k].
//
// scan.wgsl gives a column (a plane's four words of bins, all its rays) to one thread, which walks
// the rays in turn: on two CPU cores that is the cheapest order, but a GPU then holds one thread
// per column (12 288 at the default grid, 2 048 at 1024x1024x256, where an H200 keeps ~270 000
// in flight) and each waits on memory once per ray: 0.44-0.49 ms on an H200 (docs/results.md).
// Here the column's rays are split into THREADS runs: each thread ORs its run (A_t), the
// workgroup ORs the runs before each thread (C_t = A_0 | .. | A_{t-1}), and each thread writes its
// run's prefix-OR starting from C_t. Every word is read twice and written once; once C_t is full
// (every light ray of the four words shadowed) the run is only written. Grids whose rays start on
// four words only (Grid::quad_rays), as scan.wgsl. Same bits as scan.wgsl (tests/gpu.rs).

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<vec4u>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

const THREADS: u32 = 64u;
var<workgroup> runs: array<vec4u, THREADS>;

// A column per workgroup; the dispatch is (min(columns, 65535), ceil(columns / 65535)) (Scan::record).
@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) t: u32) {
    f = frame_in;
    let quads = f.grid.w / 4u;
    let column = wg.y * 65535u + wg.x;
    // (Uniform across the workgroup: the barrier below is reached by all of it or none.)
    if (column >= f.grid.x * quads) { return; }
    let start = ray_offset(f, column / quads, 0u) / 4u + column % quads;
    let rays = f.grid.y;
    let per = (rays + THREADS - 1u) / THREADS;
    let y0 = min(t * per, rays);
    let y1 = min(y0 + per, rays);
    var acc = vec4u(0u);
    for (var y = y0; y < y1; y++) {
        acc |= grid[start + y * quads];
    }
    runs[t] = acc;
    workgroupBarrier();
    var carry = vec4u(0u);
    for (var k = 0u; k < t; k++) {
        carry |= runs[k];
    }
    var y = y0;
    for (; y < y1; y++) {
        if (all(carry == vec4u(0xffffffffu))) { break; }
        let i = start + y * quads;
        carry |= grid[i];
        grid[i] = carry;
    }
    // The rest of the run is shadowed on all four words: written, not read.
    for (; y < y1; y++) {
        grid[start + y * quads] = vec4u(0xffffffffu);
    }
}

// scan_columns.wgsl: scan.wgsl with a workgroup per plane, for hardware GPUs: the shadow volume,
// an inclusive prefix-OR of the geometry bits along each light ray,
//
//   shadow[x, y, k] = OR_{y' <= y} geometry[x, y', k].
//
// scan.wgsl gives a column (a plane's four words of bins, all its rays) to one thread, which walks
// the rays in turn: on two CPU cores that is the cheapest order, but a GPU then holds one thread
// per column (12 288 at the default grid, 2 048 at 1024x1024x256, where an H200 keeps ~270 000
// in flight) and each waits on memory once per ray: 0.44-0.49 ms on an H200 (docs/results.md).
// Here a workgroup takes a plane, whose rays lie one after another in memory (plane-major grid):
// its threads are (run, quad) pairs, the quad fastest, so neighbouring threads read neighbouring
// 16 bytes of one ray, and each pair's run is THREADS / quads consecutive rays' share. Each thread
// ORs its run (A_r), the workgroup ORs the runs before each (C_r = A_0 | .. | A_{r-1}) in
// log2(runs) steps, and each thread writes its run's prefix-OR starting from C_r. Every word is
// read twice and written once; once C_r is full (every light ray of the four words shadowed) the
// run is only written. (A workgroup per column of four words, 64 runs each, read a ray's 16 bytes
// alone out of each 32-byte sector: the default grid's Scan took 0.20 ms on the H200 against 0.12
// here; carrying the runs one by one instead of in log steps cost the 256-bin grids 30%, session
// 25.) Grids whose rays start on four words only (Grid::quad_rays), as scan.wgsl, and at most
// THREADS of them per ray (bins <= 2048: 16). Same bits as scan.wgsl (tests/gpu.rs).

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> grid: array<vec4u>;
// Per plane, the ray cells [first, end) the frame's pixels can read (scan.wgsl).
@group(0) @binding(2) var<storage, read> plane_rays: array<vec2u>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

const THREADS: u32 = 256u;
var<workgroup> runs: array<vec4u, THREADS>;

// A plane per workgroup; the dispatch is (min(planes, 65535), ceil(planes / 65535)) (Scan::record).
@compute @workgroup_size(256)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) t: u32) {
    f = frame_in;
    let plane = wg.y * 65535u + wg.x;
    // (Uniform across the workgroup: the barriers below are reached by all of it or none.)
    if (plane >= f.grid.x) { return; }
    let quads = f.grid.w / 4u;
    let base = ray_offset(f, plane, 0u) / 4u;
    // The plane's cells [first, end) (uniform across the workgroup).
    let cells = plane_rays[plane];
    let rays = cells.y - min(cells.x, cells.y);
    let count = THREADS / quads;
    let run = t / quads;
    let q = t % quads;
    // The threads past the last whole run (THREADS not a multiple of quads) take no rays.
    let busy = run < count;
    let per = (rays + count - 1u) / count;
    var y0 = cells.y;
    if (busy) { y0 = cells.x + min(run * per, rays); }
    let y1 = min(y0 + per, cells.y);
    var acc = vec4u(0u);
    for (var y = y0; y < y1; y++) {
        acc |= grid[base + y * quads + q];
    }
    runs[t] = acc;
    workgroupBarrier();
    // Inclusive OR over each quad's runs (Hillis-Steele).
    for (var d = 1u; d < count; d *= 2u) {
        var v = runs[t];
        if (busy && run >= d) { v |= runs[t - d * quads]; }
        workgroupBarrier();
        runs[t] = v;
        workgroupBarrier();
    }
    var carry = vec4u(0u);
    if (busy && run > 0u) { carry = runs[t - quads]; }
    var y = y0;
    for (; y < y1; y++) {
        if (all(carry == vec4u(0xffffffffu))) { break; }
        let i = base + y * quads + q;
        carry |= grid[i];
        grid[i] = carry;
    }
    // The rest of the run is shadowed on all four words: written, not read.
    for (; y < y1; y++) {
        grid[base + y * quads + q] = vec4u(0xffffffffu);
    }
}

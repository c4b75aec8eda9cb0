// cull.wgsl: which triangles can shadow a visible point, and the balanced work list Voxelize runs.
//
// `cull` (one thread per run of f.work.x triangles: 1 on a GPU, 64 on a CPU): the triangle's
// footprint in light space, i.e. the planes x
// whose centre angle its arc around the eye-light axis may hold (triangle_bounds.wgsl: the
// conservative cell range, two ranges across the seam at phi = 0, all planes when the axis pierces
// it) times the 32-bit words of bins whose centre z its z range holds. A triangle is dropped when
// that footprint is empty: outside the visible wedge, past the last visible ray, or outside the
// bins' z range (beyond the farthest visible depth that the Ranges pass found); so is a closed
// mesh's face turned away from a light outside it (src/scene/solid.rs), and, for a directional
// light, a triangle the shadow map shows behind nearer surfaces all around it (`hidden_from_light`,
// below). Kept triangles get a record and a work count
//
//   items(t) = planes(t) * ceil(words(t) / f.work.y)
//
// (one item = one plane x a group of f.work.y words of one triangle: one word on a GPU, all of
// them on a CPU, src/render/voxelize.rs).
//
// `offsets_local` and `offsets_blocks` turn the counts into exclusive prefix sums (1024 per
// workgroup, then the block sums in one workgroup), and `offsets_blocks` writes Voxelize's
// indirect dispatch for the total: every item (or run of f.work.x items, Voxelize) gets one
// thread, so a wall that covers every plane is spread over thousands of threads and a sliver costs
// one or two.

#import common
#import triangle_bounds
#import hidden
#import workgroup_scan

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
// Per kept triangle: (triangle, first plane, planes, first word | words << 16).
@group(0) @binding(2) var<storage, read_write> records: array<vec4u>;
// Per kept triangle: items, then (after offsets_local) the exclusive prefix sum within its block.
@group(0) @binding(3) var<storage, read_write> offsets: array<u32>;
// Per block of 1024 kept triangles: the sum of its items, then (after offsets_blocks) the
// exclusive prefix sum of the blocks.
@group(0) @binding(4) var<storage, read_write> blocks: array<u32>;
// [0] kept (this chunk), [1] culled by z, [2] culled by rays or planes, [3] items (this chunk),
// [4] kept (all chunks), [5] items (all chunks), [6] items dropped because the list overflowed,
// [7] culled as a closed mesh's face turned away from the light, [8] culled as hidden from the
// light, [9..12] unused.
@group(0) @binding(5) var<storage, read_write> counters: array<atomic<u32>, 12>;
// DispatchIndirect arguments: [3..6] Voxelize, [6..9] Scan ([0..3] unused).
@group(0) @binding(6) var<storage, read_write> dispatch: array<u32, 12>;
// Per mesh (the first vertex's w holds a triangle's mesh, as a float): +1 keep only the faces
// whose winding normal (b - a) x (c - a) faces the light, -1 only those facing away, 0 all
// (SceneGpu::light_sides).
@group(0) @binding(7) var<storage, read> sides: array<f32>;
// The shadow map's matrices (its first layer is the directional light's orthographic view) and
// its pyramid of block maxima (shadow_pyramid.wgsl), levels PYRAMID_FIRST_LEVEL to f.work.z one
// after the other.
@group(0) @binding(8) var<storage, read> shadow: ShadowFaces;
@group(0) @binding(9) var<storage, read> pyramid: array<f32>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

const BLOCK: u32 = 1024u;     // kept triangles per offsets_local workgroup (64 threads x 16)
const VOXEL_GROUP: u32 = 64u; // Voxelize's workgroup size
const MAX_GROUPS: u32 = 65535u;

// Bins whose sample lies in [z.x, z.y], as a word range (first, count); count 0 when none.
// Samples sit a quarter bin either side of the centres (bin_offset), and a quarter bin of margin
// more on each side covers f32 differences: this range is computed from the triangle's edges,
// Voxelize's exact per-plane ranges may differ in the last bits, and an item too many only costs a
// thread that finds nothing.
fn word_range(z: vec2f) -> vec2u {
    let bins = f32(f.grid.z);
    let k0 = max(ceil(bin_coord(f, z.x) - 1.0), 0.0);
    let k1 = min(floor(bin_coord(f, z.y)), bins - 1.0);
    if (!(k0 <= k1)) { return vec2u(0u, 0u); } // also catches NaN
    let w0 = u32(k0) / 32u;
    let w1 = u32(k1) / 32u;
    return vec2u(w0, w1 - w0 + 1u);
}

// Whether the sun's shadow map shows the triangle hidden (hidden.wgsl), from the pyramid of an
// earlier frame with the same casters and light (f.work.z: its coarsest level, 0 when there is
// none), projected with the matrix that frame's map had: a map fitted to another view still shows
// which triangles nearer surfaces hide from the light. A grid-shadow frame draws no map
// (GRID_SHADOWS, a pipeline constant: behind f.work.z = 0 alone, llvmpipe ran the test for every
// triangle anyway, a tenth of that frame's Cull, session 29).
fn hidden_from_light(p0: vec3f, p1: vec3f, p2: vec3f) -> bool {
    if (POINT_LIGHT || GRID_SHADOWS) { return false; }
    return hidden_in_pyramid(sun.matrix, sun.texels, f.work.z, p0, p1, p2);
}

// The pyramid's matrix and the map's texels per side, copied at the entry point like `f`: read in
// the loop over triangles they were 17 loads per triangle, and inside a branch or loop llvmpipe
// loads a storage value lane by lane even where its address is a constant (common.wgsl,
// "Parameters"; the classroom's Cull 4.4 -> 3.6 ms, session 36).
struct Sun {
    matrix: mat4x4f,
    texels: f32,
}
var<private> sun: Sun;

// Why a triangle is dropped, or its record and items.
struct Kept {
    // 0: kept, 1: culled by z, 2: culled by rays or planes, 3: a solid's face away from the light,
    // 4: hidden from the light.
    why: u32,
    record: vec4u,
    items: u32,
}

fn cull_one(tri: u32) -> Kept {
    // A triangle of zero area hides no light ray: no work for it (loaders drop them too).
    var k = Kept(2u, vec4u(0u), 0u);
    // The vertices are read once and handed on to the bounds.
    let v0 = tris[3u * tri];
    let p0 = v0.xyz;
    let p1 = tris[3u * tri + 1u].xyz;
    let p2 = tris[3u * tri + 2u].xyz;
    let n = cross(p1 - p0, p2 - p0);
    if (all(n == vec3f(0.0))) { return k; }
    // A closed mesh's face turned away from a light outside it: the light's rays enter the solid
    // through a face toward the light first, and the scan shadows everything behind that hit
    // (src/scene/solid.rs). Edge-on faces (dot 0) are kept.
    k.why = 3u;
    let to_light = select(f.light.xyz, f.light.xyz - p0, is_point_light());
    if (sides[u32(v0.w)] * dot(n, to_light) < 0.0) { return k; }
    k.why = 2u;
    let rects = triangle_rects(p0, p1, p2);
    if (rects.a.x >= rects.a.z) { return k; }
    let z = triangle_z_range(p0, p1, p2);
    let words = word_range(z);
    k.why = 1u;
    if (words.y == 0u) { return k; }
    // Planes as one range, wrapping past the last plane when the planes cover the full circle.
    let x0 = u32(rects.a.x);
    var nx = u32(rects.a.z) - x0;
    if (rects.b.x < rects.b.z) { nx += u32(rects.b.z) - u32(rects.b.x); }
    nx = min(nx, f.grid.x);
    k.why = 4u;
    if (hidden_from_light(p0, p1, p2)) { return k; }
    k.why = 0u;
    k.record = vec4u(tri, x0, nx, words.x | (words.y << 16u));
    k.items = nx * word_groups(f, words.y);
    return k;
}

// A thread culls a run of f.work.x consecutive triangles (64 on a CPU, 1 on a GPU; Voxelize's
// run of items): on a CPU adapter a workgroup's start-up and the parameters' copy cost as much as
// culling a triangle.
@compute @workgroup_size(64)
fn cull(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    f = frame_in;
    if (!(POINT_LIGHT || GRID_SHADOWS)) { sun = Sun(pyramid_matrix(), shadow.params.x); }
    // Meshes past the adapter's largest binding come in chunks: `tris` is this chunk's, and the
    // records hold indices into it.
    let count = arrayLength(&tris) / 3u;
    let run = max(f.work.x, 1u);
    let first = (id.x + id.y * groups.x * 64u) * run;
    let last = min(first + run, count);
    // Culled counts by reason 1 to 4, in a vector's lanes (no private array, architecture.md).
    var culled = vec4u(0u);
    for (var tri = first; tri < last; tri++) {
        let k = cull_one(tri);
        if (k.why == 0u) {
            let slot = atomicAdd(&counters[0], 1u);
            records[slot] = k.record;
            offsets[slot] = k.items;
        } else {
            culled += vec4u(vec4u(k.why) == vec4u(1u, 2u, 3u, 4u));
        }
    }
    if (culled.x > 0u) { atomicAdd(&counters[1], culled.x); }
    if (culled.y > 0u) { atomicAdd(&counters[2], culled.y); }
    if (culled.z > 0u) { atomicAdd(&counters[7], culled.z); }
    if (culled.w > 0u) { atomicAdd(&counters[8], culled.w); }
}

@compute @workgroup_size(1)
fn cull_finish() {
    f = frame_in;
    atomicAdd(&counters[4], atomicLoad(&counters[0]));
}

// ---- exclusive prefix sum of the items -------------------------------------------------------

// (scan_partial over `partial`: workgroup_scan.wgsl.)
var<workgroup> block_count: u32;

// offsets_local runs 64 threads of 16 consecutive counts each: on a CPU adapter every barrier
// switches between all of a workgroup's invocations, and 256 threads x 4 spent 40 of the pass's
// ~175 ms at a million kept triangles in the Hillis-Steele steps' barriers.
const LOCAL_THREADS: u32 = 64u;
const PER_THREAD: u32 = 16u; // LOCAL_THREADS x PER_THREAD = BLOCK

@compute @workgroup_size(64)
fn offsets_local(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    if (lid == 0u) { block_count = (atomicLoad(&counters[0]) + BLOCK - 1u) / BLOCK; }
    // Dispatched for every triangle of the chunk: blocks past the kept ones have nothing to do.
    if (wg.x >= workgroupUniformLoad(&block_count)) { return; }
    let kept = atomicLoad(&counters[0]);
    let base = wg.x * BLOCK + lid * PER_THREAD;
    let end = min(base + PER_THREAD, kept);
    // Sums saturate: a list past 2^32 items is cut (counted in counters[6]) rather than wrapped.
    var sum = 0u;
    for (var i = base; i < end; i++) { sum = sat_add(sum, offsets[i]); }
    partial[lid] = sum;
    scan_partial(lid, LOCAL_THREADS);
    var running = 0u;
    if (lid > 0u) { running = partial[lid - 1u]; }
    for (var i = base; i < end; i++) {
        let v = offsets[i];
        offsets[i] = running;
        running = sat_add(running, v);
    }
    if (lid == LOCAL_THREADS - 1u) { blocks[wg.x] = partial[LOCAL_THREADS - 1u]; }
}

fn sat_add(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}

@compute @workgroup_size(256)
fn offsets_blocks(@builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    if (lid == 0u) { block_count = (atomicLoad(&counters[0]) + BLOCK - 1u) / BLOCK; }
    // The loop holds barriers: its bound must be uniform across the workgroup.
    let n = workgroupUniformLoad(&block_count);
    var carry = 0u;
    for (var start = 0u; start < n; start += 256u) {
        var v = 0u;
        if (start + lid < n) { v = blocks[start + lid]; }
        let chunk = scan_chunk(lid, v);
        if (start + lid < n) { blocks[start + lid] = sat_add(carry, chunk.x); }
        carry = sat_add(carry, chunk.y);
    }
    if (lid == 0u) {
        // A saturated total cannot be told from a true one: cap the list below it and count what is cut.
        // Voxelize's threads take runs of f.work.x items (at least 1).
        let per_group = VOXEL_GROUP * max(f.work.x, 1u);
        let total = min(carry, 0xffffffffu - per_group);
        if (carry == 0xffffffffu) { atomicAdd(&counters[6], 1u); }
        atomicStore(&counters[3], total);
        atomicAdd(&counters[5], total);
        let groups = (total + per_group - 1u) / per_group;
        let gx = min(groups, MAX_GROUPS);
        dispatch[3] = gx;
        dispatch[4] = (groups + MAX_GROUPS - 1u) / MAX_GROUPS;
        dispatch[5] = 1u;
        // Scan: nothing to carry when no triangle was kept anywhere.
        // One thread per plane and group of four words (scan.wgsl's vectors, scan_words.wgsl's GROUP).
        let columns = f.grid.x * ((f.grid.w + 3u) / 4u);
        dispatch[6] = select(0u, (columns + 63u) / 64u, atomicLoad(&counters[4]) > 0u);
        dispatch[7] = 1u;
        dispatch[8] = 1u;
    }
}

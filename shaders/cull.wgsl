// cull.wgsl: which triangles can shadow a visible point, and the balanced work list Voxelize runs.
//
// `cull` (one thread per run of f.work.x triangles: 1 on a GPU, 64 on a CPU, a SIMD group's runs
// interleaved; the cheap tests, zero area and a solid's face turned away, in a loop of their own
// that moves on to the next triangle they keep): the triangle's footprint in light space, i.e. the
// planes x whose centre angle its arc around the eye-light axis may hold (triangle_bounds.wgsl: the
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
// them on a CPU, src/render/voxelize.rs). Under a sun, a large kept triangle's planes are then
// tested in blocks of HIDDEN_BLOCK against the same pyramid (`hidden_blocks`, in offsets_local):
// the hidden blocks at either end of its range leave its record and items, the others Voxelize
// skips.
//
// `offsets_local` and `offsets_blocks` turn the counts into exclusive prefix sums (1024 per
// workgroup, then the block sums in one workgroup), and `offsets_blocks` writes Voxelize's
// indirect dispatch for the total: every item (or run of f.work.x items, Voxelize) gets one
// thread, so a wall that covers every plane is spread over thousands of threads and a sliver costs
// one or two.

#import common
#import triangle_bounds
#import hidden
#import plane_segment
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
// Per kept triangle: bit i set where block i of its planes (HIDDEN_BLOCK each, from its record's
// first plane) holds only parts of it the sun's pyramid shows hidden (`hidden_blocks`, in
// offsets_local); Voxelize skips those planes' items.
@group(0) @binding(10) var<storage, read_write> hidden: array<atomic<u32>>;
// offsets_local's (triangle, block) pairs to test, PAIRS per workgroup of 1024 kept triangles
// (`hidden_blocks`): in a buffer rather than workgroup memory, which llvmpipe zeroes for every
// workgroup of the dispatch, most of which return at once.
@group(0) @binding(11) var<storage, read_write> pairs: array<u32>;

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

// The pyramid's matrix and the map's width and height, copied at the entry point like `f`: read in
// the loop over triangles they were 17 loads per triangle, and inside a branch or loop llvmpipe
// loads a storage value lane by lane even where its address is a constant (common.wgsl,
// "Parameters"; the classroom's Cull 4.4 -> 3.6 ms, session 36).
struct Sun {
    matrix: mat4x4f,
    // The map's width and height in texels.
    texels: vec2f,
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

// A triangle's vertices (the first one's w its mesh, as a float).
struct Verts {
    v0: vec4f,
    p1: vec3f,
    p2: vec3f,
}

fn load_triangle(tri: u32) -> Verts {
    return Verts(tris[3u * tri], tris[3u * tri + 1u].xyz, tris[3u * tri + 2u].xyz);
}

// Why the cheap tests drop a triangle (Kept::why), 0 when they keep it. A triangle of zero area
// hides no light ray: no work for it (loaders drop them too). A closed mesh's face turned away
// from a light outside it: the light's rays enter the solid through a face toward the light
// first, and the scan shadows everything behind that hit (src/scene/solid.rs). Edge-on faces
// (dot 0) are kept.
fn cheap_cull(t: Verts) -> u32 {
    let p0 = t.v0.xyz;
    let n = cross(t.p1 - p0, t.p2 - p0);
    if (all(n == vec3f(0.0))) { return 2u; }
    let to_light = select(f.light.xyz, f.light.xyz - p0, is_point_light());
    if (sides[u32(t.v0.w)] * dot(n, to_light) < 0.0) { return 3u; }
    return 0u;
}

// The rest of the tests, for a triangle cheap_cull keeps.
fn cull_one(tri: u32, t: Verts) -> Kept {
    var k = Kept(2u, vec4u(0u), 0u);
    let p0 = t.v0.xyz;
    let p1 = t.p1;
    let p2 = t.p2;
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
    if (!(POINT_LIGHT || GRID_SHADOWS)) { sun = Sun(pyramid_matrix(), shadow.size.xy); }
    // Meshes past the adapter's largest binding come in chunks: `tris` is this chunk's, and the
    // records hold indices into it.
    let count = arrayLength(&tris) / 3u;
    let run = max(f.work.x, 1u);
    // A group of LANES threads takes LANES x run consecutive triangles, interleaved: at
    // every step its lanes hold neighbouring triangles, alike in facing, so that the skip loop
    // below moves them on together.
    let thread = id.x + id.y * groups.x * 64u;
    let lane = thread % LANES;
    let first = (thread - lane) * run + lane;
    let last = min((thread - lane + LANES) * run, count);
    // Culled counts by reason 1 to 4, in a vector's lanes (no private array, architecture.md).
    var culled = vec4u(0u);
    // The cheap tests first, in a loop of their own that runs on to the next triangle they keep:
    // llvmpipe runs the whole of a loop's body for every lane of a SIMD group, whether a lane
    // takes a branch or not (docs/results.md, session 29), so with one loop the faces turned away
    // from the light paid for every test (the million-triangle room's spheres turn half their
    // faces away: its Cull 26.5 -> 20.4 ms, session 38).
    var tri = first;
    loop {
        var t: Verts;
        loop {
            if (tri >= last) { break; }
            t = load_triangle(tri);
            let why = cheap_cull(t);
            if (why == 0u) { break; }
            culled += vec4u(vec4u(why) == vec4u(1u, 2u, 3u, 4u));
            tri += LANES;
        }
        if (tri >= last) { break; }
        let k = cull_one(tri, t);
        if (k.why == 0u) {
            let slot = atomicAdd(&counters[0], 1u);
            records[slot] = k.record;
            offsets[slot] = k.items;
        } else {
            culled += vec4u(vec4u(k.why) == vec4u(1u, 2u, 3u, 4u));
        }
        tri += LANES;
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
    if (!(POINT_LIGHT || GRID_SHADOWS)) { sun = Sun(pyramid_matrix(), shadow.size.xy); }
    if (lid == 0u) { block_count = (atomicLoad(&counters[0]) + BLOCK - 1u) / BLOCK; }
    // Dispatched for every triangle of the chunk: blocks past the kept ones have nothing to do.
    if (wg.x >= workgroupUniformLoad(&block_count)) { return; }
    let kept = atomicLoad(&counters[0]);
    let base = wg.x * BLOCK + lid * PER_THREAD;
    let end = min(base + PER_THREAD, kept);
    hidden_blocks(wg.x * BLOCK, lid, base, end);
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

// ---- blocks of a large triangle's planes hidden from the sun --------------------------------
//
// The whole-triangle test (`hidden_from_light`) keeps a large triangle that the sun sees anywhere,
// and its items in every plane: on the classroom, triangles over 64 planes or more hold 86% of
// Voxelize's items, and much of a wall's or the floor's planes lie where the map shows them behind
// the roof. So the planes of each kept triangle over more than one block of HIDDEN_BLOCK planes are
// tested a block at a time: the part of the triangle in block i lies in the wedge between the
// block's first plane and the next block's; its corners are the two planes' segments' ends
// (plane_segment.wgsl) and the vertices inside the wedge, and an orthographic depth takes its least
// at a corner, so `hidden_in_pyramid`'s test on that part's box (with the whole triangle's margin)
// says that every light ray in those planes that meets the triangle meets a nearer surface first:
// its bits would change nothing after the scan, up to an occluder's gap narrower than a texel, as
// for whole triangles (docs/pruning.md). The leading and trailing hidden blocks leave the
// triangle's range (its record and items), the others are skipped by Voxelize (`hidden`). On the
// classroom at 512x512: 1.27 M items -> 1.07 M, the shadow volume the same word for word;
// Voxelize ~4 ms shorter and Cull ~2 ms longer on llvmpipe (session 37).
//
// The tests run here, before the items are summed, one (triangle, block) pair per thread: the
// workgroup lists its 1024 triangles' pairs first (`pairs`), so that a SIMD group's lanes each
// test a pair (with a loop per triangle in `cull`, the lanes of the small triangles waited for
// the large ones' loops: Cull 3.6 ms longer on the classroom, not 2).

// Pairs a workgroup lists (more are not tested: their blocks count as shown), each
// (index of the triangle in the workgroup's 1024) << 5 | block.
const PAIRS: u32 = 2048u;
var<workgroup> pair_count: atomic<u32>;

// Whether a sun's frame tests blocks (`hidden_blocks` leaves out the others): asked to
// (FLAG_HIDDEN_BLOCKS), a pyramid to read, and blocks narrower than 45 degrees.
fn tests_blocks() -> bool {
    let asked = (f.image.w & FLAG_HIDDEN_BLOCKS) != 0u;
    return asked && f.work.z != 0u && f32(HIDDEN_BLOCK) * f.b2.w / f32(f.grid.x) <= 0.7853982;
}

// Tests the blocks of the workgroup's kept triangles (from `first`; this thread's are [base, end))
// and trims their records and items.
fn hidden_blocks(first: u32, lid: u32, base: u32, end: u32) {
    // Pipeline constants: point lights, grid shadows and the Cartesian grid never test blocks, and
    // Voxelize does not read `hidden` there (at a million kept triangles, its atomic zeroing alone
    // took the bench room's Cull 14 ms longer, session 37).
    if (POINT_LIGHT || GRID_SHADOWS || CARTESIAN) { return; }
    let test = tests_blocks();
    let region = (first / BLOCK) * PAIRS;
    for (var i = base; i < end; i++) {
        atomicStore(&hidden[i], 0u);
        let nx = records[i].z;
        if (test && nx > HIDDEN_BLOCK) {
            let nb = min((nx + HIDDEN_BLOCK - 1u) / HIDDEN_BLOCK, 32u);
            let at = atomicAdd(&pair_count, nb);
            for (var b = 0u; b < nb; b++) {
                if (at + b < PAIRS) { pairs[region + at + b] = ((i - first) << 5u) | b; }
            }
        }
    }
    storageBarrier();
    let count = min(workgroupUniformLoad(&pair_count), PAIRS);
    for (var p = lid; p < count; p += LOCAL_THREADS) {
        let pair = pairs[region + p];
        if (block_hidden(first + (pair >> 5u), pair & 31u)) {
            atomicOr(&hidden[first + (pair >> 5u)], 1u << (pair & 31u));
        }
    }
    storageBarrier();
    for (var i = base; i < end; i++) {
        var mask = atomicLoad(&hidden[i]);
        if (mask != 0u) {
            var rec = records[i];
            let words = rec.w >> 16u;
            // (32 where all 32 tested blocks are hidden; planes past them were not tested.)
            let lead = countTrailingZeros(~mask);
            if (lead * HIDDEN_BLOCK >= rec.z) {
                // Every plane hidden: one item left, skipped (the sums need one per triangle).
                rec.z = 1u;
                mask = 1u;
            } else {
                rec.y += lead * HIDDEN_BLOCK;
                rec.z -= lead * HIDDEN_BLOCK;
                mask = select(mask >> lead, 0u, lead >= 32u);
                let blocks = (rec.z + HIDDEN_BLOCK - 1u) / HIDDEN_BLOCK;
                if (blocks <= 32u) {
                    let shown = ~mask & (0xffffffffu >> (32u - blocks));
                    rec.z = min(rec.z, (32u - countLeadingZeros(shown)) * HIDDEN_BLOCK);
                }
                if (rec.y >= f.grid.x) { rec.y -= f.grid.x; }
            }
            records[i] = rec;
            offsets[i] = rec.z * word_groups(f, words);
            atomicStore(&hidden[i], mask);
        }
    }
}

// Whether block b of kept triangle `slot`'s planes holds only parts of it the pyramid shows hidden.
fn block_hidden(slot: u32, b: u32) -> bool {
    let rec = records[slot];
    let p0 = tris[3u * rec.x].xyz;
    let p1 = tris[3u * rec.x + 1u].xyz;
    let p2 = tris[3u * rec.x + 2u].xyz;
    let e = f.eye.xyz;
    let t = Tri(p0 - e, p1 - e, p2 - e);
    // The vertices in the map, and the whole triangle's margin (its depth plane's slope:
    // hidden.wgsl).
    let c0 = sun_point(p0);
    let c1 = sun_point(p1);
    let c2 = sun_point(p2);
    let margin = depth_margin(c0.xy, c1.xy, c2.xy, vec3f(c0.z, c1.z, c2.z), 4e-6);
    // The wedge from the block's first plane to the next block's (or the range's last).
    let x_lo = f32(rec.y + b * HIDDEN_BLOCK) + 0.5;
    let x_hi = f32(rec.y + min((b + 1u) * HIDDEN_BLOCK, rec.z - 1u)) + 0.5;
    let n_lo = plane_normal(f, phi_of_plane(f, x_lo));
    let n_hi = plane_normal(f, phi_of_plane(f, x_hi));
    let m = plane_half(f, phi_of_plane(f, 0.5 * (x_lo + x_hi)));
    var part = Part(vec2f(3.0e38), vec2f(-3.0e38), 3.0e38);
    let s_lo = plane_segment(t, n_lo);
    let s_hi = plane_segment(t, n_hi);
    part = part_add(part, sun_point(e + s_lo.p), s_lo.ok);
    part = part_add(part, sun_point(e + s_lo.q), s_lo.ok);
    part = part_add(part, sun_point(e + s_hi.p), s_hi.ok);
    part = part_add(part, sun_point(e + s_hi.q), s_hi.ok);
    part = part_add(part, c0, dot(t.p0, n_lo) >= 0.0 && dot(t.p0, n_hi) <= 0.0 && dot(t.p0, m) >= 0.0);
    part = part_add(part, c1, dot(t.p1, n_lo) >= 0.0 && dot(t.p1, n_hi) <= 0.0 && dot(t.p1, m) >= 0.0);
    part = part_add(part, c2, dot(t.p2, n_lo) >= 0.0 && dot(t.p2, n_hi) <= 0.0 && dot(t.p2, m) >= 0.0);
    // Nothing of the triangle in these planes: nothing to skip (and no box to test).
    if (!(part.lo.x <= part.hi.x)) { return false; }
    return box_hidden(part.lo, part.hi, part.depth - margin, sun.texels, f.work.z);
}

// A point in the sun's map (hidden.wgsl `map_point`).
fn sun_point(p: vec3f) -> vec3f {
    return map_point(sun.matrix, sun.texels, p);
}

// A box in the map (texel coordinates) and the least depth of the points added to it (empty:
// lo > hi).
struct Part {
    lo: vec2f,
    hi: vec2f,
    depth: f32,
}

fn part_add(part: Part, c: vec3f, add: bool) -> Part {
    return Part(
        select(part.lo, min(part.lo, c.xy), add),
        select(part.hi, max(part.hi, c.xy), add),
        select(part.depth, min(part.depth, c.z), add),
    );
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

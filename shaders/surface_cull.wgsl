// surface_cull.wgsl: the eye's draw list without the triangles that would draw nothing, made
// before Surface draws (the Surface pass, `src/render/surface.rs`).
//
// The rasterizer writes a pixel only where a triangle covers the pixel's centre (i + 1/2, j + 1/2).
// A triangle in front of the eye (w > 0 at its three vertices; the part the near plane leaves is
// a piece of it) lies inside its vertices' bounding box [lo, hi] in pixel coordinates, so where
//
//   ceil(lo - 1/2 - eps) > floor(hi - 1/2 + eps)   in x or in y (the centres clamped to the image)
//
// no centre lies in the box and the triangle draws nothing. eps = 1/64 pixel covers the rounding:
// the rasterizer snaps vertices to 1/256 of a pixel, and this projection rounds apart from the
// vertex shader's by far less. Where the box holds at most 3x3 centres, each is tested against the
// triangle's edges: one outside an edge by more than eps (snapping moves an edge by less) is not
// covered, and a triangle covering none of them draws nothing (a sliver between the centres: a
// fifth of the classroom's list at 512x512, session 36). Nor does a solid's face turned away from the eye where Surface's
// pipeline culls that side (`sides`, per mesh: its winding normal n against the way to the eye,
//
//   side * n . (eye - p0) < -t |n| |eye - p0|,   t = FACING_TOL = 1e-3,
//
// a margin for the rasterizer's snapping of vertices to 1/256 pixel, which turns a face over
// about two pixels across by less than that). Scenes of tessellated or scanned meshes hold mostly
// such triangles (the bench's million-triangle room at 512x512: 61% cover no pixel centre and half
// of the rest face away, 81% in all; the classroom: 66%).
//
// Nor, third, does a triangle behind the depth an earlier frame of this very view left at every
// pixel centre it covers (f.work.w: the coarsest level of that depth's pyramid of block maxima,
// shadow_pyramid.wgsl; 0 when there is none). Surface tests depth with `less`, and a triangle's
// depth z / w is affine across the screen, so its nearest over the pixels it covers is at least
// its vertices' least, up to a margin (below):
//
//   min(z_i / w_i) - margin > max(depth over the pixels whose centres lie in [lo, hi])
//
// makes it fail the depth test at every pixel: the frame draws the same depth and targets without
// it, and so the next frame's pyramid is the same too. A small triangle (at most 3x3 centres in
// its box) is tested pixel by pixel instead, against the depth itself, which the pyramid keeps
// after its levels: only at the centres it covers (`shows_a_centre`). The margin (`depth_margin`,
// hidden.wgsl): the rasterizer takes the depth's plane from the vertices as they are but its
// coverage from the vertices snapped to 1/256 pixel, so at a covered centre just past an edge the
// plane runs on below the vertices' least by its slope times the snapping; plus 1e-6 for
// rounding. Same view means the same view-projection, eye, image size, geometry and one-sided
// solids (EyeInputs): the pyramid is made at the end of Surface in a frame of any other view,
// and read from the next one on (the classroom at 512x512: 28 430 triangles drawn in a view's
// first frame, 19 504 from its second with the blocks alone, 15 933 with the small triangles'
// pixels; Surface 13.1 -> 10.3 -> 10.0 ms, session 36).
//
// The others are compacted in their order, so that Surface draws the same triangles in the same
// order and its targets are the same, bit for bit (a tie in depth keeps the first drawn): an
// exclusive prefix sum of the kept counts gives each kept triangle t its place
//
//   place(t) = sum of keep(s) over s < t,
//
// and run r of meshes (triangles [s_r, e_r)) draws indices 3 place(s_r) .. 3 place(e_r). Three
// steps: `mark` (a thread per 16 triangles, a SIMD group's interleaved so that its lanes hold
// neighbours, a workgroup per block of 1024: the kept triangles as a bit mask per thread and their
// prefix within the block; the turned-away and between-the-centres tests in a loop of their own
// that moves on to the next triangle they leave to the rest), `places` (one workgroup: the blocks'
// prefix, and the runs' indirect draw arguments) and `compact` (the copies). Emptying them in place
// as (i0, i0, i0) instead (sessions 21-27) still sent them through llvmpipe's single-threaded
// index fetch and primitive assembly: leaving them out took a million-triangle room's Surface from
// 61-62 to 51-54 ms (session 28).

#import common
#import workgroup_scan
#import hidden

@group(0) @binding(0) var<storage, read> frame_in: Frame;
// The scene's triangles, three vec4 vertices each in the order of `indices`, the first one's w its
// mesh (SceneGpu's triangles, all of them in one chunk: Surface::bind makes no list otherwise).
// Three vector loads a triangle where the index and vertex buffers took thirteen scalar ones (the
// indices, nine coordinates, the mesh): on llvmpipe each is a loop over the SIMD group's lanes.
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
// The indices Surface draws: the kept triangles of `indices`, in their order.
@group(0) @binding(3) var<storage, read_write> lists: array<u32>;
// Per mesh: +1 Surface draws only the faces whose winding normal (b - a) x (c - a) faces the eye,
// -1 only those facing away, 0 all (SceneGpu::eye_sides, the pipelines' cull modes).
@group(0) @binding(4) var<storage, read> sides: array<f32>;
// Per thread of `mark` (16 triangles): the kept ones as bits, and how many the block's threads
// before it keep.
@group(0) @binding(5) var<storage, read_write> threads: array<vec2u>;
// Per block of 1024 triangles: its kept count, then (after `places`) the kept count of the blocks
// before it; one more entry after the last block: the total.
@group(0) @binding(6) var<storage, read_write> blocks: array<u32>;
// x of the first entry: how many runs this frame draws; then per run its triangles [x, y).
@group(0) @binding(7) var<storage, read> runs: array<vec2u>;
// Per run: DrawIndexedIndirect arguments (index count, instances, first index, base vertex, first
// instance).
@group(0) @binding(8) var<storage, read_write> args: array<u32>;
// The pyramid of the depth an earlier frame of this view left (shadow_pyramid.wgsl), for `hidden`.
@group(0) @binding(9) var<storage, read> pyramid: array<f32>;

// Private copy of the frame's parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// How far past the bounding box a pixel centre may be and still count, in pixels: what the
// rasterizer's snapping may move an edge (hidden.wgsl).
const EPS: f32 = COVER_EPS;
// How clearly a face must turn away from the eye to be emptied (the sine of its angle to the way
// toward the eye).
const FACING_TOL: f32 = 1e-3;

// Whether the triangle is a face Surface's pipeline culls: turned away from the eye on the side
// its mesh skips.
fn turned_away(mesh: u32, p0: vec3f, p1: vec3f, p2: vec3f) -> bool {
    let n = cross(p1 - p0, p2 - p0);
    let to_eye = f.eye.xyz - p0;
    return sides[mesh] * dot(n, to_eye) < -FACING_TOL * length(n) * length(to_eye);
}

fn clip_of(p: vec3f) -> vec4f {
    return f.view_proj * vec4f(p, 1.0);
}

// Pixel coordinates (x right, y down) of a clip-space point with w > 0.
fn pixel_of(c: vec4f) -> vec2f {
    return (c.xy / c.w * vec2f(0.5, -0.5) + 0.5) * vec2f(f.image.xy);
}

// Whether [lo, hi] (pixels along one axis of n) holds no pixel centre; false for NaN.
fn misses_centres(lo: f32, hi: f32, n: u32) -> bool {
    let first = max(ceil(lo - 0.5 - EPS), 0.0);
    let last = min(floor(hi - 0.5 + EPS), f32(n) - 1.0);
    return first > last;
}

// A triangle after the cheap tests: `state` 0 draws nothing (turned away, or no pixel centre in
// its box), 1 draws (a vertex at or behind the eye: the near plane clips it; no test applies), 2
// needs the rest of the tests (`empty_rest`), with its vertices in pixels and their depths.
struct Projected {
    state: u32,
    pa: vec2f,
    pb: vec2f,
    pc: vec2f,
    z: vec3f,
}

fn project(t: u32) -> Projected {
    var o = Projected(0u, vec2f(0.0), vec2f(0.0), vec2f(0.0), vec3f(0.0));
    let v0 = tris[3u * t];
    let p0 = v0.xyz;
    let p1 = tris[3u * t + 1u].xyz;
    let p2 = tris[3u * t + 2u].xyz;
    if (turned_away(u32(v0.w), p0, p1, p2)) { return o; }
    let a = clip_of(p0);
    let b = clip_of(p1);
    let c = clip_of(p2);
    if (!(min(a.w, min(b.w, c.w)) > 0.0)) {
        o.state = 1u;
        return o;
    }
    o.pa = pixel_of(a);
    o.pb = pixel_of(b);
    o.pc = pixel_of(c);
    let lo = min(o.pa, min(o.pb, o.pc));
    let hi = max(o.pa, max(o.pb, o.pc));
    if (misses_centres(lo.x, hi.x, f.image.x) || misses_centres(lo.y, hi.y, f.image.y)) { return o; }
    o.state = 2u;
    o.z = vec3f(a.z / a.w, b.z / b.w, c.z / c.w);
    return o;
}

// Whether a triangle `project` left at state 2 draws nothing after all: it covers none of the
// pixel centres of a small box, or an earlier frame's depth hides it.
fn empty_rest(q: Projected) -> bool {
    let lo = min(q.pa, min(q.pb, q.pc));
    let hi = max(q.pa, max(q.pb, q.pc));
    // The nearest depth the rasterizer can give the triangle at a pixel it covers.
    let nearest = min(q.z.x, min(q.z.y, q.z.z)) - depth_margin(q.pa, q.pb, q.pc, q.z, 1e-6);
    let first = max(ceil(lo - 0.5 - EPS), vec2f(0.0));
    let last = min(floor(hi - 0.5 + EPS), vec2f(f.image.xy) - 1.0);
    if (all(last - first <= vec2f(2.0))) {
        return !shows_a_centre(q.pa, q.pb, q.pc, first, last, nearest);
    } else if (f.work.w != 0u) {
        return pyramid_max(vec2u(first), vec2u(last), max(f.image.x, f.image.y), f.work.w) < nearest;
    }
    return false;
}

// Whether a small triangle (pixel coordinates pa, pb, pc; the pixel centres first..last of its box,
// at most 3x3) shows at one of them: it covers the centre, unless the centre lies outside one of
// its edges by more than EPS pixels (the edge function, a cross product, is the edge's length
// times the distance), and, with an earlier frame's depth of this view (f.work.w), that depth
// there is not nearer than `nearest` (its least depth less the margin, `depth_margin`).
fn shows_a_centre(pa: vec2f, pb: vec2f, pc: vec2f, first: vec2f, last: vec2f, nearest: f32) -> bool {
    // Inside is where all three edge functions have the sign of the triangle's area.
    let area = (pb.x - pa.x) * (pc.y - pa.y) - (pb.y - pa.y) * (pc.x - pa.x);
    let s = select(-1.0, 1.0, area > 0.0);
    let e0 = pb - pa;
    let e1 = pc - pb;
    let e2 = pa - pc;
    let margin = EPS * vec3f(length(e0), length(e1), length(e2));
    let depths = f.work.w != 0u;
    var shows = false;
    for (var y = first.y; y <= last.y; y += 1.0) {
        for (var x = first.x; x <= last.x; x += 1.0) {
            let q = vec2f(x, y) + 0.5;
            let d = s * vec3f(
                e0.x * (q.y - pa.y) - e0.y * (q.x - pa.x),
                e1.x * (q.y - pb.y) - e1.y * (q.x - pb.x),
                e2.x * (q.y - pc.y) - e2.y * (q.x - pc.x),
            );
            if (all(d >= -margin)) {
                shows = shows || !depths || !(pyramid[image_start + u32(y) * f.image.x + u32(x)] < nearest);
            }
        }
    }
    return shows;
}

// Where the eye's pyramid holds the image itself, after its levels (EyePyramid, made with it).
var<private> image_start: u32;

fn whole_image_start(size: u32, coarsest: u32) -> u32 {
    var offset = PYRAMID_MATRIX_FLOATS;
    for (var level = PYRAMID_FIRST_LEVEL; level <= coarsest; level++) {
        let side = (size + (1u << level) - 1u) >> level;
        offset += side * side;
    }
    return offset;
}

const PER_THREAD: u32 = 16u;
const BLOCK: u32 = 1024u; // 64 threads x PER_THREAD

fn triangle_count() -> u32 {
    return arrayLength(&lists) / 3u;
}

// The block's thread `lid`: which of its 16 triangles are kept, and the block's prefix of them.
@compute @workgroup_size(64)
fn mark(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    image_start = whole_image_start(max(f.image.x, f.image.y), f.work.w);
    let block = wg.x + wg.y * groups.x;
    let n = triangle_count();
    // Workgroups past the last block (the dispatch's second row) have nothing to do; the test is
    // the same for the whole workgroup, so the barriers below stay uniform.
    if (block * BLOCK >= n) { return; }
    let thread = block * 64u + lid;
    // The cheap tests in a loop of their own that runs on to the next triangle they leave to the
    // rest: llvmpipe runs the whole of a loop's body for every lane of a SIMD group, taken or not
    // (docs/results.md, session 29), so in one loop the triangles turned away or between the
    // pixel centres paid for the small triangles' centre tests too. The lanes hold neighbouring
    // triangles (`interleaved`), alike in facing and size, so they skip together.
    let base = interleaved(thread, 0u);
    var mask = 0u;
    var i = 0u;
    loop {
        var q: Projected;
        loop {
            if (i >= PER_THREAD) { break; }
            let t = base + i * LANES;
            if (t >= n) {
                i = PER_THREAD;
                break;
            }
            q = project(t);
            if (q.state != 0u) { break; }
            i++;
        }
        if (i >= PER_THREAD) { break; }
        if (q.state == 1u || !empty_rest(q)) { mask |= 1u << i; }
        i++;
    }
    let count = countOneBits(mask);
    partial[lid] = count;
    scan_partial(lid, 64u);
    threads[thread] = vec2u(mask, partial[lid] - count);
    if (lid == 63u) { blocks[block] = partial[63]; }
}

// A SIMD group's LANES threads (common.wgsl) take LANES x PER_THREAD consecutive triangles,
// interleaved: thread lane l of the group holds triangles l, l + LANES, l + 2 LANES, ... of its
// stretch, bit i of its mask the i-th of them.

// Thread `thread`'s i-th triangle.
fn interleaved(thread: u32, i: u32) -> u32 {
    let lane = thread % LANES;
    return (thread - lane) * PER_THREAD + lane + i * LANES;
}

// The masks of the group of LANES threads from thread `group` on, lanes 0-3 and 4-7.
struct GroupMasks {
    lo: vec4u,
    hi: vec4u,
}

fn group_masks(group: u32) -> GroupMasks {
    return GroupMasks(
        vec4u(threads[group].x, threads[group + 1u].x, threads[group + 2u].x, threads[group + 3u].x),
        vec4u(threads[group + 4u].x, threads[group + 5u].x, threads[group + 6u].x, threads[group + 7u].x),
    );
}

// Kept triangles of a group before the i-th triangle of its lane `lane`: the lanes before it
// count their bits up to and with position i, the others (and it) those before i.
fn kept_before(m: GroupMasks, lane: u32, i: u32) -> u32 {
    let bits_lo = select(vec4u(i), vec4u(i + 1u), vec4u(0u, 1u, 2u, 3u) < vec4u(lane));
    let bits_hi = select(vec4u(i), vec4u(i + 1u), vec4u(4u, 5u, 6u, 7u) < vec4u(lane));
    let n = countOneBits(m.lo & ((vec4u(1u) << bits_lo) - 1u)) + countOneBits(m.hi & ((vec4u(1u) << bits_hi) - 1u));
    return n.x + n.y + n.z + n.w;
}

// Kept triangles before triangle t (t up to the count; `blocks` already summed): the block's,
// then the group's earlier threads' (their scan), then the group's bits before t.
fn place(t: u32) -> u32 {
    let n = triangle_count();
    if (t >= n) { return blocks[(n + BLOCK - 1u) / BLOCK]; }
    let within = t % (LANES * PER_THREAD);
    let group = t / (LANES * PER_THREAD) * LANES;
    return blocks[t / BLOCK] + threads[group].y + kept_before(group_masks(group), within % LANES, within / LANES);
}

// The blocks' exclusive prefix (and the total after them), then each run's draw arguments.
@compute @workgroup_size(256)
fn places(@builtin(local_invocation_index) lid: u32) {
    let count = (triangle_count() + BLOCK - 1u) / BLOCK;
    var carry = 0u;
    for (var start = 0u; start < count; start += 256u) {
        var v = 0u;
        if (start + lid < count) { v = blocks[start + lid]; }
        let chunk = scan_chunk(lid, v);
        if (start + lid < count) { blocks[start + lid] = carry + chunk.x; }
        carry += chunk.y;
    }
    if (lid == 0u) { blocks[count] = carry; }
    storageBarrier();
    workgroupBarrier();
    let run_count = runs[0].x;
    for (var r = lid; r < run_count; r += 256u) {
        let range = runs[r + 1u];
        let a = place(range.x);
        let b = place(range.y);
        args[5u * r] = 3u * (b - a);
        args[5u * r + 1u] = 1u;
        args[5u * r + 2u] = 3u * a;
        args[5u * r + 3u] = 0u;
        args[5u * r + 4u] = 0u;
    }
}

// The kept triangles of a `mark` thread, copied to their places.
@compute @workgroup_size(64)
fn compact(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) groups: vec3u, @builtin(local_invocation_index) lid: u32) {
    let block = wg.x + wg.y * groups.x;
    if (block * BLOCK >= triangle_count()) { return; }
    let thread = block * 64u + lid;
    let lane = thread % LANES;
    let group = thread - lane;
    // The group's masks, read once for all of the thread's kept triangles.
    let masks = group_masks(group);
    let start = blocks[block] + threads[group].y;
    var mask = threads[thread].x;
    while (mask != 0u) {
        let i = firstTrailingBit(mask);
        mask &= mask - 1u;
        let t = interleaved(thread, i);
        let at = start + kept_before(masks, lane, i);
        lists[3u * at] = indices[3u * t];
        lists[3u * at + 1u] = indices[3u * t + 1u];
        lists[3u * at + 2u] = indices[3u * t + 2u];
    }
}

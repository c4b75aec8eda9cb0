// voxelize.wgsl: the geometry bits of the epipolar grid, by point-sampled light rays.
//
// The grid's planes and bins are *sample positions*: plane x is the half-plane at the angle of its
// centre, phi_x = phi(x + 1/2), and bin k the light ray in it at the centre of its z range,
// z_k = z(k + 1/2) (psi at a point light, the distance r from the axis for a directional one,
// view depth for the Cartesian grid). A triangle sets
//
//   geometry[x, y, k] = 1   where light ray (phi_x, z_k) meets it at an angle gamma in ray cell y
//
// (every hit, not only the first, so the inspector's geometry layer shows the surfaces; of a solid
// the light lies outside of, only the faces toward the light, which Cull keeps). The rays y stay
// binned: a hit marks the cell that holds its gamma, so after the scan a receiver in the same cell
// but in front of the caster is shadowed too: a bias of at most one ray cell toward the light
// (Integrate reads the pixel's own ray cell, so it never leaks through a closed surface). With
// FIRST_HITS (the default volume, `first_hits` below) each light ray keeps instead the least
// angle a triangle meets it at, volume[x, k] = max over its hits of hit_key(gamma) (common.wgsl):
// no ray cell at all.
//
// Work comes from the Cull pass's list, one item per triangle, plane and group of f.work.y 32-bit
// words of bins (one word on a GPU, all of them on a CPU, where a plane's set-up costs more than
// its bins); a thread takes a run of items (one on a GPU, up to 64 on a CPU, Voxelize::run_for;
// every LANES-th of a stretch shared with its SIMD group: main, below); the items in the blocks
// of a large triangle's planes that Cull found hidden from the sun are skipped (`hidden`). In the
// plane, the triangle is a segment (its edges' crossings of the plane, plane_segment.wgsl); along
// a segment z and gamma are both monotonic, so the bins whose centre z lies in the segment's z
// range are exactly the light rays that hit it, and the hit of each follows in closed form; where
// the first and the last hit fall in one ray cell, so do all between, and the bins are set a word
// at a time.
//
// Watertight: a crossing on an edge is computed from the edge's two vertices in a canonical order,
// so the two triangles that share the edge get the same point bit for bit; a vertex on the plane is
// taken as it is. Bins are counted on closed ranges, so a light ray through a shared point is hit by
// both neighbours, and inside a closed mesh no light ray slips between two triangles.

#import common
#import plane_segment

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> grid: array<atomic<u32>>;
// Written by the Cull pass (cull.wgsl).
@group(0) @binding(3) var<storage, read> records: array<vec4u>;
@group(0) @binding(4) var<storage, read> offsets: array<u32>;
@group(0) @binding(5) var<storage, read> blocks: array<u32>;
@group(0) @binding(6) var<storage, read> counters: array<u32, 12>;
// Per plane, the ray cells [first, end) the frame's pixels can read (GridMapping::plane_rays): no
// hit past them is set, and the casters before them go to `first`, which the scan carries forward.
@group(0) @binding(7) var<storage, read> plane_rays: array<vec2u>;
// Per kept triangle, the blocks of HIDDEN_BLOCK planes of its range that Cull found hidden from
// the sun (bit i: block i, cull.wgsl `hidden_blocks`): their items' bits would change nothing
// after the scan, and they are skipped.
@group(0) @binding(8) var<storage, read> hidden: array<u32>;
// Per plane, the last bin its pixels' view rays reach (ranges.wgsl, `reach`: two past the bin of
// the greatest z they reach, -1 for none), where the frame has FLAG_PLANE_REACH: the first hits
// stop there.
@group(0) @binding(9) var<storage, read> reach: array<i32>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// The grid's axes as scales, set once per thread (main): common.wgsl's ray_coord, bin_coord,
// z_of_bin and phi_of_plane divide by the axis' span or size, and the walk over bins ran two of
// those divisions per bin (llvmpipe runs every division of a SIMD group in full; the classroom's
// Voxelize took 9% less with products, session 31). The samples move by an ulp or two at most.
struct Scales {
    rays_per_radian: f32, // ray cells per radian of gamma
    bins_per_z: f32,      // bins per unit of z (psi or r; uniform bins)
    z_per_bin: f32,       // its inverse
    radians_per_plane: f32,
}
var<private> scale: Scales;

fn set_scales() {
    scale = Scales(
        f32(f.grid.y) / (f.ranges.y - f.ranges.x),
        f32(f.grid.z) / (f.ranges.w - f.ranges.z),
        (f.ranges.w - f.ranges.z) / f32(f.grid.z),
        f.b2.w / f32(f.grid.x),
    );
}

// The continuous bin coordinate of z (common.wgsl's bin_coord, as a product), and the z of bin
// coordinate k.
fn bin_of_z(z: f32) -> f32 {
    if (COSINE_BINS) { return bin_coord(f, z); }
    return (z - f.ranges.z) * scale.bins_per_z;
}

fn z_of(k: f32) -> f32 {
    return z_of_bin_step(f, k, scale.z_per_bin);
}

const BLOCK: u32 = 1024u;

// ---- the work list ---------------------------------------------------------------------------

// The kept triangle whose items hold `item`: the last block, then the last triangle in it, whose
// exclusive prefix sum is at most `item` (every kept triangle has at least one item, so the sums
// strictly increase). Returns (kept slot, item within the triangle).
fn find_item(item: u32) -> vec2u {
    let kept = counters[0];
    var lo = 0u;
    var hi = (kept + BLOCK - 1u) / BLOCK;
    while (hi - lo > 1u) {
        let mid = (lo + hi) / 2u;
        if (blocks[mid] <= item) { lo = mid; } else { hi = mid; }
    }
    let rest = item - blocks[lo];
    var l = lo * BLOCK;
    var h = min(kept, l + BLOCK);
    while (h - l > 1u) {
        let mid = (l + h) / 2u;
        if (offsets[mid] <= rest) { l = mid; } else { h = mid; }
    }
    return vec2u(l, rest - offsets[l]);
}

// ---- per item --------------------------------------------------------------------------------

// The item's plane's cells that pixels read, [first, end) (plane_rays), as floats.
var<private> cells: vec2f;

// The ray cell of gamma: -1 past the last ray the plane's pixels read (no pixel's light ray meets
// such a hit before its view ray); casters before the first such ray go to that ray's cell, which
// the scan carries forward (an empty plane, end 0, takes none).
fn ray_cell(gamma: f32) -> i32 {
    let y = max(floor((gamma - f.ranges.x) * scale.rays_per_radian), cells.x);
    if (y >= cells.y) { return -1; }
    return i32(y);
}

fn cartesian_cell(q: vec3f) -> i32 {
    let y = floor(grid_coords(f, normalize(q)).y);
    if (y >= f32(f.grid.y)) { return -1; }
    return i32(max(y, 0.0));
}

var<private> run_cell: i32;
var<private> run_word: u32;
var<private> run_mask: u32;

fn flush(x: u32) {
    if (run_mask != 0u && run_cell >= 0) {
        atomicOr(&grid[ray_offset(f, x, u32(run_cell)) + run_word], run_mask);
    }
    run_mask = 0u;
}

// Adds bin k's hit in cell y to the run of equal cells in one word; a run becomes one atomic OR.
fn mark(x: u32, k: u32, y: i32) {
    let w = k / 32u;
    if (y != run_cell || w != run_word) {
        flush(x);
        run_cell = y;
        run_word = w;
    }
    run_mask |= 1u << (k - w * 32u);
}

// Bins whose sample z (k + 1/2 + offset) lies in [z0, z1] (either order), within words w.x to
// w.y: (first, last), empty when first > last.
fn bins_in(z0: f32, z1: f32, w: vec2u, offset: f32) -> vec2i {
    let c0 = bin_of_z(min(z0, z1)) - 0.5 - offset;
    let c1 = bin_of_z(max(z0, z1)) - 0.5 - offset;
    let lo = max(ceil(c0), f32(w.x * 32u));
    let hi = min(floor(c1), f32(w.y * 32u + 31u));
    if (!(lo <= hi)) { return vec2i(1, 0); } // also NaN
    return vec2i(i32(lo), i32(hi));
}

@compute @workgroup_size(64)
fn main(
    @builtin(workgroup_id) wg: vec3u,
    @builtin(num_workgroups) groups: vec3u,
    @builtin(local_invocation_index) lid: u32,
) {
    f = frame_in;
    set_scales();
    let total = counters[3];
    // A run of `run` items (the renderer's choice per adapter, cull.wgsl sizes the dispatch by
    // it): one search for the first, then the list is walked.
    let run = max(f.work.x, 1u);
    // The workgroup takes 64 x run consecutive items, each group of LANES threads (a SIMD group
    // on a CPU adapter) LANES x run of them, interleaved: at every step of the run its lanes hold
    // LANES consecutive items, mostly neighbouring planes of one triangle, whose segments are
    // alike; with a run of consecutive items each, the lanes held unrelated items and every step
    // waited for its longest walk over bins (the classroom's Voxelize took 1-8% longer, session 16).
    let lane = lid % LANES;
    let base = stretch(wg, groups) * 64u * run + (lid - lane) * run;
    let first = base + lane;
    if (first >= total) { return; }
    let found = find_item(first);
    var slot = found.x;
    var rec = records[slot];
    var hid = hidden_of(slot);
    var per_plane = word_groups(f, rec.w >> 16u);
    // The triangle's vertices, loaded again only when the run moves on to the next triangle: a
    // thread's items are mostly one triangle's planes (three vector loads fewer per item; on the
    // classroom 1-2 ms of Voxelize at best on llvmpipe, at the noise's edge; session 27).
    var tri = triangle(rec.x);
    // The item's index within its triangle's items, followed along the run.
    var within = found.y;
    let last = min(base + LANES * run, total);
    for (var item = first; item < last; item += LANES) {
        if (item != first) {
            within += LANES;
            // Past the triangle's items: on to the triangle that holds this one (a real loop,
            // so that lanes still inside their triangle skip it).
            let before = slot;
            loop {
                let n = rec.z * per_plane;
                if (within < n) { break; }
                within -= n;
                slot++;
                rec = records[slot];
                hid = hidden_of(slot);
                per_plane = word_groups(f, rec.w >> 16u);
            }
            if (slot != before) { tri = triangle(rec.x); }
        }
        // within / per_plane in f32 (llvmpipe divides integers one lane at a time). Exact: within
        // < 2^19 and per_plane <= 64 (Grid limits), so (within + 1/2) / per_plane lies at least
        // 1/(2 per_plane) from an integer, more than its rounding error.
        let plane = u32(floor((f32(within) + 0.5) / f32(per_plane)));
        // Not in a block Cull found hidden (a branch around the item: with a `continue` instead,
        // llvmpipe's Voxelize took 2.4 ms more on the classroom with nothing skipped, session 37).
        let block = plane / HIDDEN_BLOCK;
        if (block >= 32u || ((hid >> block) & 1u) == 0u) {
            voxelize_item(rec, plane, within - plane * per_plane, tri);
        }
    }
}

// Kept triangle `slot`'s hidden blocks; none where Cull tests none (pipeline constants: it leaves
// `hidden` unwritten there).
fn hidden_of(slot: u32) -> u32 {
    if (POINT_LIGHT || GRID_SHADOWS || CARTESIAN) { return 0u; }
    return hidden[slot];
}

// The stretch of the list workgroup `wg` takes: the even workgroups the first half of the list in
// order, the odd ones the second half. A CPU adapter runs consecutive workgroups at the same time,
// one a core; with consecutive stretches its cores ORed into the same lines of the grid (the list
// holds a triangle's planes, and neighbouring triangles, together), and each took the lines from
// the other's cache (llvmpipe on 2 cores, session 35: the built-in room's Voxelize 0.85x in two
// runs, the classroom's 0.90x, 0.96x and 1.04x in three; the bits the same). A GPU's many
// workgroups at once gain nothing from it and lose nothing.
fn stretch(wg: vec3u, groups: vec3u) -> u32 {
    let w = wg.y * groups.x + wg.x;
    let half = (groups.x * groups.y + 1u) / 2u;
    return select(half + w / 2u, w / 2u, w % 2u == 0u);
}

// Triangle `tri`'s vertices relative to the eye.
fn triangle(tri: u32) -> Tri {
    let e = f.eye.xyz;
    return Tri(tris[3u * tri].xyz - e, tris[3u * tri + 1u].xyz - e, tris[3u * tri + 2u].xyz - e);
}

// The item of the triangle with record `rec` (vertices p) in its `plane`-th plane and `group`-th
// group of words of bins (first and last, w).
fn voxelize_item(rec: vec4u, plane: u32, group: u32, p: Tri) {
    let words = rec.w >> 16u;
    let per = words_per_item(f);
    let first = (rec.w & 0xffffu) + group * per;
    let w = vec2u(first, min(first + per, (rec.w & 0xffffu) + words) - 1u);
    var x = rec.y + plane;
    if (x >= f.grid.x) { x -= f.grid.x; } // wraps only when the planes cover the full circle
    cells = vec2f(plane_rays[x]);
    run_cell = -1;
    run_word = 0xffffffffu;
    run_mask = 0u;
    let offset = bin_offset(x);

    if (is_cartesian()) {
        // The plane of grid row (or column) x: through the eye and two of its view directions;
        // the light rays in it are lines of constant view depth.
        let n = cross(cell_dir(f, f32(x) + 0.5, 0.0), cell_dir(f, f32(x) + 0.5, f32(f.grid.y)));
        let s = plane_segment(p, n);
        if (!s.ok) { return; }
        let fw = f.cam_fwd.xyz;
        let z0 = dot(s.p, fw);
        let z1 = dot(s.q, fw);
        let ks = bins_in(z0, z1, w, offset);
        for (var k = ks.x; k <= ks.y; k++) {
            var q = s.p;
            if (z1 != z0) {
                let t = clamp((z_of(f32(k) + 0.5 + offset) - z0) / (z1 - z0), 0.0, 1.0);
                q = s.p + (s.q - s.p) * t;
            }
            mark(x, u32(k), cartesian_cell(q));
        }
        flush(x);
        return;
    }

    // Epipolar: the plane through the axis at the plane's centre angle, in 2-D coordinates
    // (u along the axis, v toward the half-plane side m), with the eye at the origin.
    let phi = f.b1.w + (f32(x) + 0.5) * scale.radians_per_plane;
    let a = f.axis.xyz;
    let m = plane_half(f, phi);
    let n = plane_normal(f, phi);
    let s = plane_segment(p, n);
    if (!s.ok) { return; }
    var sp = dot(s.p, m);
    var sq = dot(s.q, m);
    if (sp < 0.0 && sq < 0.0) { return; } // the other half of the plane
    var up = dot(s.p, a);
    var uq = dot(s.q, a);
    // Clip to the half-plane v >= 0. A clipped end lies on the axis: v = 0 exactly, so its z is
    // exactly 0 or pi (or r = 0), and the neighbours' ranges meet there.
    if (sp < 0.0) {
        up = up + (uq - up) * (sp / (sp - sq));
        sp = 0.0;
    }
    if (sq < 0.0) {
        uq = uq + (up - uq) * (sq / (sq - sp));
        sq = 0.0;
    }
    // abs: a -0 would make atan2 below return -pi instead of pi.
    let pa = vec2f(up, abs(sp));
    let pb = vec2f(uq, abs(sq));
    let dist = f.axis.w;
    var z0 = pa.y;
    var z1 = pb.y;
    if (is_point_light()) {
        z0 = atan2(pa.y, dist - pa.x);
        z1 = atan2(pb.y, dist - pb.x);
    }
    let ks = bins_in(z0, z1, w, offset);
    if (ks.x > ks.y) { return; }
    // The end nearer the light along its light ray (smaller gamma): where a light ray runs along
    // the segment, that is where it meets the triangle first.
    var near_end = pa;
    // pb has the smaller angle when it turns clockwise from pa (both lie in the half-plane v >= 0);
    // of two ends on one line through the eye, the one toward the light.
    let turn = pb.x * pa.y - pb.y * pa.x;
    if (turn > 0.0 || (turn == 0.0 && pb.x > pa.x)) { near_end = pb; }
    let s2 = InPlane(pa, pb - pa, vec2f(z0, z1), 1.0 / (z1 - z0), near_end, offset);
    if (FIRST_HITS) {
        first_hits(x, ks, s2);
        return;
    }
    // gamma is monotonic along the segment, so the cells of bins ks.x..ks.y are too: when the
    // first and the last bin meet the same cell, every bin between does, and the run is set a
    // word at a time (on the classroom, a third of the bins; one hit each costs an atan2).
    let c_first = hit_cell(s2, ks.x);
    let c_last = hit_cell(s2, ks.y);
    if (c_first == c_last) {
        fill(x, vec2u(ks), c_first);
        return;
    }
    // One loop over every bin, the first and the last taken again: each call of `mark` is an
    // atomic OR of its own in llvmpipe's code, run for every item whether its lanes mark or not
    // (the classroom's Voxelize 0.98x against marking both ends outside the loop, session 38).
    for (var k = ks.x; k <= ks.y; k++) {
        mark(x, u32(k), hit_cell(s2, k));
    }
    flush(x);
}

// A triangle's segment in an epipolar plane, in the plane's 2-D coordinates (u along the axis, v
// away from it): its end pa, pb - pa, the z of both ends and 1 / (z.y - z.x) (a directional
// light's hits interpolate in z), the end nearer the light, and the plane's bin offset.
struct InPlane {
    pa: vec2f,
    dp: vec2f,
    z: vec2f,
    per_z: f32,
    near_end: vec2f,
    offset: f32,
}

// Where bin k's light ray meets the segment, in the plane's coordinates.
fn hit_point(s: InPlane, k: i32) -> vec2f {
    let zk = z_of(f32(k) + 0.5 + s.offset);
    var q = s.near_end;
    if (is_point_light()) {
        // Light ray from (D, 0) in direction (-cos zk, sin zk) against pa + t dp.
        let dist = f.axis.w;
        let sc = vec2f(sin(zk), cos(zk));
        let den = s.dp.x * sc.x + s.dp.y * sc.y;
        if (abs(den) > 1e-30) {
            let t = clamp(-((s.pa.x - dist) * sc.x + s.pa.y * sc.y) / den, 0.0, 1.0);
            q = s.pa + s.dp * t;
        }
    } else if (s.z.y != s.z.x) {
        // Light ray v = zk.
        q = s.pa + s.dp * clamp((zk - s.z.x) * s.per_z, 0.0, 1.0);
    }
    return q;
}

// The ray cell where bin k's light ray meets the segment.
fn hit_cell(s: InPlane, k: i32) -> i32 {
    let q = hit_point(s, k);
    // (atan2_approx: cells only bin the hits, and every walk's bin takes one.)
    return ray_cell(atan2_approx(q.y, q.x));
}

// The first-hit volume (FIRST_HITS, common.wgsl `hit_key`): each bin's light ray keeps the least
// angle at which a triangle meets it, one atomic max per bin. The angle is atan2_approx's: within
// 1.7e-6 rad either way, and near the axis within 2.3e-5 of itself (there below: the hit looks
// nearer the light): at every angle under 4e-5 sin(gamma) (tests/shader_math.rs), a fifth of the
// slack Integrate compares it with on the classroom (HIT_SLACK: half a plane's angle times
// sin(gamma), there 2048 planes over 0.83 rad), so a pixel's own surface does not shadow itself;
// a hit moved away from the light lets light past it by no more than that angle. (Planes spread
// over less than a tenth of a radian would leave the slack under the error: a surface's last bins
// could then shadow themselves by that much.) The built-in atan2 took 7-15% of the classroom's
// Voxelize on llvmpipe in three runs, and the image moved by 0.0008% (rel RMSE; docs/results.md,
// session 49). A hit past the plane's last kept ray cell is left out, as in the bits (no pixel of
// the plane reads a light ray that far, and a hit there shadows none of them); one before its
// first is kept as it is (it shadows them all). Nor is a hit past the plane's reach kept
// (FLAG_PLANE_REACH): no pixel's walk reads a light ray beyond its surface's bin (integrate.wgsl
// `lit_plane`: a boundary at or past z_end ends it, and the bits after z_end in its last word only
// make boundaries there), so the bins past the reach's change no pixel.
fn first_hits(x: u32, ks: vec2i, s: InPlane) {
    let row = x * f.grid.z;
    let reached = (f.image.w & FLAG_PLANE_REACH) != 0u;
    let last = select(ks.y, min(ks.y, reach[REACH_PLANES_AT + x]), reached);
    for (var k = ks.x; k <= last; k++) {
        let q = hit_point(s, k);
        let gamma = atan2_approx(q.y, q.x);
        if (ray_cell(gamma) >= 0) {
            atomicMax(&grid[row + u32(k)], hit_key(gamma));
        }
    }
}

// Sets bins ks.x..ks.y of ray cell y in plane x: one atomic OR per word.
fn fill(x: u32, ks: vec2u, y: i32) {
    if (y < 0) { return; }
    let base = ray_offset(f, x, u32(y));
    for (var w = ks.x / 32u; w <= ks.y / 32u; w++) {
        let lo = max(ks.x, w * 32u) - w * 32u;
        let hi = min(ks.y, w * 32u + 31u) - w * 32u;
        atomicOr(&grid[base + w], (0xffffffffu >> (31u - hi)) & (0xffffffffu << lo));
    }
}

// ranges.wgsl: the z range the bins must cover this frame, from the depth the Surface pass wrote.
//
// A view ray's points run from z = 0 at the eye to z_s at its surface (psi for a point light,
// r = t sin(gamma) for a directional one, view depth for the Cartesian grid), and z grows along
// the ray. No shadow bit beyond the largest visible z is ever read, so the bins only need
//
//   [z_lo, z_hi] = [casters' z_lo, min(casters' z_hi, max over pixels of z_s)]
//
// `reduce` takes that maximum with an atomic max on the float's bits (non-negative floats order
// like their bit patterns), first per thread (a column of ROWS pixels), then per workgroup;
// `finish` clamps it into the casters' range. The renderer then copies the result into the frame
// uniforms' `ranges.zw` before the voxelizer runs, with no CPU round trip.
//
// Under a first-hit volume (FIRST_HITS), in a frame whose planes do not wrap round the circle
// (FLAG_PLANE_REACH), `reduce` also takes the reach of each group of REACH_GROUP planes,
//
//   reach[g] >= max { z_s(p) : pixel p blends a plane of group g }
//
// A pixel at plane coordinate c blends planes floor(c - 1/2) and the next (integrate.wgsl). A
// piece of REACH_ROWS pixels of a thread's column is a segment of the image, which holds no
// epipole when the planes do not wrap, so c runs monotonically along it: its pixels blend planes
// between those of its two ends (taken `reach_slack` wider: `atan2_approx`'s bound, and
// Integrate's own rounding of c), and the piece's greatest z goes to each group they fall in: two
// angles and a few atomics a piece, not an angle and atomics a pixel (across the epipolar lines
// the plane changes from one pixel to the next: session 49's first try, Ranges +4-6 ms).
// No pixel reads a light ray of plane x past its group's reach (its walk stops at its surface's
// bin), so Voxelize keeps no hit there (voxelize.wgsl `first_hits`). `finish` turns each plane's
// group's reach into the last bin Voxelize keeps in it (an i32, past the groups).

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var distance: texture_2d<f32>;
// [0]: max visible z (float bits), [1], [2]: the final z_lo, z_hi (float bits).
@group(0) @binding(2) var<storage, read_write> out: array<atomic<u32>, 4>;
// Per group of REACH_GROUP planes its reach (float bits; Ranges::reach, cleared before the pass),
// then from REACH_PLANES_AT per plane the last bin Voxelize keeps (an i32, `finish`).
@group(0) @binding(3) var<storage, read_write> reach: array<atomic<u32>>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

fn visible_z(p: vec2u, v: vec3f) -> f32 {
    let t_s = textureLoad(distance, vec2i(p), 0).x;
    if (is_cartesian()) {
        let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
        var t = span.y;
        if (t_s >= 0.0) { t = min(t, t_s); }
        return max(t, 0.0) * dot(v, f.cam_fwd.xyz);
    }
    if (is_point_light()) {
        let gamma = angle_between(f.axis.xyz, v);
        if (t_s < 0.0) { return PI - gamma; }
        return z_along(f, gamma, t_s);
    }
    let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
    var t = span.y;
    if (t_s >= 0.0) { t = min(t, t_s); }
    // sin(gamma) of two unit vectors as |axis x v|: no angle, an atan2 and a sine less a pixel
    // (the classroom's Ranges 0.78x on llvmpipe, 4 of 4 rounds; session 40).
    return max(t, 0.0) * length(cross(f.axis.xyz, v));
}

var<workgroup> group_max: atomic<u32>;

// The plane coordinate c - 1/2 of direction v (phi_of_dir and plane_coord, with atan2_approx and
// products: `reach_slack` covers the difference; a coordinate near 0 cannot come out near the
// span's end instead, as the planes do not wrap and the span holds the image with a margin).
fn plane_of(v: vec3f) -> f32 {
    var phi = atan2_approx(dot(v, f.b2.xyz), dot(v, f.b1.xyz)) - f.b1.w;
    phi -= floor(phi * (1.0 / TAU)) * TAU;
    return phi * (f32(f.grid.x) / f.b2.w) - 0.5;
}

// How far beyond its ends' plane coordinates a piece's pixels are taken (plane units):
// atan2_approx's bound (2.5e-6 rad, tests/shader_math.rs) in planes, and 16 ulps of f32 at 2048
// planes, a 250th of a plane, for the rounding.
fn reach_slack() -> f32 {
    return 2.5e-6 * f32(f.grid.x) / f.b2.w + 4e-3;
}

// A piece of a column, pixels p0 to p1 (its ends), with greatest visible z: into the reach of
// every group its pixels' planes fall in.
fn add_reach(p0: vec2u, p1: vec2u, z: f32) {
    let c0 = plane_of(pixel_dir(f, vec2f(p0)));
    let c1 = plane_of(pixel_dir(f, vec2f(p1)));
    let slack = reach_slack();
    let last = i32(f.grid.x) - 1;
    let lo = clamp(i32(floor(min(c0, c1) - slack)), 0, last);
    let hi = clamp(i32(floor(max(c0, c1) + slack)) + 1, 0, last);
    for (var g = u32(lo) / REACH_GROUP; g <= u32(hi) / REACH_GROUP; g++) {
        atomicMax(&reach[g], bitcast<u32>(z));
    }
}

// Rows of pixels per thread: a thread keeps its own maximum over a column of ROWS pixels, then one
// atomic per thread on the workgroup's and one per workgroup on the result (64 per pixel block on
// one address serialise badly). On llvmpipe every barrier switches between all of a workgroup's
// invocations: with a workgroup per 8x8 pixels the pass took ~7 ms on the classroom, per 64x16 ~5.
const ROWS: u32 = 16u;
// Pixels a piece of a column whose planes share one reach: each spans some 4 planes a pixel
// across the epipolar lines at 2048 planes over 512 pixels, and takes its greatest z to all.
const REACH_ROWS: u32 = 4u;

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    // group_max starts at 0 without a store and a barrier of our own: WGSL zero-initialises
    // workgroup memory (wgpu's default; lavapipe does it in the driver). The explicit store and
    // barrier cost the classroom's Ranges 0.5 ms on llvmpipe (3.14 -> 2.68 ms, 6 of 6 rounds,
    // session 37; more than a barrier costs alone, docs/results.md).
    var z = 0.0;
    if (id.x < f.image.x) {
        let y0 = id.y * ROWS;
        let y1 = min(y0 + ROWS, f.image.y);
        let reaching = FIRST_HITS && (f.image.w & FLAG_PLANE_REACH) != 0u;
        // The column in pieces of REACH_ROWS pixels, each with its own greatest z.
        for (var ys = y0; ys < y1; ys += REACH_ROWS) {
            let ye = min(ys + REACH_ROWS, y1);
            var zs = 0.0;
            for (var y = ys; y < ye; y++) {
                let p = vec2u(id.x, y);
                zs = max(zs, visible_z(p, pixel_dir(f, vec2f(p))));
            }
            z = max(z, zs);
            if (reaching) { add_reach(vec2u(id.x, ys), vec2u(id.x, ye - 1u), zs); }
        }
    }
    atomicMax(&group_max, bitcast<u32>(z));
    workgroupBarrier();
    if (lid == 0u) { atomicMax(&out[0], atomicLoad(&group_max)); }
}

@compute @workgroup_size(1)
fn finish() {
    f = frame_in;
    let lo = f.ranges.z;
    let hi = f.ranges.w;
    // Half a percent of margin: the depth is per pixel centre, a neighbour's ray may reach a bit further.
    var z = bitcast<f32>(atomicLoad(&out[0]));
    z = z + 0.005 * (hi - lo);
    let new_hi = clamp(z, lo + 1e-6 * max(hi - lo, 1e-30), hi);
    atomicStore(&out[1], bitcast<u32>(lo));
    atomicStore(&out[2], bitcast<u32>(new_hi));
    // Each plane's reach as the last bin Voxelize keeps (an i32: -1 for none), under the bins'
    // new range: floor of its bin coordinate less the plane's offset, and two bins more for the
    // offsets' and the roundings' differences (Voxelize's bin_of_z takes a product where
    // bin_coord divides). Once a plane here, not once a work item in Voxelize.
    if (FIRST_HITS && (f.image.w & FLAG_PLANE_REACH) != 0u) {
        var g = f;
        g.ranges.w = new_hi;
        for (var x = 0u; x < f.grid.x; x++) {
            let z = bitcast<f32>(atomicLoad(&reach[x / REACH_GROUP]));
            let k = floor(bin_coord(g, z) - bin_offset(x)) + 2.0;
            atomicStore(&reach[REACH_PLANES_AT + x], bitcast<u32>(i32(clamp(k, -1.0, f32(f.grid.z)))));
        }
    }
}

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

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var distance: texture_2d<f32>;
// [0]: max visible z (float bits), [1], [2]: the final z_lo, z_hi (float bits).
@group(0) @binding(2) var<storage, read_write> out: array<atomic<u32>, 4>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

fn visible_z(p: vec2u) -> f32 {
    let v = pixel_dir(f, vec2f(p));
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

// Rows of pixels per thread: a thread keeps its own maximum over a column of ROWS pixels, then one
// atomic per thread on the workgroup's and one per workgroup on the result (64 per pixel block on
// one address serialise badly). On llvmpipe every barrier switches between all of a workgroup's
// invocations: with a workgroup per 8x8 pixels the pass took ~7 ms on the classroom, per 64x16 ~5.
const ROWS: u32 = 16u;

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
        for (var y = y0; y < min(y0 + ROWS, f.image.y); y++) {
            z = max(z, visible_z(vec2u(id.x, y)));
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
}

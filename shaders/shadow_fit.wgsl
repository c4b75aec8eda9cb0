// shadow_fit.wgsl: the directional shadow map's rectangle, fitted to what this frame looks up.
//
// The CPU fits the sun's orthographic map to the rectangle the casters' box projects to across the
// light (ShadowMap::uniforms): camera-independent, but on the classroom 48 x 14 m, where the view
// sees 13 x 5 m of it. Every lookup of the map lies on a visible view segment: Composite's at the
// surface point eye + t v, the march's between the segment's ends inside the medium box. In the
// casters' map coordinates m = (M_core P).xy (in [-1, 1]^2) the segments' ends span a rectangle
// [a, b], and so, the rectangle being convex, do the segments. With
//
//   [a, b] = ([lo, hi] of the ends ∩ [-1, 1]^2), widened to multiples of 2/64 and half a texel,
//   M_fit  = S M_core,   S: m -> (2 m - (a + b)) / (b - a)   (x and y only; depth unchanged)
//
// the map's texels go where they are looked up (the casters outside the rectangle shadow no
// visible point: along the light they project outside it too). The steps of 2/64 keep the map
// still while the view moves a little. `reduce` takes the ends' extremes with atomic max on
// order-preserving integer codes (the minimum as the maximum of the negation); `finish` builds
// M_fit and the texel size, which the renderer copies into the map's face, its list's
// parameters and the lookups' ShadowFaces, with no CPU round trip.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
// The casters' fit (ShadowMap::uniforms), as the CPU wrote it this frame.
@group(0) @binding(1) var<storage, read> shadow: ShadowFaces;
@group(0) @binding(2) var distance: texture_2d<f32>;
@group(0) @binding(3) var<storage, read_write> fit: Fit;

// ShadowFit's result (FitResult in shadow_fit.rs; a layout test checks it).
struct Fit {
    // Codes of -a.x, -a.y, b.x, b.y (`code`); zero (below every float) before `reduce`.
    extremes: array<atomic<u32>, 4>,
    // M_fit, the texel size (the coarser side, scene units), the rectangle's width over its height
    // in scene units, and the rectangle [a, b] in the casters' map coordinates (a.x, a.y, b.x, b.y).
    view_proj: mat4x4f,
    texel: f32,
    aspect: f32,
    rect: vec4f,
}

// Private copy of the frame's parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// An unsigned code that orders like the float (NaN aside): flip every bit of a negative, only the
// sign bit of a positive.
fn code(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

fn decode(c: u32) -> f32 {
    return bitcast<f32>(select(~c, c & 0x7fffffffu, (c & 0x80000000u) != 0u));
}

// Pixels per thread of `reduce`, a column (as Ranges: one barrier switch per workgroup on llvmpipe).
const ROWS: u32 = 16u;

var<workgroup> group_codes: array<atomic<u32>, 4>;

// Adds point p's map coordinates under m (as -x, -y, x, y) to the thread's extremes.
fn extend(e: vec4f, m: mat4x4f, p: vec3f) -> vec4f {
    let c = (m * vec4f(p, 1.0)).xy;
    return max(e, vec4f(-c, c));
}

@compute @workgroup_size(64)
fn reduce(@builtin(global_invocation_id) id: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    // group_codes start at 0 (below every code): WGSL zero-initialises workgroup memory, as in
    // ranges.wgsl's reduce.
    var e = vec4f(-3.0e38);
    // Read once: on llvmpipe every read of a storage buffer is a load per lane.
    let m = shadow.view_proj[0];
    let eye = f.eye.xyz;
    let eye_inside = eye_in_box();
    if (id.x < f.image.x) {
        let y0 = id.y * ROWS;
        for (var y = y0; y < min(y0 + ROWS, f.image.y); y++) {
            let v = pixel_dir(f, vec2f(f32(id.x), f32(y)));
            let t_s = textureLoad(distance, vec2i(i32(id.x), i32(y)), 0).x;
            // The view segment inside the medium's box ends at the surface (which the box holds:
            // Composite's lookup) or, for the sky, on the box; it starts at the eye (`finish` adds
            // it) or, from outside, where the ray enters the box.
            let span = box_span(eye, v, f.medium_min.xyz, f.medium_max.xyz);
            if (t_s >= 0.0) {
                e = extend(e, m, eye + v * t_s);
            } else if (span.x <= span.y) {
                e = extend(e, m, eye + v * span.y);
            }
            if (!eye_inside && span.x <= span.y) {
                e = extend(e, m, eye + v * span.x);
            }
        }
    }
    for (var i = 0u; i < 4u; i++) {
        atomicMax(&group_codes[i], code(e[i]));
    }
    workgroupBarrier();
    if (lid < 4u) { atomicMax(&fit.extremes[lid], atomicLoad(&group_codes[lid])); }
}

fn eye_in_box() -> bool {
    return all(f.eye.xyz >= f.medium_min.xyz) && all(f.eye.xyz <= f.medium_max.xyz);
}

// Steps of the fitted rectangle's sides, in the casters' map coordinates ([-1, 1]: 64 steps).
const STEP: f32 = 2.0 / 64.0;

@compute @workgroup_size(1)
fn finish() {
    f = frame_in;
    var e = vec4f(0.0);
    for (var i = 0u; i < 4u; i++) {
        e[i] = decode(atomicLoad(&fit.extremes[i]));
    }
    let m = shadow.view_proj[0];
    if (eye_in_box()) {
        // Every view segment starts at the eye.
        e = extend(e, m, f.eye.xyz);
    }
    var a = max(-e.xy, vec2f(-1.0));
    var b = min(e.zw, vec2f(1.0));
    // Nothing looked up inside the casters' rectangle (or NaN): keep all of it.
    if (!(a.x <= b.x && a.y <= b.y)) {
        a = vec2f(-1.0);
        b = vec2f(1.0);
    }
    a = max(floor((a + 1.0) / STEP) * STEP - 1.0, vec2f(-1.0));
    b = min(max(ceil((b + 1.0) / STEP) * STEP - 1.0, a + STEP), vec2f(1.0));
    // Half a texel of the new map beyond the extremes, as the casters' fit keeps (size.zw: one over
    // the map's width and height).
    let pad = (b - a) * 0.5 * shadow.size.zw;
    a -= pad;
    b += pad;
    let s = 2.0 / (b - a);
    let o = -(a + b) / (b - a);
    fit.view_proj = mat4x4f(vec4f(s.x, 0.0, 0.0, 0.0), vec4f(0.0, s.y, 0.0, 0.0), vec4f(0.0, 0.0, 1.0, 0.0), vec4f(o, 0.0, 1.0)) * m;
    // The casters' map spans 2 / |row i of M_core| scene units along its axis i (the rows of an
    // orthographic view-projection are scaled unit vectors).
    let span = 2.0 / vec2f(length(vec3f(m[0].x, m[1].x, m[2].x)), length(vec3f(m[0].y, m[1].y, m[2].y)));
    let side = span * (b - a) * 0.5;
    fit.texel = max(side.x * shadow.size.z, side.y * shadow.size.w);
    // Its shape, which the renderer gives the next frames' map (ShadowMap::dims): square texels.
    fit.aspect = side.x / side.y;
    fit.rect = vec4f(a, b);
}

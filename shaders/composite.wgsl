// composite.wgsl: lights the surfaces and gives the final linear radiance of each pixel.
//
//   L_pixel = L_surface * T_view + L_scatter
//   T_view = exp(-sigma_t * t_s)            (point light: the medium is unbounded)
//          = exp(-sigma_t * |[0, t_s] ∩ box|) (directional light: the medium fills the box)
//   L_surface = albedo / pi * max(cos theta_i, 0) * V * E_in   (n faces the eye: an opaque sheet
//   lit from behind stays dark in front)
//   V: the shadow map's 2x2 filtered test, or in a grid-shadow frame (GRID_SHADOWS, a VSV frame
//   that draws no map) the shadow volume's, which Integrate wrote in the scattered light's alpha
//   (integrate.wgsl), or under a sun with exact shadows (EXACT_SHADOWS) the test of the point
//   against the triangles (exact_shadows.wgsl)
//   point:        E_in = I0 * exp(-sigma_t d) / (d^2 + r^2)
//   directional:  E_in = E0 * exp(-sigma_t l(P)),  l = path toward the light inside the medium box
//
// Deferred: Surface wrote the albedo, cos theta_i and t of the nearest surface (surface.wgsl);
// the point is P = eye + t v on the pixel's own view ray, so each pixel is lit once, not every
// fragment the rasterizer shaded.

#import common
#import shadow_lookup

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> shadow_in: ShadowFaces;
@group(0) @binding(2) var shadow_map: texture_depth_2d_array;
// The 2x2 filtered test as one comparison sample (Composite::samplers): linear, clamped to the
// edge; the sun's passes where reference <= depth, the cube's where reference >= depth.
@group(0) @binding(3) var shadow_sun: sampler_comparison;
@group(0) @binding(4) var shadow_cube: sampler_comparison;
@group(0) @binding(5) var material: texture_2d<f32>;
@group(0) @binding(6) var distance: texture_2d<f32>;
@group(0) @binding(7) var scatter: texture_2d<f32>;
@group(0) @binding(8) var hdr: texture_storage_2d<rgba32float, write>;
// Per pixel 1 where the sun reaches the surface, 0 where a triangle hides it (EXACT_SHADOWS:
// exact_shadows.wgsl; unread otherwise).
@group(0) @binding(9) var<storage, read> exact_vis: array<u32>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters"). A
// pixel's lookup read the map's parameters inside its branches, where llvmpipe loads a storage
// value lane by lane (the classroom's Composite 7.4 -> 6.7 ms with the copy, session 36).
var<private> f: Frame;
var<private> shadow: ShadowFaces;

// Fraction of a 2x2 texel neighbourhood that sees the light, weighted bilinearly: texel c is lit
// where s.value <= stored(c) + bias (shadow_lookup.wgsl), which the comparison sampler tests in the
// map's own depth. Sun: stored = depth * far, so lit where (value - bias) / far <= depth (an empty
// texel, depth 1, always: the reference is capped at 1). Point light: stored = per_depth / depth,
// so lit where depth <= per_depth / (value - bias) (an empty texel, depth 0, always; and every
// texel where value <= bias). The sampler's linear filter blends the four results with the same
// weights as texel centres at i + 1/2, and clamping to the edge repeats the edge texels.
fn visibility(p: vec3f, bias: f32) -> f32 {
    let s = shadow_coords(p);
    if (!s.inside) { return 1.0; }
    let uv = s.uv * shadow.size.zw;
    let d = s.value - bias;
    if (POINT_LIGHT) {
        let reference = select(3.0e38, s.per_depth / d, d > 0.0);
        return textureSampleCompareLevel(shadow_map, shadow_cube, uv, s.layer, reference);
    }
    let reference = min(d / shadow.params.w, 1.0);
    return textureSampleCompareLevel(shadow_map, shadow_sun, uv, s.layer, reference);
}

// Depth bias against shadow acne: a texel of the map covers texel / cos of the surface along the
// light's direction, so the bias grows with the slope (capped where the surface grazes the light).
fn slope_bias(texel: f32, cos_i: f32) -> f32 {
    let c = max(cos_i, 1e-3);
    let tan_i = sqrt(max(1.0 - c * c, 0.0)) / c;
    return texel * (1.5 + 1.5 * min(tan_i, 8.0));
}

// Direct light leaving the surface point p toward the eye (before the view path's attenuation).
// `given_vis`: the visibility Integrate read from the shadow volume (GRID_SHADOWS) or the exact
// test's (EXACT_SHADOWS), which then stands for the map's.
fn surface_light(p: vec3f, albedo: vec3f, cos_i: f32, given_vis: f32) -> vec3f {
    // Lit from behind (or edge-on): dark in front. The shadow lookups are skipped too.
    if (cos_i <= 0.0) { return vec3f(0.0); }
    // A texel of the map spans params.y scene units (directional) or params.y per unit of distance
    // from the light (point).
    var texel = shadow.params.y;
    var e_in = vec3f(0.0);
    if (is_point_light()) {
        let dist = length(f.light.xyz - p);
        let r = f.light_power.w;
        e_in = f.light_power.xyz * exp(-f.sigma_t.xyz * dist) / (dist * dist + r * r);
        texel *= dist;
    } else {
        var l = 0.0;
        let lo = f.medium_min.xyz;
        let hi = f.medium_max.xyz;
        if (all(p >= lo) && all(p <= hi)) {
            l = exit_distance(p, f.light.xyz, lo, hi);
        }
        e_in = f.light_power.xyz * exp(-f.sigma_t.xyz * l);
    }
    var vis = given_vis;
    // A pipeline constant, not the frame's flag: llvmpipe runs the map's lookups behind a run-time
    // flag in every pixel of a grid-shadow frame, which cost its Composite a third (session 29).
    if (!(GRID_SHADOWS || EXACT_SHADOWS)) { vis = visibility(p, slope_bias(texel, cos_i)); }
    return albedo / PI * cos_i * e_in * vis;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    shadow = shadow_in;
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    let p = vec2i(id.xy);
    let t = textureLoad(distance, p, 0).x;
    let s = textureLoad(scatter, p, 0);
    var c = s.xyz;
    if (t >= 0.0) {
        let v = pixel_dir(f, vec2f(id.xy));
        var path = t;
        if (!is_point_light()) {
            let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
            path = max(0.0, min(span.y, t) - span.x);
        }
        let m = textureLoad(material, p, 0);
        var given_vis = s.w;
        if (EXACT_SHADOWS) { given_vis = f32(exact_vis[id.y * f.image.x + id.x]); }
        c += surface_light(f.eye.xyz + v * t, m.xyz, m.w, given_vis) * exp(-f.sigma_t.xyz * path);
    }
    textureStore(hdr, p, vec4f(c, 1.0));
}

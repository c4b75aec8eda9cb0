// raymarch.wgsl: the baseline — per-pixel ray marching with one shadow-map lookup per step.
//
// The usual sampling approach (the paper's equation 2 as games do it), kept beside the shadow-volume
// passes so that both can be measured against the reference. Per pixel, `steps` samples along the
// view ray, midpoint rule (or one jittered offset u in [0, 1) per pixel, the same for every step):
//
//   point:        L = sum_i sigma_s p(cos theta_i) V_i I0 exp(-sigma_t (d_i + t_i)) / (d_i^2 + r^2) dt
//   directional:  L = sum_i sigma_s p(dot(w, v)) V_i E0 exp(-sigma_t (l_i + m_i)) dt
//
// with t_i = t_0 + (i + u) dt, d the distance to the light, r its softening radius, l the path toward
// the light inside the medium box, m the view path inside it (the same terms as integrate.wgsl and the
// reference). V_i is ONE nearest-texel lookup of the shadow map (shadow_map.wgsl: the cube of distances
// for a point light, the orthographic layer for a directional one) with a bias of 1.5 texels; a
// sample just behind a surface, within that bias, counts as lit.
//
// Where the march runs:
// - directional: the view ray's part inside the medium box, ended at the surface (composite.wgsl's box);
// - point light, surface pixel: [0, t_s];
// - point light, sky pixel: the medium is unbounded, so the integral runs to infinity. The `steps`
//   samples cover [0, t_b], t_b = where the ray leaves the scene's box (all casters and surfaces are
//   inside it); the remainder [t_b, inf) is mapped to a finite range with the reference's variable
//   alpha = atan((t - t_c) / H) (t_c: closest approach to the light, H = sqrt(h^2 + r^2), so that
//   dt / (d^2 + r^2) = dalpha / H, alpha(inf) = pi / 2) and sampled with max(steps / 4, 4) more steps
//   of the same kind (one shadow lookup each: shadows of casters can run on past the box), placed by
//   their distance b = pi/2 - alpha from the end, t = t_c + H / tan(b), so that none lands on pi/2. A plain
//   march to a fixed far distance would drop that tail (up to half of a sky ray's light when the light
//   is near the box's side) and never converge to the reference.

#import common
#import shadow_lookup

// RaymarchUniforms in raymarch.rs.
struct March {
    // x: steps, y: 1 = jitter, zw: unused.
    params: vec4u,
}

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> shadow_in: ShadowFaces;
@group(0) @binding(2) var shadow_map: texture_depth_2d_array;
@group(0) @binding(3) var distance: texture_2d<f32>;
@group(0) @binding(4) var scatter_out: texture_storage_2d<rgba32float, write>;
@group(0) @binding(5) var<storage, read> march_in: March;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;
var<private> shadow: ShadowFaces;
var<private> march: March;

// 1 when the light reaches p: one nearest-texel lookup.
fn lit(p: vec3f) -> f32 {
    let s = shadow_coords(p);
    if (!s.inside) { return 1.0; }
    // 1.5 texels of bias (a texel is params.y, per unit of distance for the cube): only samples
    // just behind a surface are affected, and no normal exists in the medium to slope it by.
    var texel = shadow.params.y;
    if (POINT_LIGHT) { texel *= s.value; }
    return select(0.0, 1.0, s.value <= shadow_stored(s, floor(s.uv)) + 1.5 * texel);
}

// A well-mixed hash of the pixel (PCG), as a number in [0, 1).
fn pixel_hash(p: vec2u) -> f32 {
    var s = p.x * 747796405u + p.y * 2891336453u + 12345u;
    s = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    s = (s >> 22u) ^ s;
    return f32(s >> 8u) * (1.0 / 16777216.0);
}

// Point light: sigma_s I0 p(cos theta) V exp(-sigma_t (d + t)) at distance t along v, without the
// 1 / (d^2 + r^2) (the caller's measure carries it). sigma_s I0 goes into the exponent: in a thick
// medium exp(-sigma_t (d + t)) alone underflows f32 although the product is representable.
fn point_term(v: vec3f, t: f32) -> vec3f {
    let p = f.eye.xyz + t * v;
    let to_p = p - f.light.xyz;
    let d = length(to_p);
    let cos_theta = -dot(to_p, v) / max(d, 1e-30);
    let ph = phase(f.sigma_s.w, cos_theta);
    let pre = f.sigma_s.xyz * f.light_power.xyz;
    let e = select(exp(log(pre) - f.sigma_t.xyz * (d + t)), vec3f(0.0), pre <= vec3f(0.0));
    return ph * lit(p) * e;
}

fn march_point(v: vec3f, t_s: f32, u: f32) -> vec3f {
    let n = max(march.params.x, 1u);
    let r = f.light_power.w;
    var sum = vec3f(0.0);
    // [0, t_b] uniformly in t.
    var t_b = t_s;
    if (t_s < 0.0) {
        let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
        t_b = select(0.0, span.y, span.y > span.x);
    }
    if (t_b > 0.0) {
        let dt = t_b / f32(n);
        for (var i = 0u; i < n; i++) {
            let t = (f32(i) + u) * dt;
            let d = f.eye.xyz + t * v - f.light.xyz;
            sum += point_term(v, t) * dt / (dot(d, d) + r * r);
        }
    }
    // The sky's tail [t_b, inf) in alpha.
    if (t_s < 0.0) {
        let el = f.light.xyz - f.eye.xyz;
        let t_c = dot(el, v);
        let h = length(cross(el, v));
        let big_h = max(sqrt(h * h + r * r), 1e-6 * max(length(el), 1e-20));
        // pi/2 - alpha(t_b), without the cancellation of pi/2 - atan(..) when t_b is far past t_c.
        let a_left = atan2(big_h, t_b - t_c);
        let m = max(n / 4u, 4u);
        let da = a_left / f32(m);
        for (var j = 0u; j < m; j++) {
            // alpha = pi/2 - b, t = t_c + H / tan(b), b > 0 measured from pi/2: with a jittered u
            // near 1, a0 + (j + u) da rounds to f32(pi/2) itself, whose tan is -2.3e7 (a sample
            // far behind the eye) or, with a GPU's fast tan, infinite (the H200 gave infinite pixels).
            let b = (f32(m - j) - u) * da;
            let t = t_c + big_h / tan(b);
            sum += point_term(v, t) * (da / big_h);
        }
    }
    return sum;
}

fn march_directional(v: vec3f, t_s: f32, u: f32) -> vec3f {
    let lo = f.medium_min.xyz;
    let hi = f.medium_max.xyz;
    let span = box_span(f.eye.xyz, v, lo, hi);
    var t_end = span.y;
    if (t_s >= 0.0) { t_end = min(t_end, t_s); }
    if (!(t_end > span.x)) { return vec3f(0.0); }
    let w = f.light.xyz;
    let n = max(march.params.x, 1u);
    let dt = (t_end - span.x) / f32(n);
    var sum = vec3f(0.0);
    for (var i = 0u; i < n; i++) {
        let t = span.x + (f32(i) + u) * dt;
        let p = f.eye.xyz + t * v;
        let l = exit_distance(p, w, lo, hi);
        // A grey medium: one exponential for the three channels (GREY_MEDIUM, a pipeline constant).
        if (GREY_MEDIUM) {
            sum += lit(p) * exp(-f.sigma_t.x * (l + t - span.x));
        } else {
            sum += lit(p) * exp(-f.sigma_t.xyz * (l + t - span.x));
        }
    }
    let ph = phase(f.sigma_s.w, dot(w, v));
    return f.sigma_s.xyz * f.light_power.xyz * ph * sum * dt;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    shadow = shadow_in;
    march = march_in;
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    let v = pixel_dir(f, vec2f(id.xy));
    let t_s = textureLoad(distance, vec2i(id.xy), 0).x;
    var u = 0.5;
    if (march.params.y != 0u) { u = pixel_hash(id.xy); }
    var l = vec3f(0.0);
    if (is_point_light()) {
        l = march_point(v, t_s, u);
    } else {
        l = march_directional(v, t_s, u);
    }
    textureStore(scatter_out, vec2i(id.xy), vec4f(l, 1.0));
}

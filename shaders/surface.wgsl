// surface.wgsl: direct lighting of the surfaces, before the medium's view-path attenuation.
//
//   L_surface = albedo / pi * max(cos theta_i, 0) * V_shadow_map * E_in   (n faces the eye: an
//   opaque sheet lit from behind stays dark in front)
//   point:        E_in = I0 * exp(-sigma_t d) / (d^2 + r^2)
//   directional:  E_in = E0 * exp(-sigma_t l(P)),  l = path toward the light inside the medium box
//
// Also writes the distance t from the eye to the surface (negative for the sky): the integrate
// pass ends each view ray there, and the composite pass attenuates L_surface by exp(-sigma_t t).
// The second channel is |cos| between the view ray and the normal when the light is behind the
// surface (0 otherwise): Integrate shadows the thin layer of medium in front of such a surface
// that the surface itself shadows (integrate.wgsl, "own shadow").

#import common
#import shadow_lookup

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> shadow_in: ShadowFaces;
@group(0) @binding(2) var shadow_map: texture_depth_2d_array;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;
var<private> shadow: ShadowFaces;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) albedo: vec3f,
}

struct FsOut {
    @location(0) radiance: vec4f,
    @location(1) distance: vec4f,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) albedo: vec3f) -> VsOut {
    f = frame_in;
    shadow = shadow_in;
    var o: VsOut;
    o.clip = f.view_proj * vec4f(position, 1.0);
    o.world = position;
    o.albedo = albedo;
    return o;
}

// Fraction of a 2x2 texel neighbourhood that sees the light.
fn visibility(p: vec3f, bias: f32) -> f32 {
    let s = shadow_coords(p);
    if (!s.inside) { return 1.0; }
    let uv = s.uv - 0.5;
    let base = floor(uv);
    let fr = uv - base;
    var lit = vec4f(0.0);
    for (var k = 0; k < 4; k++) {
        let o = vec2f(f32(k & 1), f32(k >> 1));
        lit[k] = select(0.0, 1.0, s.value <= shadow_stored(s, base + o) + bias);
    }
    return mix(mix(lit.x, lit.y, fr.x), mix(lit.z, lit.w, fr.x), fr.y);
}

// Depth bias against shadow acne: a texel of the map covers texel / cos of the surface along the
// light's direction, so the bias grows with the slope (capped where the surface grazes the light).
fn slope_bias(texel: f32, cos_i: f32) -> f32 {
    let c = max(cos_i, 1e-3);
    let tan_i = sqrt(max(1.0 - c * c, 0.0)) / c;
    return texel * (1.5 + 1.5 * min(tan_i, 8.0));
}

@fragment
fn fs_main(i: VsOut) -> FsOut {
    f = frame_in;
    shadow = shadow_in;
    let to_eye = f.eye.xyz - i.world;
    var n = normalize(cross(dpdx(i.world), dpdy(i.world)));
    if (dot(n, to_eye) < 0.0) { n = -n; }
    var radiance = vec3f(0.0);
    // Cosine of the incidence angle on the eye's side (negative: the light is behind the surface).
    var cos_i = 0.0;
    let sigma_t = f.sigma_t.xyz;
    if (is_point_light()) {
        let d = f.light.xyz - i.world;
        let dist = length(d);
        cos_i = dot(n, d / dist);
        let r = f.light_power.w;
        let e_in = f.light_power.xyz * exp(-sigma_t * dist) / (dist * dist + r * r);
        var vis = 0.0;
        if (cos_i > 0.0) { vis = visibility(i.world, slope_bias(shadow.params.y * dist, cos_i)); }
        radiance = i.albedo / PI * max(cos_i, 0.0) * e_in * vis;
    } else {
        let w = f.light.xyz;
        cos_i = dot(n, w);
        var l = 0.0;
        let lo = f.medium_min.xyz;
        let hi = f.medium_max.xyz;
        if (all(i.world >= lo) && all(i.world <= hi)) {
            l = exit_distance(i.world, w, lo, hi);
        }
        let e_in = f.light_power.xyz * exp(-sigma_t * l);
        var vis = 0.0;
        if (cos_i > 0.0) { vis = visibility(i.world, slope_bias(shadow.params.y, cos_i)); }
        radiance = i.albedo / PI * max(cos_i, 0.0) * e_in * vis;
    }
    // Back-lit (the light behind the surface): the cosine between the view ray and the normal, with
    // which Integrate finds the medium that the surface itself shadows; 0 when lit from the front.
    let back = select(0.0, dot(n, normalize(to_eye)), cos_i < 0.0);
    var o: FsOut;
    o.radiance = vec4f(radiance, 1.0);
    o.distance = vec4f(length(to_eye), back, 0.0, 0.0);
    return o;
}

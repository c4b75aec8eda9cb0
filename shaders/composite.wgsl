// composite.wgsl: the final linear radiance of each pixel.
//
//   L_pixel = L_surface * T_view + L_scatter
//   T_view = exp(-sigma_t * t_s)            (point light: the medium is unbounded)
//          = exp(-sigma_t * |[0, t_s] ∩ box|) (directional light: the medium fills the box)

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var surface: texture_2d<f32>;
@group(0) @binding(2) var distance: texture_2d<f32>;
@group(0) @binding(3) var scatter: texture_2d<f32>;
@group(0) @binding(4) var hdr: texture_storage_2d<rgba32float, write>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    let p = vec2i(id.xy);
    let t = textureLoad(distance, p, 0).x;
    let s = textureLoad(scatter, p, 0).xyz;
    var c = s;
    if (t >= 0.0) {
        var path = t;
        if (!is_point_light()) {
            let v = pixel_dir(f, vec2f(id.xy));
            let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
            path = max(0.0, min(span.y, t) - span.x);
        }
        c += textureLoad(surface, p, 0).xyz * exp(-f.sigma_t.xyz * path);
    }
    textureStore(hdr, p, vec4f(c, 1.0));
}

// surface.wgsl: what the eye sees of the surfaces, per pixel, for deferred lighting.
//
// Rasterizes the scene from the eye and writes, for the nearest surface of each pixel:
//   material = (albedo, cos theta_i)   cos theta_i = n . (direction toward the light), n turned
//                                      toward the eye (negative: the light is behind the surface)
//   distance = (t, back)               t the distance from the eye (negative for the sky), back the
//                                      |cos| between the view ray and n when the light is behind
//                                      the surface (0 otherwise)
// Composite lights each pixel once from these (composite.wgsl: L_surface with the shadow map),
// instead of every fragment the rasterizer shades and a nearer one then covers. Integrate ends
// each view ray at t and shadows the thin layer of medium in front of a back-lit surface
// (integrate.wgsl, "own shadow").

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;

// Private copy of the frame's parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// The eye and the light (`f.light.xyz`) reach the fragments as flat outputs of the vertex stage, so
// the fragment stage reads no storage buffer: on llvmpipe, reading the two from `frame_in` there
// cost the classroom's Surface, and the raster work it leaves to the next pass, ~6 ms a frame
// (session 35; the images the same to the bit).
struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
    @location(1) albedo: vec3f,
    @location(2) @interpolate(flat) eye: vec3f,
    @location(3) @interpolate(flat) light: vec3f,
}

struct FsOut {
    @location(0) material: vec4f,
    @location(1) distance: vec4f,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) albedo: vec3f) -> VsOut {
    f = frame_in;
    var o: VsOut;
    o.clip = f.view_proj * vec4f(position, 1.0);
    o.world = position;
    o.albedo = albedo;
    o.eye = f.eye.xyz;
    o.light = f.light.xyz;
    return o;
}

@fragment
fn fs_main(i: VsOut) -> FsOut {
    let to_eye = i.eye - i.world;
    var n = normalize(cross(dpdx(i.world), dpdy(i.world)));
    if (dot(n, to_eye) < 0.0) { n = -n; }
    // Direction toward the light: from the point (point light) or the light's own (directional).
    var w = i.light;
    if (is_point_light()) { w = normalize(i.light - i.world); }
    let cos_i = dot(n, w);
    let back = select(0.0, dot(n, normalize(to_eye)), cos_i < 0.0);
    var o: FsOut;
    o.material = vec4f(i.albedo, cos_i);
    o.distance = vec4f(length(to_eye), back, 0.0, 0.0);
    return o;
}

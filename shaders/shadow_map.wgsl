// shadow_map.wgsl: distance from the light to the nearest surface, per shadow-map texel.
//
// Point light: six 90-degree faces of a cube around the light; each texel stores |P - L|.
// Directional light: one orthographic view along -w; each texel stores dot(P_far - P, -w), the
// distance from a plane beyond the scene on the light's side. The surface pass compares a point's
// own value with the stored one: larger (plus a bias) means something nearer the light covers it.

#import common

struct Face {
    view_proj: mat4x4f,
    // xyz: light position (point) or direction toward the light (directional); w: 1 point, 0 dir
    // (informational: the shader takes the light type from the POINT_LIGHT override).
    light: vec4f,
    // Directional: the reference point far on the light's side.
    origin: vec4f,
}

@group(0) @binding(0) var<uniform> face: Face;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) world: vec3f,
}

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) albedo: vec3f) -> VsOut {
    var o: VsOut;
    o.clip = face.view_proj * vec4f(position, 1.0);
    o.world = position;
    return o;
}

@fragment
fn fs_main(i: VsOut) -> @location(0) vec4f {
    if (POINT_LIGHT) {
        return vec4f(length(i.world - face.light.xyz), 0.0, 0.0, 0.0);
    }
    return vec4f(dot(face.origin.xyz - i.world, face.light.xyz), 0.0, 0.0, 0.0);
}

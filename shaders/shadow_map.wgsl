// shadow_map.wgsl: the depth of the nearest surface seen from the light, per shadow-map texel.
//
// Point light: six 90-degree faces of a cube around the light, reversed infinite perspective:
// depth = near / a, a the distance along the face's axis (1 at the near plane, 0 for nothing).
// Directional light: one orthographic view along -w: depth = s / far, s = dot(P_far - P, w) the
// distance from a plane beyond the scene on the light's side (1 for nothing).
// Depth only, no fragment shader: shadow_lookup.wgsl turns the stored depth back into a distance
// along the looked-up point's own direction and compares it with the point's (plus a bias).

#import common

struct Face {
    view_proj: mat4x4f,
    // Informational (the map needs only view_proj): xyz the light's position (point) or the
    // direction toward it (directional), w 1 point / 0 directional.
    light: vec4f,
    // Directional: the reference point far on the light's side (informational).
    origin: vec4f,
}

@group(0) @binding(0) var<uniform> face: Face;

@vertex
fn vs_main(@location(0) position: vec3f, @location(1) albedo: vec3f) -> @builtin(position) vec4f {
    return face.view_proj * vec4f(position, 1.0);
}

// shadow_lookup.wgsl: where a world point falls in the shadow map, shared by Composite (the surfaces'
// light: 2x2 filtered, slope-biased) and Raymarch (one nearest texel per step).
//
// The importing file declares `f: Frame`, `shadow: ShadowFaces` (a private copy, made at its entry
// point: common.wgsl, "Parameters") and `shadow_map: texture_depth_2d_array`. The map holds only depth
// (shadow_map.wgsl); a point is lit when its own value is within a bias of the value the stored
// depth gives along the point's own direction:
//   point light (six faces, reversed infinite perspective, depth = near / a, a the distance along
//   the face's axis):  stored = near / depth * |P - L| / a(P - L)   (the point's |P - L| units)
//   directional (one orthographic layer, depth = s / far, s the distance from a plane far on the
//   light's side):  stored = depth * far
// An empty texel (depth 0 for the cube, 1 for the orthographic layer) stores "nothing": 3e38.

// ShadowFaces (common.wgsl) holds the matrices and the map's parameters.

// The face's matrix, picked from the private copy with constant indices only: a private array
// indexed by a value that differs between lanes is a gather from memory on llvmpipe (point lights:
// the march ~10% faster).
fn face_matrix(layer: u32) -> mat4x4f {
    var m = shadow.view_proj[0];
    if (POINT_LIGHT) {
        if (layer == 1u) { m = shadow.view_proj[1]; }
        if (layer == 2u) { m = shadow.view_proj[2]; }
        if (layer == 3u) { m = shadow.view_proj[3]; }
        if (layer == 4u) { m = shadow.view_proj[4]; }
        if (layer == 5u) { m = shadow.view_proj[5]; }
    }
    return m;
}

// Cube face of a direction, in the order +x -x +y -y +z -z (as shadow_map.rs renders them).
fn cube_face(d: vec3f) -> u32 {
    let a = abs(d);
    if (a.x >= a.y && a.x >= a.z) { return select(1u, 0u, d.x > 0.0); }
    if (a.y >= a.z) { return select(3u, 2u, d.y > 0.0); }
    return select(5u, 4u, d.z > 0.0);
}

struct ShadowCoords {
    // The map layer (cube face) and the continuous texel coordinates (texel i spans [i, i + 1)).
    layer: u32,
    uv: vec2f,
    // The point's own distance, to compare with the stored one.
    value: f32,
    // Point light: near * |P - L| / a(P - L), so that a stored depth d means this / d.
    per_depth: f32,
    // False outside the map. Fitted to the view (shadow_fit.wgsl), the map holds every point the
    // frame looks up; spread over the casters (ShadowMap::uniforms) it covers every caster but
    // backdrops (Scene::core_bounds), so a point projecting outside it can only be shadowed by a
    // backdrop, which lies under everything.
    inside: bool,
}

fn shadow_coords(p: vec3f) -> ShadowCoords {
    var s = ShadowCoords(0u, vec2f(0.0), 0.0, 0.0, false);
    if (POINT_LIGHT) {
        let d = p - f.light.xyz;
        s.layer = cube_face(d);
        s.value = length(d);
        let a = abs(d);
        s.per_depth = shadow.params.w * s.value / max(max(a.x, a.y), max(a.z, 1e-30));
    } else {
        s.value = dot(shadow.origin.xyz - p, f.light.xyz);
    }
    let clip = face_matrix(s.layer) * vec4f(p, 1.0);
    if (clip.w <= 0.0) { return s; }
    let ndc = clip.xy / clip.w;
    if (any(abs(ndc) > vec2f(1.0))) { return s; }
    s.uv = vec2f(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * shadow.size.xy;
    s.inside = true;
    return s;
}

// The distance texel c (clamped into the map) stores along s's direction, in s.value's units.
fn shadow_stored(s: ShadowCoords, c: vec2f) -> f32 {
    let depth = textureLoad(shadow_map, vec2i(clamp(c, vec2f(0.0), shadow.size.xy - 1.0)), i32(s.layer), 0);
    if (POINT_LIGHT) {
        return select(s.per_depth / depth, 3.0e38, depth <= 0.0);
    }
    return select(depth * shadow.params.w, 3.0e38, depth >= 1.0);
}

// shadow_cull.wgsl: which faces of a point light's cube shadow map each triangle can touch, so
// that each face draws only those (`main`), and which triangles the sun's map needs at all (`sun`)
// (ShadowMap pass; `src/render/shadow_map.rs`).
//
// Face k looks along axis c = k / 2 with sign s (+X, -X, +Y, -Y, +Z, -Z, the order of the faces'
// matrices). With q = P - L, its 90-degree pyramid is s q_c >= |q_u| and s q_c >= |q_v| for the
// two other axes: four planes through the light. The pyramid is convex, so a triangle whose three
// vertices all lie outside one of the planes cannot reach the face; every other triangle is kept
// (conservative: a kept triangle the face's frustum then clips costs only its vertices). Kept
// triangles' indices are appended to face k's region of `lists` and counted into its
// DrawIndexedIndirect arguments.
//
// `sun`: a directional map draws, into region 0, the triangles that are not a solid's faces away
// from the light, that do not lie wholly beyond one side of the map (once ShadowFit narrowed it to
// the view, most of a large scene) and that the pyramid of an earlier frame with the same map does
// not show hidden (hidden.wgsl; a pyramid of this map, with this matrix): at every texel centre
// such a triangle covers, the map holds a nearer depth, so the map drawn without them is the same
// map, bit for bit, and its binning (single-threaded on llvmpipe) has fewer triangles to set up.

#import hidden

struct ShadowCull {
    // xyz: the light's position (point) or the direction toward it (sun).
    light: vec4f,
    // x: triangles, y: indices per region (the scene's index count), z: the pyramid's coarsest
    // level (sun; 0: none), w: unused.
    counts: vec4u,
    // The sun map's view-projection.
    view_proj: mat4x4f,
    // The sun map's width and height in texels; zw unused.
    map_size: vec4u,
}

@group(0) @binding(0) var<storage, read> cull_in: ShadowCull;
// The scene's triangles, three vec4 vertices each in the order of `indices`, the first one's w its
// mesh (SceneGpu's triangles, all of them in one chunk: ShadowMap::bind makes no lists otherwise):
// three vector loads for a triangle's vertices and mesh where the vertex buffer took ten scalar
// ones (on llvmpipe each a loop over the SIMD group's lanes).
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
// Six regions of `counts.y` indices, face k's from k * counts.y.
@group(0) @binding(3) var<storage, read_write> lists: array<u32>;
// Six DrawIndexedIndirect arguments (index count, instances, first index, base vertex, first
// instance); the index counts start at 0 each frame.
@group(0) @binding(4) var<storage, read_write> args: array<atomic<u32>, 30>;
// Per mesh: +1 keep only the faces whose winding normal (b - a) x (c - a) faces the light, -1
// only those facing away, 0 all (SceneGpu::light_sides).
@group(0) @binding(5) var<storage, read> sides: array<f32>;
// The sun map's pyramid of block maxima (shadow_pyramid.wgsl), for `sun`.
@group(0) @binding(6) var<storage, read> pyramid: array<f32>;

// The parameters (and the sun's pyramid matrix) are read once at each entry point, before its
// first branch: inside a branch or a loop llvmpipe loads a storage value lane by lane even where its
// address is a constant (common.wgsl, "Parameters"; the classroom's sun list read its 39 floats
// after its first test: ~1 ms a frame, which llvmpipe's timestamps book to ShadowFit, session 36).

// The four plane values of q for face k (>= 0 inside), with a margin for rounding.
fn planes(q: vec3f, k: u32) -> vec4f {
    let c = k / 2u;
    let s = select(1.0, -1.0, (k & 1u) == 1u);
    let m = s * q[c];
    let u = q[(c + 1u) % 3u];
    let v = q[(c + 2u) % 3u];
    // f32 rounding of the faces' matrices must never cut a triangle the rasterizer would draw.
    let margin = 1e-5 * (abs(m) + abs(u) + abs(v));
    return vec4f(m - u, m + u, m - v, m + v) + margin;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let u = cull_in;
    let t = id.x + id.y * groups.x * 64u;
    if (t >= u.counts.x) { return; }
    let l = u.light.xyz;
    let v0 = tris[3u * t];
    let q0 = v0.xyz - l;
    let q1 = tris[3u * t + 1u].xyz - l;
    let q2 = tris[3u * t + 2u].xyz - l;
    // Toward the light is -q0; edge-on faces (dot 0) are kept.
    if (sides[u32(v0.w)] * dot(cross(q1 - q0, q2 - q0), q0) > 0.0) { return; }
    let i0 = indices[3u * t];
    let i1 = indices[3u * t + 1u];
    let i2 = indices[3u * t + 2u];
    for (var k = 0u; k < 6u; k++) {
        let outside = planes(q0, k) < vec4f(0.0) & planes(q1, k) < vec4f(0.0) & planes(q2, k) < vec4f(0.0);
        if (any(outside)) { continue; }
        let at = atomicAdd(&args[5u * k], 3u);
        let base = k * u.counts.y + at;
        lists[base] = i0;
        lists[base + 1u] = i1;
        lists[base + 2u] = i2;
    }
}

@compute @workgroup_size(64)
fn sun(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    let u = cull_in;
    let pm = pyramid_matrix();
    let t = id.x + id.y * groups.x * 64u;
    if (t >= u.counts.x) { return; }
    let v0 = tris[3u * t];
    let p0 = v0.xyz;
    let p1 = tris[3u * t + 1u].xyz;
    let p2 = tris[3u * t + 2u].xyz;
    // A solid's face away from the sun (Cull's test); edge-on faces (dot 0) are kept.
    if (sides[u32(v0.w)] * dot(cross(p1 - p0, p2 - p0), u.light.xyz) < 0.0) { return; }
    // Wholly beyond one side of the map (fitted to the view, ShadowFit): it covers no texel.
    let m = u.view_proj;
    let n0 = (m * vec4f(p0, 1.0)).xy;
    let n1 = (m * vec4f(p1, 1.0)).xy;
    let n2 = (m * vec4f(p2, 1.0)).xy;
    // A margin for the rounding of the matrix: a triangle the rasterizer would draw is never cut.
    let edge = vec2f(1.0 + 1e-5);
    if (any((n0 > edge) & (n1 > edge) & (n2 > edge)) || any((n0 < -edge) & (n1 < -edge) & (n2 < -edge))) { return; }
    // Only from a pyramid of this very map (a fitted map's earlier view may have had other texel
    // centres, where a hidden triangle could show through a gap between them).
    let c = u.counts;
    let same = all(pm[0] == m[0]) && all(pm[1] == m[1]) && all(pm[2] == m[2]) && all(pm[3] == m[3]);
    if (same && hidden_in_pyramid(m, vec2f(u.map_size.xy), c.z, p0, p1, p2)) { return; }
    let at = atomicAdd(&args[0], 3u);
    lists[at] = indices[3u * t];
    lists[at + 1u] = indices[3u * t + 1u];
    lists[at + 2u] = indices[3u * t + 2u];
}

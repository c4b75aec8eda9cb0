// hidden.wgsl: whether the directional shadow map shows a triangle behind nearer surfaces all
// around it, from the pyramid of its block maxima (shadow_pyramid.wgsl). Imported by Cull (which
// then does not voxelize the triangle) and by the shadow map's sun list (shadow_cull.wgsl, which
// then does not draw it: it could not win the depth test at any texel centre it covers); and, for
// the pyramid of the eye's depth, by Surface's culling (surface_cull.wgsl, `pyramid_max` and
// `depth_margin`).
//
// The importing file declares `pyramid: array<f32>`: the view-projection of the map it was made
// from (PYRAMID_MATRIX_FLOATS floats, column by column), then levels PYRAMID_FIRST_LEVEL to the
// coarsest, one after the other, each square (a pyramid of a W x H image is one of max(W, H) per
// side, its blocks past the image's edge repeating the edge).

// The shadow pyramid's finest level (ShadowPyramid::FIRST_LEVEL): blocks of 4x4 texels.
const PYRAMID_FIRST_LEVEL: u32 = 2u;
// Floats before the first level (ShadowPyramid::MATRIX_FLOATS).
const PYRAMID_MATRIX_FLOATS: u32 = 16u;

// The view-projection the pyramid's map was drawn with (a sun's map fitted to an earlier view may
// differ from this frame's).
fn pyramid_matrix() -> mat4x4f {
    return mat4x4f(pyramid_column(0u), pyramid_column(1u), pyramid_column(2u), pyramid_column(3u));
}

fn pyramid_column(i: u32) -> vec4f {
    return vec4f(pyramid[4u * i], pyramid[4u * i + 1u], pyramid[4u * i + 2u], pyramid[4u * i + 3u]);
}

// Whether the directional shadow map shows the triangle behind nearer surfaces all around it:
// its nearest depth (an orthographic depth is linear, so a vertex's) lies beyond the farthest
// depth over the map's texels within one texel of its footprint, read as at most 3x3 texels of the
// first pyramid level whose blocks are that coarse. Every light ray through the triangle then
// meets a nearer surface first (at a smaller gamma: after the scan the triangle's bits would change
// nothing), up to an occluder's gap narrower than a texel between texel centres, which the map
// cannot see (docs/pruning.md); and at every texel centre it covers, the map holds a nearer depth
// (drawn again, it would not change the map). Triangles reaching past the map's edge, or wider
// than the coarsest level's blocks, are kept. `m`: the map's view-projection, `dims` its width and
// height in texels, `coarsest` the pyramid's coarsest level (0: no pyramid, nothing is hidden).
fn hidden_in_pyramid(m: mat4x4f, dims: vec2f, coarsest: u32, p0: vec3f, p1: vec3f, p2: vec3f) -> bool {
    if (coarsest == 0u) { return false; }
    let c0 = map_point(m, dims, p0);
    let c1 = map_point(m, dims, p1);
    let c2 = map_point(m, dims, p2);
    // A margin of a few float steps of depth 1 (the rasterizer's own depth at a texel centre may
    // round below the vertices' least), and a steep sliver's slope past its snapped edges.
    let margin = depth_margin(c0.xy, c1.xy, c2.xy, vec3f(c0.z, c1.z, c2.z), 4e-6);
    let lo = min(c0.xy, min(c1.xy, c2.xy));
    let hi = max(c0.xy, max(c1.xy, c2.xy));
    return box_hidden(lo, hi, min(c0.z, min(c1.z, c2.z)) - margin, dims, coarsest);
}

// Point p under the map's view-projection m: texel coordinates (xy, as shadow_lookup.wgsl's: texel
// i spans [i, i + 1), for a map of dims texels) and depth (z).
fn map_point(m: mat4x4f, dims: vec2f, p: vec3f) -> vec3f {
    let c = (m * vec4f(p, 1.0)).xyz;
    return vec3f(vec2f(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5) * dims, c.z);
}

// Whether every texel the box [lo, hi] (texel coordinates) touches, and a ring of one around them,
// holds a depth nearer than `nearest`; false for a box reaching past the map's edge (also NaN). The
// pyramid of a `dims` map is one of the larger side's square (shadow_pyramid.wgsl).
fn box_hidden(lo: vec2f, hi: vec2f, nearest: f32, dims: vec2f, coarsest: u32) -> bool {
    let a = floor(lo) - 1.0;
    let b = floor(hi) + 1.0;
    if (!(all(a >= vec2f(0.0)) && all(b <= dims - 1.0))) { return false; }
    return pyramid_max(vec2u(a), vec2u(b), u32(max(dims.x, dims.y)), coarsest) < nearest;
}

// How far outside a triangle's edges the rasterizer may take a texel (or pixel) centre as covered:
// it snaps the vertices to 1/256 of a texel, which moves an edge outward by under this.
const COVER_EPS: f32 = 0.015625;

// How far below its vertices' least depth z the rasterizer may give a triangle (texel or pixel
// coordinates a, b, c) at a centre it covers: the depth's plane, taken from the vertices as they
// are, goes on past an edge that snapping moved outward (by under COVER_EPS), by the plane's slope
// times that. A sliver's slope is steep (with a fixed margin Surface's culling left out slivers of
// the built-in room that drew a pixel below their least depth: tests/shadow_faces.rs caught it,
// session 36), and that of a triangle of no area unbounded: infinite, so that it is never left
// out. Plus `rounding`.
fn depth_margin(a: vec2f, b: vec2f, c: vec2f, z: vec3f, rounding: f32) -> f32 {
    let e1 = b - a;
    let e2 = c - a;
    let area2 = e1.x * e2.y - e1.y * e2.x;
    let dz = vec2f(z.y - z.x, z.z - z.x);
    // The plane's gradient: (dz/dx, dz/dy) = (dz1 e2.y - dz2 e1.y, dz2 e1.x - dz1 e2.x) / area2.
    let slope = abs(dz.x * e2.y - dz.y * e1.y) + abs(dz.y * e1.x - dz.x * e2.x);
    if (!(abs(area2) > 0.0)) { return 3.0e38; }
    return rounding + COVER_EPS * slope / abs(area2);
}

// The farthest depth over texels [a, b] (inclusive, inside a map of `size` texels per side), read
// as at most 3x3 texels of the first pyramid level whose blocks hold the range in three per side;
// 3e38 (nothing is behind it) where even `coarsest`'s blocks are too fine.
fn pyramid_max(a: vec2u, b: vec2u, size: u32, coarsest: u32) -> f32 {
    var level = PYRAMID_FIRST_LEVEL;
    var offset = PYRAMID_MATRIX_FLOATS;
    loop {
        if (all((b >> vec2u(level)) - (a >> vec2u(level)) <= vec2u(2u))) { break; }
        if (level >= coarsest) { return 3.0e38; }
        let side = (size + (1u << level) - 1u) >> level;
        offset += side * side;
        level++;
    }
    let side = (size + (1u << level) - 1u) >> level;
    let i = a >> vec2u(level);
    let j = b >> vec2u(level);
    let mid = min(i + 1u, j);
    // Rows i, mid and j (the same row twice where the range holds fewer).
    let r0 = offset + i.y * side;
    let r1 = offset + mid.y * side;
    let r2 = offset + j.y * side;
    return max(
        max(max(pyramid[r0 + i.x], pyramid[r0 + mid.x]), max(pyramid[r0 + j.x], pyramid[r1 + i.x])),
        max(max(pyramid[r1 + mid.x], pyramid[r1 + j.x]), max(max(pyramid[r2 + i.x], pyramid[r2 + mid.x]), pyramid[r2 + j.x])),
    );
}

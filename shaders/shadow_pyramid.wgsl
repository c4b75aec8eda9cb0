// shadow_pyramid.wgsl: the farthest first hit over square blocks of the directional shadow map,
// for Cull's test of triangles the light cannot reach (cull.wgsl, `hidden_from_light`).
//
//   level L, texel (i, j) = max of the map's depth over texels [2^L i, 2^L (i + 1)) x [2^L j, 2^L (j + 1))
//
// Level 2 reduces 4x4 texels of the map, every further level 2x2 texels of the one before (edge
// texels repeat where a level has an odd size). Depth grows away from the light (the orthographic
// map stores s / far, 1 for nothing): a triangle whose nearest depth lies beyond a block's value
// is behind a nearer surface at every texel centre of the block. The same reduction makes the
// pyramid of the eye's depth (Surface's culling, surface_cull.wgsl), of a W x H image as of one
// max(W, H) texels square: the reads clamp to the image, so the blocks past its edge repeat it.

// ShadowPyramid's per-level parameters (shadow_pyramid.rs, `Level`; a layout test checks them).
struct Level {
    // Texels per side of the level read (the map for the first level) and of the level written.
    src_size: u32,
    dst_size: u32,
    // Where the read and the written level start in `pyramid` (src_offset unused for the first).
    src_offset: u32,
    dst_offset: u32,
}

@group(0) @binding(0) var shadow_map: texture_depth_2d_array;
@group(0) @binding(1) var<storage, read_write> pyramid: array<f32>;
@group(0) @binding(2) var<storage, read> level: Level;

// Texel p of the level read, for `from_level`.
fn src(l: Level, p: vec2u) -> f32 {
    return pyramid[l.src_offset + p.y * l.src_size + p.x];
}

// The first level (2: blocks of 4x4 texels), from the map's (only) layer. Level 1 is not made:
// on the classroom it would drop 0.4% more work items, and its million threads cost more than that.
@compute @workgroup_size(8, 8)
fn from_map(@builtin(global_invocation_id) id: vec3u) {
    let l = level;
    if (any(id.xy >= vec2u(l.dst_size))) { return; }
    let last = textureDimensions(shadow_map) - 1u;
    var d = 0.0;
    for (var j = 0u; j < 4u; j++) {
        for (var i = 0u; i < 4u; i++) {
            d = max(d, textureLoad(shadow_map, min(4u * id.xy + vec2u(i, j), last), 0, 0));
        }
    }
    pyramid[l.dst_offset + id.y * l.dst_size + id.x] = d;
}

// The levels after the first, from the level before.
@compute @workgroup_size(8, 8)
fn from_level(@builtin(global_invocation_id) id: vec3u) {
    let l = level;
    if (any(id.xy >= vec2u(l.dst_size))) { return; }
    let a = min(2u * id.xy, vec2u(l.src_size - 1u));
    let b = min(2u * id.xy + 1u, vec2u(l.src_size - 1u));
    let d = max(max(src(l, a), src(l, vec2u(b.x, a.y))), max(src(l, vec2u(a.x, b.y)), src(l, b)));
    pyramid[l.dst_offset + id.y * l.dst_size + id.x] = d;
}

// The image itself, for the eye's pyramid (EyePyramid), after its levels: `whole_image` copies the
// W x H depth (src_size x dst_size in its Level) from dst_offset on, row by row, for Surface's
// culling to read single pixels (surface_cull.wgsl, small triangles).
@compute @workgroup_size(8, 8)
fn whole_image(@builtin(global_invocation_id) id: vec3u) {
    let l = level;
    if (any(id.xy >= vec2u(l.src_size, l.dst_size))) { return; }
    pyramid[l.dst_offset + id.y * l.src_size + id.x] = textureLoad(shadow_map, id.xy, 0, 0);
}

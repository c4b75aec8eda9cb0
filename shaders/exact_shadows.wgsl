// exact_shadows.wgsl: which visible surface points the sun cannot see, tested against the
// triangles themselves (an irregular z-buffer over the fitted map's rectangle), for Composite.
//
// A surface point P is in the sun's shadow when the ray from P toward the light meets a triangle.
// Under the sun's orthographic view (the fitted map's matrix, shadow_fit.wgsl) that ray is one
// point q = (u, v) of light space, in tiles of the rectangle, and triangle T meets it when q lies
// in T's projection and T is nearer the light there:
//
//   inside:  E_k(q) = n_k . (q - q_k) >= -TOL       for its three edges (n_k: the unit inward normal),
//   nearer:  s_T(q) = A u + B v + C  <  s_P - eps,   s = dot(origin - X, w)
//
// (s as the map stores it: the distance from a plane beyond the scene on the light's side, larger
// away from the light; eps = (EPS_FLOOR + EPS_PER_DISTANCE t + ROUNDING) / max(cos theta_i,
// MIN_COS): P comes from the rasterized distance t, a few f32 steps off its own triangle's plane,
// and the rasterizer places it from world positions, which far from the origin keep only their
// f32 spacing (ROUNDING: a few of those steps); that offset along the light clears it at any slope
// but the most grazing, where cos theta_i leaves little light to lose). TOL (a millionth of a tile) makes neighbouring triangles overlap at their shared edge:
// no point slips between them. The same test as the reference's shadow ray (src/reference), up to
// f32: no texels, no filtering, no bias against acne. (The test also asks q to lie in T's
// projection's box widened by TOL, in 256ths of the tile: a point the edges let in always does, and
// one word per entry then leaves out most of a tile's triangles before their planes are read.)
//
// Six dispatches:
//   `points`  (a thread per pixel) finds each surface point's tile and keeps, per tile, the least
//             and the greatest of its points' s - eps;
//   `block_bounds` (a thread per block of BLOCK x BLOCK tiles) the same per block;
//   `count`   (a thread per triangle) projects the triangle, keeps its edge and depth planes, and
//             adds one to each tile its projection overlaps, but for tiles it cannot darken: with
//             no point, or where its plane lies beyond the tile's greatest s - eps (whole blocks
//             of them passed over at once); and a tile it covers whole, nearer the light than the
//             tile's least s - eps, it marks dark (every point of it shadowed) instead (a wall
//             between the window and the room: on the classroom at 512x512, 807 of the 1 921
//             tiles with points, docs/results.md, session 44). Each entry is recorded with its
//             tile, its place among the tile's entries (the count before it) and the part of the
//             tile the triangle's box covers (`local_box`);
//   `offsets` (one workgroup) turns the counts into each tile's first entry of the list (an
//             exclusive prefix sum);
//   `fill`    (threads striding over the recorded entries) moves each to its place in the list;
//   `test`    (a thread per pixel) takes a dark tile's shadow, or tests the pixel's point against
//             its tile's triangles whose box holds the point (a word each, in runs of 32), stopping
//             at the first that hides it, and writes 1 (lit) or 0 (shadowed) for Composite.
// A triangle edge-on to the light (no area across it) hides nothing a neighbour does not, nor does
// a solid's face turned away from the sun (its ray leaves the solid through a face toward the sun
// later, src/scene/solid.rs): neither is listed. Nor is one the sun's pyramid shows hidden (Cull's
// test, hidden.wgsl, from the pyramid an earlier frame of this light made; f.work.z = 0 without
// one): every ray toward the sun through it meets a nearer surface first, which is listed, so no
// point's answer changes, up to an occluder's gap narrower than a map texel, which the map cannot
// see (docs/pruning.md, "hidden casters"). On the classroom at 512x512 the pass is ~7% shorter,
// the images the same to the bit (docs/results.md, session 50). One whose projection leaves the
// rectangle keeps the tiles inside it.

#import common
#import workgroup_scan
#import hidden

// Per frame (ExactShadows::params; src/render/exact_shadows.rs, `ExactParams`).
struct ExactParams {
    // Tiles across and down the rectangle, their number, and the list's capacity in entries.
    tiles: vec4u,
    // x: EPS_FLOOR (scene units), y: EPS_PER_DISTANCE, z: MIN_COS, w: TOL (tiles).
    eps: vec4f,
    // x: ROUNDING, the scene's positions' f32 rounding (scene units): EPS_PER_ULP times the
    // largest coordinate of the eye and the scene's box times 2^-23.
    rounding: vec4f,
}

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read> shadow_in: ShadowFaces;
@group(0) @binding(2) var<storage, read> params_in: ExactParams;
// The scene's triangles: three vec4 world vertices each, the first one's w its mesh
// (SceneGpu::whole_triangles).
@group(0) @binding(3) var<storage, read> tris: array<vec4f>;
// Per tile (T of them), in stretches (where each starts: the `*_at` functions below): [0, T] the
// number of list entries (count), then the first entry (offsets; entry T the total); two words,
// the entries `count` recorded and those past the capacity; the complement of the least s - eps
// of the tile's points (`key`; 0 for a tile without points); the greatest; 1 where a triangle
// darkens the whole tile; then per block of tiles its least (complemented) and greatest.
@group(0) @binding(4) var<storage, read_write> tiles: array<atomic<u32>>;
// Per triangle: its three edges (n_k, -n_k . q_k) with the depth plane's A, B, C in w, and the
// box of its projection in tiles (least u, least v, greatest u, greatest v; empty, least past
// greatest, for a triangle that darkens nothing).
@group(0) @binding(5) var<storage, read_write> planes: array<vec4f>;
// Per entry: the triangle, and its projection's box within the tile (`local_box`).
@group(0) @binding(6) var<storage, read_write> list: array<vec2u>;
// Per entry in the order `count` made them: its tile, its place among the tile's entries, and
// the list entry (`fill` moves it to its tile's stretch of the list).
@group(0) @binding(11) var<storage, read_write> recorded: array<vec4u>;
// Per pixel: 1 lit, 0 in the sun's shadow (rows top to bottom).
@group(0) @binding(7) var<storage, read_write> vis: array<u32>;
// Surface's distance to the nearest surface (x; negative for the sky) and (albedo, cos theta_i).
@group(0) @binding(8) var distance: texture_2d<f32>;
@group(0) @binding(9) var material: texture_2d<f32>;
// Per mesh (SceneGpu::light_sides): +1 or -1 for a solid, the winding's side toward the light that
// its shadow needs (src/scene/solid.rs); 0 for an open mesh.
@group(0) @binding(10) var<storage, read> sides: array<f32>;
// The sun's pyramid of block maxima (shadow_pyramid.wgsl; hidden.wgsl reads it), as Cull's.
@group(0) @binding(12) var<storage, read> pyramid: array<f32>;

var<private> f: Frame;
var<private> params: ExactParams;
// The fitted map's matrix and its reference point far on the light's side, copied at each entry
// point (common.wgsl, "Parameters"; the six matrices of a private ShadowFaces would be copied too).
var<private> sun_matrix: mat4x4f;
// The eye's light-space point (`light_point`).
var<private> eye_light: vec3f;

fn copy_parameters() {
    f = frame_in;
    params = params_in;
    sun_matrix = shadow_in.view_proj[0];
    let c = (sun_matrix * vec4f(f.eye.xyz, 1.0)).xy;
    eye_light = vec3f(vec2f(c.x * 0.5 + 0.5, 0.5 - c.y * 0.5) * vec2f(params.tiles.xy), dot(shadow_in.origin.xyz - f.eye.xyz, f.light.xyz));
}

// Light-space point of eye + d: (u, v) in tiles of the fitted rectangle (the map's texel
// convention: u right, v down) and s. From d, the offset from the eye, and the eye's own point:
// every point and vertex is the same eye_light (whose rounding then moves them all alike) plus a
// small vector's image. Transforming world positions instead cancels large terms: 141 km from the
// origin, where f32 positions keep 8 mm, the floor shadowed itself in bands (`tests/exact_shadows.rs`,
// `exact_shadows_hold_at_every_scale`).
fn light_point(d: vec3f) -> vec3f {
    let c = (sun_matrix * vec4f(d, 0.0)).xy;
    let uv = vec2f(c.x * 0.5, -c.y * 0.5) * vec2f(params.tiles.xy);
    return vec3f(eye_light.xy + uv, eye_light.z - dot(d, f.light.xyz));
}

// Where the stretches of `tiles` start (T: params.tiles.z).
fn recorded_at() -> u32 { return params.tiles.z + 1u; }
fn overflow_at() -> u32 { return params.tiles.z + 2u; }
fn near_at() -> u32 { return params.tiles.z + 3u; }
fn far_at() -> u32 { return 2u * params.tiles.z + 3u; }
fn dark_at() -> u32 { return 3u * params.tiles.z + 3u; }
// Per block of BLOCK x BLOCK tiles: the complement of its points' least key and their greatest.
fn block_near_at() -> u32 { return 4u * params.tiles.z + 3u; }
fn block_far_at() -> u32 { return block_near_at() + blocks().x * blocks().y; }

const BLOCK: u32 = 8u;

fn blocks() -> vec2u {
    return (params.tiles.xy + BLOCK - 1u) / BLOCK;
}

// One thread per block of tiles: its points' least and greatest key, from its tiles'.
@compute @workgroup_size(64)
fn block_bounds(@builtin(global_invocation_id) id: vec3u) {
    params = params_in;
    let nb = blocks();
    if (id.x >= nb.x * nb.y) { return; }
    let b = vec2u(id.x % nb.x, id.x / nb.x);
    var near = 0u;
    var far = 0u;
    for (var y = b.y * BLOCK; y < min((b.y + 1u) * BLOCK, params.tiles.y); y++) {
        for (var x = b.x * BLOCK; x < min((b.x + 1u) * BLOCK, params.tiles.x); x++) {
            let tile = y * params.tiles.x + x;
            near = max(near, atomicLoad(&tiles[near_at() + tile]));
            far = max(far, atomicLoad(&tiles[far_at() + tile]));
        }
    }
    atomicStore(&tiles[block_near_at() + id.x], near);
    atomicStore(&tiles[block_far_at() + id.x], far);
}

// Whether triangle (depth plane in e0..e2's w) may shadow a point of the block of tiles
// [lo, hi): the block has points, and the plane comes nearer the light than the farthest.
fn block_wanted(e0: vec4f, e1: vec4f, e2: vec4f, block: u32, lo: vec2f, hi: vec2f) -> bool {
    let near = atomicLoad(&tiles[block_near_at() + block]);
    if (near == 0u) { return false; }
    let least = e0.w * select(hi.x, lo.x, e0.w > 0.0) + e1.w * select(hi.y, lo.y, e1.w > 0.0) + e2.w;
    return key(least) < atomicLoad(&tiles[block_far_at() + block]);
}

// An order-preserving code of a float: a < b exactly when key(a) < key(b).
fn key(x: f32) -> u32 {
    let b = bitcast<u32>(x);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

// A surface point that takes light from the test: its tile and s - eps. None (tile ~0u) for the
// sky, a surface turned away from the light and a point outside the rectangle.
struct SurfacePoint {
    uv: vec2f,
    tile: u32,
    reach: f32,
}

fn surface_point(id: vec2u) -> SurfacePoint {
    var o = SurfacePoint(vec2f(0.0), ~0u, 0.0);
    let p = vec2i(id);
    let t = textureLoad(distance, p, 0).x;
    let cos_i = textureLoad(material, p, 0).w;
    if (!(t >= 0.0 && cos_i > 0.0)) { return o; }
    let q = light_point(pixel_dir(f, vec2f(id)) * t);
    let cell = floor(q.xy);
    if (!(all(cell >= vec2f(0.0)) && all(cell < vec2f(params.tiles.xy)))) { return o; }
    o.uv = q.xy;
    o.tile = u32(cell.y) * params.tiles.x + u32(cell.x);
    o.reach = q.z - (params.eps.x + params.eps.y * t + params.rounding.x) / max(cos_i, params.eps.z);
    return o;
}

@compute @workgroup_size(8, 8)
fn points(@builtin(global_invocation_id) id: vec3u) {
    copy_parameters();
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    let s = surface_point(id.xy);
    if (s.tile == ~0u) { return; }
    atomicMax(&tiles[near_at() + s.tile], ~key(s.reach));
    atomicMax(&tiles[far_at() + s.tile], key(s.reach));
}

// What triangle (edges e0..e2, depth plane in their w) does to tile (x, y): 0 nothing (no point
// there, or every point nearer the light than its plane), 1 a list entry, 2 every point shadowed.
fn tile_role(e0: vec4f, e1: vec4f, e2: vec4f, x: f32, y: f32) -> u32 {
    let tile = u32(y) * params.tiles.x + u32(x);
    let near = atomicLoad(&tiles[near_at() + tile]);
    if (near == 0u || !overlaps(e0, e1, e2, x, y)) { return 0u; }
    // The plane's least and greatest s over the tile (at corners).
    let ab = vec2f(e0.w, e1.w);
    let lo = ab.x * select(x + 1.0, x, ab.x > 0.0) + ab.y * select(y + 1.0, y, ab.y > 0.0) + e2.w;
    let hi = ab.x * select(x, x + 1.0, ab.x > 0.0) + ab.y * select(y, y + 1.0, ab.y > 0.0) + e2.w;
    if (key(lo) >= atomicLoad(&tiles[far_at() + tile])) { return 0u; }
    let whole = edge_min(e0, x, y) >= 0.0 && edge_min(e1, x, y) >= 0.0 && edge_min(e2, x, y) >= 0.0;
    if (whole && key(hi) < ~near) { return 2u; }
    return 1u;
}

// The least value edge (e.x u + e.y v + e.z) takes over tile (x, y).
fn edge_min(e: vec4f, x: f32, y: f32) -> f32 {
    return e.x * select(x + 1.0, x, e.x > 0.0) + e.y * select(y + 1.0, y, e.y > 0.0) + e.z;
}

fn triangle_count() -> u32 {
    return arrayLength(&tris) / 3u;
}

fn thread_index(id: vec3u, groups: vec3u) -> u32 {
    return id.x + id.y * groups.x * 64u;
}

// The largest value edge (e.x u + e.y v + e.z) takes over tile (x, y) (at one of its corners).
fn edge_max(e: vec4f, x: f32, y: f32) -> f32 {
    return e.x * select(x, x + 1.0, e.x > 0.0) + e.y * select(y, y + 1.0, e.y > 0.0) + e.z;
}

// Whether triangle (edges e0..e2) may cover a point of tile (x, y): no edge has the whole tile
// outside it by more than TOL (a conservative test of the tile against the three half-planes).
fn overlaps(e0: vec4f, e1: vec4f, e2: vec4f, x: f32, y: f32) -> bool {
    let tol = -2.0 * params.eps.w;
    return edge_max(e0, x, y) >= tol && edge_max(e1, x, y) >= tol && edge_max(e2, x, y) >= tol;
}

// Edge from a to b of a counter-clockwise triangle: its unit inward normal n and -n . a, in xyz.
fn edge(a: vec2f, b: vec2f) -> vec3f {
    let d = b - a;
    let n = vec2f(-d.y, d.x) / max(length(d), 1e-30);
    return vec3f(n, -dot(n, a));
}

// The tiles a projection's box (in tiles) may reach, widened by TOL and cut to the rectangle
// (first x, first y, last x, last y; empty, first past last, outside it).
fn tile_box(bounds: vec4f) -> vec4f {
    let lo = max(floor(bounds.xy - params.eps.w), vec2f(0.0));
    let hi = min(floor(bounds.zw + params.eps.w), vec2f(params.tiles.xy) - 1.0);
    return vec4f(lo, hi);
}

// Where a point or a box lies within tile (x, y): in 256ths of the tile across and down, clamped
// to [0, 255]. Rounding keeps order (fl(a - x) grows with a, and * 256 is exact), so a point
// inside a box [lo, hi] is inside its `local_box` too.
fn local_cells(p: vec2f, x: f32, y: f32) -> vec2u {
    return vec2u(clamp(floor((p - vec2f(x, y)) * 256.0), vec2f(0.0), vec2f(255.0)));
}

// A triangle's projection box `bounds` (in tiles), widened by TOL, within tile (x, y): the first
// and last cells across (bits 0-7, 8-15) and down (16-23, 24-31). `test` tests a point against
// the triangle only where its cell lies inside: the same answer (a point the triangle covers,
// within TOL of its edges, lies in the widened box), for one word's load instead of the planes'.
fn local_box(bounds: vec4f, x: f32, y: f32) -> u32 {
    let lo = local_cells(bounds.xy - params.eps.w, x, y);
    let hi = local_cells(bounds.zw + params.eps.w, x, y);
    return lo.x | (hi.x << 8u) | (lo.y << 16u) | (hi.y << 24u);
}

fn in_local_box(cell: vec2u, box: u32) -> bool {
    return cell.x >= (box & 255u) && cell.x <= ((box >> 8u) & 255u)
        && cell.y >= ((box >> 16u) & 255u) && cell.y <= (box >> 24u);
}

// The tiles of triangle t's box it may darken or list (`tile_role`; `bounds`: its projection's
// box in tiles), whole blocks of them passed over where `block_wanted` says none: a listing tile
// gets one entry more, recorded with its place among the tile's entries for `fill`, and a
// darkened one is marked.
fn visit_tiles(t: u32, e0: vec4f, e1: vec4f, e2: vec4f, bounds: vec4f) {
    let box = tile_box(bounds);
    let w = params.tiles.x;
    let nb = blocks();
    let b_lo = vec2u(box.xy) / BLOCK;
    let b_hi = vec2u(box.zw) / BLOCK;
    for (var by = b_lo.y; by <= b_hi.y; by++) {
        for (var bx = b_lo.x; bx <= b_hi.x; bx++) {
            let t_lo = max(vec2f(vec2u(bx, by) * BLOCK), box.xy);
            let t_hi = min(vec2f(vec2u(bx, by) * BLOCK + BLOCK - 1u), box.zw);
            if (!block_wanted(e0, e1, e2, by * nb.x + bx, t_lo, t_hi + 1.0)) { continue; }
            for (var y = t_lo.y; y <= t_hi.y; y += 1.0) {
                for (var x = t_lo.x; x <= t_hi.x; x += 1.0) {
                    let role = tile_role(e0, e1, e2, x, y);
                    let tile = u32(y) * w + u32(x);
                    if (role == 1u) {
                        let place = atomicAdd(&tiles[tile], 1u);
                        let at = atomicAdd(&tiles[recorded_at()], 1u);
                        if (at < params.tiles.w) { recorded[at] = vec4u(tile, place, t, local_box(bounds, x, y)); }
                    } else if (role == 2u) {
                        atomicStore(&tiles[dark_at() + tile], 1u);
                    }
                }
            }
        }
    }
}

@compute @workgroup_size(64)
fn count(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    copy_parameters();
    let t = thread_index(id, groups);
    if (t >= triangle_count()) { return; }
    let v0 = tris[3u * t];
    let p1 = tris[3u * t + 1u].xyz;
    let p2 = tris[3u * t + 2u].xyz;
    let eye = f.eye.xyz;
    var a = light_point(v0.xyz - eye);
    var b = light_point(p1 - eye);
    var c = light_point(p2 - eye);
    let area2 = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    let bounds = vec4f(min(a.xy, min(b.xy, c.xy)), max(a.xy, max(b.xy, c.xy)));
    let tiles = tile_box(bounds);
    // Nothing to list: no area across the light, outside the rectangle, or a solid's face turned
    // away from the sun (a ray toward the sun that meets such a face leaves the solid later
    // through a face toward it, which is listed: src/scene/solid.rs; edge-on faces are kept), or
    // one the pyramid shows behind nearer surfaces all around it (`hid`; none without a pyramid).
    let away = sides[u32(v0.w)] * dot(cross(p1 - v0.xyz, p2 - v0.xyz), f.light.xyz) < 0.0;
    let hid = hidden_in_pyramid(pyramid_matrix(), shadow_in.size.xy, f.work.z, v0.xyz, p1, p2);
    if (!(abs(area2) > 1e-12) || !all(tiles.xy <= tiles.zw) || away || hid) {
        planes[4u * t + 3u] = vec4f(1.0, 1.0, 0.0, 0.0);
        return;
    }
    if (area2 < 0.0) {
        let swap = b;
        b = c;
        c = swap;
    }
    // s = A u + B v + C through the three vertices.
    let d1 = b - a;
    let d2 = c - a;
    let det = abs(area2);
    let ab = vec2f(d1.z * d2.y - d2.z * d1.y, d2.z * d1.x - d1.z * d2.x) / det;
    let cs = a.z - ab.x * a.x - ab.y * a.y;
    let e0 = vec4f(edge(a.xy, b.xy), ab.x);
    let e1 = vec4f(edge(b.xy, c.xy), ab.y);
    let e2 = vec4f(edge(c.xy, a.xy), cs);
    planes[4u * t] = e0;
    planes[4u * t + 1u] = e1;
    planes[4u * t + 2u] = e2;
    planes[4u * t + 3u] = bounds;
    visit_tiles(t, e0, e1, e2, bounds);
}

// One workgroup: tiles[0, T] become each tile's first entry (tiles[T] the total).
@compute @workgroup_size(256)
fn offsets(@builtin(local_invocation_index) lid: u32) {
    params = params_in;
    let n = params.tiles.z;
    var carried = 0u;
    for (var base = 0u; base < n; base += 256u) {
        let i = base + lid;
        var v = 0u;
        if (i < n) { v = atomicLoad(&tiles[i]); }
        let s = scan_chunk(lid, v);
        if (i < n) { atomicStore(&tiles[i], carried + s.x); }
        carried += s.y;
    }
    if (lid == 0u) {
        atomicStore(&tiles[n], carried);
        atomicStore(&tiles[overflow_at()], select(0u, carried - params.tiles.w, carried > params.tiles.w));
    }
}

// Each recorded entry to its place in its tile's stretch of the list (threads striding over
// them: their number is known only here).
@compute @workgroup_size(64)
fn fill(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    params = params_in;
    let n = min(atomicLoad(&tiles[recorded_at()]), params.tiles.w);
    for (var i = id.x; i < n; i += groups.x * 64u) {
        let e = recorded[i];
        let at = atomicLoad(&tiles[e.x]) + e.y;
        if (at < params.tiles.w) { list[at] = e.zw; }
    }
}

@compute @workgroup_size(8, 8)
fn test(@builtin(global_invocation_id) id: vec3u) {
    copy_parameters();
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    let s = surface_point(id.xy);
    var lit = 1u;
    if (s.tile != ~0u) {
        if (atomicLoad(&tiles[dark_at() + s.tile]) != 0u) {
            lit = 0u;
        } else {
            let first = atomicLoad(&tiles[s.tile]);
            let end = min(atomicLoad(&tiles[s.tile + 1u]), params.tiles.w);
            let tol = -params.eps.w;
            let q = s.uv;
            let cell = local_cells(q, floor(q.x), floor(q.y));
            // In runs of 32 entries: first which of them have the point's cell in their box (a
            // word each), then the planes of only those.
            for (var run = first; run < end && lit == 1u; run += 32u) {
                let n = min(end - run, 32u);
                var near = 0u;
                for (var j = 0u; j < n; j++) {
                    near |= select(0u, 1u << j, in_local_box(cell, list[run + j].y));
                }
                while (near != 0u) {
                    let k = list[run + countTrailingZeros(near)].x;
                    near &= near - 1u;
                    let e0 = planes[4u * k];
                    let e1 = planes[4u * k + 1u];
                    let e2 = planes[4u * k + 2u];
                    let depth = e0.w * q.x + e1.w * q.y + e2.w;
                    let inside = dot(e0.xy, q) + e0.z >= tol && dot(e1.xy, q) + e1.z >= tol && dot(e2.xy, q) + e2.z >= tol;
                    if (inside && depth < s.reach) {
                        lit = 0u;
                        break;
                    }
                }
            }
        }
    }
    vis[id.y * f.image.x + id.x] = lit;
}

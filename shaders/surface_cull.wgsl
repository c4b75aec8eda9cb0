// surface_cull.wgsl: the eye's triangles that cover no pixel centre, made empty before Surface
// draws (the Surface pass, `src/render/surface.rs`).
//
// The rasterizer writes a pixel only where a triangle covers the pixel's centre (i + 1/2, j + 1/2).
// A triangle in front of the eye (w > 0 at its three vertices; the part the near plane leaves is
// a piece of it) lies inside its vertices' bounding box [lo, hi] in pixel coordinates, so where
//
//   ceil(lo - 1/2 - eps) > floor(hi - 1/2 + eps)   in x or in y (the centres clamped to the image)
//
// no centre lies in the box and the triangle draws nothing. eps = 1/64 pixel covers the rounding:
// the rasterizer snaps vertices to 1/256 of a pixel, and this projection rounds apart from the
// vertex shader's by far less. Such a triangle is listed as (i0, i0, i0): zero area, which the
// rasterizer drops before setting it up, and which costs one vertex instead of three. Every other
// triangle is copied as it is, in its place: the runs draw the same ranges in the same order, so
// the targets are the same, bit for bit. Scenes of tessellated or scanned meshes hold mostly such
// triangles (a million-triangle scene at 512x512: several per pixel), and on llvmpipe the vertex
// work before the rasterizer's own test runs on one thread, while this pass runs on all of them.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
// The scene's vertex buffer: [x, y, z, r, g, b] per vertex.
@group(0) @binding(1) var<storage, read> vertices: array<f32>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
// The indices Surface draws: `indices` with the triangles that cover no centre emptied.
@group(0) @binding(3) var<storage, read_write> lists: array<u32>;

// Private copy of the frame's parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// How far past the bounding box a pixel centre may be and still count, in pixels.
const EPS: f32 = 0.015625;

fn clip_of(i: u32) -> vec4f {
    return f.view_proj * vec4f(vertices[6u * i], vertices[6u * i + 1u], vertices[6u * i + 2u], 1.0);
}

// Pixel coordinates (x right, y down) of a clip-space point with w > 0.
fn pixel_of(c: vec4f) -> vec2f {
    return (c.xy / c.w * vec2f(0.5, -0.5) + 0.5) * vec2f(f.image.xy);
}

// Whether [lo, hi] (pixels along one axis of n) holds no pixel centre; false for NaN.
fn misses_centres(lo: f32, hi: f32, n: u32) -> bool {
    let first = max(ceil(lo - 0.5 - EPS), 0.0);
    let last = min(floor(hi - 0.5 + EPS), f32(n) - 1.0);
    return first > last;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    f = frame_in;
    let t = id.x + id.y * groups.x * 64u;
    if (t >= arrayLength(&lists) / 3u) { return; }
    let i0 = indices[3u * t];
    let i1 = indices[3u * t + 1u];
    let i2 = indices[3u * t + 2u];
    let a = clip_of(i0);
    let b = clip_of(i1);
    let c = clip_of(i2);
    var empty = false;
    if (min(a.w, min(b.w, c.w)) > 0.0) {
        let pa = pixel_of(a);
        let pb = pixel_of(b);
        let pc = pixel_of(c);
        let lo = min(pa, min(pb, pc));
        let hi = max(pa, max(pb, pc));
        empty = misses_centres(lo.x, hi.x, f.image.x) || misses_centres(lo.y, hi.y, f.image.y);
    }
    lists[3u * t] = i0;
    lists[3u * t + 1u] = select(i1, i0, empty);
    lists[3u * t + 2u] = select(i2, i0, empty);
}

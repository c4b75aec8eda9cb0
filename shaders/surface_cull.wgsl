// surface_cull.wgsl: the eye's triangles that would draw nothing, made empty before Surface draws
// (the Surface pass, `src/render/surface.rs`).
//
// The rasterizer writes a pixel only where a triangle covers the pixel's centre (i + 1/2, j + 1/2).
// A triangle in front of the eye (w > 0 at its three vertices; the part the near plane leaves is
// a piece of it) lies inside its vertices' bounding box [lo, hi] in pixel coordinates, so where
//
//   ceil(lo - 1/2 - eps) > floor(hi - 1/2 + eps)   in x or in y (the centres clamped to the image)
//
// no centre lies in the box and the triangle draws nothing. eps = 1/64 pixel covers the rounding:
// the rasterizer snaps vertices to 1/256 of a pixel, and this projection rounds apart from the
// vertex shader's by far less. Nor does a solid's face turned away from the eye where Surface's
// pipeline culls that side (`sides`, per mesh: its winding normal n against the way to the eye,
//
//   side * n . (eye - p0) < -t |n| |eye - p0|,   t = FACING_TOL = 1e-3,
//
// a margin for the rasterizer's snapping of vertices to 1/256 pixel, which turns a face over
// about two pixels across by less than that). Such a triangle is listed as (i0, i0, i0): zero area, which the rasterizer
// drops before setting it up, and which costs one vertex instead of three. Every other
// triangle is copied as it is, in its place: the runs draw the same ranges in the same order, so
// the targets are the same, bit for bit. Scenes of tessellated or scanned meshes hold mostly such
// triangles (the bench's million-triangle room at 512x512: 61% cover no pixel centre and half of
// the rest face away, 81% in all; the classroom: 66%), and on llvmpipe the vertex work before the rasterizer's own tests runs on
// one thread, while this pass runs on all of them.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
// The scene's vertex buffer: [x, y, z, r, g, b] per vertex.
@group(0) @binding(1) var<storage, read> vertices: array<f32>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
// The indices Surface draws: `indices` with the triangles that cover no centre emptied.
@group(0) @binding(3) var<storage, read_write> lists: array<u32>;
// Per triangle: its mesh.
@group(0) @binding(4) var<storage, read> triangle_meshes: array<u32>;
// Per mesh: +1 Surface draws only the faces whose winding normal (b - a) x (c - a) faces the eye,
// -1 only those facing away, 0 all (SceneGpu::eye_sides, the pipelines' cull modes).
@group(0) @binding(5) var<storage, read> sides: array<f32>;

// Private copy of the frame's parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// How far past the bounding box a pixel centre may be and still count, in pixels.
const EPS: f32 = 0.015625;
// How clearly a face must turn away from the eye to be emptied (the sine of its angle to the way
// toward the eye).
const FACING_TOL: f32 = 1e-3;

fn position(i: u32) -> vec3f {
    return vec3f(vertices[6u * i], vertices[6u * i + 1u], vertices[6u * i + 2u]);
}

// Whether the triangle is a face Surface's pipeline culls: turned away from the eye on the side
// its mesh skips.
fn turned_away(t: u32, p0: vec3f, p1: vec3f, p2: vec3f) -> bool {
    let n = cross(p1 - p0, p2 - p0);
    let to_eye = f.eye.xyz - p0;
    return sides[triangle_meshes[t]] * dot(n, to_eye) < -FACING_TOL * length(n) * length(to_eye);
}

fn clip_of(p: vec3f) -> vec4f {
    return f.view_proj * vec4f(p, 1.0);
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
    let p0 = position(i0);
    let p1 = position(i1);
    let p2 = position(i2);
    let a = clip_of(p0);
    let b = clip_of(p1);
    let c = clip_of(p2);
    var empty = turned_away(t, p0, p1, p2);
    if (!empty && min(a.w, min(b.w, c.w)) > 0.0) {
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

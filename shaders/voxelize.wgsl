// voxelize.wgsl: marks, for every grid texel (plane x, ray y), the bins z that geometry occupies.
//
// The transform to epipolar space is non-linear, so rasterizing transformed triangles gives curved
// edges wrong and misses thin casters (no conservative rasterization on the software driver).
// Instead a compute pass (`cull`) finds each triangle's *epipolar bounding rectangle* (two when it
// straddles the seam at phi = 0, every plane when the eye-light axis pierces it), drops triangles
// that cannot shadow a visible point (outside the visible wedge, past the last visible ray, or
// outside the bins' z range), and writes the draw's indirect arguments; the render pass draws the
// kept rectangles and every fragment tests its triangle exactly against the texel's cell:
//
//   cell(x, y) = the pyramid from the eye spanned by the four view rays (phi_x, gamma_y),
//                (phi_x+1, gamma_y), (phi_x+1, gamma_y+1), (phi_x, gamma_y+1)
//   polygon    = triangle clipped to the cell (Sutherland-Hodgman against its four planes)
//   bins       = [bin(min z over polygon), bin(max z over polygon)], z = psi or r
//
// The z extremes of a convex polygon lie on its edges (closed-form stationary point per edge), so a
// surface seen edge-on marks every bin it spans and closed surfaces do not leak. Casters before the
// first visible ray (gamma < gamma_lo) are clamped into row 0: the scan only carries them forward.

#import common
#import triangle_bounds

@group(0) @binding(0) var<uniform> f: Frame;
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> grid: array<atomic<u32>>;
// Written by the Cull pass (cull.wgsl): the kept triangles and their rectangles.
@group(0) @binding(3) var<storage, read> kept: array<u32>;
@group(0) @binding(4) var<storage, read> kept_rects: array<vec4f>;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) @interpolate(flat) tri: u32,
}

// ---- vertex stage: a kept triangle's rectangles ----------------------------------------------

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> VsOut {
    var o: VsOut;
    let i = vi / 12u;
    let corner = vi % 12u;
    let quad = corner / 6u;
    o.tri = kept[i];
    let r = kept_rects[2u * i + quad];
    if (r.x >= r.z) {
        o.clip = vec4f(2.0, 2.0, 0.0, 1.0); // no second rectangle: a degenerate triangle
        return o;
    }
    let k = corner % 6u;
    let cx = select(r.x, r.z, k == 1u || k == 4u || k == 5u);
    let cy = select(r.y, r.w, k == 2u || k == 3u || k == 5u);
    o.clip = vec4f(cx / f32(f.grid.x) * 2.0 - 1.0, 1.0 - cy / f32(f.grid.y) * 2.0, 0.0, 1.0);
    return o;
}



// ---- fragment stage: exact triangle-cell test -------------------------------------------------

var<private> poly: array<vec3f, 10>;
var<private> tmp: array<vec3f, 10>;
var<private> count: u32;

// Keeps the part of the polygon with dot(n, p) >= 0 (coordinates relative to the eye).
fn clip_plane(n: vec3f) {
    if (dot(n, n) < 1e-30) { return; } // degenerate face (the cell touches the axis)
    var m = 0u;
    for (var i = 0u; i < count; i++) {
        let p = poly[i];
        let q = poly[(i + 1u) % count];
        let dp = dot(n, p);
        let dq = dot(n, q);
        if (dp >= 0.0) { tmp[m] = p; m++; }
        if ((dp >= 0.0) != (dq >= 0.0)) {
            tmp[m] = p + (q - p) * (dp / (dp - dq));
            m++;
        }
    }
    count = min(m, 10u);
    for (var i = 0u; i < count; i++) { poly[i] = tmp[i]; }
}

@fragment
fn fs_main(i: VsOut) -> @location(0) vec4f {
    let ix = u32(i.clip.x);
    let iy = u32(i.clip.y);
    let e = f.eye.xyz;
    let x0 = f32(ix);
    let y0 = f32(iy);
    var faces: array<vec3f, 4>;
    if (is_cartesian(f)) {
        // Screen-space cells: planes through the eye and two adjacent corner rays.
        let d00 = cell_dir(f, x0, y0);
        let d10 = cell_dir(f, x0 + 1.0, y0);
        let d11 = cell_dir(f, x0 + 1.0, y0 + 1.0);
        let d01 = cell_dir(f, x0, y0 + 1.0);
        let centre = cell_dir(f, x0 + 0.5, y0 + 0.5);
        faces = array<vec3f, 4>(cross(d00, d10), cross(d10, d11), cross(d11, d01), cross(d01, d00));
        for (var k = 0; k < 4; k++) {
            if (dot(faces[k], centre) < 0.0) { faces[k] = -faces[k]; }
        }
    } else {
        // Epipolar cells, faces in closed form (cross products of nearly parallel corner rays
        // lose their sign near the axis, which dropped whole planes of row 0 at 1024 planes).
        // With m, q the unit directions at phi_m and phi_m + 90 degrees around the axis a and
        // delta the half-width in phi: the plane faces are -+(-sin phi b1 + cos phi b2), and the
        // chord through the corner rays at gamma is normal to sin(gamma) cos(delta) a - cos(gamma) m.
        let phi0 = phi_of_plane(f, x0);
        let phi1 = phi_of_plane(f, x0 + 1.0);
        let g0 = gamma_of_ray(f, y0);
        let g1 = gamma_of_ray(f, y0 + 1.0);
        let a = f.axis.xyz;
        let b1 = f.b1.xyz;
        let b2 = f.b2.xyz;
        let pm = 0.5 * (phi0 + phi1);
        let cd = cos(0.5 * (phi1 - phi0));
        let m = b1 * cos(pm) + b2 * sin(pm);
        faces[0] = cos(g0) * m - sin(g0) * cd * a;          // gamma > gamma_0
        faces[1] = b1 * sin(phi1) - b2 * cos(phi1);         // phi < phi_1
        faces[2] = sin(g1) * cd * a - cos(g1) * m;          // gamma < gamma_1
        faces[3] = -b1 * sin(phi0) + b2 * cos(phi0);        // phi > phi_0
    }

    count = 3u;
    poly[0] = tris[3u * i.tri].xyz - e;
    poly[1] = tris[3u * i.tri + 1u].xyz - e;
    poly[2] = tris[3u * i.tri + 2u].xyz - e;
    // Ray 0 also holds the casters before the first visible ray (toward the light): its cell is
    // open on that side.
    for (var k = select(0, 1, iy == 0u); k < 4; k++) {
        let n = faces[k];
        clip_plane(n);
        if (count < 3u) { return vec4f(0.0); }
    }

    // z range of the clipped polygon.
    var zr = vec2f(1e30, -1e30);
    for (var k = 0u; k < count; k++) {
        let p = poly[k] + e;
        let q = poly[(k + 1u) % count] + e;
        var r: vec2f;
        if (is_cartesian(f)) {
            let dp = dot(p - e, f.cam_fwd.xyz);
            let dq = dot(q - e, f.cam_fwd.xyz);
            r = vec2f(min(dp, dq), max(dp, dq));
        } else if (is_point_light()) {
            let l = f.light.xyz;
            r = segment_angle_range(l, normalize(e - l), p, q);
        } else {
            r = segment_axis_distance_range(p, q);
        }
        zr = vec2f(min(zr.x, r.x), max(zr.y, r.y));
    }
    let bins = f32(f.grid.z);
    let b0 = bin_coord(f, zr.x);
    let b1 = bin_coord(f, zr.y);
    if (b1 < 0.0 || b0 >= bins) { return vec4f(0.0); }
    let k0 = u32(clamp(b0, 0.0, bins - 1.0));
    let k1 = u32(clamp(b1, 0.0, bins - 1.0));
    let base = (iy * f.grid.x + ix) * f.grid.w;
    for (var w = k0 / 32u; w <= k1 / 32u; w++) {
        let lo = max(k0, w * 32u) - w * 32u;
        let hi = min(k1, w * 32u + 31u) - w * 32u;
        let n = hi - lo + 1u;
        var mask = 0xffffffffu;
        if (n < 32u) { mask = ((1u << n) - 1u) << lo; }
        atomicOr(&grid[base + w], mask);
    }
    return vec4f(0.0);
}

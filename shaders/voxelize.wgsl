// voxelize.wgsl: marks, for every grid texel (plane x, ray y), the bins z that geometry occupies.
//
// The transform to epipolar space is non-linear, so rasterizing transformed triangles gives curved
// edges wrong and misses thin casters (no conservative rasterization on the software driver).
// Instead each triangle is drawn as its *epipolar bounding rectangle* (two quads when it straddles
// the seam at phi = 0, every plane when the eye-light axis pierces it), and every fragment tests
// the triangle exactly against its texel's cell:
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

@group(0) @binding(0) var<uniform> f: Frame;
@group(0) @binding(1) var<storage, read> tris: array<vec4f>;
@group(0) @binding(2) var<storage, read_write> grid: array<atomic<u32>>;

struct VsOut {
    @builtin(position) clip: vec4f,
    @location(0) @interpolate(flat) tri: u32,
}

// Angle at `origin` between direction c (unit) and the points of segment [p, q]: min and max,
// from the end points and the one stationary point of the segment.
fn segment_angle_range(origin: vec3f, c: vec3f, p: vec3f, q: vec3f) -> vec2f {
    let u = p - origin;
    let w = q - p;
    let a0 = angle_between(c, u);
    let a1 = angle_between(c, u + w);
    var r = vec2f(min(a0, a1), max(a0, a1));
    let uc = dot(u, c);
    let wc = dot(w, c);
    let uw = dot(u, w);
    let den = wc * uw - uc * dot(w, w);
    if (abs(den) > 1e-30) {
        let s = (uc * uw - wc * dot(u, u)) / den;
        if (s > 0.0 && s < 1.0) {
            let a = angle_between(c, u + s * w);
            r = vec2f(min(r.x, a), max(r.y, a));
        }
    }
    return r;
}

// Distance of the points of segment [p, q] from the axis line through the eye: min and max.
fn segment_axis_distance_range(p: vec3f, q: vec3f) -> vec2f {
    let a = f.axis.xyz;
    let u = p - f.eye.xyz;
    let w = q - p;
    let up = u - dot(u, a) * a;
    let wp = w - dot(w, a) * a;
    let d0 = length(up);
    let d1 = length(up + wp);
    var r = vec2f(min(d0, d1), max(d0, d1));
    let ww = dot(wp, wp);
    if (ww > 1e-30) {
        let s = -dot(up, wp) / ww;
        if (s > 0.0 && s < 1.0) {
            r.x = min(r.x, length(up + s * wp));
        }
    }
    return r;
}

// Where the line eye + s * axis crosses the triangle: s, or NaN-free sentinel 0 with hit = false.
fn axis_hit(p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    let d = f.axis.xyz;
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if (abs(det) < 1e-20) { return vec2f(0.0, 0.0); }
    let tv = f.eye.xyz - p0;
    let u = dot(tv, pv) / det;
    let qv = cross(tv, e1);
    let v = dot(d, qv) / det;
    // A small tolerance: an axis through an edge or vertex counts as a hit (both triangles of a
    // quad pierced through its diagonal), which only makes the rectangle larger.
    let eps = 1e-4;
    if (u < -eps || v < -eps || u + v > 1.0 + eps) { return vec2f(0.0, 0.0); }
    return vec2f(1.0, dot(e2, qv) / det);
}

// ---- vertex stage: the triangle's bounding rectangle in grid texels --------------------------

// Cartesian: the rectangle (x0, y0, x1, y1) of the triangle's screen projection; empty (x0 >= x1)
// when it is culled. A triangle crossing the eye's plane covers the whole screen (conservative).
fn cartesian_rect(p0: vec3f, p1: vec3f, p2: vec3f) -> vec4f {
    let e = f.eye.xyz;
    let fw = f.cam_fwd.xyz;
    let z = vec3f(dot(p0 - e, fw), dot(p1 - e, fw), dot(p2 - e, fw));
    let planes = f32(f.grid.x);
    let rays = f32(f.grid.y);
    if (all(z <= vec3f(0.0))) { return vec4f(0.0); }
    var lo = vec2f(0.0, 0.0);
    var hi = vec2f(planes, rays);
    if (all(z > vec3f(0.0))) {
        let c0 = grid_coords(f, normalize(p0 - e));
        let c1 = grid_coords(f, normalize(p1 - e));
        let c2 = grid_coords(f, normalize(p2 - e));
        lo = floor(min(c0, min(c1, c2)));
        hi = ceil(max(c0, max(c1, c2)));
    }
    // Casters beyond the screen edge on the light's side are clamped into ray 0.
    if (lo.y >= rays || lo.x >= planes || hi.x <= 0.0) { return vec4f(0.0); }
    lo = vec2f(max(lo.x, 0.0), clamp(lo.y, 0.0, rays - 1.0));
    hi = vec2f(min(hi.x, planes), clamp(hi.y, lo.y + 1.0, rays));
    return vec4f(lo, hi);
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> VsOut {
    var o: VsOut;
    let tri = vi / 12u;
    let corner = vi % 12u;
    let quad = corner / 6u;
    o.tri = tri;
    o.clip = vec4f(2.0, 2.0, 0.0, 1.0); // culled unless set below

    let p0 = tris[3u * tri].xyz;
    let p1 = tris[3u * tri + 1u].xyz;
    let p2 = tris[3u * tri + 2u].xyz;
    let e = f.eye.xyz;
    let a = f.axis.xyz;
    if (is_cartesian(f)) {
        if (quad == 1u) { return o; }
        let r = cartesian_rect(p0, p1, p2);
        if (r.x >= r.z) { return o; }
        let k = corner % 6u;
        let cx = select(r.x, r.z, k == 1u || k == 4u || k == 5u);
        let cy = select(r.y, r.w, k == 2u || k == 3u || k == 5u);
        o.clip = vec4f(cx / f32(f.grid.x) * 2.0 - 1.0, 1.0 - cy / f32(f.grid.y) * 2.0, 0.0, 1.0);
        return o;
    }

    // gamma range: edges, plus the axis piercing the triangle.
    var g = segment_angle_range(e, a, p0, p1);
    let g12 = segment_angle_range(e, a, p1, p2);
    let g20 = segment_angle_range(e, a, p2, p0);
    g = vec2f(min(g.x, min(g12.x, g20.x)), max(g.y, max(g12.y, g20.y)));
    let hit = axis_hit(p0, p1, p2);
    var full_phi = false;
    if (hit.x > 0.5) {
        full_phi = true;
        if (hit.y > 0.0) { g.x = 0.0; } else { g.y = PI; }
    }

    // Rows: clamp casters before the first visible ray into row 0; cull those after the last.
    let rays = f32(f.grid.y);
    var y0 = floor(ray_coord(f, g.x));
    var y1 = ceil(ray_coord(f, g.y));
    if (y0 >= rays) { return o; }
    y0 = clamp(y0, 0.0, rays - 1.0);
    y1 = clamp(y1, y0 + 1.0, rays);

    // Planes: the smallest arc holding the three vertex angles (the triangle subtends < pi around
    // the axis unless the axis pierces it).
    let planes = f32(f.grid.x);
    var x0 = 0.0;
    var x1 = planes;
    var second = false; // a second rectangle for the part past the seam
    var sx0 = 0.0;
    var sx1 = 0.0;
    if (!full_phi) {
        // (the arc test below assumes the triangle subtends less than pi around the axis)
        var ph = array<f32, 3>(phi_of_dir(f, p0 - e), phi_of_dir(f, p1 - e), phi_of_dir(f, p2 - e));
        // sort
        if (ph[0] > ph[1]) { let t = ph[0]; ph[0] = ph[1]; ph[1] = t; }
        if (ph[1] > ph[2]) { let t = ph[1]; ph[1] = ph[2]; ph[2] = t; }
        if (ph[0] > ph[1]) { let t = ph[0]; ph[0] = ph[1]; ph[1] = t; }
        let gaps = vec3f(ph[1] - ph[0], ph[2] - ph[1], TAU - ph[2] + ph[0]);
        var start = ph[1];
        var len = TAU - gaps.x;
        if (gaps.y >= gaps.x && gaps.y >= gaps.z) { start = ph[2]; len = TAU - gaps.y; }
        if (gaps.z >= gaps.x && gaps.z >= gaps.y) { start = ph[0]; len = TAU - gaps.z; }
        if (len > PI - 1e-3) { full_phi = true; }
        let span = f.b2.w;
        // Arc relative to the first plane, in plane units.
        var u0 = start - f.b1.w;
        u0 = u0 - floor(u0 / TAU) * TAU;
        let scale = planes / span;
        if ((f.image.w & FLAG_PHI_WRAPS) != 0u) {
            x0 = floor(u0 * scale);
            x1 = ceil((u0 + len) * scale);
            if (x1 > planes) {
                second = true;
                sx0 = 0.0;
                sx1 = x1 - planes;
                x1 = planes;
            }
        } else {
            var lo = u0;
            var hi = u0 + len;
            if (hi > TAU) { lo -= TAU; hi -= TAU; } // the arc crosses the wedge's start
            if (lo > span || hi < 0.0) { return o; }
            x0 = floor(clamp(lo, 0.0, span) * scale);
            x1 = max(ceil(clamp(hi, 0.0, span) * scale), x0 + 1.0);
            x1 = min(x1, planes);
        }
    }
    if (full_phi) {
        x0 = 0.0;
        x1 = planes;
        second = false;
    }
    if (quad == 1u) {
        if (!second) { return o; }
        x0 = sx0;
        x1 = sx1;
    }
    let k = corner % 6u;
    let cx = select(x0, x1, k == 1u || k == 4u || k == 5u);
    let cy = select(y0, y1, k == 2u || k == 3u || k == 5u);
    o.clip = vec4f(cx / planes * 2.0 - 1.0, 1.0 - cy / rays * 2.0, 0.0, 1.0);
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
    let d00 = cell_dir(f, x0, y0);
    let d10 = cell_dir(f, x0 + 1.0, y0);
    let d11 = cell_dir(f, x0 + 1.0, y0 + 1.0);
    let d01 = cell_dir(f, x0, y0 + 1.0);
    let centre = cell_dir(f, x0 + 0.5, y0 + 0.5);

    count = 3u;
    poly[0] = tris[3u * i.tri].xyz - e;
    poly[1] = tris[3u * i.tri + 1u].xyz - e;
    poly[2] = tris[3u * i.tri + 2u].xyz - e;
    var faces = array<vec3f, 4>(cross(d00, d10), cross(d10, d11), cross(d11, d01), cross(d01, d00));
    // Ray 0 also holds the casters before the first visible ray (toward the light): its cell is
    // open on that side.
    for (var k = select(0, 1, iy == 0u); k < 4; k++) {
        var n = faces[k];
        if (dot(n, centre) < 0.0) { n = -n; }
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
        } else if (is_point_light(f)) {
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

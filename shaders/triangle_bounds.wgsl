// triangle_bounds.wgsl: where a triangle lies in the grid (its planes, rays and bins), for the Cull pass.
//
// The importing file declares `f: Frame` and `tris: array<vec4f>` (three world vertices per
// triangle). psi (at a point light) over a segment is extremal at its ends or at one stationary
// point (closed form below); over a triangle, on its edges unless the axis pierces it (where
// Voxelize's items hold whole rays, from the triangle's bounding ball instead). gamma (at
// the eye, from the axis) only culls, and comes from the triangle's bounding ball: within
// asin(radius / distance) of its centre's. Every angle here is a bound with a margin, so they
// come from atan2_approx (common.wgsl, 1.7e-6 rad), which took a tenth off Cull at a million
// triangles on llvmpipe (session 31): the margins below cover it.

// The angle between directions a and b, and phi of direction v (common.wgsl's, from atan2_approx).
fn bound_angle(a: vec3f, b: vec3f) -> f32 {
    return atan2_approx(length(cross(a, b)), dot(a, b));
}

fn bound_phi(v: vec3f) -> f32 {
    var p = atan2_approx(dot(v, f.b2.xyz), dot(v, f.b1.xyz));
    if (p < 0.0) { p += TAU; }
    return p;
}

// Angle at `origin` between direction c (unit) and the points of segment [p, q], given the end
// points' angles ap and aq: min and max, from the ends and the segment's one stationary point.
fn segment_angle_range(origin: vec3f, c: vec3f, p: vec3f, q: vec3f, ap: f32, aq: f32) -> vec2f {
    let u = p - origin;
    let w = q - p;
    var r = vec2f(min(ap, aq), max(ap, aq));
    let uc = dot(u, c);
    let wc = dot(w, c);
    let uw = dot(u, w);
    let den = wc * uw - uc * dot(w, w);
    if (abs(den) > 1e-30) {
        let s = (uc * uw - wc * dot(u, u)) / den;
        if (s > 0.0 && s < 1.0) {
            let a = bound_angle(c, u + s * w);
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

// Where the line origin + s * d crosses the triangle: (1, s) on a hit, (0, 0) otherwise. A small
// tolerance: a line through an edge or vertex counts as a hit (both triangles of a quad pierced
// through its diagonal), which only makes ranges larger.
fn line_hit(origin: vec3f, d: vec3f, p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if (abs(det) < 1e-20) { return vec2f(0.0, 0.0); }
    let tv = origin - p0;
    let u = dot(tv, pv) / det;
    let qv = cross(tv, e1);
    let v = dot(d, qv) / det;
    let eps = 1e-4;
    if (u < -eps || v < -eps || u + v > 1.0 + eps) { return vec2f(0.0, 0.0); }
    return vec2f(1.0, dot(e2, qv) / det);
}

// Where the eye-light axis crosses the triangle.
fn axis_hit(p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    return line_hit(f.eye.xyz, f.axis.xyz, p0, p1, p2);
}

// ---- angle ranges from a bounding ball ---------------------------------------------------------

// A ball holding the triangle: centre the vertices' mean, radius the farthest vertex's distance
// (xyz, w), rounded up so that f32 never puts a vertex outside.
fn bounding_ball(p0: vec3f, p1: vec3f, p2: vec3f) -> vec4f {
    let c = (p0 + p1 + p2) / 3.0;
    let r = sqrt(max(dot(p0 - c, p0 - c), max(dot(p1 - c, p1 - c), dot(p2 - c, p2 - c))));
    return vec4f(c, r * (1.0 + 1e-5) + 1e-7 * length(c));
}

// The angle between direction `dir` (unit) and the points of a ball of radius r at offset `u`
// from the angle's origin: within asin(r / |u|) of the centre's, clamped to [0, pi]; every angle
// when the ball holds the origin. ANGLE_MARGIN covers atan2_approx's error and the f32 rounding
// of it and asin.
fn ball_angle_range(u: vec3f, dir: vec3f, r: f32) -> vec2f {
    let d = length(u);
    let centre = bound_angle(dir, u);
    let half = select(asin(min(r / d, 1.0)) + ANGLE_MARGIN, PI, r >= d * (1.0 - 1e-6));
    return vec2f(max(centre - half, 0.0), min(centre + half, PI));
}

// ---- a triangle's bounding rectangle in grid texels -------------------------------------------

// Planes' margin around a triangle's arc, in planes: f32 puts an arc's end (atan2 of a vertex,
// less the first plane's angle, times planes / span) within ~1e-3 plane of its true value at 8192
// planes over the full circle. Plus ANGLE_MARGIN in radians (atan2_approx's 1.7e-6 and f32's
// rounding of it), which is more than a plane where the planes span a narrow wedge.
const PLANE_MARGIN: f32 = 0.015625;
const ANGLE_MARGIN: f32 = 4e-6;

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

// The triangle's bounding rectangles in grid texels (x0, y0, x1, y1); an empty one has x0 >= x1.
// The second holds the part past the seam at phi = 0.
struct Rects {
    a: vec4f,
    b: vec4f,
}

fn triangle_rects(p0: vec3f, p1: vec3f, p2: vec3f) -> Rects {
    var o = Rects(vec4f(0.0), vec4f(0.0));
    let e = f.eye.xyz;
    let a = f.axis.xyz;
    if (is_cartesian()) {
        o.a = cartesian_rect(p0, p1, p2);
        return o;
    }

    // gamma range. gamma only culls (rows past the last visible ray), so every triangle takes its
    // bounding ball's, from one angle instead of the edges' six to nine: a CPU adapter runs both
    // sides of a branch, so an exact fallback for large triangles would cost as much as it saves.
    let ball = bounding_ball(p0, p1, p2);
    var g = ball_angle_range(ball.xyz - e, a, ball.w);
    // Where the axis pierces the triangle, every plane holds a part of it (its gamma, 0 or pi,
    // is already in the ball's range).
    var full_phi = axis_hit(p0, p1, p2).x > 0.5;

    // Rows: clamp casters before the first visible ray into row 0; cull those after the last.
    let rays = f32(f.grid.y);
    var y0 = floor(ray_coord(f, g.x));
    var y1 = ceil(ray_coord(f, g.y));
    if (y0 >= rays) { return o; } // past the last visible ray: no visible point behind it
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
        let ph = sort3(vec3f(bound_phi(p0 - e), bound_phi(p1 - e), bound_phi(p2 - e)));
        let gaps = vec3f(ph.y - ph.x, ph.z - ph.y, TAU - ph.z + ph.x);
        var start = ph.y;
        var len = TAU - gaps.x;
        if (gaps.y >= gaps.x && gaps.y >= gaps.z) { start = ph.z; len = TAU - gaps.y; }
        if (gaps.z >= gaps.x && gaps.z >= gaps.y) { start = ph.x; len = TAU - gaps.z; }
        if (len > PI - 1e-3) { full_phi = true; }
        let span = f.b2.w;
        // Arc relative to the first plane, in plane units.
        var u0 = start - f.b1.w;
        u0 = u0 - floor(u0 / TAU) * TAU;
        let scale = planes / span;
        let margin = PLANE_MARGIN + ANGLE_MARGIN * scale;
        // Planes are samples at their centres (x + 1/2 in plane units): the ones the arc holds,
        // widened by the margin for f32 (the arc's ends come from atan2 of the vertices, the
        // voxelizer's test from the plane's own normal). None when the arc lies between two
        // centres. Taking every cell the arc touched gave Voxelize 3.5% more items on the
        // classroom and 47% more on the bunny, none of which could cut the triangle (session 12).
        if ((f.image.w & FLAG_PHI_WRAPS) != 0u) {
            x0 = ceil(u0 * scale - 0.5 - margin);
            x1 = floor((u0 + len) * scale - 0.5 + margin) + 1.0;
            if (x1 > planes) {
                second = true;
                sx0 = 0.0;
                sx1 = x1 - planes;
                x1 = planes;
                // Only centres past the seam: they are the first rectangle.
                if (x0 >= x1) {
                    x0 = sx0;
                    x1 = sx1;
                    second = false;
                }
            }
        } else {
            var lo = u0;
            var hi = u0 + len;
            if (hi > TAU) { lo -= TAU; hi -= TAU; } // the arc crosses the wedge's start
            // Outside the visible wedge, or between two centres: x0 >= x1, culled.
            x0 = max(ceil(lo * scale - 0.5 - margin), 0.0);
            x1 = min(floor(hi * scale - 0.5 + margin) + 1.0, planes);
        }
    }
    if (full_phi) {
        x0 = 0.0;
        x1 = planes;
        second = false;
    }
    o.a = vec4f(x0, y0, x1, y1);
    if (second) { o.b = vec4f(sx0, y0, sx1, y1); }
    return o;
}

// z range (psi, r or view depth) a triangle occupies: its edges' extremes, plus 0 (or pi) where
// the light's axis pierces it.
fn triangle_z_range(p0: vec3f, p1: vec3f, p2: vec3f) -> vec2f {
    let e = f.eye.xyz;
    if (is_cartesian()) {
        let fw = f.cam_fwd.xyz;
        let z = vec3f(dot(p0 - e, fw), dot(p1 - e, fw), dot(p2 - e, fw));
        return vec2f(min(z.x, min(z.y, z.z)), max(z.x, max(z.y, z.z)));
    }
    if (is_point_light()) {
        let l = f.light.xyz;
        let c = normalize(e - l);
        // Where each Voxelize item holds all of a ray's words (WHOLE_RAY_ITEMS, a CPU adapter's
        // list), a wider range costs no item, and Voxelize clips each plane's bins to its own
        // segment: the bounding ball's cone gives the range from one angle and an arcsine instead
        // of the edges' six angles, which were half of Cull's time per triangle on llvmpipe (the
        // million-triangle room's Cull ~3 ms lower, session 42; the same bits).
        if (WHOLE_RAY_ITEMS) {
            let ball = bounding_ball(p0, p1, p2);
            return ball_angle_range(ball.xyz - l, c, ball.w);
        }
        // Otherwise exact, not the ball's (as gamma is): psi sets the words of bins, one item
        // each, and a large triangle's ball would give it many more (+35% Voxelize on the
        // built-in room). Each vertex's angle is computed once for its two edges.
        let a0 = bound_angle(c, p0 - l);
        let a1 = bound_angle(c, p1 - l);
        let a2 = bound_angle(c, p2 - l);
        let r0 = segment_angle_range(l, c, p0, p1, a0, a1);
        let r1 = segment_angle_range(l, c, p1, p2, a1, a2);
        let r2 = segment_angle_range(l, c, p2, p0, a2, a0);
        var r = vec2f(min(r0.x, min(r1.x, r2.x)), max(r0.y, max(r1.y, r2.y)));
        let hit = line_hit(l, c, p0, p1, p2);
        if (hit.x > 0.5) {
            if (hit.y > 0.0) { r.x = 0.0; } else { r.y = PI; }
        }
        // The angles' margin (atan2_approx): the bins' own quarter-bin margin (Cull's word_range)
        // is less than it where many bins span a narrow range of psi.
        return r + vec2f(-ANGLE_MARGIN, ANGLE_MARGIN);
    }
    let r0 = segment_axis_distance_range(p0, p1);
    let r1 = segment_axis_distance_range(p1, p2);
    let r2 = segment_axis_distance_range(p2, p0);
    var r = vec2f(min(r0.x, min(r1.x, r2.x)), max(r0.y, max(r1.y, r2.y)));
    if (axis_hit(p0, p1, p2).x > 0.5) { r.x = 0.0; }
    return r;
}


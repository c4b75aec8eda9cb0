// integrate.wgsl: per-pixel single scattering from the shadow volume.
//
// For the pixel's view ray (plane phi, angle gamma, surface at t_s) the lit part of the ray is
// [0, t_s] minus the shadowed bins of the ray's bit words. We walk the *runs* of set bits only, so
// the cost grows with the number of shadow boundaries, not with the number of bins:
//
//   point light:  L = sigma_s I0 / h * (G(psi_s) - sum_runs [G(psi_b) - G(psi_a)])      (scatter_table.wgsl)
//   directional:  L = sigma_s E0 p(cos gamma) * (I(t_0, t_1) - sum_runs I(t_a, t_b)),
//                 I(a, b) = integral_a^b exp(-sigma_t (l(t) + m(t))) dt in closed form: l (path
//                 to the light inside the medium box) and m (view path inside the box) are
//                 piecewise linear in t, so each piece is exp(-sigma_t g_min) * len * (1 - e^-x) / x.
//
// The four grid rays around the pixel's (plane, ray) coordinate are evaluated with the pixel's own
// gamma and t_s and blended bilinearly, which hides the grid's rays and planes.

#import common

@group(0) @binding(0) var<uniform> f: Frame;
@group(0) @binding(1) var<storage, read> grid: array<u32>;
@group(0) @binding(2) var<storage, read> table: array<vec4f>;
@group(0) @binding(3) var distance: texture_2d<f32>;
@group(0) @binding(4) var scatter_out: texture_storage_2d<rgba32float, write>;

// ---- point light ---------------------------------------------------------------------------

fn table_row(row: u32, u: f32) -> vec3f {
    let cols = f.table.y;
    let c = u * f32(cols);
    let c0 = min(u32(c), cols - 1u);
    let base = row * (cols + 1u);
    return mix(table[base + c0].xyz, table[base + c0 + 1u].xyz, c - f32(c0));
}

// G(gamma, psi) / (pi - gamma): bilinear in (gamma, u = psi / (pi - gamma)) between the two table
// rows around gamma. Interpolating at equal u (the same fraction of each row's extent) keeps rays
// near gamma = pi, whose extent collapses, as accurate as the others. The rows are quadratic in
// gamma (scatter_table.wgsl); the weight between them is linear in gamma itself, which keeps G
// linear toward a soft light (G ~ h there: G / h stays finite, as it must).
fn table_g(gamma: f32, psi: f32) -> vec3f {
    let rows = f.table.x;
    let q = clamp((gamma - f.ranges.x) / (f.ranges.y - f.ranges.x), 0.0, 1.0);
    let gy = sqrt(q) * f32(rows - 1u);
    let r0 = min(u32(gy), rows - 2u);
    let s0 = f32(r0) / f32(rows - 1u);
    let s1 = f32(r0 + 1u) / f32(rows - 1u);
    let wy = clamp((q - s0 * s0) / (s1 * s1 - s0 * s0), 0.0, 1.0);
    let u = clamp(psi / max(PI - gamma, 1e-7), 0.0, 1.0);
    return mix(table_row(r0, u), table_row(r0 + 1u, u), wy);
}

// Unshadowed weight of [0, psi_s] minus the shadowed runs of one grid ray.
// Shadow runs are cut at psi_cut: the start of the surface's own bin when the surface faces the
// light on the eye's side (that bin is set by the surface itself), psi_s otherwise.
fn lit_point(base: u32, gamma: f32, psi_s: f32, psi_cut: f32) -> vec3f {
    var total = table_g(gamma, psi_s);
    let bins = f.grid.z;
    for (var w = 0u; w < f.grid.w; w++) {
        var bits = grid[base + w];
        loop {
            if (bits == 0u) { break; }
            let start = firstTrailingBit(bits);
            let run = countTrailingZeros(~(bits >> start));
            let k0 = w * 32u + start;
            let psi_a = z_of_bin(f, f32(k0));
            if (psi_a >= psi_cut) { return total; }
            let psi_b = min(z_of_bin(f, f32(k0 + run)), psi_cut);
            total -= table_g(gamma, psi_b) - table_g(gamma, psi_a);
            if (start + run >= 32u) { break; }
            bits = bits & ~(((1u << run) - 1u) << start);
        }
    }
    return total;
}

// ---- directional light ---------------------------------------------------------------------

// integral_a^b exp(-sigma_t (l(t) + t - t_in)) dt along ray v, with l the exit distance toward the
// light from E + t v inside the medium box; [a, b] lies inside the box span starting at t_in.
fn box_integral(v: vec3f, t_in: f32, a: f32, b: f32) -> vec3f {
    if (b <= a) { return vec3f(0.0); }
    let w = safe_dir(f.light.xyz);
    let e = f.eye.xyz;
    let bound = select(f.medium_min.xyz, f.medium_max.xyz, w > vec3f(0.0));
    // l(t) = min_i (alpha_i + beta_i t)
    let alpha = (bound - e) / w;
    let beta = -v / w;
    // Breakpoints of the minimum inside (a, b), sorted.
    var cuts = array<f32, 5>(a, b, b, b, b);
    var n = 1u;
    for (var i = 0u; i < 3u; i++) {
        for (var j = i + 1u; j < 3u; j++) {
            let den = beta[i] - beta[j];
            if (abs(den) > 1e-12) {
                let t = (alpha[j] - alpha[i]) / den;
                if (t > a && t < b) { cuts[n] = t; n++; }
            }
        }
    }
    cuts[n] = b;
    n++;
    // insertion sort of the interior cuts
    for (var i = 1u; i < n; i++) {
        var k = i;
        loop {
            if (k == 0u || cuts[k - 1u] <= cuts[k]) { break; }
            let tmp = cuts[k]; cuts[k] = cuts[k - 1u]; cuts[k - 1u] = tmp;
            k--;
        }
    }
    let sigma_t = f.sigma_t.xyz;
    var sum = vec3f(0.0);
    for (var i = 0u; i + 1u < n; i++) {
        let p0 = cuts[i];
        let p1 = cuts[i + 1u];
        if (p1 <= p0) { continue; }
        let mid = 0.5 * (p0 + p1);
        let ls = alpha + beta * mid;
        var k = 0u;
        if (ls.y < ls[k]) { k = 1u; }
        if (ls.z < ls[k]) { k = 2u; }
        let g0 = max(0.0, alpha[k] + beta[k] * p0) + p0 - t_in;
        let g1 = max(0.0, alpha[k] + beta[k] * p1) + p1 - t_in;
        let gmin = max(0.0, min(g0, g1));
        let x = sigma_t * abs(g1 - g0);
        sum += exp(-sigma_t * gmin) * (p1 - p0) * one_minus_exp_over_x(x);
    }
    return sum;
}

// z_scale converts a bin's z to distance along the view ray: t = z / z_scale (sin gamma for the
// epipolar grid, cos of the angle to the view axis for the Cartesian one).
fn lit_directional(base: u32, v: vec3f, z_scale: f32, t_in: f32, t_end: f32, t_cut: f32) -> vec3f {
    var total = box_integral(v, t_in, t_in, t_end);
    for (var w = 0u; w < f.grid.w; w++) {
        var bits = grid[base + w];
        loop {
            if (bits == 0u) { break; }
            let start = firstTrailingBit(bits);
            let run = countTrailingZeros(~(bits >> start));
            let k0 = w * 32u + start;
            let ta = max(z_of_bin(f, f32(k0)) / max(z_scale, 1e-12), t_in);
            if (ta >= t_cut) { return total; }
            let tb = min(z_of_bin(f, f32(k0 + run)) / max(z_scale, 1e-12), t_cut);
            total -= box_integral(v, t_in, ta, tb);
            if (start + run >= 32u) { break; }
            bits = bits & ~(((1u << run) - 1u) << start);
        }
    }
    return total;
}

// ---- per pixel -----------------------------------------------------------------------------

fn ray_base(x: u32, y: u32) -> u32 {
    return (y * f.grid.x + x) * f.grid.w;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    if ((f.image.w & FLAG_NO_SCATTER) != 0u) {
        textureStore(scatter_out, vec2i(id.xy), vec4f(0.0, 0.0, 0.0, 1.0));
        return;
    }
    let v = pixel_dir(f, vec2f(id.xy));
    let a = f.axis.xyz;
    let gamma = angle_between(a, v);
    let gc = grid_coords(f, v);
    let surface = textureLoad(distance, vec2i(id.xy), 0).xy;
    let t_s = surface.x;
    let facing = t_s >= 0.0 && surface.y > 0.5;

    // The four grid rays around the pixel and their bilinear weights.
    let planes = f.grid.x;
    let rays = f.grid.y;
    // Planes blend around their centres. Rays blend from the pixel's own row toward the *next*
    // one only: a row's bits hold every caster up to its end (inclusive scan), the previous row's
    // may not yet hold a caster that lies just before the pixel, so blending backward would leak
    // light through closed surfaces. Forward blending can only over-shadow, by under one row.
    let xf = gc.x - 0.5;
    let yf = clamp(gc.y, 0.0, f32(rays - 1u));
    let x0f = floor(xf);
    let fx = xf - x0f;
    var x0: i32 = i32(x0f);
    var x1: i32 = x0 + 1;
    if ((f.image.w & FLAG_PHI_WRAPS) != 0u) {
        x0 = (x0 + i32(planes)) % i32(planes);
        x1 = x1 % i32(planes);
    } else {
        x0 = clamp(x0, 0, i32(planes) - 1);
        x1 = clamp(x1, 0, i32(planes) - 1);
    }
    let y0 = min(u32(yf), rays - 1u);
    let y1 = min(y0 + 1u, rays - 1u);
    let fy = yf - f32(y0);
    let weights = vec4f((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy), (1.0 - fx) * fy, fx * fy);
    let bases = vec4u(ray_base(u32(x0), y0), ray_base(u32(x1), y0), ray_base(u32(x0), y1), ray_base(u32(x1), y1));

    var l = vec3f(0.0);
    if (is_point_light()) {
        // Within 1e-6 rad of the light the f32 angle is noise (~6e-8), so the point-light formulas use
        // gp = max(gamma, 1e-6). For a soft light (r > 0) the table's G and h = D sin(gamma) both
        // vanish linearly toward the light and their ratio keeps its finite limit; with the raw angle
        // the 1e-7 D clamp of h below cut the pixel through the light by gamma / 1e-7, a random factor
        // (numerical-stability fix, docs/stability.md, light/through-pixel-*).
        let gp = max(gamma, 1e-6);
        var psi_s = PI - gp;
        if (t_s >= 0.0) { psi_s = min(z_along(f, gp, t_s), psi_s); }
        var psi_cut = psi_s;
        if (facing) { psi_cut = min(psi_s, z_of_bin(f, floor(bin_coord(f, psi_s)))); }
        var lit = vec3f(0.0);
        for (var k = 0; k < 4; k++) {
            if (weights[k] > 0.0) { lit += weights[k] * lit_point(bases[k], gp, psi_s, psi_cut); }
        }
        // The table holds G / (pi - gamma); the ray's weight is (pi - gamma) / h with h = D sin(gamma).
        // Written as x / sin(x) (x = pi - gamma) it stays finite looking straight away from the light.
        let x = PI - gp;
        var ratio = 1.0 / f.axis.w;
        if (x > 1e-4) { ratio = x / max(f.axis.w * sin(gp), 1e-7 * f.axis.w); }
        // The table has exp(-sigma_t D) factored out; it joins the log of the prefactor in one exp,
        // so a bright light in a thick medium (sigma_t D > 87) is not flushed to 0 with exp(-sigma_t D)
        // (numerical-stability fix, docs/stability.md, medium/thick-bright).
        let pre = f.sigma_s.xyz * f.light_power.xyz * ratio;
        let scale = exp(log(max(pre, vec3f(1e-38))) - f.sigma_t.xyz * f.axis.w);
        l = select(vec3f(0.0), scale, pre > vec3f(0.0)) * max(lit, vec3f(0.0));
    } else {
        let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
        var t_end = span.y;
        if (t_s >= 0.0) { t_end = min(t_end, t_s); }
        if (t_end > span.x) {
            var lit = vec3f(0.0);
            var z_scale = sin(gamma);
            if (is_cartesian(f)) { z_scale = dot(v, f.cam_fwd.xyz); }
            var t_cut = t_end;
            if (facing && t_s <= t_end) {
                let z_cut = z_of_bin(f, floor(bin_coord(f, t_s * z_scale)));
                t_cut = clamp(z_cut / max(z_scale, 1e-12), span.x, t_end);
            }
            for (var k = 0; k < 4; k++) {
                if (weights[k] > 0.0) { lit += weights[k] * lit_directional(bases[k], v, z_scale, span.x, t_end, t_cut); }
            }
            // The deflection angle is gamma: the phase of the angle keeps the lobes' peaks exact.
            let ph = phase_of_angle(f.sigma_s.w, gamma);
            l = f.sigma_s.xyz * f.light_power.xyz * ph * max(lit, vec3f(0.0));
        }
    }
    textureStore(scatter_out, vec2i(id.xy), vec4f(l, 1.0));
}

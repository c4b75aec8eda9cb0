// scatter_table.wgsl: the cumulative unshadowed in-scattering along view rays, for a point light.
//
// With dt / d^2 = dpsi / h (h = D sin gamma), the in-scattering of a lit stretch [psi_a, psi_b] of a
// view ray at angle gamma is  sigma_s I0 / h * (G(gamma, psi_b) - G(gamma, psi_a)),  where
//
//   G(gamma, psi) = integral_0^psi p(cos(gamma + psi')) exp(-sigma_t (t + d)) h^2 / (h^2 + r^2 sin^2(gamma + psi')) dpsi'
//   t + d = D (sin psi' + sin gamma) / sin(gamma + psi')
//
// (the last factor is the light's softening radius r: 1/d^2 -> 1/(d^2 + r^2)). The exponent is one
// number, never a product of exponentials, so thick media neither overflow nor underflow early.
// The table holds G with exp(-sigma_t D) factored out (t + d >= D on every path): the integrate pass
// folds it into one exp with the log of the prefactor, so the result survives sigma_t D > 87, where
// exp(-sigma_t D) alone is below f32's range (docs/stability.md, medium/thick-bright).
// Row j holds gamma_j = gamma_lo + (j / (rows - 1))^2 * (gamma_hi - gamma_lo): quadratic, so the
// rows near gamma_lo (the light's own direction when it is on screen) are rows^2 / 2 times finer
// there than uniform rows, where G changes fastest: the lobe of |g| -> 1 (width 1 - |g|) and a soft
// light's core (width r / D); integrate.wgsl interpolates linearly in gamma between them
// (numerical-stability fix, docs/stability.md, phase/hg-0.999, light/through-pixel-*). Column c holds
// psi = c / cols * (pi - gamma_j) and stores G / (pi - gamma_j). Each cell is integrated with
// 4-point Gauss-Legendre.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
@group(0) @binding(1) var<storage, read_write> table: array<vec4f>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

fn integrand(gamma: f32, psi: f32, h2: f32) -> vec3f {
    let s = sin_rel(gamma + psi);
    // t + d - D = D (sin psi + sin gamma - sin(gamma + psi)) / sin(gamma + psi), with the numerator
    // as 2 sin psi sin^2(gamma/2) + 2 sin gamma sin^2(psi/2): non-negative terms, no cancellation.
    let sg = sin(0.5 * gamma);
    let sp = sin(0.5 * psi);
    let k = 2.0 * f.axis.w * (sin(psi) * sg * sg + sin(gamma) * sp * sp) / max(s, 1e-30);
    let sigma_t = f.sigma_t.xyz;
    let expo = select(sigma_t * k, vec3f(0.0), sigma_t == vec3f(0.0));
    let r = f.light_power.w;
    var soft = 1.0;
    if (r > 0.0) { soft = h2 / (h2 + r * r * s * s); }
    // The deflection angle is gamma + psi: the phase of the angle keeps the lobes' peaks exact.
    return phase_of_angle(f.sigma_s.w, gamma + psi) * exp(-expo) * soft;
}

// One workgroup per row, THREADS threads: each integrates its run of cells and their running sum,
// then adds the sum of the runs before its own (the row's prefix sum in two steps). One thread per
// row walking all 512 cells took 0.37 ms on an H200 (4 workgroups for its 132 processors, docs/results.md).
const THREADS: u32 = 64u;
var<workgroup> run_sums: array<vec3f, THREADS>;

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) t: u32) {
    f = frame_in;
    let rows = f.table.x;
    let cols = f.table.y;
    // (The dispatch holds exactly `rows` workgroups: j is in range, and the barrier below uniform.)
    let j = wg.x;
    let sj = f32(j) / f32(rows - 1u);
    let gamma = f.ranges.x + sj * sj * (f.ranges.y - f.ranges.x);
    let h = f.axis.w * sin_rel(gamma);
    let h2 = h * h;
    let width = (PI - gamma) / f32(cols);
    // Gauss-Legendre nodes and weights on [0, 1].
    let x = array<f32, 4>(0.0694318442, 0.3300094782, 0.6699905218, 0.9305681558);
    let w = array<f32, 4>(0.1739274226, 0.3260725774, 0.3260725774, 0.1739274226);
    let base = j * (cols + 1u);
    let per = (cols + THREADS - 1u) / THREADS;
    let c0 = min(t * per, cols);
    let c1 = min(c0 + per, cols);
    var acc = vec3f(0.0);
    for (var c = c0; c < c1; c++) {
        let a = f32(c) * width;
        var cell = vec3f(0.0);
        for (var q = 0; q < 4; q++) {
            cell += w[q] * integrand(gamma, a + x[q] * width, h2);
        }
        // Stored divided by the ray's psi extent (pi - gamma): G / (pi - gamma) varies slowly with
        // gamma even where the extent collapses (gamma -> pi, light behind the camera), so
        // interpolating it between rows stays accurate.
        acc += cell / f32(cols);
        table[base + c + 1u] = vec4f(acc, 0.0);
    }
    run_sums[t] = acc;
    workgroupBarrier();
    var carry = vec3f(0.0);
    for (var k = 0u; k < t; k++) {
        carry += run_sums[k];
    }
    for (var c = c0; c < c1; c++) {
        table[base + c + 1u] += vec4f(carry, 0.0);
    }
    if (t == 0u) { table[base] = vec4f(0.0); }
}

// integrate.wgsl: per-pixel single scattering from the shadow volume.
//
// A pixel's view ray (plane phi, angle gamma, surface at t_s) runs over [z_start, z_end] in z (psi
// at a point light, r = t sin(gamma) for a directional one). With U(z) the cumulative unshadowed
// in-scattering along the ray,
//
//   point light:  U(psi) = sigma_s I0 / h * G(gamma, psi)                    (scatter_table.wgsl)
//   directional:  U(r)   = sigma_s E0 p(gamma) * integral_{t_in}^{r / sin gamma} exp(-sigma_t (l(t) + t - t_in)) dt
//
// (l: the path toward the light inside the medium's box; piecewise linear in t, so U is a sum of
// closed-form pieces built once per pixel; U(z_start) = 0), the lit part is
//
//   L = sum_j q_j (C(z_{j+1}) - C(z_j)) = C(z_end) + sum_j C(z_j) (q_{j-1} - q_j),   C(z) = U(clamp(z, z_start, z_end)),
//
// over the bins and the stretches before and after them, which no caster reaches (q_{-1} = q_B =
// 1). q_j in [0, 1] is bin j's lit fraction, blended linearly between the two planes around the
// pixel's angle (hiding the planes) on the pixel's own ray cell. Where the ray is shadowed at
// z_end, C(z_end) cancels with the boundaries past it (all at C(z_end)); so the sum takes the
// boundaries below z_end, and C(z_end) only where the ray is lit there. The sum runs only over
// the bins where q changes: the two rays' shadow boundaries, found with bit operations on four
// 32-bit words at a time (one vec4u load where the rays start on four words, QUAD_RAYS), so empty
// and fully shadowed words cost a share of one test and the cost grows with the number of shadow
// boundaries, not with the bins. (Walking the words one by one, the loop itself was half of the
// pass on llvmpipe; four at a time took it from ~80 to ~63 ms on the classroom, docs/results.md,
// session 15.) Every term is a lit run's start or end: it sums lit light directly (never "total
// minus shadowed"), so a fully shadowed ray is exactly 0.
//
// With the first-hit volume (FIRST_HITS, the default) the words are made per pixel: bin k's bit is
// set where its light ray's first hit comes before the pixel's own angle (hit_word), from each
// word's bounds or its middle gap where they settle it; the walk over boundaries is the same.
//
// By default not every pixel is integrated: along an epipolar line a pixel whose two neighbours
// on the line agree takes their mean ("pixels from their neighbours", below).
//
// Own shadow: where the light is behind the surface at the end of the ray, the thin layer of
// medium in front of it is in that surface's shadow, but the grid's neighbouring samples (up to a
// plane and 3/4 bin from the pixel's own light rays) may meet the surface just after the pixel's
// gamma. Within one such cell of the surface the layer is taken as shadowed: for a convex closed
// surface around the light this is exact (no light leaks), elsewhere it errs by under a cell.

#import common

@group(0) @binding(0) var<storage, read> frame_in: Frame;
// Four words of bins per element (with QUAD_RAYS every ray starts on an element).
@group(0) @binding(1) var<storage, read> grid: array<vec4u>;
@group(0) @binding(2) var<storage, read> table: array<vec4f>;
@group(0) @binding(3) var distance: texture_2d<f32>;
// rgb: the scattered light; a: the surface's visibility of the light (GRID_SHADOWS), else 1.
@group(0) @binding(4) var scatter_out: texture_storage_2d<rgba32float, write>;
// Surface's (albedo, cos theta_i): the slope of the surface toward the light, for its shadow's bias.
@group(0) @binding(5) var material: texture_2d<f32>;
// Adaptive pixels (below, "pixels from their neighbours"): for each pixel others are taken from
// (pixels 0 and 2 of each strip of four), its lit sum without the light factor and its visibility;
// the two lists of pixels left to integrate (the first at 0, the second at `strips()`) and their
// lengths.
@group(0) @binding(6) var<storage, read_write> values: array<vec4f>;
@group(0) @binding(7) var<storage, read_write> refine_list: array<u32>;
@group(0) @binding(8) var<storage, read_write> refine_count: array<atomic<u32>, 2>;

// Private copies of the parameters, made at each entry point (common.wgsl, "Parameters").
var<private> f: Frame;

// ---- point light: the scatter table ----------------------------------------------------------

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

// ---- directional light: U along the view ray in closed-form pieces ---------------------------

// l(t) = min_i (alpha_i + beta_i t) is the distance from E + t v to the medium box's exit toward
// the light; between the breakpoints of the min it is linear, so on a piece starting at p the
// exponent g(t) = l(t) + t - t_in is linear too, g = g_p + k (t - p), k = dl/dt + 1 (of either
// sign: moving along a face, the exit toward a grazing light can shrink faster than t grows), and
//   integral_p^t exp(-sigma_t g) = exp(-sigma_t min(g_p, g_t)) (t - p) E(sigma_t |k| (t - p)),
// E(x) = (1 - e^-x) / x: the exponent is taken at its smaller end, so E's argument is >= 0.
// Up to four pieces in vector lanes (index i is lane i), with no private array: on llvmpipe an
// index that differs between the lanes of a SIMD group is a gather through memory, and even
// arrays indexed by constants stayed in memory while another function indexed them by a loop
// counter (the classroom's Integrate: 72 ms with arrays, 39 ms without, session 12).
struct Pieces {
    start: vec4f,
    g: vec4f,
    k: vec4f,
    cum0: vec3f,
    cum1: vec3f,
    cum2: vec3f,
    cum3: vec3f,
    // GREY_MEDIUM: exp(-sigma_t g) at each piece's start (piece_integral_grey).
    e: vec4f,
    count: u32,
}

var<private> pieces: Pieces;

// The integral over the piece starting at `start` (exponent g there, slope k) up to t, per
// channel. Every shadow boundary of every pixel evaluates it; a grey medium (GREY_MEDIUM, a
// pipeline constant) takes piece_integral_grey instead, one channel's exponential for all three.
fn piece_integral(start: f32, g: f32, k: f32, t: f32) -> vec3f {
    let len = max(t - start, 0.0);
    let g_min = max(0.0, g + min(k, 0.0) * len);
    let sigma_t = f.sigma_t.xyz;
    return exp(-sigma_t * g_min) * len * one_minus_exp_over_x(sigma_t * (abs(k) * len));
}

// piece_integral in a grey medium from exp(-sigma_t g) at the piece's start (e_start, made once per
// piece): one exponential per call, at t, instead of two. With e_lo and e_hi the exponential at
// the smaller and the larger exponent (g_min, g_min + |k| len),
//   integral = e_lo len E(x) = (e_lo - e_hi) / (sigma_t |k|),   x = sigma_t |k| len,
// the difference where x >= 1/2 (e_hi <= 0.61 e_lo: no cancellation), E's series below.
fn piece_integral_grey(start: f32, g: f32, k: f32, e_start: f32, t: f32) -> f32 {
    let s = f.sigma_t.x;
    let len = max(t - start, 0.0);
    let x = s * (abs(k) * len);
    let e_t = exp(-s * max(0.0, g + k * len));
    let e_lo = select(e_start, e_t, k < 0.0);
    let e_hi = select(e_t, e_start, k < 0.0);
    let series = e_lo * len * one_minus_exp_over_x_series1(x);
    let direct = (e_lo - e_hi) / max(s * abs(k), 1e-30);
    return select(direct, series, x < 0.5);
}

// A breakpoint of the minimum of exits i and j (alpha + beta t) when it lies inside (t_in, t_end);
// t_end otherwise, which sorts last and makes an empty piece.
fn cut(ai: f32, bi: f32, aj: f32, bj: f32, t_in: f32, t_end: f32) -> f32 {
    let den = bi - bj;
    if (abs(den) > 1e-12) {
        let t = (aj - ai) / den;
        if (t > t_in && t < t_end) { return t; }
    }
    return t_end;
}

// Exponent and slope of the piece [p0, p1]: the box face the light path leaves through at its
// middle decides (constant lane indices only).
fn piece_at(alpha: vec3f, beta: vec3f, p0: f32, p1: f32, t_in: f32) -> vec2f {
    let ls = alpha + beta * (0.5 * (p0 + p1));
    var al = alpha.x;
    var be = beta.x;
    var l = ls.x;
    if (ls.y < l) { al = alpha.y; be = beta.y; l = ls.y; }
    if (ls.z < l) { al = alpha.z; be = beta.z; }
    return vec2f(max(0.0, max(0.0, al + be * p0) + p0 - t_in), be + 1.0);
}

// Builds the pieces of [t_in, t_end] along v.
fn build_pieces(v: vec3f, t_in: f32, t_end: f32) {
    let w = safe_dir(f.light.xyz);
    let e = f.eye.xyz;
    let bound = select(f.medium_min.xyz, f.medium_max.xyz, w > vec3f(0.0));
    let alpha = (bound - e) / w;
    let beta = -v / w;
    // Breakpoints of the minimum inside (t_in, t_end), sorted; the missing ones are t_end, sort
    // last and are the only ones not below it.
    let cuts = sort3(vec3f(
        cut(alpha.x, beta.x, alpha.y, beta.y, t_in, t_end),
        cut(alpha.x, beta.x, alpha.z, beta.z, t_in, t_end),
        cut(alpha.y, beta.y, alpha.z, beta.z, t_in, t_end),
    ));
    let n = 1u + dot(vec3u(cuts < vec3f(t_end)), vec3u(1u));
    let start = vec4f(t_in, cuts);
    let end = vec4f(cuts, t_end);
    let q0 = piece_at(alpha, beta, start.x, end.x, t_in);
    let q1 = piece_at(alpha, beta, start.y, end.y, t_in);
    let q2 = piece_at(alpha, beta, start.z, end.z, t_in);
    let q3 = piece_at(alpha, beta, start.w, end.w, t_in);
    pieces.start = start;
    pieces.g = vec4f(q0.x, q1.x, q2.x, q3.x);
    pieces.k = vec4f(q0.y, q1.y, q2.y, q3.y);
    pieces.cum0 = vec3f(0.0);
    if (GREY_MEDIUM) {
        let e = exp(-f.sigma_t.x * max(vec4f(0.0), pieces.g));
        pieces.e = e;
        pieces.cum1 = vec3f(piece_integral_grey(start.x, q0.x, q0.y, e.x, end.x));
        pieces.cum2 = pieces.cum1 + piece_integral_grey(start.y, q1.x, q1.y, e.y, end.y);
        pieces.cum3 = pieces.cum2 + piece_integral_grey(start.z, q2.x, q2.y, e.z, end.z);
    } else {
        pieces.cum1 = piece_integral(start.x, q0.x, q0.y, end.x);
        pieces.cum2 = pieces.cum1 + piece_integral(start.y, q1.x, q1.y, end.y);
        pieces.cum3 = pieces.cum2 + piece_integral(start.z, q2.x, q2.y, end.z);
    }
    pieces.count = n;
}

// integral_{t_in}^{t} (t inside [t_in, t_end]): the last piece that starts at or before t.
fn along(t: f32) -> vec3f {
    var start = pieces.start.x;
    var g = pieces.g.x;
    var k = pieces.k.x;
    var e = pieces.e.x;
    var cum = pieces.cum0;
    if (pieces.count > 1u && t >= pieces.start.y) {
        start = pieces.start.y;
        g = pieces.g.y;
        k = pieces.k.y;
        e = pieces.e.y;
        cum = pieces.cum1;
    }
    if (pieces.count > 2u && t >= pieces.start.z) {
        start = pieces.start.z;
        g = pieces.g.z;
        k = pieces.k.z;
        e = pieces.e.z;
        cum = pieces.cum2;
    }
    if (pieces.count > 3u && t >= pieces.start.w) {
        start = pieces.start.w;
        g = pieces.g.w;
        k = pieces.k.w;
        e = pieces.e.w;
        cum = pieces.cum3;
    }
    if (GREY_MEDIUM) { return cum + piece_integral_grey(start, g, k, e, t); }
    return cum + piece_integral(start, g, k, t);
}

// ---- both: U at a bin boundary --------------------------------------------------------------

struct Ray {
    gamma: f32,
    // The view ray's extent in z: from the eye (or the medium's box) to the surface.
    z_start: f32,
    z_end: f32,
    // Directional: t = z / z_scale, and 1 / z_scale (every shadow boundary converts a z to t:
    // a product, not a division, which llvmpipe runs in full for a SIMD group, session 31).
    z_scale: f32,
    t_per_z: f32,
}

fn cumulative(r: Ray, z: f32) -> vec3f {
    let zc = clamp(z, r.z_start, r.z_end);
    if (is_point_light()) { return table_g(r.gamma, zc); }
    return along(zc * r.t_per_z);
}

// The lit part of the view ray on one plane's grid ray at `base` (the caller weights the plane):
// sum_j C(z_j) (q_{j-1} - q_j), q_j = 1 where bin j is lit, summed over the bins where q changes,
// and C(z_end) where the ray is still lit at z_end. Outside the bins' range the ray is lit (no
// caster reaches there): q = 1 before the first bin and after the last. Bin j of the plane spans
// [z(j + offset), z(j + 1 + offset)] around its sample (bin_offset), the first and the last
// extended to z(-1/4) and z(B + 1/4). Every term is a lit run's end or start: the lit light is
// summed directly, never "total minus shadowed", so a ray shadowed all along is exactly 0, and
// one lit all along is exactly C(z_end) with no boundary walked: one pass over the words, with no
// test for an all-lit ray ahead of it (which read every word twice, session 32).
fn lit_plane(r: Ray, base: u32, offset: f32, last: u32, c_end: vec3f) -> vec3f {
    var sum = vec3f(0.0);
    // The boundaries at or below z_start (C = U(z_start) = 0) are skipped: n of them, bin j's at
    // z(j + offset) and bin 0's at z(-1/4) (below). carry is the bit before boundary n (a clear
    // bit before bin 0: lit), read where n starts a word (within a word the shift below sees it).
    let bc = bin_coord(f, r.z_start);
    let n = select(0u, 1u + u32(clamp(floor(bc - offset), 0.0, f32(f.grid.z - 1u))), bc >= -0.25);
    let first = n / 32u;
    var carry = 0u;
    // A loop of 1 or 0 steps, not an if: llvmpipe runs an if's body for every lane (masked), and
    // a word read outside the walk costs several per-lane loads (hit_word).
    for (var k = 0u; k < select(0u, 1u, n > 0u && n % 32u == 0u); k++) { carry = word(base + first - 1u) >> 31u; }
    let skipped = ~0u << (n % 32u);
    // Words past `last` hold bins beyond z_end only: the ray's state at z_end is the last walked bit.
    let lanes = vec4u(0u, 1u, 2u, 3u);
    let z_per_bin = (f.ranges.w - f.ranges.z) / f32(f.grid.z);
    for (var g = first / 4u; g <= last / 4u; g++) {
        let q = quad(base, g);
        let w = vec4u(g * 4u) + lanes;
        // Where the bit differs from the one before it (bit 0 against the previous word's last),
        // in the words first..last only, from boundary n on.
        let before = vec4u(carry, q.x >> 31u, q.y >> 31u, q.z >> 31u);
        let inside = w >= vec4u(first) & w <= vec4u(last);
        let from_n = select(vec4u(~0u), vec4u(skipped), w == vec4u(first));
        var changes = (q ^ ((q << vec4u(1u)) | before)) & select(vec4u(0u), from_n, inside);
        // The carry into the next group, or past the loop: bit 31 of word `last` in the last group
        // (unchanged when there is no word to walk).
        carry = select(carry, pick(q, min(last - g * 4u, 3u)) >> 31u, first <= last);
        loop {
            if (all(changes == vec4u(0u))) { break; }
            // The first word with a change left, and its lowest change.
            let c = select(select(select(3u, 2u, changes.z != 0u), 1u, changes.y != 0u), 0u, changes.x != 0u);
            let i = firstTrailingBit(pick(changes, c));
            changes &= ~select(vec4u(0u), vec4u(1u << i), lanes == vec4u(c));
            // The first and last bins reach a quarter bin past the range on both planes (one of
            // them by its offset, the other because its sample is the nearest there).
            let j = (g * 4u + c) * 32u + i;
            let z = z_of_bin_step(f, select(f32(j) + offset, -0.25, j == 0u), z_per_bin);
            // A lit bin begins (q: 0 -> 1) where the bit goes clear, a shadowed one where it goes set:
            // bit j of the word in hand (no read of the bit before boundary n, which took a word
            // outside the walk; session 50).
            let lit_after = ((pick(q, c) >> i) & 1u) == 0u;
            if (z >= r.z_end) {
                // The ray ends in the run before this boundary: lit up to z_end where this
                // boundary starts a shadow (every later boundary sits at z_end and cancels).
                return sum + select(vec3f(0.0), c_end, !lit_after);
            }
            let cz = cumulative(r, z);
            sum += select(cz, -cz, lit_after);
        }
    }
    // Lit at z_end: the last run reaches it.
    if (carry == 0u) { return sum + c_end; }
    // Shadowed to the last bin's end, and lit from there where the ray goes on past it.
    let z_hi = z_of_bin(f, f32(f.grid.z) + 0.25);
    if (r.z_end > z_hi) { sum += c_end - cumulative(r, z_hi); }
    return sum;
}

// Component c of a vector of four words, without a dynamic index (on llvmpipe one that differs
// between lanes goes through memory).
fn pick(q: vec4u, c: u32) -> u32 {
    return select(select(q.x, q.y, c == 1u), select(q.z, q.w, c == 3u), c >= 2u);
}

// Word i of the grid: of the bit grid, or of shadow bits made from the first-hit volume.
fn word(i: u32) -> u32 {
    if (FIRST_HITS) { return hit_word(i); }
    return pick(grid[i / 4u], i % 4u);
}

// ---- the first-hit volume (FIRST_HITS) ---------------------------------------------------------
//
// The grid then holds each light ray's first hit (common.wgsl, `hit_key`), and a plane's "ray" is
// its words of bins (ray x starts at word x * words): word i = x * words + j has bin 32 j + b's
// bit set where that light ray's first hit lies before the pixel's own angle, compared as angles
// (no ray cell; the hit's is atan2_approx's, voxelize.wgsl `first_hits`). A word whose 32 keys all lie on one side of the pixel's is read from its bounds
// alone (hit_bounds.wgsl): most of them, as most words hold no shadow boundary. Of the others, a
// word whose keys split into two groups with the pixel's key between them (a shadow's edge: a near
// caster's light rays beside a far surface's) is read from its mask; only the rest compare keys.

// hit_key of the pixel's gamma moved HIT_SLACK planes' angle on (set per pixel before its walk,
// `pixel_key_of`).
var<private> pixel_key: u32;

// A hit up to HIT_SLACK planes' worth of angle past the pixel's own still shadows it. The pixel
// blends two planes whose copies of its view ray pass a closed surface's silhouette apart: where
// the pixel's own ray passes outside a box around the light, its copy in a neighbouring plane may
// graze the box's inside, lit, and its light rays leave the box just past the pixel's angle. The
// bits' ray cells hid that (a hit in the pixel's own cell shadows it: up to a cell, several
// planes' worth); exact first hits let it through along silhouettes (the tessellated box of
// tests/watertight.rs: 1 pixel at the default grid, 2% of the light at 64x64x32). Half a plane's
// angle (sin(gamma) dphi / 2: a neighbour plane's displacement across the view ray, as in
// own_shadow_start, over the distance) stops it at the default grid and leaves 1.26% there; it
// takes the classroom from 0.740% to 0.756% off the reference (docs/results.md, session 47).
const HIT_SLACK: f32 = 0.5;

fn pixel_key_of(gamma: f32) -> u32 {
    return hit_key(gamma + HIT_SLACK * sin(gamma) * f.b2.w / f32(f.grid.x));
}

// Word i's 32 shadow bits from its keys (bit b set where bin 32 j + b's key is greater than the
// pixel's), where `mixed`; else 0. A loop of 8 or 0 steps, not an if: llvmpipe runs both sides of
// a branch, and only a loop's trip count (the most any lane of a SIMD group needs) skips work.
fn hit_bits(i: u32, mixed: bool) -> u32 {
    var bits = 0u;
    for (var q = 0u; q < select(0u, 8u, mixed); q++) {
        let hit = select(vec4u(0u), vec4u(1u, 2u, 4u, 8u), grid[8u * i + q] > vec4u(pixel_key));
        bits |= (hit.x | hit.y | hit.z | hit.w) << (4u * q);
    }
    return bits;
}

// Where the bounds of word i start, in vectors: five a group of four words past the keys
// (hit_bounds.wgsl): least keys, greatest keys, the middle gaps' lower and upper keys, masks.
fn bounds_at(i: u32) -> u32 {
    return (f.grid.x * f.grid.z) / 4u + 5u * (i / 4u);
}

// Word i from its bounds, or from its gap's mask where the gap is wide and the pixel's key lies
// in it, or from its keys.
fn hit_word(i: u32) -> u32 {
    let at = bounds_at(i);
    let c = i % 4u;
    let lo_wide = pick(grid[at], c);
    let lo = lo_wide & ~1u;
    let hi = pick(grid[at + 1u], c);
    let wide = (lo_wide & 1u) != 0u;
    let gap = wide && pick(grid[at + 2u], c) <= pixel_key && pick(grid[at + 3u], c) > pixel_key;
    let mixed = lo <= pixel_key && hi > pixel_key && !gap;
    let settled = select(select(0u, ~0u, lo > pixel_key), pick(grid[at + 4u], c), gap);
    return select(settled, hit_bits(i, mixed), mixed);
}

// Words 4g to 4g + 3 of the plane whose words start at `base` (they come in fours, QUAD_RAYS):
// their bounds as two vectors; where the pixel's key lies between a word's bounds and the word has
// a wide gap, the gap (three vectors more, read only where some lane needs them: a loop of 1 or 0
// steps); the keys only of the words neither settles.
fn hit_quad(base: u32, g: u32) -> vec4u {
    let i = base + 4u * g;
    let at = bounds_at(i);
    let lo_wide = grid[at];
    let lo = lo_wide & vec4u(~1u);
    let hi = grid[at + 1u];
    let key = vec4u(pixel_key);
    let split = lo <= key & hi > key;
    let wide = split & ((lo_wide & vec4u(1u)) != vec4u(0u));
    var gap = vec4<bool>(false);
    var gap_mask = vec4u(0u);
    for (var t = 0u; t < select(0u, 1u, any(wide)); t++) {
        gap = wide & (grid[at + 2u] <= key) & (grid[at + 3u] > key);
        gap_mask = grid[at + 4u];
    }
    let mixed = split & !gap;
    let built = vec4u(
        hit_bits(i, mixed.x),
        hit_bits(i + 1u, mixed.y),
        hit_bits(i + 2u, mixed.z),
        hit_bits(i + 3u, mixed.w),
    );
    return select(select(select(vec4u(0u), vec4u(~0u), lo > key), gap_mask, gap), built, mixed);
}

// Words 4g to 4g + 3 of the grid ray that starts at word `base` (past its end: the next ray's,
// which the callers mask).
fn quad(base: u32, g: u32) -> vec4u {
    if (FIRST_HITS && QUAD_RAYS) { return hit_quad(base, g); }
    if (QUAD_RAYS) { return grid[base / 4u + g]; }
    let i = base + 4u * g;
    return vec4u(word(i), word(i + 1u), word(i + 2u), word(i + 3u));
}

// The lit part of the view ray: both planes around the pixel, on the pixel's own ray cell.
fn lit(r: Ray, x: vec2u, bases: vec2u, weights: vec2f) -> vec3f {
    // The last word holding bins of [z_start, z_end] on either plane (offsets of -1/4 and +1/4 bin).
    let last = u32(clamp(floor(bin_coord(f, r.z_end) + 0.25), 0.0, f32(f.grid.z - 1u))) / 32u;
    let c_end = cumulative(r, r.z_end);
    var sum = vec3f(0.0);
    if (weights.x > 0.0) { sum += weights.x * lit_plane(r, bases.x, bin_offset(x.x), last, c_end); }
    if (weights.y > 0.0) { sum += weights.y * lit_plane(r, bases.y, bin_offset(x.y), last, c_end); }
    return sum;
}

// Where the own-shadow layer in front of a surface lit from behind begins, in z: one cell of the
// grid from the surface at t_s, where `back` = |cos| between the view ray and the surface normal.
// A neighbouring plane's light ray is displaced by up to r_axis * dphi (r_axis = t sin(gamma), the
// distance from the axis) across the view ray, which is a height of that much above the surface,
// reached `across / back` before it on the view ray; 3/4 bin of z is displaced along the view ray
// (z_of_bin below does that in z directly).
// z_scale: z = t z_scale for a directional light (sin gamma, or the Cartesian grid's depth scale).
fn own_shadow_start(t_s: f32, gamma: f32, z_scale: f32, back: f32, z_start: f32) -> f32 {
    var across = t_s * sin(gamma) * f.b2.w / f32(f.grid.x);
    if (is_cartesian()) { across = t_s * 2.0 * max(f.cam_right.w, f.cam_up.w) / f32(f.grid.x); }
    // At grazing views the tangent plane stops standing for the surface (a curved one bends away
    // from it): the layer is at most 32 cells long on the view ray. (At 8, light leaked out of a
    // closed box at pixels grazing its faces once the rays were finer than the case's own grid:
    // 6e-5 at the default 1024x512x512, 2e-3 at 256x2048x256; from 32 on, no leak at any grid
    // tried, tests/check.rs. The cost: eye/outside-box 0.70 -> 1.10%, the bunny 0.039 -> 0.041%.)
    let t = max(t_s - across / max(back, 0.03125), 0.0);
    var z = t * z_scale;
    if (is_point_light()) { z = z_along(f, gamma, t); }
    return max(z_of_bin(f, bin_coord(f, z) - 0.75), z_start);
}

// ---- surface shadows from the shadow volume (GRID_SHADOWS) -----------------------------------
//
// The surface point P at the end of the view ray sees the light where no caster lies on its light
// ray before it, which is what the shadow volume holds. V = the lit fraction of the bins around
// P's z: on each of four planes around the pixel's angle the two bin samples around P's z, with a
// ramp half a bin wide between them (SURFACE_RAMP), and the planes weighted by a tent two planes
// wide either side (SURFACE_PLANES): a 4x2 filter, like a shadow map's percentage-closer one. Each of the eight sample light rays (its
// plane's centre, its bin's centre z_k) is read on the ray cell before the one holding the point
// where it meets the surface: the cell's bits hold every caster up to its end (inclusive scan), and
// the surface's own voxels lie in the cell after.
//
// Where it meets the surface: the sample ray against P's tangent plane, whose normal comes from the
// neighbouring pixels' points (trusted where it reproduces Surface's own cos theta_i), moved a
// quarter of s toward the light against curvature. Without a normal (an edge, a lone pixel), P's
// own light ray moved s toward the light, where s = (bin + plane) tan(theta_i) bounds how much
// nearer the light a sample ray, up to one bin and one plane away, can meet the tangent plane (the
// slope-scaled bias of a shadow map). A point is placed by its reach: along the axis for a sun (u,
// so gamma_k = atan2(z_k, u)) and from the light for a point light (d, gamma_k = atan2(d sin psi_k,
// D - d cos psi_k)). The cost is that of any bias: a caster within the margin plus a cell of P
// casts no shadow on it. (One bias s for all the samples, with no normal, self-shadowed the
// occluder's floor: 88% of its lit pixels right against 100%, tests/gpu.rs. The outer planes lie
// up to two planes away, but a bias for two planes took the classroom's whole image from 62.99 to
// 64.17% off: their weights are small.)
//
// A frame then needs no shadow map at all: on an H200 the sun's 2048^2 map was 1.4 of the
// classroom's 2.3 ms at 512x512 (docs/results.md, session 25).

// The surface point the four samples are read around: its position and normal (toward the eye;
// `exact` where its neighbours gave one), the conservative reach (P's own, moved s toward the
// light) and s.
struct SurfacePoint {
    pos: vec3f,
    n: vec3f,
    exact: bool,
    reach: f32,
    s: f32,
}

var<private> sp: SurfacePoint;

// 1 where bin j of plane x's light ray, read on the cell before its point at its reach, is lit;
// m: the plane's unit direction away from the axis.
// With the surface's normal, the reach is where the sample ray meets the surface's tangent plane
// (clamped to P's own reach +- s, the bound above), moved MARGIN s toward the light.
fn sample_lit(x: u32, m: vec3f, j: u32, offset: f32) -> f32 {
    let z = z_of_bin(f, f32(j) + 0.5 + offset);
    var reach = sp.reach;
    if (sp.exact) {
        let a = f.axis.xyz;
        if (is_point_light()) {
            let dir = m * sin(z) - a * cos(z);
            let nd = dot(sp.n, dir);
            if (nd < -1e-6) {
                let d = dot(sp.n, sp.pos - f.light.xyz) / nd;
                let d0 = length(f.light.xyz - sp.pos);
                reach = clamp(d, d0 - sp.s, d0 + sp.s) - MARGIN * sp.s;
            }
        } else {
            let u = dot(sp.pos - f.eye.xyz, a);
            let q = f.eye.xyz + a * u + m * z;
            let lambda = -dot(sp.n, q - sp.pos) / max(dot(sp.n, a), 1e-6);
            reach = u + clamp(lambda, -sp.s, sp.s) + MARGIN * sp.s;
        }
    }
    var g = atan2(z, reach);
    if (is_point_light()) { g = atan2(reach * sin(z), f.axis.w - reach * cos(z)); }
    // Before the first cell: only casters outside the rays' range (clamped into cell 0, with the
    // surface's own voxels) could shadow the point, and they cannot be told apart: taken as lit.
    let y = i32(floor(ray_coord(f, g))) - 1;
    if (y < 0) { return 1.0; }
    let w = word(ray_offset(f, x, u32(min(y, i32(f.grid.y) - 1))) + j / 32u);
    return f32(1u - ((w >> (j % 32u)) & 1u));
}

// Against curvature: the classroom's whole image at 0, 0.1, 0.25 and 0.5: 67.4, 66.7, 66.7, 67.1%.
const MARGIN: f32 = 0.25;

// One plane's lit fraction at bin coordinate b: its two bin samples around b, the step between
// them a ramp SURFACE_RAMP bins wide halfway between them. (Reading only the nearer sample
// outside the ramp gave the same bits and no measurable gain on llvmpipe.)
fn plane_lit(x: u32, b: f32) -> f32 {
    let offset = bin_offset(x);
    let u = b - 0.5 - offset;
    let j = floor(u);
    let top = f32(f.grid.z - 1u);
    let lo = u32(clamp(j, 0.0, top));
    let hi = u32(clamp(j + 1.0, 0.0, top));
    let phi = phi_of_plane(f, f32(x) + 0.5);
    let m = plane_half(f, phi);
    let t = clamp((u - j - 0.5) / SURFACE_RAMP + 0.5, 0.0, 1.0);
    return mix(sample_lit(x, m, lo, offset), sample_lit(x, m, hi, offset), t);
}

// The width of a plane's step between two bin samples, in bins. A linear blend over the whole bin
// (1.0) is the best guess from two samples alone, but the tent over four planes (SURFACE_PLANES)
// averages samples of both phases, half a bin apart, and then smeared each shadow edge over a
// bin and a half. The classroom's whole image against the reference (docs/results.md, session 27):
// 1.0 62.99%, 0.67 61.21%, 0.5 60.92%, 0.33 61.30%, a smoothstep over the bin 61.60%. At 0.5 the
// grid 2048x384x1280 gives 50.53% (the map 50.75%), 1024^2 56.66% (58.85% with 1.0), and the
// built-in room 13.85% (14.59% with 1.0, the map 14.35%).
const SURFACE_RAMP: f32 = 0.5;

// The step from pixel p's point to its neighbour along `step` (either side: the one nearer in
// distance, which is on the same surface unless both are off it), and 1 in w; 0 where neither
// neighbour sees a surface.
fn neighbour_step(p: vec2i, step: vec2i, pos: vec3f, t_s: f32) -> vec4f {
    var best = vec4f(0.0);
    var gap = 3.4e38;
    for (var k = -1; k <= 1; k += 2) {
        let q = p + step * k;
        if (any(q < vec2i(0)) || any(q >= vec2i(f.image.xy))) { continue; }
        let t = textureLoad(distance, q, 0).x;
        if (t < 0.0 || abs(t - t_s) >= gap) { continue; }
        gap = abs(t - t_s);
        best = vec4f((f.eye.xyz + pixel_dir(f, vec2f(q)) * t - pos) * f32(k), 1.0);
    }
    return best;
}

fn surface_visibility(p: vec2i, v: vec3f, t_s: f32, gamma: f32, cos_i: f32, x: vec2u, weights: vec2f) -> f32 {
    // Lit from behind: Composite draws nothing there.
    if (cos_i <= 0.0) { return 0.0; }
    let b = bin_coord(f, z_along(f, gamma, t_s));
    // No caster reaches outside the bins' range (Ranges made it hold every visible surface).
    if (b < -0.25 || b > f32(f.grid.z) + 0.25) { return 1.0; }
    let pos = f.eye.xyz + v * t_s;
    // A bin and a plane across the light ray at P, in scene units (z is an angle at a point light).
    var across = abs(z_of_bin(f, b + 0.5) - z_of_bin(f, b - 0.5));
    var d = 0.0;
    var w = f.light.xyz;
    if (is_point_light()) {
        d = length(f.light.xyz - pos);
        w = (f.light.xyz - pos) / max(d, 1e-30);
        across *= d;
    }
    across += t_s * sin(gamma) * f.b2.w / f32(f.grid.x);
    // tan(theta_i), capped where the surface grazes the light (cos < 1/16: its light is that dim).
    let c = max(cos_i, 0.0625);
    let s = across * sqrt(max(1.0 - c * c, 0.0)) / c;
    var reach = t_s * cos(gamma) + s;
    if (is_point_light()) { reach = max(d - s, 0.0); }
    // The normal from the neighbours' points; trusted where it gives the surface's own cos theta_i
    // (a neighbour across an edge would not).
    let dx = neighbour_step(p, vec2i(1, 0), pos, t_s);
    let dy = neighbour_step(p, vec2i(0, 1), pos, t_s);
    var n = normalize(cross(dx.xyz, dy.xyz));
    if (dot(n, v) > 0.0) { n = -n; }
    let exact = dx.w > 0.0 && dy.w > 0.0 && cos_i > 0.0625 && abs(dot(n, w) - cos_i) < 0.05;
    sp = SurfacePoint(pos, n, exact, reach, s);
    // Four planes, x0 - 1 to x1 + 1, weighted by a tent SURFACE_PLANES planes wide either side of
    // the pixel's angle.
    let t = max(vec4f(0.0), 1.0 - abs(vec4f(-1.0, 0.0, 1.0, 2.0) - weights.y) / SURFACE_PLANES);
    var vis = t.y * plane_lit(x.x, b) + t.z * plane_lit(x.y, b);
    if (t.x > 0.0) { vis += t.x * plane_lit(plane_beside(x.x, -1), b); }
    if (t.w > 0.0) { vis += t.w * plane_lit(plane_beside(x.y, 1), b); }
    return vis / dot(t, vec4f(1.0));
}

// The tent's half-width in planes, at most 2 (four planes are read; at 2 their weights sum to 2
// for every position between the planes). A shadow edge across the bins sits somewhere between two bin
// samples, and the planes on either side sample it at staggered bins (bin_offset): a tent over
// four planes averages two samples of each phase where two planes gave one, which turns the
// dotted edges of the classroom's sunlit floor into lines (docs/results.md, session 27, with a
// linear blend between bins: the whole image 66.65 -> 62.99% off the reference at the default
// grid, 54.41 -> 51.97% at 2048x384x1280; 1.5 planes 63.36%, 3 planes 63.56%, 4 planes 64.64%). The planes are finer than the pixels (two
// to four per pixel on the classroom at 512^2), so the wider tent spans about a pixel; at 1024^2,
// with half as many planes per pixel, it still helped (62.10 -> 58.85%).
const SURFACE_PLANES: f32 = 2.0;

// The plane `step` planes from x: around the circle where the planes cover it, else clamped.
fn plane_beside(x: u32, step: i32) -> u32 {
    let planes = i32(f.grid.x);
    var y = i32(x) + step;
    if ((f.image.w & FLAG_PHI_WRAPS) != 0u) { y = (y + planes) % planes; }
    return u32(clamp(y, 0, planes - 1));
}

// ---- per pixel -----------------------------------------------------------------------------

// Every pixel (`main`), or (the other entry points, "pixels from their neighbours") a quarter of
// them first, then only those their neighbours on the epipolar line cannot stand for.
@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3u) {
    f = frame_in;
    if (id.x >= f.image.x || id.y >= f.image.y) { return; }
    textureStore(scatter_out, vec2i(id.xy), scattered(integrate_pixel(id.xy)));
}

// A pixel's light: its lit sum without the light factor (`light_factor`), that factor and its
// surface's visibility of the light.
struct PixelLight {
    lit: vec3f,
    factor: vec3f,
    vis: f32,
}

// What the scattered image holds: the scattered light (rgb) and the visibility (a).
fn scattered(p: PixelLight) -> vec4f {
    return vec4f(p.factor * p.lit, p.vis);
}

// Pixel `id`'s light.
fn integrate_pixel(id: vec2u) -> PixelLight {
    if ((f.image.w & FLAG_NO_SCATTER) != 0u) { return PixelLight(vec3f(0.0), vec3f(0.0), 1.0); }
    let v = pixel_dir(f, vec2f(id.xy));
    let a = f.axis.xyz;
    let gamma = gamma_of_pixel(f, vec2f(id.xy), v);
    let gc = grid_coords(f, v);
    let surface = textureLoad(distance, vec2i(id.xy), 0).xy;
    let t_s = surface.x;
    let back = select(0.0, surface.y, t_s >= 0.0);

    // The two grid rays around the pixel and their weights. Planes are samples at their centres
    // and blend around them. Rays are cells (voxelize.wgsl): the pixel reads its own, whose bits
    // hold every caster up to the cell's end (inclusive scan), so it never leaks light through a
    // closed surface and over-shadows by under one cell. Blending toward the next cell added up
    // to one more cell of bias (docs/accuracy.md); blending backward would leak.
    let planes = f.grid.x;
    let rays = f.grid.y;
    let xf = gc.x - 0.5;
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
    let y = u32(clamp(gc.y, 0.0, f32(rays - 1u)));
    let weights = vec2f(1.0 - fx, fx);
    var bases = vec2u(ray_offset(f, u32(x0), y), ray_offset(f, u32(x1), y));
    if (FIRST_HITS) {
        // Each plane's words of shadow bits are made for this pixel's angle (`hit_word`).
        bases = vec2u(u32(x0), u32(x1)) * f.grid.w;
    }

    let factor = light_factor(gamma);
    // The lit sum: the scattered light without its light factor.
    var lit_sum = vec3f(0.0);
    if (is_point_light()) {
        // Within 1e-6 rad of the light the f32 angle is noise (~6e-8), so the point-light formulas use
        // gp = max(gamma, 1e-6). For a soft light (r > 0) the table's G and h = D sin(gamma) both
        // vanish linearly toward the light and their ratio keeps its finite limit; with the raw angle
        // the 1e-7 D clamp of h below cut the pixel through the light by gamma / 1e-7, a random factor
        // (numerical-stability fix, docs/stability.md, light/through-pixel-*).
        let gp = max(gamma, 1e-6);
        var psi_s = PI - gp;
        if (t_s >= 0.0) { psi_s = min(z_along(f, gp, t_s), psi_s); }
        var z_end = psi_s;
        if (back > 0.0) { z_end = min(z_end, own_shadow_start(t_s, gp, 1.0, back, 0.0)); }
        let r = Ray(gp, 0.0, z_end, 1.0, 1.0);
        pixel_key = pixel_key_of(gp);
        let lit = lit(r, vec2u(u32(x0), u32(x1)), bases, weights);
        lit_sum = max(lit, vec3f(0.0));
    } else {
        let span = box_span(f.eye.xyz, v, f.medium_min.xyz, f.medium_max.xyz);
        var t_end = span.y;
        if (t_s >= 0.0) { t_end = min(t_end, t_s); }
        if (t_end > span.x) {
            var z_scale = sin(gamma);
            if (is_cartesian()) { z_scale = dot(v, f.cam_fwd.xyz); }
            build_pieces(v, span.x, t_end);
            let z_start = span.x * z_scale;
            var z_end = t_end * z_scale;
            if (back > 0.0 && t_s <= t_end) { z_end = min(z_end, own_shadow_start(t_s, gamma, z_scale, back, z_start)); }
            let r = Ray(gamma, z_start, z_end, z_scale, 1.0 / max(z_scale, 1e-12));
            pixel_key = pixel_key_of(gamma);
            let lit = lit(r, vec2u(u32(x0), u32(x1)), bases, weights);
            lit_sum = max(lit, vec3f(0.0));
        }
    }
    var vis = 1.0;
    // A pipeline constant, not the frame's flag: as a run-time branch never taken, the surface
    // shadows' code still cost a frame with the map 12% of Integrate on llvmpipe (session 27).
    if (GRID_SHADOWS && t_s >= 0.0) {
        let cos_i = textureLoad(material, vec2i(id.xy), 0).w;
        vis = surface_visibility(vec2i(id.xy), v, t_s, gamma, cos_i, vec2u(u32(x0), u32(x1)), weights);
    }
    return PixelLight(lit_sum, factor, vis);
}

// The factor of a pixel's lit sum that depends on its angle gamma to the axis alone: what its
// light is, taken out before pixels are compared and interpolated (below), so that a point
// light's steep 1 / sin(gamma) in view does not keep its neighbours from agreeing.
fn light_factor(gamma: f32) -> vec3f {
    if (is_point_light()) {
        let gp = max(gamma, 1e-6);
        // The table holds G / (pi - gamma); the ray's weight is (pi - gamma) / h with h = D sin(gamma).
        // Written as x / sin(x) (x = pi - gamma) it stays finite looking straight away from the light.
        let x = PI - gp;
        var ratio = 1.0 / f.axis.w;
        if (x > 1e-4) { ratio = x / max(f.axis.w * sin_rel(gp), 1e-7 * f.axis.w); }
        // The table has exp(-sigma_t D) factored out; it joins the log of the prefactor in one exp,
        // so a bright light in a thick medium (sigma_t D > 87) is not flushed to 0 with exp(-sigma_t D)
        // (numerical-stability fix, docs/stability.md, medium/thick-bright).
        let pre = f.sigma_s.xyz * f.light_power.xyz * ratio;
        let scale = exp(log(max(pre, vec3f(1e-38))) - f.sigma_t.xyz * f.axis.w);
        return select(vec3f(0.0), scale, pre > vec3f(0.0));
    }
    // The deflection angle is gamma: the phase of the angle keeps the lobes' peaks exact.
    return f.sigma_s.xyz * f.light_power.xyz * phase_of_angle(f.sigma_s.w, gamma);
}

// Pixel p's light factor (for a pixel taken from its neighbours, which is not integrated).
fn pixel_light_factor(p: vec2u) -> vec3f {
    let v = pixel_dir(f, vec2f(p));
    return light_factor(gamma_of_pixel(f, vec2f(p), v));
}

// ---- pixels from their neighbours ----------------------------------------------------------
//
// Shafts of light and the shadows between them run along the epipolar lines (a light ray's image
// lies on the line through the epipole, the light's image point), and along an epipolar line the
// scattered light is continuous but where the view rays' ends jump (all view rays of a line lie
// in one epipolar plane, whose lit region each cuts in a length that changes continuously with
// the ray's angle). So along the line it can be interpolated, across it not: a shaft a pixel wide
// would vanish between two samples on either side of it.
//
// The image is cut into 8x8 blocks, each taken as running along x or along y, whichever the
// epipolar line through its centre is closer to (`block_along_x`). A block along x holds eight
// rows of two strips of four pixels; pixel k of a strip (k = x mod 4) is taken from neighbours a
// step back and a step on, a step being one pixel along x and, where the line runs more than 22.5
// degrees off the axis, one along y toward it (`block_step`): so a pixel's neighbours lie within
// 1.6 px of its epipolar line even where the lines run diagonally (with steps along the axis
// alone they strayed 2.8 px there, a shaft crossed between them, and the built-in room at 192x192
// measured 0.85% against the reference where every pixel integrated gives 0.76%). Along y the
// same with x and y swapped. Pixels are taken coarse to fine:
//
//   `lattice_pixels` integrates pixel 0 of every strip (x = 0 mod 4: a quarter of the pixels);
//   `classify_mid` gives pixel 2 the mean of its neighbours two steps back and on (two pixels 0)
//   where they stand for it, and lists it otherwise; `refine_mid` integrates the listed ones;
//   `classify` then gives pixels 1 and 3 the mean of their neighbours a step back and on (a pixel
//   0 and a pixel 2) where they stand for them, and lists the others; `refine` integrates those.
//
// Neighbours a and c stand for a pixel where
//
//   they lie in the image in blocks that run the same way (which have their pixels 0 and 2 at the
//   same places), not in a block within EPIPOLE_PX of the epipole (a point light's singular peak
//   there could sit on a pixel between two equal neighbours: those blocks are integrated whole);
//   their view rays end on its surface (all sky, or |t_n - t| <= DEPTH_TOL t);
//   their surfaces' visibilities agree within VIS_TOL;
//   and their values v without their light factors (`light_factor`: a point light's
//   1 / sin(gamma), a sun's phase) agree within VALUE_TOL per channel (max - min <= VALUE_TOL max),
//   or lie on a straight stretch: with a' and c' as far again beyond a and c (pixels 0 or 2 as
//   well), |v(a') - 2 v(a) + v(c)| and |v(a) - 2 v(c) + v(c')| are within VALUE_TOL of the largest.
//
// The pixel then takes the mean times its own light factor. The straight stretch lets a smooth
// slope through, which the test of agreement alone refused wherever the light changed by more than
// 1% over four pixels: on the bench's room, lit by a point light in view, 63% of the pixels 2 were
// integrated, and with it 32%; a step between the neighbours shows in both second differences,
// and is refused as before. A pixel 2 taken from its neighbours passes its mean on to pixels 1 and
// 3, which then agree with it by construction: a stretch where the coarse test holds is filled
// without another integration, and one where it fails is refined pixel by pixel.
//
// Measured at 512^2 (docs/results.md, session 30): 43% of the classroom's pixels are integrated
// (59% with session 29's 2x2 blocks, every other pixel first), 44% of the built-in room's, 40% of
// the bench's room. Against the reference the mean of pixels on one epipolar line is closer than
// every pixel integrated: it smooths the planes' pixel-to-pixel alternation at shaft edges.
const VALUE_TOL: f32 = 0.01;
const DEPTH_TOL: f32 = 0.02;
const VIS_TOL: f32 = 0.02;
const EPIPOLE_PX: f32 = 6.0;
// Pixels of a strip (along the axis), and of a block's side: a block's rows (or columns) hold two
// strips each.
const SIDE: u32 = 4u;
const BLOCK: u32 = 8u;
// tan(22.5 degrees): past it a line runs nearer the diagonal than the axis.
const TAN_HALF_OCTANT: f32 = 0.41421357;

// Blocks per row and per column.
fn blocks() -> vec2u {
    return (f.image.xy + vec2u(BLOCK - 1u)) / BLOCK;
}

// Strips in the image (sixteen a block): the second list (`classify`'s) starts past the first's
// (`classify_mid`, at most one pixel a strip).
fn strips() -> u32 {
    let b = blocks();
    return b.x * b.y * BLOCK * (BLOCK / SIDE);
}

// The direction of the epipolar line through block b's centre, in pixels (x right, y down;
// unnormalised): the image of the axis toward the light, moved from a view direction (x, y, 1) in
// tangent units by a little along the axis a, goes by (a_x - x a_z, a_y - y a_z); in pixels
// (c = the point in pixels, size the image's, (tx, ty) the half-angles' tangents) that is
//
//   d(c) = (a_x size_x / tx + a_z size_x, a_z size_y - a_y size_y / ty) - 2 a_z c,
//
// affine in c: `line_setup` computes its two parts once a thread.
fn block_line(b: vec2u) -> vec2f {
    return line.xy + line.z * (vec2f(b) * f32(BLOCK) + 0.5 * f32(BLOCK));
}

var<private> line: vec3f;

fn line_setup() {
    let size = vec2f(f.image.xy);
    let a = vec3f(dot(f.axis.xyz, f.cam_right.xyz), dot(f.axis.xyz, f.cam_up.xyz), dot(f.axis.xyz, f.cam_fwd.xyz));
    line = vec3f(a.x * size.x / f.cam_right.w + a.z * size.x, a.z * size.y - a.y * size.y / f.cam_up.w, -2.0 * a.z);
}

// Whether block b's epipolar line runs closer to the image's x axis than to its y axis.
fn block_along_x(b: vec2u) -> bool {
    let d = block_line(b);
    return abs(d.x) >= abs(d.y);
}

// One step along block b's epipolar line: a pixel along its axis, and one across toward the line
// where it runs more than 22.5 degrees off the axis.
fn block_step(b: vec2u, along_x: bool) -> vec2i {
    let d = block_line(b);
    let major = select(d.y, d.x, along_x);
    let minor = select(d.x, d.y, along_x);
    let across = select(0, select(-1, 1, minor * major > 0.0), abs(minor) > TAN_HALF_OCTANT * abs(major));
    return select(vec2i(across, 1), vec2i(1, across), along_x);
}

// Whether a pixel of block b lies within EPIPOLE_PX of the epipole (pixel p's centre is at p; the
// block's centre is 3.5 px from its outer pixels' centres on either axis).
fn block_near_epipole(b: vec2u) -> bool {
    if (f.epipole.x >= 1e38) { return false; }
    let h = 0.5 * f32(BLOCK - 1u);
    let d = max(abs((vec2f(b) * f32(BLOCK) + h - f.epipole.xy) - f.epipole.zw) - vec2f(h), vec2f(0.0));
    return dot(d, d) < EPIPOLE_PX * EPIPOLE_PX;
}

fn inside(p: vec2i) -> bool {
    return all(p >= vec2i(0)) && all(vec2u(p) < f.image.xy);
}

// Pixel p's entry in `values`.
fn value_index(p: vec2u) -> u32 {
    return p.y * f.image.x + p.x;
}

// Whether a neighbour whose view ray ends at tn lies on the same surface as a pixel whose ray ends
// at t (negative: the sky).
fn stands_for(t: f32, tn: f32) -> bool {
    if (t < 0.0 || tn < 0.0) { return t < 0.0 && tn < 0.0; }
    return abs(tn - t) <= DEPTH_TOL * t;
}

// Whether pixel p was taken from its neighbours, and the mean it took (its lit sum without the
// light factor, and its visibility).
struct Taken {
    ok: bool,
    mean: vec4f,
}

// Pixel p of block b from its neighbours `back` steps back and `on` steps on where they stand for
// it (above): then it is stored in the image.
fn from_neighbours(p: vec2u, b: vec2u, along_x: bool, back: i32, on: i32) -> Taken {
    var taken = Taken(false, vec4f(0.0));
    let step = block_step(b, along_x);
    let a = vec2i(p) - back * step;
    let c = vec2i(p) + on * step;
    if (block_near_epipole(b) || !lends(a, along_x) || !lends(c, along_x)) { return taken; }
    let va = values[value_index(vec2u(a))];
    let vc = values[value_index(vec2u(c))];
    let t = textureLoad(distance, vec2i(p), 0).x;
    let hi = max(va, vc);
    let lo = min(va, vc);
    let ok = stands_for(t, textureLoad(distance, a, 0).x) && stands_for(t, textureLoad(distance, c, 0).x) && hi.w - lo.w <= VIS_TOL;
    var agree = all(hi.xyz - lo.xyz <= VALUE_TOL * hi.xyz);
    // Or a straight stretch: the pixels as far again beyond either neighbour continue the line
    // through them.
    let span = back + on;
    let a2 = a - span * step;
    let c2 = c + span * step;
    if (ok && !agree && lends(a2, along_x) && lends(c2, along_x)) {
        let va2 = values[value_index(vec2u(a2))].xyz;
        let vc2 = values[value_index(vec2u(c2))].xyz;
        let top = max(max(hi.xyz, va2), vc2);
        agree = all(abs(va2 - 2.0 * va.xyz + vc.xyz) <= VALUE_TOL * top) && all(abs(va.xyz - 2.0 * vc.xyz + vc2) <= VALUE_TOL * top);
    }
    taken.ok = ok && agree;
    if (taken.ok) {
        taken.mean = 0.5 * (va + vc);
        textureStore(scatter_out, vec2i(p), vec4f(pixel_light_factor(p) * taken.mean.xyz, taken.mean.w));
    }
    return taken;
}

// Whether pixel q can lend its value along a block's step: it lies in the image, in a block that
// runs the same way (whose pixels 0 and 2 lie where the step expects them).
fn lends(q: vec2i, along_x: bool) -> bool {
    return inside(q) && block_along_x(vec2u(q) / BLOCK) == along_x;
}

// A strip of four pixels along its block's axis: its block, the block's way and its pixel 0.
struct Strip {
    b: vec2u,
    along_x: bool,
    origin: vec2u,
}

// Pixel k of strip s.
fn strip_pixel(s: Strip, k: u32) -> vec2u {
    return s.origin + select(vec2u(0u, k), vec2u(k, 0u), s.along_x);
}

// The strip of thread `lid` of workgroup `wg`: a workgroup takes 2x2 blocks, a 16x16 patch of the
// image, and a SIMD group of eight threads (lid / 8) one strip along the axis (of two) of each of
// a block's eight rows (or columns), lid % 8. So a SIMD group's lanes hold neighbours across the
// epipolar lines whichever way the block runs, and a workgroup's lanes read nearby grid rays.
// (Lanes four pixels apart along the rows, as a first build had them, cost Integrate ~10% more on
// llvmpipe, session 30.)
fn strip_of(wg: vec3u, lid: u32) -> Strip {
    let g = lid / BLOCK;
    let b = wg.xy * 2u + vec2u((g / 2u) % 2u, g / 4u);
    let along_x = block_along_x(b);
    let r = lid % BLOCK;
    let q = g % 2u * SIDE;
    return Strip(b, along_x, b * BLOCK + select(vec2u(r, q), vec2u(q, r), along_x));
}

@compute @workgroup_size(8, 8)
fn lattice_pixels(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    line_setup();
    let p = strip_pixel(strip_of(wg, lid), 0u);
    if (!inside(vec2i(p))) { return; }
    integrate_and_keep(p);
}

// Integrates pixel p into the image and keeps its lit sum and visibility in `values`, where its
// neighbours' classification reads them (pixels 0 and 2).
fn integrate_and_keep(p: vec2u) {
    let light = integrate_pixel(p);
    textureStore(scatter_out, vec2i(p), scattered(light));
    values[value_index(p)] = vec4f(light.lit, light.vis);
}

// Pixel 2 of each strip: from the pixels 0 two steps back and on, else listed (first list).
@compute @workgroup_size(8, 8)
fn classify_mid(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    line_setup();
    append(0u, mid_pixel(strip_of(wg, lid)));
}

// Pixel 2 of strip s: (1, the pixel packed) when it is left to integrate, else 0.
fn mid_pixel(s: Strip) -> Listed {
    let p = strip_pixel(s, 2u);
    if (!inside(vec2i(p))) { return Listed(0u, vec2u(0u)); }
    let taken = from_neighbours(p, s.b, s.along_x, 2, 2);
    if (taken.ok) {
        values[value_index(p)] = taken.mean;
        return Listed(0u, vec2u(0u));
    }
    return Listed(1u, vec2u(pack(p), 0u));
}

// Up to two pixels left to integrate, packed (`pack`).
struct Listed {
    count: u32,
    pixels: vec2u,
}

fn pack(p: vec2u) -> u32 {
    return p.x | (p.y << 16u);
}

fn unpack(packed: u32) -> vec2u {
    return vec2u(packed & 0xffffu, packed >> 16u);
}

// Appends a thread's listed pixels to list `list` (0: `classify_mid`'s, at 0; 1: `classify`'s, at
// `strips()`). (Appending a workgroup's pixels together, with one atomic per workgroup, measured
// the same on llvmpipe, session 30: its barriers cost what keeping a refine's lanes on nearby
// pixels gained.)
fn append(list: u32, listed: Listed) {
    if (listed.count == 0u) { return; }
    let at = select(0u, strips(), list == 1u) + atomicAdd(&refine_count[list], listed.count);
    refine_list[at] = listed.pixels.x;
    if (listed.count > 1u) { refine_list[at + 1u] = listed.pixels.y; }
}

// The first list's pixels, integrated, into the image and `values` (a grid-stride loop over the
// list, like `refine`).
@compute @workgroup_size(64)
fn refine_mid(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    f = frame_in;
    let n = atomicLoad(&refine_count[0]);
    let stride = groups.x * 64u;
    for (var i = id.x; i < n; i += stride) {
        integrate_and_keep(unpack(refine_list[i]));
    }
}

// Pixels 1 and 3 of each strip: from their neighbours a step back and on, else listed (second
// list).
@compute @workgroup_size(8, 8)
fn classify(@builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) lid: u32) {
    f = frame_in;
    line_setup();
    append(1u, fine_pixels(strip_of(wg, lid)));
}

// Pixels 1 and 3 of strip s: those left to integrate.
fn fine_pixels(s: Strip) -> Listed {
    var listed = Listed(0u, vec2u(0u));
    let p1 = strip_pixel(s, 1u);
    let p3 = strip_pixel(s, 3u);
    if (!inside(vec2i(p1))) { return listed; }
    if (!from_neighbours(p1, s.b, s.along_x, 1, 1).ok) {
        listed = Listed(1u, vec2u(pack(p1), 0u));
    }
    if (inside(vec2i(p3)) && !from_neighbours(p3, s.b, s.along_x, 1, 1).ok) {
        listed.pixels = select(listed.pixels, vec2u(pack(p3)), vec2u(listed.count) == vec2u(0u, 1u));
        listed.count++;
    }
    return listed;
}

// The second list's pixels, integrated: a grid-stride loop over the list (its length is only known
// on the GPU; the renderer dispatches a few workgroups on a CPU adapter, enough for any list on a
// GPU). `refine_mid`'s loop is the same but for its store to `values`: one function for both
// lists, with that store behind the list's index, cost the bench room's Integrate 8% on llvmpipe,
// and with the store made in both 1-2% (session 30).
@compute @workgroup_size(64)
fn refine(@builtin(global_invocation_id) id: vec3u, @builtin(num_workgroups) groups: vec3u) {
    f = frame_in;
    let n = atomicLoad(&refine_count[1]);
    let base = strips();
    let stride = groups.x * 64u;
    for (var i = id.x; i < n; i += stride) {
        let p = unpack(refine_list[base + i]);
        textureStore(scatter_out, vec2i(p), scattered(integrate_pixel(p)));
    }
}

// common.wgsl: the per-frame uniforms and the mathematics every pass shares.
//
// Mirrors `src/render/frame.rs` (FrameUniforms) and `src/epipolar.rs`: the epipolar frame of the eye
// and the light (axis `a`, basis b1/b2 around it), the fitted grid ranges, the pixel convention and
// the phase functions. A layout test checks this struct against the Rust one.

// Parameters: each pass binds the frame's parameters (and the shadow map's, the march's) as a
// read-only *storage* buffer (`frame_in`) and copies it into a private `f` at every entry point.
// Not a uniform buffer: lavapipe recompiles a shader for every new value of a uniform that steers
// control flow (about 2 s a frame for the voxel passes whenever the camera moves). The private
// copy lets the compiler keep the values in registers instead of reloading them from the buffer
// in every loop iteration (the march: 2.5x faster on llvmpipe than reading the buffer directly).
// Copy before the entry point's first branch or loop: llvmpipe (Mesa 22.3) loads a storage value
// whose address is a constant with one load for the whole SIMD group only outside control flow;
// inside a branch or a loop (an early `return` puts the rest of the shader inside one) every lane
// loads it in turn, a loop with a branch per lane. Parameters read there instead cost the
// classroom's Cull, sun list and Composite ~3 ms a frame (session 36). Fragment shaders never get
// the single load: they take what they need from the vertex stage (surface.wgsl).

const PI: f32 = 3.14159265358979;
const TAU: f32 = 6.28318530717959;
const INV_4PI: f32 = 0.0795774715459477;

// Specialisation (DESIGN section 6): the light type, the phase function, a grey medium and the
// grid's axes are pipeline-overridable constants, set per pipeline by `src/render/variant.rs` (one
// pipeline per variant in use), so the branches on them fold away when the pipeline is built
// instead of running per pixel. (llvmpipe runs both sides of a branch on a buffer value: the
// Cartesian grid's code, never taken in an epipolar frame, cost Voxelize a third of its time.)
// The values here are only defaults for validation; every pipeline sets them all.
override POINT_LIGHT: bool = true; // point light (else directional)
override PHASE: u32 = 0u;          // Phase::id(): 0 isotropic, 1 HG, 2 Schlick, 3 Cornette-Shanks, 4 Rayleigh
override GREY_MEDIUM: bool = false; // sigma_t equal in R, G and B: one channel's exponentials
override CARTESIAN: bool = false;   // the screen-space Cartesian grid (the paper's section 2), else epipolar
override COSINE_BINS: bool = false; // bins uniform in cos(psi) (point lights only), else uniform in psi / r
override QUAD_RAYS: bool = true;    // every grid ray starts on four words (bins a multiple of 128): Integrate reads them as vec4u
override GRID_SHADOWS: bool = false; // the surfaces' shadows come from the shadow volume: Integrate computes them, no map is drawn (Integrate, Composite, Cull)
override EXACT_SHADOWS: bool = false; // the surfaces' sun shadows come from exact_shadows.wgsl's test against the triangles, not the map (Composite)
override FIRST_HITS: bool = false; // the shadow volume as each light ray's first hit (Voxelize, Integrate; `hit_key` below), not the bits of ray cells
override WHOLE_RAY_ITEMS: bool = false; // each Voxelize item holds all of a ray's words (a CPU adapter's list): Cull may give a triangle more words than it spans at no cost (triangle_bounds.wgsl)

// flags (bits 1, 4 and 8 were the light type, cosine bins and the Cartesian grid: now overrides)
const FLAG_PHI_WRAPS: u32 = 2u;    // planes cover the full circle: plane P-1 neighbours plane 0
const FLAG_NO_SCATTER: u32 = 16u;  // nothing scatters: Integrate writes zeros, the voxel passes are skipped
const FLAG_HIDDEN_BLOCKS: u32 = 64u; // Cull tests large triangles' blocks of planes against the sun's pyramid
const FLAG_PLANE_REACH: u32 = 512u; // Ranges wrote each plane's reach this frame: Voxelize's first hits stop there

// The planes' reach (ranges.wgsl, Ranges::reach): per group of REACH_GROUP planes the greatest
// visible z of the pixels that blend them, then from REACH_PLANES_AT each plane's last bin kept
// (Ranges::REACH_GROUP and REACH_PLANES_AT on the CPU).
const REACH_GROUP: u32 = 8u;
const REACH_PLANES_AT: u32 = 1024u; // groups of the most planes a grid has (8192 / REACH_GROUP)

struct Frame {
    // Camera: right/up/forward unit vectors; w holds tan(half fov x), tan(half fov y), near.
    cam_right: vec4f,
    cam_up: vec4f,
    cam_fwd: vec4f,
    // Eye position; w = far.
    eye: vec4f,
    view_proj: mat4x4f,
    // Point light: position, w = 1. Directional: unit vector toward the light, w = 0.
    light: vec4f,
    // Intensity (W/sr) or irradiance (W/m^2); w = softening radius.
    light_power: vec4f,
    // Unit axis from the eye toward the light; w = eye-light distance D (point light).
    axis: vec4f,
    // Basis around the axis; w = first plane angle phi0 / angular span of the planes.
    b1: vec4f,
    b2: vec4f,
    // sigma_s (rgb), w = phase asymmetry g.
    sigma_s: vec4f,
    // sigma_t (rgb), w = unused.
    sigma_t: vec4f,
    // gamma_lo, gamma_hi, z_lo, z_hi: the fitted ray and bin ranges.
    ranges: vec4f,
    // The box the medium fills for a directional light.
    medium_min: vec4f,
    medium_max: vec4f,
    // planes, rays, bins, 32-bit words per ray.
    grid: vec4u,
    // image width, height, unused (the phase function is the PHASE override), flags.
    image: vec4u,
    // scatter table rows, columns; Cartesian light axis (0 +right, 1 -right, 2 +up, 3 -up); unused.
    table: vec4u,
    // Voxelize's work list (cull.wgsl, voxelize.wgsl): work items per thread, 32-bit words of bins
    // per item, the coarsest shadow-pyramid level Cull may read (0: no test of hidden triangles,
    // shadow_pyramid.wgsl); w the coarsest level of the eye's depth pyramid Surface's culling may
    // read (0: none, surface_cull.wgsl).
    work: vec4u,
    // Where the axis toward the light meets the image, in pixels: whole pixels in xy, the fraction
    // in zw (gamma_of_pixel); x = NO_EPIPOLE (3e38) when the light is not in front of the camera.
    epipole: vec4f,
}

// The shadow map's matrices and parameters (ShadowUniforms in shadow_map.rs; a layout test checks
// it): read by shadow_lookup.wgsl's importers and by Cull's test of hidden triangles.
struct ShadowFaces {
    view_proj: array<mat4x4f, 6>,
    // x: the budget's texels per side (the map holds about x^2 texels), y: texel size (directional:
    // the longer side, scene units; point: per unit of distance), z: informational (the light type
    // is the POINT_LIGHT override), w: the cube's near distance (point) or the orthographic depth
    // range (directional).
    params: vec4f,
    // Directional: the reference point far on the light's side.
    origin: vec4f,
    // Each layer's width and height in texels (a cube's faces are square; a sun's map is shaped to
    // its rectangle, ShadowMap::dims), and their reciprocals.
    size: vec4f,
}

fn is_point_light() -> bool { return POINT_LIGHT; }

// 32-bit words of bins per Voxelize work item (at least 1).
fn words_per_item(f: Frame) -> u32 {
    return max(f.work.y, 1u);
}

// Threads per SIMD group on llvmpipe (8 lanes of 32 bits). Voxelize, Cull and Surface's culling
// hand a group's lanes neighbouring work (interleaved runs), so that lanes alike in their branches
// and loops move together; a GPU runs one item per thread there, where it changes nothing.
const LANES: u32 = 8u;

// Planes per block of a large triangle's range that Cull tests against the sun's pyramid on its
// own (cull.wgsl `hidden_blocks`); Voxelize skips the items of the blocks it finds hidden.
const HIDDEN_BLOCK: u32 = 64u;

// Voxelize's work items for a triangle's `words` words of bins in one plane. In f32: llvmpipe
// divides integers one lane at a time; both operands are at most 64 (Grid::BINS.max / 32), where
// the float quotient's ceiling is exact.
fn word_groups(f: Frame, words: u32) -> u32 {
    return u32(ceil(f32(words) / f32(words_per_item(f))));
}

// ---- pixels --------------------------------------------------------------------------------

// World direction of the ray through the centre of pixel `p` (row 0 at the top): the same formula
// as `Camera::pixel_dir_f64`.
fn pixel_dir(f: Frame, p: vec2f) -> vec3f {
    let size = vec2f(f32(f.image.x), f32(f.image.y));
    let ndc_x = (2.0 * (p.x + 0.5) / size.x - 1.0) * f.cam_right.w;
    let ndc_y = (1.0 - 2.0 * (p.y + 0.5) / size.y) * f.cam_up.w;
    return normalize(f.cam_fwd.xyz + f.cam_right.xyz * ndc_x + f.cam_up.xyz * ndc_y);
}

// ---- epipolar coordinates (src/epipolar.rs) ------------------------------------------------

// sin(x) for x in [0, pi] with a small relative error also near both ends, where formulas divide
// by it. WGSL bounds sin only by an absolute error of 2^-11 on [-pi, pi] (NVIDIA's hardware sine
// by about 2^-21): near 0 or pi that is an unbounded relative error, and 1 / sin(gamma) of a ray
// through the light multiplies it. The ends take sin's series (truncation < 1e-10 relative).
fn sin_rel(x: f32) -> f32 {
    // (Near pi, y keeps f32(pi)'s excess of 8.7e-8 over pi: taking it off again is folded away by
    // drivers that reassociate, llvmpipe among them. gamma near pi is looking away from the light.)
    let y = min(x, PI - x);
    if (y < 0.25) {
        let y2 = y * y;
        return y * (1.0 - y2 / 6.0 * (1.0 - y2 / 20.0 * (1.0 - y2 / 42.0)));
    }
    return sin(x);
}

fn angle_between(a: vec3f, b: vec3f) -> f32 {
    return atan2(length(cross(a, b)), dot(a, b));
}

// atan2(y, x) from a polynomial for atan on [0, 1] and the octants' symmetries: within 1.7e-6 rad
// (the polynomial's largest error, measured in f64) plus f32's rounding for points at least
// 1e-37 from the origin (tests/shader_math.rs), and 0 at (0, 0). For angles that only bin or
// bound (Voxelize's hit cells, Cull's ranges, which have margins above it) and for the first
// hits' angles, which Integrate compares with a slack above it (voxelize.wgsl, `first_hits`);
// never for the angles Integrate integrates over. The built-in atan2's range reduction and
// quadrant logic, which llvmpipe runs in full for a SIMD group, cost a tenth of Cull's time at a
// million triangles and of the classroom's Voxelize (session 31).
fn atan2_approx(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let t = min(ax, ay) / max(max(ax, ay), 1e-37);
    let t2 = t * t;
    var a = t * (0.99997726 + t2 * (-0.33262347 + t2 * (0.19354346 + t2 * (-0.11643287 + t2 * (0.05265332 + t2 * -0.01172120)))));
    a = select(a, 0.5 * PI - a, ay > ax);
    a = select(a, PI - a, x < 0.0);
    return select(a, -a, y < 0.0);
}

// gamma, the angle between the axis toward the light and the ray through pixel p (direction v),
// with a small relative error also within a few pixels of the light. There the f32 direction's
// error of ~6e-8 (an ulp of its unit components) is a relative error of 6e-8 / gamma in gamma,
// and a point light's in-scattering goes as 1 / sin(gamma): on the bunny at 1024x1024 the light's
// own pixel (gamma ~ 3e-4) moves by 2e-4 on llvmpipe when v is nudged by an ulp, the size of its
// 1.6e-4 error on an H200 (docs/stability.md, fix 6). Near the epipole e the angle is taken between the camera-space
// directions w = (x, y, 1) and (e_x, e_y, 1) (tangent units) from the pixel's offset d = p - e,
// which the f64 split of e keeps exact:  w x e = (d_y, -d_x, d_x e_y - d_y e_x).
fn gamma_of_pixel(f: Frame, p: vec2f, v: vec3f) -> f32 {
    let g = angle_between(f.axis.xyz, v);
    if (g > 0.01 || f.epipole.x >= 1e38) { return g; }
    let size = vec2f(f32(f.image.x), f32(f.image.y));
    // Pixels to tangents of the view: x grows rightward, y upward (pixel rows grow downward).
    let scale = vec2f(2.0 * f.cam_right.w / size.x, -2.0 * f.cam_up.w / size.y);
    let d = ((p - f.epipole.xy) - f.epipole.zw) * scale;
    let e = (vec2f(0.5) + f.epipole.xy + f.epipole.zw) * scale + vec2f(-f.cam_right.w, f.cam_up.w);
    let c = vec3f(d.y, -d.x, d.x * e.y - d.y * e.x);
    return atan2(length(c), 1.0 + dot(e + d, e));
}

fn phi_of_dir(f: Frame, v: vec3f) -> f32 {
    var p = atan2(dot(v, f.b2.xyz), dot(v, f.b1.xyz));
    if (p < 0.0) { p += TAU; }
    return p;
}

fn dir_of(f: Frame, phi: f32, gamma: f32) -> vec3f {
    return f.axis.xyz * cos(gamma) + plane_half(f, phi) * sin(gamma);
}

// The epipolar half-plane at angle phi around the axis, from the frame's basis b1, b2 across the
// axis: the direction of its half away from the axis, and its normal (the plane's points p have
// dot(p - eye, normal) = 0). Shared by Voxelize, Cull's hidden blocks and Integrate.
fn plane_half(f: Frame, phi: f32) -> vec3f {
    return f.b1.xyz * cos(phi) + f.b2.xyz * sin(phi);
}

fn plane_normal(f: Frame, phi: f32) -> vec3f {
    return f.b2.xyz * cos(phi) - f.b1.xyz * sin(phi);
}

// Continuous plane coordinate in [0, planes) (plane i covers [i, i+1)).
fn plane_coord(f: Frame, phi: f32) -> f32 {
    var u = phi - f.b1.w;
    u = u - floor(u / TAU) * TAU;
    return u / f.b2.w * f32(f.grid.x);
}

fn phi_of_plane(f: Frame, x: f32) -> f32 {
    return f.b1.w + x / f32(f.grid.x) * f.b2.w;
}

fn ray_coord(f: Frame, gamma: f32) -> f32 {
    return (gamma - f.ranges.x) / (f.ranges.y - f.ranges.x) * f32(f.grid.y);
}

fn gamma_of_ray(f: Frame, y: f32) -> f32 {
    return f.ranges.x + y / f32(f.grid.y) * (f.ranges.y - f.ranges.x);
}

// Continuous bin coordinate of z (psi or r).
fn bin_coord(f: Frame, z: f32) -> f32 {
    let b = f32(f.grid.z);
    if (COSINE_BINS) {
        // (cos z_lo - cos z) / (cos z_lo - cos z_hi) as products of sines: the plain form is 0/0
        // in f32 once the range is below ~3e-4 rad (src/epipolar.rs has the same).
        let lo = f.ranges.z;
        let num = sin(0.5 * (lo + z)) * sin(0.5 * (z - lo));
        let den = sin(0.5 * (lo + f.ranges.w)) * sin(0.5 * (f.ranges.w - lo));
        return num / max(den, 1e-30) * b;
    }
    return (z - f.ranges.z) / (f.ranges.w - f.ranges.z) * b;
}

fn z_of_bin(f: Frame, k: f32) -> f32 {
    let s = k / f32(f.grid.z);
    if (COSINE_BINS) {
        // cos z = cos z_lo - s (cos z_lo - cos z_hi), solved for sin^2 and cos^2 of z / 2 and put
        // back together with atan2: precise at both ends, where cos is flat (src/epipolar.rs).
        let lo = f.ranges.z;
        let p = s * sin(0.5 * (lo + f.ranges.w)) * sin(0.5 * (f.ranges.w - lo));
        let sh = sin(0.5 * lo);
        let ch = cos(0.5 * lo);
        return 2.0 * atan2(sqrt(max(sh * sh + p, 0.0)), sqrt(max(ch * ch - p, 0.0)));
    }
    return f.ranges.z + s * (f.ranges.w - f.ranges.z);
}

// z_of_bin with the bins' width z_per_bin = (ranges.w - ranges.z) / bins computed by the caller
// once: for uniform bins a product, not a division, in the loops over bins (Voxelize's walk,
// Integrate's shadow boundaries; llvmpipe runs a division in full for a SIMD group, session 31).
fn z_of_bin_step(f: Frame, k: f32, z_per_bin: f32) -> f32 {
    if (COSINE_BINS) { return z_of_bin(f, k); }
    return f.ranges.z + k * z_per_bin;
}

// Interleaved bins: plane x samples its light rays at z(k + 1/2 + bin_offset(x)), a quarter bin
// before the centre on even planes and after it on odd ones. Integrate blends neighbouring planes,
// so where a shadow edge falls between two bins the two planes place it half a bin apart and the
// blend averages their errors (interleaved sampling): the same bits, a third less error.
fn bin_offset(x: u32) -> f32 {
    return select(-0.25, 0.25, (x & 1u) == 1u);
}

// z (psi for a point light, r for a directional one) of the point at distance t along a view ray
// that makes angle gamma with the axis.
fn z_along(f: Frame, gamma: f32, t: f32) -> f32 {
    if (is_point_light()) {
        return atan2(t * sin(gamma), f.axis.w - t * cos(gamma));
    }
    return t * sin(gamma);
}

// ---- the grid's (plane, ray) axes, epipolar or Cartesian -----------------------------------

// The first word of grid ray (plane x, ray y). The grid is plane-major: a plane's rays follow one
// another, each `words` words long (Grid::ray_offset in Rust). A light ray (fixed x and bin)
// therefore steps `words` words from one ray cell to the next: the scan streams down it, and a
// Voxelize item's ORs into consecutive cells fall in neighbouring cache lines.
fn ray_offset(f: Frame, x: u32, y: u32) -> u32 {
    return (x * f.grid.y + y) * f.grid.w;
}

fn is_cartesian() -> bool { return CARTESIAN; }

// The first-hit volume (FIRST_HITS; `Renderer::shadow_volume`): per plane x and bin k, the key of
// the least angle gamma at which bin k's light ray meets a triangle, planes x bins words (0: no
// hit), then per word of 32 bins (plane x, word j, index x * words + j) the least and the greatest
// key of its bins (hit_bounds.wgsl). A point at angle gamma on a view ray of plane x lies on bin
// k's light ray after that hit, in its shadow, exactly when
//
//   volume[x * bins + k] > hit_key(gamma)
//
// (gamma grows along a light ray away from the light, DESIGN section 2). The key orders angles
// backward (the complement of a non-negative float's bits, which order like the floats), so that
// the least angle is an atomic max over a buffer cleared to zero.
fn hit_key(gamma: f32) -> u32 {
    return ~bitcast<u32>(max(gamma, 0.0));
}

// Continuous (plane, ray) coordinates of a view direction. Cartesian (the paper's section 2): a
// directional light along a screen axis; planes are the screen rows (or columns) and rays run
// across them starting at the screen edge nearest the light, so the scan follows the light.
fn grid_coords(f: Frame, v: vec3f) -> vec2f {
    if (is_cartesian()) {
        let z = dot(v, f.cam_fwd.xyz);
        let sx = dot(v, f.cam_right.xyz) / z / f.cam_right.w;
        let sy = dot(v, f.cam_up.xyz) / z / f.cam_up.w;
        let p = f32(f.grid.x);
        let r = f32(f.grid.y);
        switch f.table.z {
            case 0u: { return vec2f((1.0 - sy) * 0.5 * p, (1.0 - sx) * 0.5 * r); }
            case 1u: { return vec2f((1.0 - sy) * 0.5 * p, (1.0 + sx) * 0.5 * r); }
            case 2u: { return vec2f((1.0 + sx) * 0.5 * p, (1.0 - sy) * 0.5 * r); }
            default: { return vec2f((1.0 + sx) * 0.5 * p, (1.0 + sy) * 0.5 * r); }
        }
    }
    return vec2f(plane_coord(f, phi_of_dir(f, v)), ray_coord(f, angle_between(f.axis.xyz, v)));
}

// The view direction at continuous grid coordinates (x, y): the inverse of grid_coords.
fn cell_dir(f: Frame, x: f32, y: f32) -> vec3f {
    if (is_cartesian()) {
        let u = x / f32(f.grid.x) * 2.0;
        let w = y / f32(f.grid.y) * 2.0;
        var sx = 0.0;
        var sy = 0.0;
        switch f.table.z {
            case 0u: { sy = 1.0 - u; sx = 1.0 - w; }
            case 1u: { sy = 1.0 - u; sx = w - 1.0; }
            case 2u: { sx = u - 1.0; sy = 1.0 - w; }
            default: { sx = u - 1.0; sy = w - 1.0; }
        }
        return normalize(f.cam_fwd.xyz + f.cam_right.xyz * (sx * f.cam_right.w) + f.cam_up.xyz * (sy * f.cam_up.w));
    }
    return dir_of(f, phi_of_plane(f, x), gamma_of_ray(f, y));
}

// ---- phase functions (src/params.rs, Phase::eval) ------------------------------------------

// The lobes' denominator 1 + g^2 - 2 g c, written as a sum of non-negative terms so that it keeps
// its relative precision at the peak (numerical-stability fix, docs/stability.md): in f32 the plain
// form cancels to ~1e-7 absolute while the peak value of |g| = 0.999 is d = 1e-6, a 10% error in
// the phase there. omc = 1 - c, opc = 1 + c (exact when the caller knows the angle).
fn lobe_den(g: f32, omc: f32, opc: f32) -> f32 {
    if (g >= 0.0) { return (1.0 - g) * (1.0 - g) + 2.0 * g * omc; }
    return (1.0 + g) * (1.0 + g) - 2.0 * g * opc;
}

fn phase_core(g: f32, c: f32, omc: f32, opc: f32) -> f32 {
    switch PHASE {
        case 1u: { // Henyey-Greenstein
            let d = lobe_den(g, omc, opc);
            return (1.0 - g) * (1.0 + g) * INV_4PI / (d * sqrt(d));
        }
        case 2u: { // Schlick
            let k = 1.55 * g - 0.55 * g * g * g;
            let d = select((1.0 + k) - k * opc, (1.0 - k) + k * omc, k >= 0.0); // 1 - k c
            return (1.0 - k) * (1.0 + k) * INV_4PI / (d * d);
        }
        case 3u: { // Cornette-Shanks
            let d = lobe_den(g, omc, opc);
            return 3.0 * (1.0 - g) * (1.0 + g) * (1.0 + c * c) / (8.0 * PI * (2.0 + g * g) * d * sqrt(d));
        }
        case 4u: { // Rayleigh
            return 3.0 * (1.0 + c * c) / (16.0 * PI);
        }
        default: { return INV_4PI; }
    }
}

// The phase function of the cosine c of the deflection angle.
fn phase(g: f32, c: f32) -> f32 {
    return phase_core(g, c, 1.0 - c, 1.0 + c);
}

// The phase function of the deflection angle theta itself: 1 -+ cos(theta) from half-angle sines,
// exact near the lobes' peaks where cos(theta) has lost them (f32 cos(1e-3) keeps 1 - c to 12%).
fn phase_of_angle(g: f32, theta: f32) -> f32 {
    let s = sin(0.5 * theta);
    let co = cos(0.5 * theta);
    return phase_core(g, cos(theta), 2.0 * s * s, 2.0 * co * co);
}

// (1 - exp(-x)) / x, accurate for small x (the expm1 trap of DESIGN section 5). The direct form
// loses ~ulp / x (3e-5 at x = 1e-3, where the old 3-term series took over); the 7-term series is
// used up to x = 0.5 (truncation x^7 / 8! < 2e-7) and the direct form beyond (error < 4e-7).
fn one_minus_exp_over_x(x: vec3f) -> vec3f {
    let series = 1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0 - x * (1.0 / 720.0 - x * (1.0 / 5040.0))))));
    let direct = (1.0 - exp(-x)) / max(x, vec3f(1e-30));
    return select(direct, series, abs(x) < vec3f(0.5));
}

// Its series alone for one channel, for |x| < 1/2 (a grey medium: integrate.wgsl's
// piece_integral_grey, which takes the other side without an exponential of its own).
fn one_minus_exp_over_x_series1(x: f32) -> f32 {
    return 1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0 - x * (1.0 / 120.0 - x * (1.0 / 720.0 - x * (1.0 / 5040.0))))));
}

// v's components in ascending order, by a min/max network (no private array to sort in:
// docs/architecture.md, "No private arrays in the hot shaders").
fn sort3(v: vec3f) -> vec3f {
    let lo = min(v.x, v.y);
    let hi = max(v.x, v.y);
    let m = min(hi, v.z);
    return vec3f(min(lo, m), max(lo, m), max(hi, v.z));
}

// A direction with no zero component, so slab tests never compute 0 * inf.
fn safe_dir(d: vec3f) -> vec3f {
    let s = select(vec3f(1.0), vec3f(-1.0), d < vec3f(0.0));
    return select(d, s * 1e-20, abs(d) < vec3f(1e-20));
}

// Length of the segment from p in direction w (unit) inside the box [lo, hi]; p is inside.
fn exit_distance(p: vec3f, w: vec3f, lo: vec3f, hi: vec3f) -> f32 {
    let inv = 1.0 / safe_dir(w);
    let t1 = (lo - p) * inv;
    let t2 = (hi - p) * inv;
    let tmax = max(t1, t2);
    return max(0.0, min(tmax.x, min(tmax.y, tmax.z)));
}

// [t_in, t_out] of a ray against a box; t_in > t_out means a miss.
fn box_span(o: vec3f, d: vec3f, lo: vec3f, hi: vec3f) -> vec2f {
    let inv = 1.0 / safe_dir(d);
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    let tmin = min(t1, t2);
    let tmax = max(t1, t2);
    return vec2f(max(0.0, max(tmin.x, max(tmin.y, tmin.z))), min(tmax.x, min(tmax.y, tmax.z)));
}

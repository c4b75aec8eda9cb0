// The editor's viewport: shows one of the renderer's linear RGBA32Float images inside egui's render
// pass (an egui_wgpu paint callback), in two steps:
//
//   fs_tonemap  once per picture or exposure, at the picture's size, into an RGBA8 texture:
//               c = encode_srgb(aces(exposure * hdr))   (the ACES fit of `tone_map_aces`, src/image.rs)
//   fs_show     every UI frame, over the viewport's rectangle: that texture, filtered bilinearly
//               (fs_show_linear decodes it to linear for an *Srgb target, which encodes on write).
//
// Why two: the window repaints far more often than pictures arrive (every hover and drag), and on the
// software driver the tone curve, the sRGB encoding and four float fetches per pixel on every repaint
// were a third of a UI frame; one 8-bit filtered fetch per pixel is what a repaint now pays. Previews
// smaller than the viewport are filtered after the tone curve, as image viewers do.
//
// A full-screen triangle covers the target (egui sets the viewport to the widget's rectangle).

struct Display {
    // 2^stops.
    exposure: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

// fs_tonemap's inputs (the picture's bind group).
@group(0) @binding(0) var<uniform> display: Display;
@group(0) @binding(1) var image: texture_2d<f32>;
// fs_show's inputs (the tone-mapped picture).
@group(0) @binding(2) var shown: texture_2d<f32>;
@group(0) @binding(3) var shown_sampler: sampler;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_main(@builtin(vertex_index) index: u32) -> VertexOut {
    // (0,0), (2,0), (0,2): one triangle that covers the unit square.
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    var out: VertexOut;
    out.position = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.0, 1.0);
    out.uv = uv;
    return out;
}

// Narkowicz's fit of the ACES curve, as `tone_map_aces` in src/image.rs (NaN and negatives to 0).
fn tone_map_aces(x: f32) -> f32 {
    if !(x > 0.0) {
        return 0.0;
    }
    let c = min(x, 1.0e4);
    let y = (c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14);
    return clamp(y, 0.0, 1.0);
}

fn encode_srgb(l: f32) -> f32 {
    let c = clamp(l, 0.0, 1.0);
    if c <= 0.0031308 {
        return 12.92 * c;
    }
    return 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

fn decode_srgb(e: f32) -> f32 {
    if e <= 0.04045 {
        return e / 12.92;
    }
    return pow((e + 0.055) / 1.055, 2.4);
}

// One texel of the picture per target pixel (the target has the picture's size).
@fragment
fn fs_tonemap(in: VertexOut) -> @location(0) vec4<f32> {
    let hdr = textureLoad(image, vec2<i32>(in.position.xy), 0).rgb * display.exposure;
    let mapped = vec3<f32>(tone_map_aces(hdr.r), tone_map_aces(hdr.g), tone_map_aces(hdr.b));
    return vec4<f32>(encode_srgb(mapped.r), encode_srgb(mapped.g), encode_srgb(mapped.b), 1.0);
}

// The tone-mapped picture as it is (a target that stores encoded values). Kept to a plain texture
// fetch on purpose: on llvmpipe this costs about what a constant colour does over the viewport,
// while the same fetch followed by a branch cost several times more (measured in the window).
@fragment
fn fs_show(in: VertexOut) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSample(shown, shown_sampler, in.uv).rgb, 1.0);
}

// The same, decoded to linear, for a target that encodes on write (an *Srgb format).
@fragment
fn fs_show_linear(in: VertexOut) -> @location(0) vec4<f32> {
    let c = textureSample(shown, shown_sampler, in.uv).rgb;
    return vec4<f32>(decode_srgb(c.r), decode_srgb(c.g), decode_srgb(c.b), 1.0);
}

// The editor's viewport: shows one of the renderer's linear RGBA32Float images inside egui's render
// pass (an egui_wgpu paint callback), with exposure, the ACES-fitted tone curve of `src/image.rs`
// (`tone_map_aces`) and, when the window's surface is not an sRGB format, the sRGB encoding.
//
// A full-screen triangle covers the callback's viewport (egui sets it to the widget's rectangle).
// The image may be smaller than the viewport (a preview, or fewer pixels): it is filtered
// bilinearly by hand, with four textureLoads, because RGBA32Float is not filterable everywhere.

struct Display {
    // 2^stops.
    exposure: f32,
    // 1: the target stores linear values (an *Srgb format encodes on write); 0: encode here.
    linear_target: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<uniform> display: Display;
@group(0) @binding(1) var image: texture_2d<f32>;

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

// The linear image at `uv` (0..1), bilinear between the four nearest texel centres.
fn sample_linear(uv: vec2<f32>) -> vec3<f32> {
    let dims = vec2<i32>(textureDimensions(image));
    let p = clamp(uv, vec2<f32>(0.0), vec2<f32>(1.0)) * vec2<f32>(dims) - vec2<f32>(0.5);
    let f = fract(p);
    let i0 = clamp(vec2<i32>(floor(p)), vec2<i32>(0), dims - vec2<i32>(1));
    let i1 = min(i0 + vec2<i32>(1), dims - vec2<i32>(1));
    let a = textureLoad(image, i0, 0).rgb;
    let b = textureLoad(image, vec2<i32>(i1.x, i0.y), 0).rgb;
    let c = textureLoad(image, vec2<i32>(i0.x, i1.y), 0).rgb;
    let d = textureLoad(image, i1, 0).rgb;
    return mix(mix(a, b, f.x), mix(c, d, f.x), f.y);
}

@fragment
fn fs_main(in: VertexOut) -> @location(0) vec4<f32> {
    let hdr = sample_linear(in.uv) * display.exposure;
    var mapped = vec3<f32>(tone_map_aces(hdr.r), tone_map_aces(hdr.g), tone_map_aces(hdr.b));
    if display.linear_target == 0u {
        mapped = vec3<f32>(encode_srgb(mapped.r), encode_srgb(mapped.g), encode_srgb(mapped.b));
    }
    return vec4<f32>(mapped, 1.0);
}

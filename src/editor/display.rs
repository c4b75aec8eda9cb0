//! Putting a finished picture on screen: `shaders/display.wgsl` drawn inside egui's render pass
//! through an `egui_wgpu` paint callback.
//!
//! The render worker (its own device) reads each frame back and writes the final and the
//! scattered image into two textures on the *window's* device ([`DisplayImages::upload`], called
//! on the worker thread: wgpu queues are shared between threads). The UI thread never renders a
//! frame, waits or copies pixels: when the picture or the exposure changes, the callback's
//! `prepare` records one small pass that tone-maps the picture into an 8-bit texture at the
//! picture's size ([`ShownImage`]); every repaint then draws that texture, one filtered fetch per
//! pixel. (Drawing the float picture through the tone curve on every repaint cost about 13 of the
//! 45 ms a UI frame took on the software driver; docs/editor.md.)

use crate::gpu::{GpuContext, GpuError, ShaderLibrary};
use crate::image::Image;
use crate::render::util::{texture_2d, texture_entry, uniform_entry};
use eframe::egui_wgpu::{CallbackResources, CallbackTrait, ScreenDescriptor};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// Which of the two images the viewport shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Shown {
    Hdr,
    Scatter,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DisplayUniforms {
    exposure: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// The display shader's bind group layout. Written here, not reflected, so a reloaded
/// `display.wgsl` must match it (a mismatch is a reload error, and the old pipeline stays).
pub fn display_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("editor::Display::layout"),
        entries: &[uniform_entry(0, fragment), texture_entry(1, fragment, wgpu::TextureViewDimension::D2)],
    })
}

/// A unique id per pipeline and per picture, so the tone-mapped texture knows what it shows
/// (addresses can be reused once freed; ids are not).
fn next_id() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// The format of the tone-mapped picture: sRGB-encoded values in plain 8-bit channels.
const SHOWN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The two pipelines of `display.wgsl`: the tone curve into [`SHOWN_FORMAT`] and the filtered draw
/// into the window's format, with the layout of the second one's inputs.
pub struct DisplayPipeline {
    id: u64,
    tonemap: wgpu::RenderPipeline,
    show: wgpu::RenderPipeline,
    show_layout: wgpu::BindGroupLayout,
}

impl DisplayPipeline {
    /// Builds the pipelines from `lib`'s `display.wgsl` inside an error scope (error scopes are per
    /// thread, so this may run on the worker). `layout` is the pictures' layout ([`display_layout`]).
    pub fn new(
        ctx: &GpuContext,
        lib: &ShaderLibrary,
        layout: &wgpu::BindGroupLayout,
        format: wgpu::TextureFormat,
    ) -> Result<DisplayPipeline, GpuError> {
        let d = &ctx.device;
        ctx.scoped("creating the display pipeline", || -> Result<DisplayPipeline, GpuError> {
            let module = lib.module(d, "display.wgsl")?;
            let show_layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some("editor::Display::show_layout"),
                entries: &[
                    wgpu::BindGroupLayoutEntry {
                        binding: 2,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Texture {
                            sample_type: wgpu::TextureSampleType::Float { filterable: true },
                            view_dimension: wgpu::TextureViewDimension::D2,
                            multisampled: false,
                        },
                        count: None,
                    },
                    wgpu::BindGroupLayoutEntry {
                        binding: 3,
                        visibility: wgpu::ShaderStages::FRAGMENT,
                        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                        count: None,
                    },
                ],
            });
            let pipeline = |label: &'static str, layout: &wgpu::BindGroupLayout, entry: &str, format| {
                let pl = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                    label: Some(label),
                    bind_group_layouts: &[Some(layout)],
                    immediate_size: 0,
                });
                d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(&pl),
                    vertex: wgpu::VertexState {
                        module: &module,
                        entry_point: Some("vs_main"),
                        compilation_options: Default::default(),
                        buffers: &[],
                    },
                    fragment: Some(wgpu::FragmentState {
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        targets: &[Some(wgpu::ColorTargetState {
                            format,
                            blend: None,
                            write_mask: wgpu::ColorWrites::ALL,
                        })],
                    }),
                    primitive: wgpu::PrimitiveState::default(),
                    // egui's pass: no depth attachment and one sample (eframe is started that way).
                    depth_stencil: None,
                    multisample: wgpu::MultisampleState::default(),
                    multiview_mask: None,
                    cache: None,
                })
            };
            let tonemap = pipeline("editor::Display::tonemap_pipeline", layout, "fs_tonemap", SHOWN_FORMAT);
            // An *Srgb target encodes on write: give it linear values.
            let show_entry = if format.is_srgb() { "fs_show_linear" } else { "fs_show" };
            let show = pipeline("editor::Display::show_pipeline", &show_layout, show_entry, format);
            Ok(DisplayPipeline { id: next_id(), tonemap, show, show_layout })
        })?
    }

    /// Draws a tone-mapped texture (its bind group from `show_bind_group`) over the callback's
    /// rectangle, inside egui's pass.
    fn draw(&self, pass: &mut wgpu::RenderPass<'static>, bind_group: &wgpu::BindGroup) {
        pass.set_pipeline(&self.show);
        pass.set_bind_group(0, bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

/// One picture's images on the window's device, with the bind groups that tone-map them.
pub struct DisplayImages {
    id: u64,
    size: (u32, u32),
    uniforms: wgpu::Buffer,
    hdr: wgpu::BindGroup,
    scatter: wgpu::BindGroup,
}

impl std::fmt::Debug for DisplayImages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "DisplayImages({}x{})", self.size.0, self.size.1)
    }
}

impl DisplayImages {
    /// Creates the textures on `ui` (the window's device) and queues the pixels' upload; the
    /// window's next submission carries it, before the frame that shows them.
    pub fn upload(ui: &GpuContext, layout: &wgpu::BindGroupLayout, hdr: &Image, scatter: &Image) -> DisplayImages {
        let d = &ui.device;
        let uniforms = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("editor::Display::uniforms"),
            size: std::mem::size_of::<DisplayUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind = |img: &Image, label: &'static str| {
            let size = wgpu::Extent3d { width: img.width, height: img.height, depth_or_array_layers: 1 };
            let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
            let texture = texture_2d(d, label, img.width, img.height, 1, wgpu::TextureFormat::Rgba32Float, usage);
            let rgba: Vec<f32> = img.pixels.iter().flat_map(|p| [p[0], p[1], p[2], 1.0]).collect();
            ui.queue.write_texture(
                texture.as_image_copy(),
                bytemuck::cast_slice(&rgba),
                wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(img.width * 16), rows_per_image: None },
                size,
            );
            let view = texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("editor::Display::image_view"),
                ..Default::default()
            });
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("editor::Display::bind_group"),
                layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&view) },
                ],
            })
        };
        let hdr_group = bind(hdr, "editor::Display::hdr");
        let scatter_group = bind(scatter, "editor::Display::scatter");
        DisplayImages { id: next_id(), size: (hdr.width, hdr.height), uniforms, hdr: hdr_group, scatter: scatter_group }
    }
}

/// What the tone-mapped texture holds: which picture, which image, at what exposure, drawn by
/// which pipeline (a reload may change the tone curve).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct ShownKey {
    images: u64,
    shown: Shown,
    exposure_bits: u32,
    pipeline: u64,
}

/// The picture on screen, tone-mapped into [`SHOWN_FORMAT`] at its own size, with the bind group
/// that draws it. Kept while the size and the pipeline stay; redrawn when the key changes.
struct ShownImage {
    key: ShownKey,
    size: (u32, u32),
    view: wgpu::TextureView,
    bind_group: wgpu::BindGroup,
}

impl ShownImage {
    fn new(device: &wgpu::Device, display: &DisplayPipeline, key: ShownKey, size: (u32, u32)) -> ShownImage {
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let texture =
            texture_2d(device, "editor::Display::shown", size.0.max(1), size.1.max(1), 1, SHOWN_FORMAT, usage);
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            label: Some("editor::Display::shown_view"),
            ..Default::default()
        });
        let bind_group = show_bind_group(device, display, &texture, wgpu::FilterMode::Linear);
        ShownImage { key, size, view, bind_group }
    }
}

/// What the window keeps in egui_wgpu's callback resources: the display pipelines (replaced by a
/// successful reload) and the tone-mapped picture.
pub struct ViewportResources {
    pub display: DisplayPipeline,
    shown: Option<ShownImage>,
    pictures: HashMap<PictureSlot, SlotTexture>,
}

impl ViewportResources {
    pub fn new(display: DisplayPipeline) -> ViewportResources {
        ViewportResources { display, shown: None, pictures: HashMap::new() }
    }
}

/// The paint callback of one viewport frame: the picture to show, which image, at what exposure.
pub struct ViewportCallback {
    pub images: Arc<DisplayImages>,
    pub shown: Shown,
    /// In stops.
    pub exposure: f32,
}

impl CallbackTrait for ViewportCallback {
    /// Tone-maps the picture when it, the image shown, the exposure or the pipeline changed: one
    /// pass at the picture's size, recorded before egui's render pass. Otherwise nothing.
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<ViewportResources>() else { return Vec::new() };
        let exposure = 2f32.powf(self.exposure);
        let key = ShownKey {
            images: self.images.id,
            shown: self.shown,
            exposure_bits: exposure.to_bits(),
            pipeline: res.display.id,
        };
        if res.shown.as_ref().is_some_and(|s| s.key == key) {
            return Vec::new();
        }
        let size = self.images.size;
        let mut shown = match res.shown.take() {
            Some(s) if s.size == size && s.key.pipeline == key.pipeline => s,
            _ => ShownImage::new(device, &res.display, key, size),
        };
        shown.key = key;
        let u = DisplayUniforms { exposure, _pad0: 0, _pad1: 0, _pad2: 0 };
        queue.write_buffer(&self.images.uniforms, 0, bytemuck::bytes_of(&u));
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("editor::Display::tonemap_pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &shown.view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&res.display.tonemap);
            pass.set_bind_group(
                0,
                match self.shown {
                    Shown::Hdr => &self.images.hdr,
                    Shown::Scatter => &self.images.scatter,
                },
                &[],
            );
            pass.draw(0..3, 0..1);
        }
        res.shown = Some(shown);
        Vec::new()
    }

    fn paint(
        &self,
        _info: eframe::egui::epaint::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else { return };
        if let Some(shown) = &res.shown {
            res.display.draw(pass, &shown.bind_group);
        }
    }
}

/// An opaque 8-bit sRGB picture drawn by the display's fast path, [`PictureCallback`] (the
/// inspector's pictures): the same as an egui image of it, at a fraction of the cost on the
/// software driver, where egui's shader decodes and re-encodes every pixel of every repaint.
pub struct FlatPicture {
    id: u64,
    pub image: eframe::egui::ColorImage,
}

impl FlatPicture {
    pub fn new(image: eframe::egui::ColorImage) -> Arc<FlatPicture> {
        Arc::new(FlatPicture { id: next_id(), image })
    }
}

/// Where a [`FlatPicture`] is drawn; each slot keeps one texture on the window's device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PictureSlot {
    InspectorGrid,
    InspectorSlice,
}

/// A slot's texture and what it holds (picture id, pipeline id).
struct SlotTexture {
    holds: (u64, u64),
    size: [usize; 2],
    texture: wgpu::Texture,
    bind_group: wgpu::BindGroup,
}

/// Draws a [`FlatPicture`] over the callback's rectangle, texel for texel (nearest), uploading it
/// to its slot's texture when the slot holds another picture.
pub struct PictureCallback {
    pub slot: PictureSlot,
    pub picture: Arc<FlatPicture>,
}

impl CallbackTrait for PictureCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<ViewportResources>() else { return Vec::new() };
        let img = &self.picture.image;
        let holds = (self.picture.id, res.display.id);
        if img.size[0] == 0 || img.size[1] == 0 || res.pictures.get(&self.slot).is_some_and(|t| t.holds == holds) {
            return Vec::new();
        }
        let slot = match res.pictures.remove(&self.slot) {
            Some(t) if t.size == img.size && t.holds.1 == holds.1 => t,
            _ => {
                let (w, h) = (img.size[0] as u32, img.size[1] as u32);
                let usage = wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST;
                let texture = texture_2d(device, "editor::Display::picture", w, h, 1, SHOWN_FORMAT, usage);
                let bind_group = show_bind_group(device, &res.display, &texture, wgpu::FilterMode::Nearest);
                SlotTexture { holds, size: img.size, texture, bind_group }
            }
        };
        queue.write_texture(
            slot.texture.as_image_copy(),
            img.as_raw(),
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(img.size[0] as u32 * 4),
                rows_per_image: None,
            },
            slot.texture.size(),
        );
        res.pictures.insert(self.slot, SlotTexture { holds, ..slot });
        Vec::new()
    }

    fn paint(
        &self,
        _info: eframe::egui::epaint::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else { return };
        if let Some(slot) = res.pictures.get(&self.slot) {
            res.display.draw(pass, &slot.bind_group);
        }
    }
}

/// The bind group that draws `texture` with `display`'s show pipeline.
fn show_bind_group(
    device: &wgpu::Device,
    display: &DisplayPipeline,
    texture: &wgpu::Texture,
    filter: wgpu::FilterMode,
) -> wgpu::BindGroup {
    let view = texture
        .create_view(&wgpu::TextureViewDescriptor { label: Some("editor::Display::show_view"), ..Default::default() });
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("editor::Display::show_sampler"),
        mag_filter: filter,
        min_filter: filter,
        ..Default::default()
    });
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("editor::Display::show_bind_group"),
        layout: &display.show_layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 3, resource: wgpu::BindingResource::Sampler(&sampler) },
        ],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use eframe::egui;

    #[test]
    fn display_uniforms_match_wgsl() {
        let (module, _) = ShaderLibrary::embedded().validate("display.wgsl").unwrap_or_else(|e| panic!("{e}"));
        let (members, span) = module
            .types
            .iter()
            .find_map(|(_, ty)| match &ty.inner {
                naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some("Display") => Some((
                    members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect::<Vec<_>>(),
                    *span,
                )),
                _ => None,
            })
            .expect("struct Display in display.wgsl");
        let rust = [
            ("exposure", std::mem::offset_of!(DisplayUniforms, exposure)),
            ("_pad0", std::mem::offset_of!(DisplayUniforms, _pad0)),
            ("_pad1", std::mem::offset_of!(DisplayUniforms, _pad1)),
            ("_pad2", std::mem::offset_of!(DisplayUniforms, _pad2)),
        ];
        let rust: Vec<(String, u32)> = rust.iter().map(|(n, o)| (n.to_string(), *o as u32)).collect();
        assert_eq!(members, rust);
        assert_eq!(span as usize, std::mem::size_of::<DisplayUniforms>());
    }

    /// Draws `cb` as egui would (prepare, then paint inside a pass) into a `w` x `h` RGBA8 target
    /// and reads it back.
    fn draw(gpu: &GpuContext, res: &mut CallbackResources, cb: &ViewportCallback, w: u32, h: u32) -> Vec<u8> {
        let d = &gpu.device;
        let target = d.create_texture(&wgpu::TextureDescriptor {
            label: Some("display test target"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = target.create_view(&Default::default());
        let mut enc = d.create_command_encoder(&Default::default());
        let screen = ScreenDescriptor { size_in_pixels: [w, h], pixels_per_point: 1.0 };
        let extra = cb.prepare(d, &gpu.queue, &screen, &mut enc, res);
        assert!(extra.is_empty());
        {
            let pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("display test pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color::RED), store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            let mut pass = pass.forget_lifetime();
            let rect = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(w as f32, h as f32));
            let info = egui::epaint::PaintCallbackInfo {
                viewport: rect,
                clip_rect: rect,
                pixels_per_point: 1.0,
                screen_size_px: [w, h],
            };
            cb.paint(info, &mut pass, res);
        }
        let row = (w * 4).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let staging = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("display test staging"),
            size: (row * h) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(h) },
            },
            target.size(),
        );
        gpu.queue.submit([enc.finish()]);
        let bytes = gpu.map_read(&staging).expect("read back");
        (0..h as usize).flat_map(|y| bytes[y * row as usize..][..w as usize * 4].to_vec()).collect()
    }

    fn max_diff(a: &[u8], b: &[u8]) -> u8 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
    }

    /// The window shows what `Image::to_srgb8` writes to a PNG, within one step of 8 bits (the
    /// GPU's pow and division round differently from Rust's), for the image and exposure asked
    /// for: a new picture, another exposure or the other image is tone-mapped again, the same
    /// ones are not.
    #[test]
    fn the_viewport_shows_the_tone_mapped_picture_and_follows_its_inputs() {
        let Ok(gpu) = GpuContext::headless() else {
            eprintln!("SKIPPED: no GPU adapter at all (install mesa-vulkan-drivers for the software one)");
            return;
        };
        let (w, h) = (64u32, 16u32);
        let ramp = |k: f32| {
            let px = (0..w * h).map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [k * x / 8.0, k * y / 4.0, k * (x + y) / 64.0]
            });
            Image::from_pixels(w, h, px.collect()).expect("image")
        };
        let (hdr, scatter, other) = (ramp(1.0), ramp(0.05), ramp(3.0));
        let layout = display_layout(&gpu.device);
        let display = DisplayPipeline::new(&gpu, &ShaderLibrary::embedded(), &layout, wgpu::TextureFormat::Rgba8Unorm)
            .expect("display pipeline");
        let mut res = CallbackResources::default();
        res.insert(ViewportResources::new(display));
        let first = Arc::new(DisplayImages::upload(&gpu, &layout, &hdr, &scatter));
        let cb =
            |images: &Arc<DisplayImages>, shown, exposure| ViewportCallback { images: images.clone(), shown, exposure };

        let tone_maps =
            |res: &CallbackResources| res.get::<ViewportResources>().and_then(|r| r.shown.as_ref().map(|s| s.key));
        let got = draw(&gpu, &mut res, &cb(&first, Shown::Hdr, 0.0), w, h);
        assert!(max_diff(&got, &hdr.to_srgb8(0.0)) <= 1, "the final image at 0 EV");
        let key = tone_maps(&res);
        let again = draw(&gpu, &mut res, &cb(&first, Shown::Hdr, 0.0), w, h);
        assert_eq!(got, again);
        assert_eq!(tone_maps(&res), key, "the same picture was tone-mapped again");

        let got = draw(&gpu, &mut res, &cb(&first, Shown::Hdr, 1.5), w, h);
        assert!(max_diff(&got, &hdr.to_srgb8(1.5)) <= 1, "the final image at 1.5 EV");
        let got = draw(&gpu, &mut res, &cb(&first, Shown::Scatter, 4.0), w, h);
        assert!(max_diff(&got, &scatter.to_srgb8(4.0)) <= 1, "the scattered light at 4 EV");
        let second = Arc::new(DisplayImages::upload(&gpu, &layout, &other, &scatter));
        let got = draw(&gpu, &mut res, &cb(&second, Shown::Hdr, 1.5), w, h);
        assert!(max_diff(&got, &other.to_srgb8(1.5)) <= 1, "a new picture");

        // A preview drawn over a viewport twice its size: every pixel between its texels' values.
        let small = Arc::new(DisplayImages::upload(&gpu, &layout, &hdr, &scatter));
        let big = draw(&gpu, &mut res, &cb(&small, Shown::Hdr, 0.0), 2 * w, 2 * h);
        let texels = hdr.to_srgb8(0.0);
        for y in 0..2 * h as usize {
            for x in 0..2 * w as usize {
                let (tx, ty) = (x / 2, y / 2);
                for c in 0..3 {
                    let near = |dx: i64, dy: i64| {
                        let (nx, ny) =
                            ((tx as i64 + dx).clamp(0, w as i64 - 1), (ty as i64 + dy).clamp(0, h as i64 - 1));
                        texels[(ny as usize * w as usize + nx as usize) * 4 + c]
                    };
                    let around: Vec<u8> =
                        (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (dx, dy))).map(|(dx, dy)| near(dx, dy)).collect();
                    let v = big[(y * 2 * w as usize + x) * 4 + c] as u16;
                    let (lo, hi) =
                        (*around.iter().min().unwrap_or(&0) as u16, *around.iter().max().unwrap_or(&255) as u16);
                    assert!(v + 1 >= lo && v <= hi + 1, "pixel ({x}, {y}) channel {c}: {v} outside [{lo}, {hi}]");
                }
            }
        }
    }
}

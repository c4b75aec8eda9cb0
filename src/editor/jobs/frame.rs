//! What the UI and the render worker exchange: requests, finished pictures, failures and events.

use crate::editor::display::{DisplayImages, DisplayPipeline};
use crate::editor::document::Look;
use crate::editor::panels::inspector::GridSnapshot;
use crate::editor::panels::GridLimits;
use crate::image::Image;
use crate::params::Grid;
use crate::render::{FrameInfo, Method, PruneReport, ShadowVolume, SurfaceShadows};
use crate::scene::{Camera, Scene};
use std::sync::Arc;

/// Grids above this are not read back for the inspector: reading hundreds of MiB per frame would
/// slow every frame down.
pub const INSPECT_LIMIT: u64 = 256 << 20;

/// Everything that decides a picture (the exposure is applied at display time).
#[derive(Clone)]
pub struct FrameRequest {
    /// Changes whenever the picture must be drawn again.
    pub generation: u64,
    /// The scene as loaded; the worker keeps its own copy per `scene_generation` and writes the
    /// look into it (no scene clone per edit).
    pub scene: Arc<Scene>,
    pub scene_generation: u64,
    pub look: Look,
    /// "Surfaces" view: the medium's density at 0.
    pub surface_only: bool,
    pub width: u32,
    pub height: u32,
    pub method: Method,
    pub shadow_map: u32,
    /// Where the surfaces' shadows come from (`Renderer::surface_shadows`).
    pub surface_shadows: SurfaceShadows,
    /// How VSV keeps its shadow volume (`Renderer::shadow_volume`).
    pub shadow_volume: ShadowVolume,
    /// Integrate takes pixels from their neighbours (`Renderer::adaptive_pixels`).
    pub adaptive_pixels: bool,
    /// The user is dragging or scrolling: previews only; the full frame when this turns false.
    pub interactive: bool,
    /// Previews allowed (off while measuring full frames with `--quit-after-frames`).
    pub progressive: bool,
    /// Read the grids back for the inspector (full frames only).
    pub grids: bool,
}

/// Full quality, or a preview at a scale of the pixels and the grid's planes, rays and bins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Quality {
    Full,
    Preview(f32),
}

impl Quality {
    pub fn is_full(&self) -> bool {
        *self == Quality::Full
    }
}

/// Luminance statistics of the two images (auto-exposure).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ImageStats {
    pub hdr_mean: f32,
    pub hdr_p99: f32,
    pub scatter_mean: f32,
    pub scatter_p99: f32,
}

fn mean_and_p99(img: &Image) -> (f32, f32) {
    let mut l: Vec<f32> =
        img.pixels.iter().map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]).filter(|v| v.is_finite()).collect();
    if l.is_empty() {
        return (0.0, 0.0);
    }
    let mean = (l.iter().map(|v| *v as f64).sum::<f64>() / l.len() as f64) as f32;
    let k = ((l.len() - 1) as f64 * 0.99) as usize;
    let (_, p99, _) = l.select_nth_unstable_by(k, f32::total_cmp);
    (mean, *p99)
}

impl ImageStats {
    pub fn of(hdr: &Image, scatter: &Image) -> ImageStats {
        let (hdr_mean, hdr_p99) = mean_and_p99(hdr);
        let (scatter_mean, scatter_p99) = mean_and_p99(scatter);
        ImageStats { hdr_mean, hdr_p99, scatter_mean, scatter_p99 }
    }
}

/// A finished frame: its images on the window's device and on the CPU, and what it measured.
pub struct Picture {
    pub generation: u64,
    pub quality: Quality,
    pub width: u32,
    pub height: u32,
    pub grid: Grid,
    pub method: Method,
    /// The look it shows (tests check that only the newest state was rendered).
    pub look: Look,
    pub camera: Camera,
    pub info: FrameInfo,
    pub prune: Option<PruneReport>,
    /// `Renderer::render`: recording, GPU, reading the images back (ms).
    pub render_ms: f64,
    /// From taking the request to delivering (ms), upload and statistics included.
    pub total_ms: f64,
    pub stats: ImageStats,
    /// CPU copies (screenshots).
    pub hdr: Image,
    pub scatter: Image,
    pub display: Arc<DisplayImages>,
    /// The grids, for the inspector (full frames while it is shown).
    pub grids: Option<Arc<GridSnapshot>>,
}

/// A frame that could not be rendered (the last picture stays).
#[derive(Debug, Clone)]
pub struct FrameFailure {
    pub generation: u64,
    pub error: String,
}

/// The worker's device.
#[derive(Debug, Clone)]
pub struct DeviceInfo {
    pub adapter: String,
    pub software: bool,
    pub timestamps: bool,
    pub limits: GridLimits,
    /// The worker renders on the window's device (no second one could be opened, or asked so).
    pub shared_queue: bool,
    /// The shader folder did not build at start-up: the embedded shaders run until it is fixed.
    pub startup_error: Option<String>,
}

/// What the worker delivers.
pub enum RenderEvent {
    /// The worker's device and renderer are ready, or could not be created.
    Started(Result<DeviceInfo, String>),
    /// The worker ended unexpectedly (a panic in the driver or the renderer): nothing more will
    /// render; the last picture stays.
    Stopped(String),
    Frame(Result<Arc<Picture>, FrameFailure>),
    /// A reload finished: the new display pipeline and how long compiling took (ms), or the error
    /// (the old pipelines keep running).
    Reloaded(Result<(DisplayPipeline, f64), String>),
    /// The GPU images (scattered, final) of a capture for the accuracy check.
    Captured(u64, Result<(Image, Image), String>),
}

impl std::fmt::Debug for RenderEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RenderEvent::Started(r) => write!(f, "Started({:?})", r.as_ref().map(|d| &d.adapter)),
            RenderEvent::Stopped(e) => write!(f, "Stopped({e})"),
            RenderEvent::Frame(Ok(p)) => write!(f, "Frame({}, {:?})", p.generation, p.quality),
            RenderEvent::Frame(Err(e)) => write!(f, "Frame({e:?})"),
            RenderEvent::Reloaded(r) => write!(f, "Reloaded({:?})", r.as_ref().map(|(_, ms)| ms)),
            RenderEvent::Captured(id, r) => write!(f, "Captured({id}, {})", r.is_ok()),
        }
    }
}

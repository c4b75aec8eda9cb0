//! The editor: an eframe (egui) window around the wgpu renderer, for tuning a medium by eye.
//!
//! How an edit reaches the screen (one direction only, as everywhere in the crate):
//!
//! ```text
//!  panels (Panel::show: draw + emit)     viewport gestures, menus, shortcuts     jobs (Jobs::poll)
//!            │ Command                              │ Command                        │ Command::Job
//!            └──────────────────────────────────────┼────────────────────────────────┘
//!                                                   ▼
//!        Editor::apply — the ONE place that changes state: Document (scene, look, history),
//!                         View (modes, camera, inspector), Jobs, Session (files, messages)
//!                                                   │ Command::RequestFrame, once per UI frame
//!                                                   ▼
//!        FrameRequest { generation, scene, look, size, method, interactive } ─► RenderJob slot
//!                                                   │ (the newest replaces the waiting one)
//!                                                   ▼
//!        render worker thread, own wgpu device: preview (coarser, when a frame is slow) then
//!        full frame; Renderer::render reads the images back; textures written on the window's
//!        device; Picture { images, timings, prune report, grids } ─► channel + request_repaint
//!                                                   │
//!                                                   ▼
//!        UI: the newest Picture is shown by a paint callback (display.wgsl: exposure, ACES, sRGB);
//!            Stats, inspector and hover linking read it
//! ```
//!
//! Side jobs never block editing: shader edits arrive from a `notify` watcher thread and compile
//! on the render worker, scenes load on a thread, file dialogs run on threads (rfd, xdg portal),
//! and the accuracy reference renders on a thread with progress and cancel.
//!
//! See `docs/editor.md` for the user's view, the measurements and the tests.

mod app;
mod apply;
mod camera;
mod command;
mod display;
mod document;
mod files;
mod jobs;
mod measure;
mod panels;
mod session;
mod view;

pub use app::Editor;
pub use camera::CameraMode;
pub use command::{Command, MergeKey};
pub use document::{History, Look};
pub use jobs::accuracy::check_options;
pub use jobs::render::{Picture, Quality, RenderPriority};
pub use panels::inspector::InspectorMode;
pub use session::Message;
pub use view::{ExposureMode, ViewMode};

use crate::gpu::{GpuContext, GpuError};
use crate::preset::{Preset, PresetError};
use crate::scene::{builtin_scene, load_scene, Scene, SceneError};
use eframe::egui_wgpu;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// What the editor starts with. Everything but the scene, preset and shader folder is for tests
/// and measurements.
#[derive(Debug, Clone)]
pub struct EditorOptions {
    /// Scene file; the built-in scene when `None`.
    pub scene: Option<PathBuf>,
    /// Preset applied to the scene at start.
    pub preset: Option<PathBuf>,
    /// Shader folder to use and watch (see [`crate::gpu::ShaderLibrary::new`]).
    pub shader_dir: Option<PathBuf>,
    /// Folder listed in the Presets panel; `presets/` in the working directory or beside the crate.
    pub presets_dir: Option<PathBuf>,
    /// Where the recent-files list lives; `$EPIVOX_CONFIG_DIR`, else `$XDG_CONFIG_HOME/epivox`,
    /// else `~/.config/epivox`.
    pub config_dir: Option<PathBuf>,
    /// Watch the shader folder and reload on change.
    pub watch_shaders: bool,
    /// Quit after this many frames (re-rendering the viewport every frame, to measure it).
    pub quit_after_frames: Option<u32>,
    /// With `quit_after_frames`: save a screenshot of the whole window here before quitting.
    pub screenshot: Option<PathBuf>,
    /// Render on the window's device and queue instead of a second device (to measure the
    /// difference; also `EPIVOX_EDITOR_SHARED_DEVICE=1`).
    pub shared_device: bool,
    /// Tests: the render worker sleeps this long before each frame (a slow GPU on any machine).
    pub frame_delay: Option<Duration>,
    /// How the render worker shares the CPU with the window (`EPIVOX_EDITOR_RENDER_PRIORITY`
    /// overrides it).
    pub render_priority: RenderPriority,
}

impl Default for EditorOptions {
    fn default() -> Self {
        EditorOptions {
            scene: None,
            preset: None,
            shader_dir: None,
            presets_dir: None,
            config_dir: None,
            watch_shaders: true,
            quit_after_frames: None,
            screenshot: None,
            shared_device: false,
            frame_delay: None,
            render_priority: RenderPriority::default(),
        }
    }
}

/// Why the editor could not start or run.
#[derive(Debug, thiserror::Error)]
pub enum EditorError {
    #[error(
        "no display: the editor needs an X11 or Wayland display, and neither DISPLAY nor WAYLAND_DISPLAY \
         is set. Render without a window instead:\n  epivox render --out shafts.png\n(see `epivox render --help`)"
    )]
    NoDisplay,
    #[error(
        "could not open the editor window: {0}\nWithout a working display, render headless instead:\n  \
         epivox render --out shafts.png"
    )]
    Window(String),
    #[error("the window has no wgpu render state (eframe must run with its wgpu renderer)")]
    NoRenderState,
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Preset(#[from] PresetError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error("{0}")]
    Io(String),
}

/// True when a window can be opened: on Linux and the BSDs that needs `DISPLAY` (X11) or
/// `WAYLAND_DISPLAY`; elsewhere there is always a desktop.
pub fn display_available() -> bool {
    if cfg!(any(
        target_os = "linux",
        target_os = "freebsd",
        target_os = "dragonfly",
        target_os = "netbsd",
        target_os = "openbsd"
    )) {
        let set = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
        set("DISPLAY") || set("WAYLAND_DISPLAY")
    } else {
        true
    }
}

/// How eframe (and the tests' kittest renderer) should open the device: the primary backends only
/// (the passes need compute and storage buffers; no GL), with the adapter's own limits so that
/// large grids fit, and encoder timestamps when the adapter has them (the Stats panel).
pub fn wgpu_setup() -> egui_wgpu::WgpuSetup {
    let mut setup = egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    setup.instance_descriptor.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    setup.device_descriptor = Arc::new(|adapter: &wgpu::Adapter| wgpu::DeviceDescriptor {
        label: Some("epivox::editor::device"),
        required_features: adapter.features() & GpuContext::OPTIONAL_FEATURES,
        required_limits: adapter.limits(),
        ..Default::default()
    });
    egui_wgpu::WgpuSetup::CreateNew(setup)
}

/// How the window presents: eframe's default, or `EPIVOX_EDITOR_PRESENT=fifo|mailbox|
/// immediate|novsync` (to measure what presentation costs on a software driver).
fn surface_config() -> egui_wgpu::SurfaceConfig {
    let mut c = egui_wgpu::SurfaceConfig::HIGH_THROUGHPUT;
    let mode = std::env::var("EPIVOX_EDITOR_PRESENT").unwrap_or_default();
    c.present_mode = match mode.as_str() {
        "fifo" => wgpu::PresentMode::Fifo,
        "mailbox" => wgpu::PresentMode::Mailbox,
        "immediate" => wgpu::PresentMode::Immediate,
        "novsync" => wgpu::PresentMode::AutoNoVsync,
        _ => c.present_mode,
    };
    c
}

/// The scene, exposure and preset path the editor starts with: the scene file or the built-in
/// scene, with the preset applied. Errors name the file and the field.
pub fn initial_scene(opts: &EditorOptions) -> Result<(Scene, f32, Option<PathBuf>), EditorError> {
    let mut scene = match &opts.scene {
        Some(p) => load_scene(p)?,
        None => builtin_scene(),
    };
    let mut exposure = 0.0;
    if let Some(p) = &opts.preset {
        let preset = Preset::load(p)?;
        preset.apply(&mut scene);
        exposure = preset.exposure.unwrap_or(0.0);
    }
    Ok((scene, exposure, opts.preset.clone()))
}

/// What a run measured (printed by `epivox edit --quit-after-frames`).
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct RunSummary {
    /// Frames rendered.
    pub frames: u32,
    /// Wall time from one full frame on screen to the next (render, read-back, upload), mean (ms).
    pub frame_ms_mean: f64,
    /// `Renderer::render` wall time on the worker (record, GPU, read-back), mean (ms).
    pub render_ms_mean: f64,
    /// Sum of the GPU pass timings, mean (ms); 0 without timestamps.
    pub gpu_ms_mean: f64,
    /// The viewport in physical pixels of the window: x, y, width, height.
    pub viewport_px: [u32; 4],
    /// Size the renderer drew at.
    pub render_size: [u32; 2],
    pub adapter: String,
    pub scene: String,
    pub screenshot: Option<PathBuf>,
    pub errors: Vec<String>,
}

/// Opens the editor window and runs until it is closed. Returns what `--quit-after-frames` measured.
pub fn run(opts: EditorOptions) -> Result<RunSummary, EditorError> {
    if !display_available() {
        return Err(EditorError::NoDisplay);
    }
    let (scene, exposure, preset) = initial_scene(&opts)?;
    let summary = Arc::new(std::sync::Mutex::new(RunSummary::default()));
    let native = eframe::NativeOptions {
        viewport: eframe::egui::ViewportBuilder::default()
            .with_title(format!("epivox — {}", scene.name))
            .with_inner_size([1280.0, 800.0])
            .with_min_inner_size([640.0, 400.0])
            .with_drag_and_drop(true),
        // The display pipeline draws into egui's pass: no depth, no MSAA, as it is built.
        depth_buffer: 0,
        multisampling: 0,
        wgpu_options: egui_wgpu::WgpuConfiguration {
            wgpu_setup: wgpu_setup(),
            surface: surface_config(),
            ..Default::default()
        },
        ..Default::default()
    };
    let startup_error: Arc<std::sync::Mutex<Option<EditorError>>> = Arc::default();
    let (summary2, startup2) = (summary.clone(), startup_error.clone());
    let result = eframe::run_native(
        "epivox",
        native,
        Box::new(move |cc| {
            let rs = cc.wgpu_render_state.clone().ok_or(EditorError::NoRenderState)?;
            match Editor::new(&cc.egui_ctx, rs, scene, exposure, preset, &opts) {
                Ok(mut e) => {
                    e.set_summary_sink(summary2);
                    Ok(Box::new(e))
                }
                Err(err) => {
                    let text = err.to_string();
                    if let Ok(mut s) = startup2.lock() {
                        *s = Some(err);
                    }
                    Err(text.into())
                }
            }
        }),
    );
    if let Some(e) = startup_error.lock().ok().and_then(|mut s| s.take()) {
        return Err(e);
    }
    result.map_err(|e| EditorError::Window(e.to_string()))?;
    let s = summary.lock().map(|s| s.clone()).unwrap_or_default();
    Ok(s)
}

//! The editor application: layout, the command loop, background jobs.

use super::accuracy::{AccuracyJob, AccuracyResult};
use super::camera::{drag_light, light_handle, CameraController, CameraMode};
use super::command::Command;
use super::files::{default_config_dir, default_presets_dir, DialogPurpose, Dialogs, Recent};
use super::inspector::{cell_of_pixel, pixel_of_cell, GridSnapshot, Inspector};
use super::panels::{
    AccuracyPanel, GridLimits, GridPanel, LightPanel, MediumPanel, PhasePanel, PresetsPanel, StatsPanel,
};
use super::state::{History, Look, ViewMode};
use super::viewport::{FrameRequest, GoodFrame, Shown, ViewportCallback, ViewportResources};
use super::watch::ShaderWatcher;
use super::{EditorError, EditorOptions, RunSummary};
use crate::gpu::{GpuContext, ShaderLibrary};
use crate::image::Image;
use crate::params::Exposure;
use crate::preset::Preset;
use crate::render::Method;
use crate::scene::{load_scene, Scene, SceneError};
use eframe::egui;
use eframe::egui_wgpu;
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc, Mutex};
use std::time::Instant;

/// A line in the status bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    pub error: bool,
    pub text: String,
}

/// Everything that decides the picture except the exposure (applied at display time).
#[derive(Debug, Clone, PartialEq)]
struct RenderKey {
    look: Look,
    view: ViewMode,
    method: Method,
    width: u32,
    height: u32,
    scene_generation: u64,
    shader_epoch: u64,
}

/// `--quit-after-frames`: render every frame, then screenshot, then close.
struct QuitPlan {
    frames_left: u32,
    screenshot: Option<PathBuf>,
    screenshot_requested: bool,
    /// Filled by the integration's screenshot callback.
    shot: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    closing: bool,
}

/// Measurements of a `--quit-after-frames` run.
#[derive(Default)]
struct Samples {
    frame_ms: Vec<f64>,
    render_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    last_frame: Option<Instant>,
    last_generation: Option<u64>,
}

/// The method list of the toolbar, with the ray-marching baseline's default steps.
pub fn method_label(m: &Method) -> String {
    #[allow(unreachable_patterns)] // other engineers may add methods; they show by their Debug name
    match m {
        Method::Vsv => "VSV".into(),
        Method::Cartesian => "Cartesian".into(),
        Method::Raymarch { steps, jitter } => {
            format!("ray march ({steps} steps{})", if *jitter { ", jittered" } else { "" })
        }
        other => format!("{other:?}"),
    }
}

pub struct Editor {
    render_state: egui_wgpu::RenderState,
    ctx: egui::Context,
    // ---- the document
    scene: Arc<Scene>,
    scene_generation: u64,
    look: Look,
    history: History,
    preset_path: Option<PathBuf>,
    // ---- how it is shown
    view: ViewMode,
    method: Method,
    /// Steps of the ray-marching baseline when it is picked.
    raymarch_steps: u32,
    render_scale: f32,
    camera: CameraController,
    dragging_light: bool,
    // ---- render plumbing
    composed: Option<(RenderKey, Arc<Scene>)>,
    generation: u64,
    last_key: Option<RenderKey>,
    shaders: ShaderLibrary,
    shader_epoch: u64,
    watcher: Option<ShaderWatcher>,
    /// The last reload's error (file:line:col), shown over the viewport until a reload succeeds.
    pub shader_error: Option<String>,
    adapter: String,
    timestamps: bool,
    limits: GridLimits,
    // ---- panels
    medium_panel: MediumPanel,
    phase_panel: PhasePanel,
    light_panel: LightPanel,
    grid_panel: GridPanel,
    stats_panel: StatsPanel,
    accuracy_panel: AccuracyPanel,
    presets_panel: PresetsPanel,
    inspector: Inspector,
    // ---- files and jobs
    presets_dir: PathBuf,
    config_dir: Option<PathBuf>,
    recent: Recent,
    dialogs: Dialogs,
    scene_job: Option<(PathBuf, mpsc::Receiver<Result<Scene, SceneError>>)>,
    accuracy_job: Option<AccuracyJob>,
    accuracy_result: Option<AccuracyResult>,
    confirm_overwrite: Option<PathBuf>,
    messages: Vec<Message>,
    // ---- hover linking
    viewport_cell: Option<(f64, f64)>,
    // ---- measuring
    ui_frame_ms: f64,
    last_ui: Option<Instant>,
    quit: Option<QuitPlan>,
    samples: Samples,
    summary: Option<Arc<Mutex<RunSummary>>>,
    viewport_px: [u32; 4],
    render_size: [u32; 2],
    viewport_rect: Option<egui::Rect>,
    /// Open the Accuracy section on the next frame.
    open_accuracy: bool,
    /// A CPU adapter (the software Vulkan driver): frames take seconds; say so.
    software: bool,
}

impl Editor {
    /// Creates the editor on eframe's (or the test harness's) wgpu device: puts a [`Renderer`]
    /// built from the shader folder and the display pipeline into the callback resources.
    ///
    /// [`Renderer`]: crate::render::Renderer
    pub fn new(
        ctx: &egui::Context,
        render_state: egui_wgpu::RenderState,
        scene: Scene,
        exposure: f32,
        preset_path: Option<PathBuf>,
        opts: &EditorOptions,
    ) -> Result<Editor, EditorError> {
        let shaders = ShaderLibrary::new(opts.shader_dir.clone());
        let gpu = GpuContext::from_parts(
            render_state.adapter.clone(),
            render_state.device.clone(),
            render_state.queue.clone(),
        );
        let adapter = gpu.adapter_name();
        let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
        let timestamps = gpu.timestamps;
        let l = gpu.device.limits();
        let limits = GridLimits {
            buffer_bytes: l.max_storage_buffer_binding_size.min(l.max_buffer_size),
            texture_side: l.max_texture_dimension_2d,
        };
        let mut messages = Vec::new();
        // Broken shaders on disk at start-up: run on the embedded copies and show the error, so
        // the editor still opens and picks the folder up again once the file is fixed.
        let mut shader_error = None;
        let resources = match ViewportResources::new(gpu.clone(), &shaders, render_state.target_format) {
            Ok(r) => r,
            Err(e) if shaders.dir().is_some() => {
                shader_error = Some(e.to_string());
                ViewportResources::new(gpu, &ShaderLibrary::embedded(), render_state.target_format)?
            }
            Err(e) => return Err(e.into()),
        };
        render_state.renderer.write().callback_resources.insert(resources);

        let watcher = match (opts.watch_shaders, shaders.dir()) {
            (true, Some(dir)) => {
                let c = ctx.clone();
                match ShaderWatcher::new(dir, move || c.request_repaint()) {
                    Ok(w) => Some(w),
                    Err(e) => {
                        messages.push(Message { error: true, text: format!("not watching {}: {e}", dir.display()) });
                        None
                    }
                }
            }
            _ => None,
        };
        let config_dir = opts.config_dir.clone().or_else(default_config_dir);
        let recent = Recent::load(config_dir.as_deref());
        let look = Look::of(&scene, exposure);
        let quit = opts.quit_after_frames.map(|n| QuitPlan {
            frames_left: n.max(1),
            screenshot: opts.screenshot.clone(),
            screenshot_requested: false,
            shot: Arc::default(),
            closing: false,
        });
        Ok(Editor {
            render_state,
            ctx: ctx.clone(),
            scene: Arc::new(scene),
            scene_generation: 1,
            look,
            history: History::default(),
            preset_path,
            view: ViewMode::Final,
            method: Method::Vsv,
            raymarch_steps: 64,
            render_scale: 1.0,
            camera: CameraController::default(),
            dragging_light: false,
            composed: None,
            generation: 0,
            last_key: None,
            shaders,
            shader_epoch: 0,
            watcher,
            shader_error,
            adapter,
            timestamps,
            limits,
            medium_panel: MediumPanel::default(),
            phase_panel: PhasePanel::default(),
            light_panel: LightPanel,
            grid_panel: GridPanel,
            stats_panel: StatsPanel,
            accuracy_panel: AccuracyPanel::default(),
            presets_panel: PresetsPanel::default(),
            inspector: Inspector::default(),
            presets_dir: opts.presets_dir.clone().unwrap_or_else(default_presets_dir),
            config_dir,
            recent,
            dialogs: Dialogs::default(),
            scene_job: None,
            accuracy_job: None,
            accuracy_result: None,
            confirm_overwrite: None,
            messages,
            viewport_cell: None,
            ui_frame_ms: 0.0,
            last_ui: None,
            quit,
            samples: Samples::default(),
            summary: None,
            viewport_px: [0; 4],
            render_size: [0; 2],
            viewport_rect: None,
            open_accuracy: false,
            software,
        })
    }

    /// Where `run` collects the measurements of `--quit-after-frames`.
    pub fn set_summary_sink(&mut self, sink: Arc<Mutex<RunSummary>>) {
        self.summary = Some(sink);
    }

    // ------------------------------------------------------------------ read-only accessors (tests)

    pub fn look(&self) -> &Look {
        &self.look
    }
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
    pub fn history(&self) -> &History {
        &self.history
    }
    pub fn messages(&self) -> &[Message] {
        &self.messages
    }
    pub fn preset_path(&self) -> Option<&Path> {
        self.preset_path.as_deref()
    }
    pub fn view(&self) -> ViewMode {
        self.view
    }
    pub fn method(&self) -> Method {
        self.method
    }
    /// The viewport's render generation (changes whenever the picture must be redrawn).
    pub fn generation(&self) -> u64 {
        self.generation
    }
    /// Frames the viewport has rendered so far.
    pub fn frames_rendered(&self) -> u64 {
        self.with_resources(|r| r.frames_rendered).unwrap_or(0)
    }
    /// The last frame's report.
    pub fn frame_report(&self) -> Option<super::FrameReport> {
        self.with_resources(|r| r.report.clone()).flatten()
    }
    pub fn accuracy_running(&self) -> bool {
        self.accuracy_job.is_some()
    }
    /// Size of the last accuracy check's images.
    pub fn accuracy_size(&self) -> Option<(u32, u32)> {
        self.accuracy_result.as_ref().map(|r| (r.width, r.height))
    }
    /// (scattered, final) relative RMSE of the last accuracy check.
    pub fn accuracy_rel_rmse(&self) -> Option<(f64, f64)> {
        let r = self.accuracy_result.as_ref()?;
        Some((r.scatter.as_ref().ok()?.rel_rmse, r.hdr.as_ref().ok()?.rel_rmse))
    }
    /// The (plane, ray) under the pointer in the viewport, when the pointer is over it.
    pub fn viewport_cell(&self) -> Option<(f64, f64)> {
        self.viewport_cell
    }
    /// The (plane, ray) under the pointer in the inspector's grid picture.
    pub fn inspector_cell(&self) -> Option<(f64, f64)> {
        self.inspector.hovered
    }
    /// Where the inspector drew its grid picture (points).
    pub fn inspector_grid_rect(&self) -> Option<egui::Rect> {
        self.inspector.grid_rect
    }
    /// Where the light's handle is drawn in the viewport (points), when it is in view.
    pub fn light_handle_pos(&self) -> Option<egui::Pos2> {
        light_handle(&self.look.camera, self.viewport_rect?, &self.look.light)
    }
    /// The plane the inspector's slice shows.
    pub fn slice_plane(&self) -> u32 {
        self.inspector.slice_plane
    }
    /// The viewport's rectangle in points (after the first frame).
    pub fn viewport_rect(&self) -> Option<egui::Rect> {
        self.viewport_rect
    }
    /// The overwrite question is open for this path.
    pub fn confirming_overwrite(&self) -> Option<&Path> {
        self.confirm_overwrite.as_deref()
    }

    fn with_resources<T>(&self, f: impl FnOnce(&ViewportResources) -> T) -> Option<T> {
        let r = self.render_state.renderer.read();
        r.callback_resources.get::<ViewportResources>().map(f)
    }

    fn with_resources_mut<T>(&self, f: impl FnOnce(&mut ViewportResources) -> T) -> Option<T> {
        let mut r = self.render_state.renderer.write();
        r.callback_resources.get_mut::<ViewportResources>().map(f)
    }

    fn info(&mut self, text: impl Into<String>) {
        self.push_message(false, text.into());
    }
    fn error(&mut self, text: impl Into<String>) {
        self.push_message(true, text.into());
    }
    fn push_message(&mut self, error: bool, text: String) {
        if error {
            log::warn!("{text}");
        }
        self.messages.push(Message { error, text });
        if self.messages.len() > 6 {
            self.messages.remove(0);
        }
    }

    fn remember_recent(&mut self) {
        if let Err(e) = self.recent.save(self.config_dir.as_deref()) {
            log::warn!("could not remember recent files: {e}");
        }
    }

    // ------------------------------------------------------------------ the one place state changes

    /// Applies one command. Every change of editor state goes through here.
    pub fn apply(&mut self, cmd: Command) {
        match cmd {
            Command::SetMedium(m, key) => {
                if m.validate().is_ok() {
                    self.edit(key, |l| l.medium = m);
                }
            }
            Command::SetLight(light, key) => {
                if light.validate().is_ok() {
                    self.edit(key, |l| l.light = light.normalized());
                }
            }
            Command::SetGrid(g, key) => {
                if g.validate().is_ok() {
                    self.edit(key, |l| l.grid = g);
                }
            }
            Command::SetCamera(c, key) => {
                if c.validate().is_ok() {
                    self.edit(key, |l| l.camera = c);
                }
            }
            Command::SetExposure(e, key) => {
                if Exposure::STOPS.check(e as f64).is_ok() {
                    self.edit(key, |l| l.exposure = e);
                }
            }
            Command::ResetCamera => {
                let c = self.scene.camera;
                self.edit(None, |l| l.camera = c);
            }
            Command::Undo => {
                if let Some(l) = self.history.undo(self.look) {
                    self.look = l;
                }
            }
            Command::Redo => {
                if let Some(l) = self.history.redo(self.look) {
                    self.look = l;
                }
            }
            Command::SetView(v) => self.view = v,
            Command::SetMethod(m) => {
                if let Method::Raymarch { steps, .. } = m {
                    self.raymarch_steps = steps;
                }
                self.method = m;
            }
            Command::SetRenderScale(s) => self.render_scale = s.clamp(0.1, 1.0),
            Command::ShowInspector(v) => self.inspector.visible = v,
            Command::SetInspectorMode(m) => self.inspector.mode = m,
            Command::SetSlicePlane(p) => self.inspector.slice_plane = p,
            Command::LoadPreset(path) => {
                self.history.break_merge();
                self.load_preset(&path);
            }
            Command::SavePreset => match self.preset_path.clone() {
                Some(p) => self.save_preset(&p),
                None => self.apply(Command::SavePresetAsDialog),
            },
            Command::SavePresetAs { path, overwrite } => {
                if path.exists() && !overwrite {
                    // Never replace a file silently: ask (the modal sends overwrite: true).
                    self.confirm_overwrite = Some(path);
                } else {
                    self.confirm_overwrite = None;
                    self.save_preset(&path);
                }
            }
            Command::OpenScene(path) => self.start_scene_load(path),
            Command::Screenshot(path) => self.screenshot(&path),
            Command::ExportInspector(path) => match self.inspector.export(&path) {
                Ok(()) => self.info(format!("inspector picture saved to {}", path.display())),
                Err(e) => self.error(format!("could not export the inspector picture: {e}")),
            },
            Command::OpenSceneDialog => self.open_dialog(DialogPurpose::OpenScene),
            Command::OpenPresetDialog => self.open_dialog(DialogPurpose::OpenPreset),
            Command::SavePresetAsDialog => self.open_dialog(DialogPurpose::SavePresetAs),
            Command::ScreenshotDialog => self.open_dialog(DialogPurpose::Screenshot),
            Command::ExportInspectorDialog => self.open_dialog(DialogPurpose::ExportInspector),
            Command::StartAccuracy { width } => self.start_accuracy(width),
            Command::CancelAccuracy => {
                if let Some(j) = &self.accuracy_job {
                    j.cancel();
                }
            }
            Command::ReloadShaders => self.reload_shaders(),
            Command::DismissMessages => self.messages.clear(),
        }
    }

    /// An undoable change of the look; no-op changes leave no history.
    fn edit(&mut self, key: super::MergeKey, f: impl FnOnce(&mut Look)) {
        let before = self.look;
        f(&mut self.look);
        if self.look != before {
            self.history.record(before, key);
        }
    }

    fn load_preset(&mut self, path: &Path) {
        match Preset::load(path) {
            Ok(p) => {
                let mut s = (*self.scene).clone();
                self.look.apply_to(&mut s);
                p.apply(&mut s);
                let exposure = p.exposure.unwrap_or(self.look.exposure);
                let (medium, grid) = (s.medium, s.grid);
                self.edit(None, |l| {
                    l.medium = medium;
                    l.grid = grid;
                    l.exposure = exposure;
                });
                self.preset_path = Some(path.to_path_buf());
                self.presets_panel.name = p.name.clone().unwrap_or_default();
                self.recent.add_preset(path);
                self.remember_recent();
                self.info(format!("preset {} loaded", path.display()));
            }
            // The look stays as it was; the message names the file and the field.
            Err(e) => self.error(format!("preset refused: {e}")),
        }
    }

    fn save_preset(&mut self, path: &Path) {
        let mut s = (*self.scene).clone();
        self.look.apply_to(&mut s);
        let name = self.presets_panel.name.trim().to_string();
        let name = if name.is_empty() { path.file_stem().map(|s| s.to_string_lossy().to_string()) } else { Some(name) };
        let preset = Preset::from_scene(&s, name.as_deref(), self.look.exposure);
        match preset.save(path) {
            Ok(()) => {
                self.preset_path = Some(path.to_path_buf());
                self.presets_panel.invalidate();
                self.recent.add_preset(path);
                self.remember_recent();
                self.info(format!("preset saved to {}", path.display()));
            }
            Err(e) => self.error(format!("preset not saved: {e}")),
        }
    }

    fn start_scene_load(&mut self, path: PathBuf) {
        let (tx, rx) = mpsc::channel();
        let (p, ctx) = (path.clone(), self.ctx.clone());
        let spawned = std::thread::Builder::new().name("epivox-scene-load".into()).spawn(move || {
            let _ = tx.send(load_scene(&p));
            ctx.request_repaint();
        });
        match spawned {
            Ok(_) => {
                self.info(format!("loading {} …", path.display()));
                self.scene_job = Some((path, rx));
            }
            Err(e) => self.error(format!("could not start loading {}: {e}", path.display())),
        }
    }

    /// A loaded scene replaces the document: its own camera, light, medium and grid; the exposure
    /// stays; the undo history starts afresh (it held looks of the old scene).
    fn scene_loaded(&mut self, path: PathBuf, scene: Scene) {
        let exposure = self.look.exposure;
        self.look = Look::of(&scene, exposure);
        self.history.clear();
        self.ctx.send_viewport_cmd(egui::ViewportCommand::Title(format!("epivox — {}", scene.name)));
        self.scene = Arc::new(scene);
        self.scene_generation += 1;
        self.inspector.snapshot = None;
        self.accuracy_job = None;
        self.accuracy_result = None;
        self.recent.add_scene(&path);
        self.remember_recent();
        self.info(format!("opened {} ({} triangles)", path.display(), self.scene.triangle_count()));
    }

    fn open_dialog(&mut self, purpose: DialogPurpose) {
        let start = match purpose {
            DialogPurpose::OpenPreset | DialogPurpose::SavePresetAs => Some(self.presets_dir.clone()),
            _ => std::env::current_dir().ok(),
        };
        let ctx = self.ctx.clone();
        self.dialogs.start(purpose, start, move || ctx.request_repaint());
    }

    fn screenshot(&mut self, path: &Path) {
        let shown = if self.view == ViewMode::Scattered { Shown::Scatter } else { Shown::Hdr };
        let exposure = self.look.exposure;
        let result = self.with_resources(|r| -> Result<(), String> {
            let tex = match shown {
                Shown::Hdr => r.renderer.hdr_texture(),
                Shown::Scatter => r.renderer.scatter_texture(),
            }
            .ok_or("nothing rendered yet")?;
            let data = r.renderer.ctx.read_texture_rgba32f(tex).map_err(|e| e.to_string())?;
            let img = Image::from_rgba_f32(tex.width(), tex.height(), &data).map_err(|e| e.to_string())?;
            img.write_png(path, exposure).map_err(|e| e.to_string())
        });
        match result {
            Some(Ok(())) => self.info(format!("screenshot saved to {}", path.display())),
            Some(Err(e)) => self.error(format!("screenshot failed: {e}")),
            None => self.error("screenshot failed: no renderer"),
        }
    }

    fn reload_shaders(&mut self) {
        let lib = self.shaders.clone();
        match self.with_resources_mut(|r| r.reload(&lib)) {
            Some(Ok(())) => {
                if self.shader_error.take().is_some() {
                    self.info("shaders fixed and reloaded");
                }
                self.shader_epoch += 1;
            }
            Some(Err(e)) => {
                // The previous pipelines keep drawing; the error stays over the viewport.
                self.shader_error = Some(e.to_string());
            }
            None => {}
        }
    }

    /// The scene the current look describes, with the medium cleared for "surface only".
    fn composed_scene(&mut self, key: &RenderKey) -> Arc<Scene> {
        if let Some((k, s)) = &self.composed {
            if k.look == key.look && k.view == key.view && k.scene_generation == key.scene_generation {
                return s.clone();
            }
        }
        let mut s = (*self.scene).clone();
        self.look.apply_to(&mut s);
        if self.view == ViewMode::Surface {
            s.medium.density = 0.0;
        }
        let s = Arc::new(s);
        self.composed = Some((key.clone(), s.clone()));
        s
    }

    fn start_accuracy(&mut self, width: u32) {
        let mut scene = (*self.scene).clone();
        self.look.apply_to(&mut scene);
        let (vw, vh) = match self.frame_report().and_then(|r| r.last_good) {
            Some(g) => (g.width, g.height),
            None => (4, 3),
        };
        let width = width.max(8);
        let height = ((width as f64 * vh as f64 / vw.max(1) as f64).round() as u32).max(8);
        let method = self.method;
        let scene = Arc::new(scene);
        // The GPU image of the same view and size, taken now (the reference is slow; the GPU not).
        let gpu = self.with_resources_mut(|r| {
            let out = r.renderer.render(&scene, width, height, method);
            // The viewport's targets were resized: draw it again at its own size.
            r.invalidate();
            out
        });
        match gpu {
            Some(Ok(out)) => {
                self.open_accuracy = true;
                let ctx = self.ctx.clone();
                self.accuracy_job = Some(AccuracyJob::start(
                    scene,
                    width,
                    height,
                    out.scatter,
                    out.hdr,
                    method_label(&method),
                    move || ctx.request_repaint(),
                ));
            }
            Some(Err(e)) => self.error(format!("accuracy check not started: {e}")),
            None => {}
        }
    }

    // ------------------------------------------------------------------ background results

    fn poll_background(&mut self, cmds: &mut Vec<Command>) {
        if let Some(w) = &mut self.watcher {
            if w.take_changed() {
                cmds.push(Command::ReloadShaders);
            }
        }
        // A cancelled dialog (None) does nothing.
        let polled = self.dialogs.poll();
        if let Some((_, None, true)) = polled {
            self.error(
                "no file dialog could be shown (it needs the XDG desktop portal or zenity); \
                 drop the file on the window instead",
            );
        }
        if let Some((purpose, Some(p), _)) = polled {
            cmds.push(match purpose {
                DialogPurpose::OpenScene => Command::OpenScene(p),
                DialogPurpose::OpenPreset => Command::LoadPreset(p),
                // The portal's own dialog asks before replacing; ask anyway (it may not).
                DialogPurpose::SavePresetAs => Command::SavePresetAs { path: p, overwrite: false },
                DialogPurpose::Screenshot => Command::Screenshot(p),
                DialogPurpose::ExportInspector => Command::ExportInspector(p),
            });
        }
        if let Some((path, rx)) = &self.scene_job {
            match rx.try_recv() {
                Ok(Ok(scene)) => {
                    let path = path.clone();
                    self.scene_job = None;
                    self.scene_loaded(path, scene);
                }
                Ok(Err(e)) => {
                    self.scene_job = None;
                    self.error(format!("scene not opened: {e}"));
                }
                Err(mpsc::TryRecvError::Empty) => {}
                Err(mpsc::TryRecvError::Disconnected) => {
                    self.scene_job = None;
                    self.error("scene loading stopped unexpectedly");
                }
            }
        }
        if let Some(job) = &self.accuracy_job {
            if let Some(done) = job.poll() {
                match done {
                    Some(r) => self.accuracy_result = Some(r),
                    None => self.info("accuracy check cancelled"),
                }
                self.accuracy_job = None;
            }
        }
        // Files dropped on the window: presets are applied, anything else is opened as a scene.
        let dropped: Vec<PathBuf> = self.ctx.input(|i| {
            i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).filter(|p| !p.as_os_str().is_empty()).collect()
        });
        for p in dropped {
            let name = p.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
            let preset = name.ends_with(".toml") && !name.ends_with(".scene.toml") && Preset::load(&p).is_ok();
            cmds.push(if preset { Command::LoadPreset(p) } else { Command::OpenScene(p) });
        }
    }

    /// Reads the grid back for the inspector when it is visible and a newer frame exists.
    fn update_inspector(&mut self) {
        // Reading back a grid of hundreds of MiB every frame would stall editing: above this the
        // inspector says so instead.
        const INSPECT_LIMIT: u64 = 256 << 20;
        let too_large = self.look.grid.bytes() > INSPECT_LIMIT;
        let visible = self.inspector.visible && !too_large;
        if self.inspector.visible && too_large {
            self.inspector.snapshot = None;
            self.inspector.error = Some(format!(
                "the {} grid ({}) is too large to inspect live; the inspector reads grids up to {}",
                self.look.grid,
                super::panels::bytes(self.look.grid.bytes()),
                super::panels::bytes(INSPECT_LIMIT)
            ));
        }
        let have = self.inspector.snapshot_generation();
        let result = self.with_resources_mut(|r| {
            if visible != r.renderer_keeps_geometry() {
                r.set_keep_geometry(visible);
            }
            if !visible {
                return None;
            }
            let good = r.report.as_ref().and_then(|rep| rep.last_good.clone())?;
            if have == Some(good.generation) || matches!(good.method, Method::Raymarch { .. }) {
                return None;
            }
            let grid = good.info.setup.mapping.grid;
            Some(r.renderer.read_grid().map(|shadow| GridSnapshot {
                generation: good.generation,
                grid,
                setup: good.info.setup,
                shadow,
                geometry: r.renderer.read_geometry_grid().ok().filter(|g| g.len() == grid.bytes() as usize / 4),
            }))
        });
        match result.flatten() {
            Some(Ok(s)) if s.shadow.len() == s.grid.bytes() as usize / 4 => self.inspector.set_snapshot(s),
            Some(Ok(_)) => {}
            Some(Err(e)) => self.inspector.error = Some(format!("grid readback failed: {e}")),
            None => {}
        }
    }

    // ------------------------------------------------------------------ drawing

    /// Draws one frame of the editor (eframe's `App::ui` and the tests call this).
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let now = Instant::now();
        if let Some(t) = self.last_ui {
            let ms = (now - t).as_secs_f64() * 1e3;
            self.ui_frame_ms = if self.ui_frame_ms == 0.0 { ms } else { self.ui_frame_ms * 0.9 + ms * 0.1 };
        }
        self.last_ui = Some(now);
        let mut cmds = Vec::new();
        self.poll_background(&mut cmds);
        self.update_inspector();
        self.shortcuts(&mut cmds);

        egui::Panel::top("epivox-menu").show(ui, |ui| self.menu_bar(ui, &mut cmds));
        egui::Panel::bottom("epivox-status").show(ui, |ui| self.status_bar(ui, &mut cmds));
        egui::Panel::left("epivox-controls").resizable(true).default_size(360.0).min_size(260.0).show(ui, |ui| {
            egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| self.side_panels(ui, &mut cmds));
        });
        egui::CentralPanel::default().show(ui, |ui| {
            self.toolbar(ui, &mut cmds);
            let area = ui.available_rect_before_wrap();
            let (view_rect, insp_rect) = if self.inspector.visible {
                let split = area.left() + area.width() * 0.6;
                (
                    egui::Rect::from_min_max(area.min, egui::pos2(split - 4.0, area.bottom())),
                    Some(egui::Rect::from_min_max(egui::pos2(split + 4.0, area.top()), area.max)),
                )
            } else {
                (area, None)
            };
            let mut vui = ui.new_child(egui::UiBuilder::new().max_rect(view_rect).id_salt("epivox-viewport"));
            self.viewport(&mut vui, &mut cmds);
            if let Some(r) = insp_rect {
                let mut iui = ui.new_child(egui::UiBuilder::new().max_rect(r).id_salt("epivox-inspector"));
                let (scene, gen) = (self.composed_for_inspector(), self.scene_generation);
                self.inspector.show(&mut iui, &scene, gen, self.viewport_cell, &mut cmds);
            }
            ui.advance_cursor_after_rect(area);
        });
        self.overwrite_modal(&mut cmds);
        for c in cmds {
            self.apply(c);
        }
        self.after_frame();
    }

    fn composed_for_inspector(&self) -> Arc<Scene> {
        match &self.composed {
            Some((_, s)) => s.clone(),
            None => self.scene.clone(),
        }
    }

    fn shortcuts(&mut self, cmds: &mut Vec<Command>) {
        if self.ctx.egui_wants_keyboard_input() {
            return; // a text field has focus: its own undo and shortcuts apply
        }
        use egui::{Key, KeyboardShortcut, Modifiers};
        let shortcut = |m, k| self.ctx.input_mut(|i| i.consume_shortcut(&KeyboardShortcut::new(m, k)));
        if shortcut(Modifiers::COMMAND | Modifiers::SHIFT, Key::Z) || shortcut(Modifiers::COMMAND, Key::Y) {
            cmds.push(Command::Redo);
        }
        if shortcut(Modifiers::COMMAND, Key::Z) {
            cmds.push(Command::Undo);
        }
        if shortcut(Modifiers::COMMAND, Key::S) {
            cmds.push(Command::SavePreset);
        }
        if shortcut(Modifiers::COMMAND, Key::O) {
            cmds.push(Command::OpenSceneDialog);
        }
        if shortcut(Modifiers::NONE, Key::F5) {
            cmds.push(Command::ReloadShaders);
        }
    }

    fn menu_bar(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open scene…").clicked() {
                    cmds.push(Command::OpenSceneDialog);
                }
                ui.menu_button("Recent scenes", |ui| {
                    if self.recent.scenes.is_empty() {
                        ui.label("none yet");
                    }
                    for p in &self.recent.scenes {
                        if ui.button(p.display().to_string()).clicked() {
                            cmds.push(Command::OpenScene(p.clone()));
                        }
                    }
                });
                ui.menu_button("Recent presets", |ui| {
                    if self.recent.presets.is_empty() {
                        ui.label("none yet");
                    }
                    for p in &self.recent.presets {
                        if ui.button(p.display().to_string()).clicked() {
                            cmds.push(Command::LoadPreset(p.clone()));
                        }
                    }
                });
                ui.separator();
                if ui.button("Open preset…").clicked() {
                    cmds.push(Command::OpenPresetDialog);
                }
                if ui.add_enabled(self.preset_path.is_some(), egui::Button::new("Save preset")).clicked() {
                    cmds.push(Command::SavePreset);
                }
                if ui.button("Save preset as…").clicked() {
                    cmds.push(Command::SavePresetAsDialog);
                }
                ui.separator();
                if ui.button("Screenshot of the viewport…").clicked() {
                    cmds.push(Command::ScreenshotDialog);
                }
                if ui.button("Export inspector picture…").clicked() {
                    cmds.push(Command::ExportInspectorDialog);
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    self.ctx.send_viewport_cmd(egui::ViewportCommand::Close);
                }
            });
            ui.menu_button("Edit", |ui| {
                if ui.add_enabled(self.history.can_undo(), egui::Button::new("Undo")).clicked() {
                    cmds.push(Command::Undo);
                }
                if ui.add_enabled(self.history.can_redo(), egui::Button::new("Redo")).clicked() {
                    cmds.push(Command::Redo);
                }
                if ui.button("Reset camera").clicked() {
                    cmds.push(Command::ResetCamera);
                }
                if ui.button("Reload shaders (F5)").clicked() {
                    cmds.push(Command::ReloadShaders);
                }
            });
            ui.separator();
            ui.label(
                egui::RichText::new(format!("{} · {} triangles", self.scene.name, self.scene.triangle_count())).weak(),
            );
            if let Some(p) = &self.preset_path {
                ui.label(
                    egui::RichText::new(format!(
                        "preset {}",
                        p.file_name().map(|n| n.to_string_lossy()).unwrap_or_default()
                    ))
                    .weak(),
                );
            }
        });
    }

    fn status_bar(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        ui.horizontal_wrapped(|ui| {
            if let Some(w) = &self.watcher {
                ui.label(egui::RichText::new(format!("watching {}", w.dir().display())).small().weak());
            } else {
                let where_ =
                    self.shaders.dir().map(|d| d.display().to_string()).unwrap_or_else(|| "embedded shaders".into());
                ui.label(egui::RichText::new(where_).small().weak());
            }
            if self.scene_job.is_some() {
                ui.spinner();
            }
            if !self.messages.is_empty() && ui.small_button("clear").clicked() {
                cmds.push(Command::DismissMessages);
            }
        });
        for m in self.messages.iter().rev().take(3) {
            if m.error {
                ui.colored_label(ui.visuals().error_fg_color, &m.text);
            } else {
                ui.label(&m.text);
            }
        }
    }

    fn side_panels(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        let look = self.look;
        let bounds = self.scene.bounds();
        egui::CollapsingHeader::new("Presets").default_open(true).show(ui, |ui| {
            let dir = self.presets_dir.clone();
            self.presets_panel.show(ui, &dir, self.preset_path.as_deref(), cmds);
        });
        egui::CollapsingHeader::new("Medium").default_open(true).show(ui, |ui| {
            self.medium_panel.show(ui, &look.medium, bounds.radius() * 2.0, cmds);
        });
        egui::CollapsingHeader::new("Phase function").default_open(true).show(ui, |ui| {
            self.phase_panel.show(ui, &look.medium, cmds);
        });
        egui::CollapsingHeader::new("Light").default_open(true).show(ui, |ui| {
            self.light_panel.show(ui, &look.light, &bounds, cmds);
        });
        egui::CollapsingHeader::new("Grid").default_open(true).show(ui, |ui| {
            self.grid_panel.show(ui, &look.grid, self.limits, cmds);
        });
        egui::CollapsingHeader::new("Stats").default_open(true).show(ui, |ui| {
            let report = self.frame_report();
            if self.software {
                ui.colored_label(
                    ui.visuals().warn_fg_color,
                    "Software driver: a frame takes seconds. A smaller grid (Grid) or fewer pixels (toolbar) keeps editing responsive.",
                );
            }
            let ctx = super::panels::StatsContext {
                ui_frame_ms: self.ui_frame_ms,
                grid_bytes: look.grid.bytes(),
                adapter: &self.adapter,
                timestamps: self.timestamps,
                point_light: look.light.is_point(),
            };
            self.stats_panel.show(ui, report.as_ref(), &ctx);
        });
        // Starting a check (from anywhere) opens the section, so its progress is in view.
        let open = std::mem::take(&mut self.open_accuracy).then_some(true);
        egui::CollapsingHeader::new("Accuracy").default_open(false).open(open).show(ui, |ui| {
            let stale = self.accuracy_result.as_ref().is_some_and(|r| {
                let l = Look::of(&r.scene, look.exposure);
                l != look
            });
            self.accuracy_panel.show(ui, self.accuracy_job.as_ref(), self.accuracy_result.as_ref(), stale, cmds);
        });
    }

    fn toolbar(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        ui.horizontal_wrapped(|ui| {
            for (mode, label) in ViewMode::ALL {
                if ui.selectable_label(self.view == mode, label).clicked() && self.view != mode {
                    cmds.push(Command::SetView(mode));
                }
            }
            ui.separator();
            let methods =
                [Method::Vsv, Method::Cartesian, Method::Raymarch { steps: self.raymarch_steps, jitter: true }];
            egui::ComboBox::new("method", "method").selected_text(method_label(&self.method)).show_ui(ui, |ui| {
                for m in methods {
                    if ui
                        .selectable_label(
                            std::mem::discriminant(&m) == std::mem::discriminant(&self.method),
                            method_label(&m),
                        )
                        .clicked()
                    {
                        cmds.push(Command::SetMethod(m));
                    }
                }
            });
            if let Method::Raymarch { steps, jitter } = self.method {
                let mut s = steps;
                if ui.add(egui::Slider::new(&mut s, 4..=1024).logarithmic(true).text("steps")).changed() {
                    cmds.push(Command::SetMethod(Method::Raymarch { steps: s, jitter }));
                }
            }
            ui.separator();
            let mut e = self.look.exposure;
            let r = ui
                .add(
                    egui::Slider::new(&mut e, Exposure::STOPS.min as f32..=Exposure::STOPS.max as f32)
                        .text("exposure")
                        .suffix(format!(" {}", Exposure::STOPS.unit)),
                )
                .on_hover_text(Exposure::STOPS.doc);
            if r.changed() {
                cmds.push(Command::SetExposure(e, super::command::merge_key(&r)));
            }
            ui.separator();
            let mut scale = self.render_scale;
            egui::ComboBox::new("render-scale", "render")
                .selected_text(format!("{}% pixels", (scale * 100.0).round()))
                .show_ui(ui, |ui| {
                    for s in [1.0f32, 0.75, 0.5, 0.25] {
                        ui.selectable_value(&mut scale, s, format!("{}% pixels", (s * 100.0).round()));
                    }
                });
            if scale != self.render_scale {
                cmds.push(Command::SetRenderScale(scale));
            }
            ui.selectable_value(&mut self.camera.mode, CameraMode::Orbit, "orbit")
                .on_hover_text("Drag: orbit · right/middle or Shift+drag: pan · wheel: dolly");
            ui.selectable_value(&mut self.camera.mode, CameraMode::Fly, "fly")
                .on_hover_text("Drag: look · W A S D Q E: move · wheel: forward/back");
            let mut insp = self.inspector.visible;
            if ui.toggle_value(&mut insp, "inspector").changed() {
                cmds.push(Command::ShowInspector(insp));
            }
            if ui.add_enabled(self.history.can_undo(), egui::Button::new("Undo")).clicked() {
                cmds.push(Command::Undo);
            }
            if ui.add_enabled(self.history.can_redo(), egui::Button::new("Redo")).clicked() {
                cmds.push(Command::Redo);
            }
            if ui.button("Screenshot…").on_hover_text("Save the viewport's picture as PNG").clicked() {
                cmds.push(Command::ScreenshotDialog);
            }
        });
    }

    fn frame_request(&mut self, width: u32, height: u32) -> FrameRequest {
        let key = RenderKey {
            look: Look { exposure: 0.0, ..self.look },
            view: self.view,
            method: self.method,
            width,
            height,
            scene_generation: self.scene_generation,
            shader_epoch: self.shader_epoch,
        };
        // Measuring: every frame renders (as if something changed each time).
        let forced = self.quit.as_ref().is_some_and(|q| q.frames_left > 0);
        if self.last_key.as_ref() != Some(&key) || forced {
            self.generation += 1;
            self.last_key = Some(key.clone());
            // One more frame after this one renders, so the inspector and stats can catch up.
            self.ctx.request_repaint();
        }
        let scene = self.composed_scene(&key);
        FrameRequest {
            generation: self.generation,
            scene_generation: self.scene_generation,
            scene,
            width,
            height,
            method: self.method,
            shown: if self.view == ViewMode::Scattered { Shown::Scatter } else { Shown::Hdr },
            exposure: self.look.exposure,
        }
    }

    fn viewport(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        let width = ((rect.width() * ppp * self.render_scale).round() as u32).max(8);
        let height = ((rect.height() * ppp * self.render_scale).round() as u32).max(8);
        self.viewport_px = [
            (rect.left() * ppp).round() as u32,
            (rect.top() * ppp).round() as u32,
            (rect.width() * ppp).round() as u32,
            (rect.height() * ppp).round() as u32,
        ];
        self.render_size = [width, height];
        self.viewport_rect = Some(rect);
        let req = self.frame_request(width, height);
        ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, ViewportCallback(Arc::new(req))));

        // --- gestures: the light's handle first, then the camera.
        let handle = light_handle(&self.look.camera, rect, &self.look.light);
        if response.drag_started() {
            self.dragging_light = match (handle, response.interact_pointer_pos()) {
                (Some(h), Some(p)) => h.distance(p) < 14.0,
                _ => false,
            } || ui.input(|i| i.modifiers.alt);
        }
        if self.dragging_light && response.dragged() {
            let d = response.drag_delta();
            if d != egui::Vec2::ZERO {
                let l = drag_light(&self.look.camera, &self.look.light, d, rect.height());
                cmds.push(Command::SetLight(
                    l,
                    Some(super::command::gesture_key(&response, response.id.with("light"))),
                ));
            }
        } else if let Some(c) =
            self.camera.handle(ui, &response, &self.look.camera, self.scene.bounds().radius(), rect.height())
        {
            // Wheel and keys (no press) merge by frame-less key: one step per burst of them.
            let key = if response.dragged() {
                super::command::gesture_key(&response, response.id.with("camera"))
            } else {
                response.id.with("camera-wheel")
            };
            cmds.push(Command::SetCamera(c, Some(key)));
        }
        if response.drag_stopped() {
            self.dragging_light = false;
        }

        // --- overlays
        let painter = ui.painter_at(rect);
        if let Some(h) = handle {
            let hot = response.hover_pos().is_some_and(|p| p.distance(h) < 14.0) || self.dragging_light;
            painter.circle_stroke(
                h,
                if hot { 10.0 } else { 7.0 },
                egui::Stroke::new(2.0, egui::Color32::from_rgb(255, 220, 90)),
            );
            painter.circle_filled(h, 2.5, egui::Color32::from_rgb(255, 220, 90));
        }
        let good = self.frame_report().and_then(|r| r.last_good);
        self.viewport_cell = None;
        if let (Some(g), Some(p)) = (&good, response.hover_pos()) {
            let px = ((p.x - rect.left()) / rect.width()) as f64 * g.width as f64 - 0.5;
            let py = ((p.y - rect.top()) / rect.height()) as f64 * g.height as f64 - 0.5;
            self.viewport_cell = cell_of_pixel(&g.info.setup, &g.camera, px, py);
            if let (Some((x, _)), true) = (self.viewport_cell, self.inspector.follow_hover) {
                let plane = x as u32;
                if plane != self.inspector.slice_plane {
                    cmds.push(Command::SetSlicePlane(plane));
                }
            }
        }
        if let (Some(g), Some((x, y))) = (&good, self.inspector.hovered) {
            self.draw_cell_highlight(&painter, rect, g, x, y);
        }
        let has_picture = self.with_resources(|r| r.has_picture()).unwrap_or(false);
        if !has_picture {
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "rendering…",
                egui::FontId::proportional(16.0),
                egui::Color32::GRAY,
            );
        }
        let render_error = self.frame_report().and_then(|r| r.result.err());
        let mut lines = Vec::new();
        if let Some(e) = &self.shader_error {
            lines.push(format!("shader error (the last good shaders keep running): {e}"));
        }
        if let Some(e) = render_error {
            lines.push(format!("render error (the last picture stays): {e}"));
        }
        if !lines.is_empty() {
            let mut child = ui.new_child(
                egui::UiBuilder::new().max_rect(rect.shrink(8.0)).layout(egui::Layout::top_down(egui::Align::LEFT)),
            );
            egui::Frame::popup(child.style()).fill(egui::Color32::from_black_alpha(200)).show(&mut child, |ui| {
                for l in &lines {
                    ui.colored_label(egui::Color32::from_rgb(255, 120, 100), l);
                }
            });
        }
        let hovering_files = ui.input(|i| !i.raw.hovered_files.is_empty());
        if hovering_files {
            painter.rect_filled(rect, 0.0, egui::Color32::from_black_alpha(140));
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "drop a scene or a preset",
                egui::FontId::proportional(20.0),
                egui::Color32::WHITE,
            );
        }
    }

    /// Marks the view ray of grid cell (plane `x`, ray `y`) and its plane's epipolar line.
    fn draw_cell_highlight(&self, painter: &egui::Painter, rect: egui::Rect, g: &GoodFrame, x: f64, y: f64) {
        let to_screen = |(px, py): (f64, f64)| {
            egui::pos2(
                rect.left() + ((px + 0.5) / g.width as f64) as f32 * rect.width(),
                rect.top() + ((py + 0.5) / g.height as f64) as f32 * rect.height(),
            )
        };
        let setup = &g.info.setup;
        let m = &setup.mapping;
        let n = 96;
        let mut line = Vec::new();
        for i in 0..=n {
            let ray = i as f64 / n as f64 * m.grid.rays as f64;
            match pixel_of_cell(setup, &g.camera, x, ray) {
                Some(p) => line.push(to_screen(p)),
                None => {
                    if line.len() > 1 {
                        painter.add(egui::Shape::line(
                            std::mem::take(&mut line),
                            egui::Stroke::new(1.0, egui::Color32::from_rgb(80, 255, 120)),
                        ));
                    }
                    line.clear();
                }
            }
        }
        if line.len() > 1 {
            painter.add(egui::Shape::line(line, egui::Stroke::new(1.0, egui::Color32::from_rgb(80, 255, 120))));
        }
        if let Some(p) = pixel_of_cell(setup, &g.camera, x, y) {
            painter.circle_stroke(to_screen(p), 6.0, egui::Stroke::new(2.0, egui::Color32::from_rgb(80, 255, 120)));
        }
    }

    fn overwrite_modal(&mut self, cmds: &mut Vec<Command>) {
        let Some(path) = self.confirm_overwrite.clone() else { return };
        let mut close = false;
        egui::Modal::new(egui::Id::unique("epivox-overwrite")).show(&self.ctx, |ui| {
            ui.label(format!("{} already exists. Replace it?", path.display()));
            ui.horizontal(|ui| {
                if ui.button("Replace").clicked() {
                    cmds.push(Command::SavePresetAs { path: path.clone(), overwrite: true });
                }
                if ui.button("Cancel").clicked() {
                    close = true;
                }
            });
        });
        if close {
            self.confirm_overwrite = None;
        }
    }

    /// Bookkeeping after a frame: measurements and the scripted quit of `--quit-after-frames`.
    fn after_frame(&mut self) {
        if self.accuracy_job.is_some() || self.scene_job.is_some() {
            // Progress bars and spinners move without input.
            self.ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
        let Some(q) = &mut self.quit else { return };
        let now = Instant::now();
        if q.frames_left > 0 {
            self.ctx.request_repaint();
            // Count rendered frames: a new report means the previous paint rendered one.
            let rep = {
                let r = self.render_state.renderer.read();
                r.callback_resources.get::<ViewportResources>().and_then(|r| r.report.clone())
            };
            if let Some(rep) = rep.filter(|r| Some(r.generation) != self.samples.last_generation) {
                self.samples.last_generation = Some(rep.generation);
                if let Some(t) = self.samples.last_frame {
                    self.samples.frame_ms.push((now - t).as_secs_f64() * 1e3);
                }
                self.samples.last_frame = Some(now);
                if let Ok(info) = &rep.result {
                    self.samples.render_ms.push(rep.render_ms);
                    self.samples.gpu_ms.push(info.timings.iter().map(|t| t.ms).sum());
                }
                q.frames_left -= 1;
            }
            return;
        }
        if !q.screenshot_requested && q.screenshot.is_some() {
            q.screenshot_requested = true;
            let (slot, ctx) = (q.shot.clone(), self.ctx.clone());
            self.ctx.request_screenshot(move |image| {
                if let Ok(mut s) = slot.lock() {
                    *s = Some(image);
                }
                ctx.request_repaint();
            });
            self.ctx.request_repaint();
            return;
        }
        if q.screenshot.is_some() && !q.closing {
            let shot = q.shot.lock().ok().and_then(|mut s| s.take());
            let Some(image) = shot else {
                self.ctx.request_repaint();
                return;
            };
            let path = q.screenshot.clone().unwrap_or_default();
            let [w, h] = image.size;
            let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
            match ::image::RgbaImage::from_raw(w as u32, h as u32, rgba).map(|img| img.save(&path)) {
                Some(Ok(())) => {}
                Some(Err(e)) => self.messages.push(Message { error: true, text: format!("{}: {e}", path.display()) }),
                None => self.messages.push(Message { error: true, text: "screenshot has the wrong size".into() }),
            }
        }
        q.closing = true;
        self.write_summary();
        self.ctx.send_viewport_cmd(egui::ViewportCommand::Close);
    }

    fn write_summary(&self) {
        let Some(sink) = &self.summary else { return };
        let mean = |v: &[f64]| {
            // The first frames include start-up (pipeline creation, first upload).
            let v = if v.len() > 4 { &v[2..] } else { v };
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        let report = self.frame_report();
        let mut errors: Vec<String> = self.messages.iter().filter(|m| m.error).map(|m| m.text.clone()).collect();
        if let Some(Err(e)) = report.as_ref().map(|r| &r.result) {
            errors.push(e.clone());
        }
        if let Some(e) = &self.shader_error {
            errors.push(e.clone());
        }
        if let Ok(mut s) = sink.lock() {
            *s = RunSummary {
                frames: self.samples.render_ms.len() as u32,
                frame_ms_mean: mean(&self.samples.frame_ms),
                render_ms_mean: mean(&self.samples.render_ms),
                gpu_ms_mean: mean(&self.samples.gpu_ms),
                viewport_px: self.viewport_px,
                render_size: self.render_size,
                adapter: self.adapter.clone(),
                scene: self.scene.name.clone(),
                screenshot: self.quit.as_ref().and_then(|q| q.screenshot.clone()),
                errors,
            };
        }
    }
}

impl eframe::App for Editor {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        Editor::ui(self, ui);
    }
}

//! The editor: its state split by concern — the [`Document`] (scene, look, history), the [`View`]
//! (how it is shown), the [`Jobs`] (render worker, accuracy reference, shader watcher, scene
//! loading, dialogs) and the [`Session`] (files, messages) — the panels that draw it, and the
//! frame loop. State changes only in [`Editor::apply`] (`apply.rs`).

use super::display::{display_layout, DisplayPipeline, ViewportResources};
use super::document::{Document, History, Look};
use super::files::{default_config_dir, default_presets_dir};
use super::jobs::render::{Picture, RenderJob, RenderPriority, Window, WorkerOptions};
use super::jobs::watch::ShaderWatcher;
use super::jobs::Jobs;
use super::measure::{FrameLine, Meter};
use super::panels::inspector::InspectorPanel;
use super::panels::menu::{overwrite_modal, MenuBar, StatusBar};
use super::panels::toolbar::Toolbar;
use super::panels::viewport::ViewportPanel;
use super::panels::{
    AccuracyPanel, GridPanel, LightPanel, MediumPanel, Panel, PanelCtx, PhasePanel, PresetsPanel, StatsPanel,
};
use super::session::{Message, Session};
use super::view::{View, ViewMode};
use super::{camera::CameraMode, Command, EditorError, EditorOptions, RunSummary};
use crate::gpu::{GpuContext, ShaderLibrary};
use crate::render::{Method, SurfaceShadows};
use crate::scene::Scene;
use eframe::egui;
use eframe::egui_wgpu;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

/// Every panel, each drawing from a [`PanelCtx`] through [`Panel::show`].
#[derive(Default)]
pub(super) struct Panels {
    pub menu: MenuBar,
    pub status: StatusBar,
    pub toolbar: Toolbar,
    pub viewport: ViewportPanel,
    pub inspector: InspectorPanel,
    pub presets: PresetsPanel,
    pub medium: MediumPanel,
    pub phase: PhasePanel,
    pub light: LightPanel,
    pub grid: GridPanel,
    pub stats: StatsPanel,
    pub accuracy: AccuracyPanel,
    /// The accuracy check count last seen (a new check opens its section once).
    accuracy_seen: u64,
}

pub struct Editor {
    pub(super) ctx: egui::Context,
    pub(super) render_state: egui_wgpu::RenderState,
    pub(super) doc: Document,
    pub(super) view: View,
    pub(super) jobs: Jobs,
    pub(super) session: Session,
    pub(super) panels: Panels,
    pub(super) meter: Meter,
    /// Accuracy checks started (opens the Accuracy section).
    pub(super) accuracy_started: u64,
}

impl Editor {
    /// Creates the editor on eframe's (or the test harness's) wgpu device: the display pipeline
    /// goes into the callback resources, and the render worker starts on its own device.
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
        let format = render_state.target_format;
        let layout = display_layout(&gpu.device);
        // A broken display.wgsl on disk at start-up: the embedded one, and the error on screen.
        let mut startup_error = None;
        let display = match DisplayPipeline::new(&gpu, &shaders, &layout, format) {
            Ok(d) => d,
            Err(e) if shaders.dir().is_some() => {
                startup_error = Some(e.to_string());
                DisplayPipeline::new(&gpu, &ShaderLibrary::embedded(), &layout, format)?
            }
            Err(e) => return Err(e.into()),
        };
        render_state.renderer.write().callback_resources.insert(ViewportResources::new(display));

        let c = ctx.clone();
        let worker = WorkerOptions {
            shared_device: opts.shared_device || std::env::var_os("EPIVOX_EDITOR_SHARED_DEVICE").is_some(),
            frame_delay: opts.frame_delay,
            priority: RenderPriority::from_env(opts.render_priority),
        };
        let job =
            RenderJob::start(Window { gpu, layout, format }, shaders.clone(), worker, move || c.request_repaint())
                .map_err(|e| EditorError::Io(format!("could not start the render thread: {e}")))?;
        let mut session = Session::new(
            opts.presets_dir.clone().unwrap_or_else(default_presets_dir),
            opts.config_dir.clone().or_else(default_config_dir),
        );
        let watcher = match (opts.watch_shaders, shaders.dir()) {
            (true, Some(dir)) => {
                let c = ctx.clone();
                match ShaderWatcher::new(dir, move || c.request_repaint()) {
                    Ok(w) => Some(w),
                    Err(e) => {
                        session.error(format!("not watching {}: {e}", dir.display()));
                        None
                    }
                }
            }
            _ => None,
        };
        let mut jobs = Jobs::new(job, shaders, watcher);
        jobs.render.shader_error = startup_error;
        Ok(Editor {
            ctx: ctx.clone(),
            render_state,
            doc: Document::new(scene, exposure, preset_path),
            view: View::default(),
            jobs,
            session,
            panels: Panels::default(),
            meter: Meter::new(opts.quit_after_frames, opts.screenshot.clone()),
            accuracy_started: 0,
        })
    }

    /// Where `run` collects the measurements of `--quit-after-frames`.
    pub fn set_summary_sink(&mut self, sink: Arc<Mutex<RunSummary>>) {
        self.meter.summary = Some(sink);
    }

    /// Draws one frame of the editor (eframe's `App::ui` and the tests call this). Never waits
    /// for the renderer: what it delivered since the last frame is applied, then the panels draw,
    /// then their commands are applied, then the worker gets the newest state.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        self.meter.begin_frame();
        for c in self.jobs.poll() {
            self.apply(c);
        }
        let mut cmds = Vec::new();
        self.dropped_files(&mut cmds);
        self.shortcuts(&mut cmds);
        self.draw(ui, &mut cmds);
        for c in cmds {
            self.apply(c);
        }
        let interactive = self.input_in_progress();
        self.apply(Command::RequestFrame { interactive });
        self.after_frame(interactive);
    }

    fn draw(&mut self, ui: &mut egui::Ui, cmds: &mut Vec<Command>) {
        let cx = PanelCtx {
            doc: &self.doc,
            view: &self.view,
            jobs: &self.jobs,
            session: &self.session,
            ui_frame_ms: self.meter.ui_frame_ms,
        };
        let p = &mut self.panels;
        // No panel paints its background: the window is cleared to the same colour
        // (`clear_color`). On the software driver every filled pixel costs, and the panels'
        // fills were most of a UI frame's rendering.
        let style = ui.style().clone();
        let side = egui::Frame::side_top_panel(&style).fill(egui::Color32::TRANSPARENT);
        let central = egui::Frame::central_panel(&style).fill(egui::Color32::TRANSPARENT);
        egui::Panel::top("epivox-menu").frame(side).show(ui, |ui| p.menu.show(ui, &cx, cmds));
        egui::Panel::bottom("epivox-status").frame(side).show(ui, |ui| p.status.show(ui, &cx, cmds));
        let open_accuracy = std::mem::replace(&mut p.accuracy_seen, self.accuracy_started) != self.accuracy_started;
        egui::Panel::left("epivox-controls").frame(side).resizable(true).default_size(360.0).min_size(260.0).show(
            ui,
            |ui| {
                egui::ScrollArea::vertical().auto_shrink([false, false]).show(ui, |ui| {
                    let side: [(&mut dyn Panel, bool); 7] = [
                        (&mut p.presets, true),
                        (&mut p.medium, true),
                        (&mut p.phase, true),
                        (&mut p.light, true),
                        (&mut p.grid, true),
                        (&mut p.stats, true),
                        (&mut p.accuracy, false),
                    ];
                    for (panel, default_open) in side {
                        // Starting a check (from anywhere) opens its section, so its progress is in view.
                        let open = (open_accuracy && panel.name() == "Accuracy").then_some(true);
                        egui::CollapsingHeader::new(panel.name())
                            .default_open(default_open)
                            .open(open)
                            .show(ui, |ui| panel.show(ui, &cx, cmds));
                    }
                });
            },
        );
        egui::CentralPanel::default().frame(central).show(ui, |ui| {
            // The panel's width before the toolbar: a wide toolbar row must not widen the viewport
            // (a resize renders again).
            let full = ui.available_rect_before_wrap();
            ui.scope_builder(egui::UiBuilder::new().max_rect(full), |ui| {
                ui.set_clip_rect(full);
                p.toolbar.show(ui, &cx, cmds);
            });
            let area = egui::Rect::from_min_max(egui::pos2(full.left(), ui.cursor().min.y), full.max);
            let (view_rect, insp_rect) = if cx.view.inspector.visible {
                let split = area.left() + area.width() * 0.6;
                (
                    egui::Rect::from_min_max(area.min, egui::pos2(split - 4.0, area.bottom())),
                    Some(egui::Rect::from_min_max(egui::pos2(split + 4.0, area.top()), area.max)),
                )
            } else {
                (area, None)
            };
            let mut vui = ui.new_child(egui::UiBuilder::new().max_rect(view_rect).id_salt("epivox-viewport"));
            p.viewport.show(&mut vui, &cx, cmds);
            if let Some(r) = insp_rect {
                let mut iui = ui.new_child(egui::UiBuilder::new().max_rect(r).id_salt("epivox-inspector"));
                // The pictures are sized to this rectangle even if a row of controls overflows it.
                iui.set_clip_rect(r);
                p.inspector.show(&mut iui, &cx, cmds);
            }
            ui.advance_cursor_after_rect(area);
        });
        overwrite_modal(&self.ctx, &cx, cmds);
    }

    /// A drag, a held key or a scroll is going on: the worker renders previews only.
    fn input_in_progress(&self) -> bool {
        let fly = self.view.camera.mode == CameraMode::Fly;
        self.ctx.input(|i| {
            use egui::Key::{A, D, E, Q, S, W};
            let keys = fly && [W, A, S, D, Q, E].iter().any(|k| i.key_down(*k));
            i.pointer.any_down() || keys || i.smooth_scroll_delta != egui::Vec2::ZERO
        })
    }

    /// Files dropped on the window: presets are applied, anything else is opened as a scene.
    fn dropped_files(&self, cmds: &mut Vec<Command>) {
        let dropped: Vec<PathBuf> = self.ctx.input(|i| {
            i.raw.dropped_files.iter().map(|f| f.path().to_path_buf()).filter(|p| !p.as_os_str().is_empty()).collect()
        });
        for p in dropped {
            let name = p.file_name().map(|n| n.to_string_lossy().to_lowercase()).unwrap_or_default();
            let preset =
                name.ends_with(".toml") && !name.ends_with(".scene.toml") && crate::preset::Preset::load(&p).is_ok();
            cmds.push(if preset { Command::LoadPreset(p) } else { Command::OpenScene(p) });
        }
    }

    fn shortcuts(&self, cmds: &mut Vec<Command>) {
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

    /// Repaints that nothing else asks for, the trace, and the scripted quit.
    fn after_frame(&mut self, interactive: bool) {
        if interactive {
            // Input may end without an event this frame would see (a scroll fading out): look again.
            self.ctx.request_repaint_after(std::time::Duration::from_millis(150));
        }
        if self.jobs.animating() {
            // Progress bars and spinners move without input.
            self.ctx.request_repaint_after(std::time::Duration::from_millis(100));
        }
        let r = &self.jobs.render;
        let line = |ui_ms, gap_ms| FrameLine {
            t: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_secs_f64())
                .unwrap_or(0.0),
            ui_ms,
            gap_ms,
            interactive,
            latest: r.generation,
            shown: r.shown.as_ref().map(|p| p.generation),
            shown_full: r.shown.as_ref().is_some_and(|p| p.quality.is_full()),
            in_flight: r.job.in_flight(),
            epoch: r.shader_epoch,
            compiling: r.compiling.is_some(),
            shader_error: r.shader_error.is_some(),
            viewport_px: self.view.layout.pixels(),
        };
        self.meter.end_frame(line);
        if self.meter.forcing_frames() {
            self.ctx.request_repaint_after(std::time::Duration::from_millis(50));
        }
        let mut errors = Vec::new();
        if self.meter.quit_step(&self.ctx, &mut errors) {
            for e in errors {
                self.session.error(e);
            }
            self.meter.write_summary(self.summary());
            self.ctx.send_viewport_cmd(egui::ViewportCommand::Close);
        }
    }

    fn summary(&self) -> RunSummary {
        let r = &self.jobs.render;
        let mut errors: Vec<String> =
            self.session.messages.iter().filter(|m| m.error).map(|m| m.text.clone()).collect();
        errors.extend(r.failure.as_ref().map(|f| f.error.clone()));
        errors.extend(r.shader_error.clone());
        RunSummary {
            viewport_px: self.view.layout.pixels(),
            render_size: r.shown.as_ref().map(|p| [p.width, p.height]).unwrap_or_default(),
            adapter: r.device.as_ref().map(|d| d.adapter.clone()).unwrap_or_default(),
            scene: self.doc.scene.name.clone(),
            errors,
            ..RunSummary::default()
        }
    }

    // ------------------------------------------------------------------ read-only accessors (tests)

    pub fn look(&self) -> &Look {
        &self.doc.look
    }
    pub fn scene(&self) -> &Scene {
        &self.doc.scene
    }
    pub fn history(&self) -> &History {
        &self.doc.history
    }
    pub fn messages(&self) -> &[Message] {
        &self.session.messages
    }
    pub fn preset_path(&self) -> Option<&Path> {
        self.doc.preset_path.as_deref()
    }
    pub fn view(&self) -> ViewMode {
        self.view.mode
    }
    pub fn method(&self) -> Method {
        self.view.method
    }
    /// Whether VSV's surface shadows come from the shadow volume (`Renderer::surface_shadows`: grid).
    pub fn grid_shadows(&self) -> bool {
        self.view.surface_shadows == SurfaceShadows::Grid
    }

    /// Whether the surfaces' sun shadows are tested against the triangles (`Renderer::surface_shadows`: exact).
    pub fn exact_shadows(&self) -> bool {
        self.view.surface_shadows == SurfaceShadows::Exact
    }

    /// How VSV keeps its shadow volume (`Renderer::shadow_volume`).
    pub fn shadow_volume(&self) -> crate::render::ShadowVolume {
        self.view.shadow_volume
    }

    /// Whether Integrate takes pixels from their neighbours (`Renderer::adaptive_pixels`).
    pub fn adaptive_pixels(&self) -> bool {
        self.view.adaptive_pixels
    }
    /// The newest render request's generation (changes whenever the picture must be redrawn).
    pub fn generation(&self) -> u64 {
        self.jobs.render.generation
    }
    /// Pictures delivered so far (previews and full frames).
    pub fn frames_rendered(&self) -> u64 {
        self.jobs.render.frames
    }
    /// Full-quality pictures delivered so far.
    pub fn full_frames_rendered(&self) -> u64 {
        self.jobs.render.full_frames
    }
    /// Every picture delivered: (generation, full quality, the medium's density it shows).
    pub fn render_log(&self) -> &[(u64, bool, f32)] {
        &self.jobs.render.log
    }
    /// The picture on screen.
    pub fn shown(&self) -> Option<&Arc<Picture>> {
        self.jobs.render.shown.as_ref()
    }
    /// The picture on screen is the newest state at full quality, and nothing is being rendered:
    /// the editor has caught up.
    pub fn settled(&self) -> bool {
        let r = &self.jobs.render;
        let shown = r.shown.as_ref().is_some_and(|p| p.generation == r.generation && p.quality.is_full());
        let failed = r.failure.as_ref().is_some_and(|f| f.generation == r.generation);
        r.generation > 0 && (shown || failed) && !r.job.in_flight() && r.compiling.is_none()
    }
    /// The worker is rendering or has a request waiting.
    pub fn render_in_flight(&self) -> bool {
        self.jobs.render.job.in_flight()
    }
    /// The last frame's error, while no newer picture arrived.
    pub fn frame_error(&self) -> Option<&str> {
        self.jobs.render.failure.as_ref().map(|f| f.error.as_str())
    }
    /// The last reload's (or start-up's) shader error, shown over the viewport until fixed.
    pub fn shader_error(&self) -> Option<&str> {
        self.jobs.render.shader_error.as_deref()
    }
    /// A shader reload is compiling.
    pub fn compiling(&self) -> bool {
        self.jobs.render.compiling.is_some()
    }
    /// Successful reloads so far.
    pub fn shader_epoch(&self) -> u64 {
        self.jobs.render.shader_epoch
    }
    /// The exposure (stops) the viewport shows the current picture at.
    pub fn shown_exposure(&self) -> f32 {
        let (m, p) = self.shown().map(|p| (p.stats.scatter_mean, p.stats.scatter_p99)).unwrap_or_default();
        self.view.shown_exposure(self.doc.look.exposure, m, p)
    }
    pub fn accuracy_running(&self) -> bool {
        self.jobs.accuracy_running()
    }
    /// Size of the last accuracy check's images.
    pub fn accuracy_size(&self) -> Option<(u32, u32)> {
        self.jobs.accuracy_result.as_ref().map(|r| (r.width, r.height))
    }
    /// (scattered, final) relative RMSE of the last accuracy check.
    pub fn accuracy_rel_rmse(&self) -> Option<(f64, f64)> {
        let r = self.jobs.accuracy_result.as_ref()?;
        Some((r.scatter.as_ref().ok()?.rel_rmse, r.hdr.as_ref().ok()?.rel_rmse))
    }
    /// The (plane, ray) under the pointer in the viewport, when the pointer is over it.
    pub fn viewport_cell(&self) -> Option<(f64, f64)> {
        self.view.layout.hover_cell
    }
    /// The (plane, ray) under the pointer in the inspector's grid picture.
    pub fn inspector_cell(&self) -> Option<(f64, f64)> {
        self.view.layout.inspector_cell
    }
    /// Where the inspector drew its grid picture (points).
    pub fn inspector_grid_rect(&self) -> Option<egui::Rect> {
        self.panels.inspector.grid_rect
    }
    /// The grid the inspector shows: (its frame's generation, planes, rays, bins).
    pub fn inspector_grid(&self) -> Option<(u64, crate::params::Grid)> {
        self.jobs.render.grids.as_ref().map(|g| (g.generation, g.grid))
    }
    /// Where the light's handle is drawn in the viewport (points), when it is in view.
    pub fn light_handle_pos(&self) -> Option<egui::Pos2> {
        super::camera::light_handle(&self.doc.look.camera, self.view.layout.rect?, &self.doc.look.light)
    }
    /// The plane the inspector's slice shows.
    pub fn slice_plane(&self) -> u32 {
        self.view.inspector.slice_plane
    }
    /// The viewport's rectangle in points (after the first frame).
    pub fn viewport_rect(&self) -> Option<egui::Rect> {
        self.view.layout.rect
    }
    /// The overwrite question is open for this path.
    pub fn confirming_overwrite(&self) -> Option<&Path> {
        self.session.confirm_overwrite.as_deref()
    }
}

impl eframe::App for Editor {
    fn ui(&mut self, ui: &mut egui::Ui, _frame: &mut eframe::Frame) {
        Editor::ui(self, ui);
    }

    /// The panels' colour: the panels paint no background of their own.
    fn clear_color(&self, visuals: &egui::Visuals) -> [f32; 4] {
        visuals.panel_fill.to_normalized_gamma_f32()
    }
}

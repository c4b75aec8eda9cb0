//! [`Editor::apply`]: the one place that changes editor state, for commands from the panels and
//! for what the background jobs delivered.

use super::app::Editor;
use super::command::Command;
use super::display::ViewportResources;
use super::document::Look;
use super::files::DialogPurpose;
use super::jobs::render::{FrameRequest, RenderEvent};
use super::jobs::{Accuracy, JobEvent, RenderContent};
use super::view::ViewMode;
use crate::params::{Baseline, Exposure};
use crate::preset::Preset;
use crate::render::Method;
use crate::scene::Scene;
use eframe::egui;
use std::path::{Path, PathBuf};
use std::time::Instant;

impl Editor {
    /// Applies one command. Every change of editor state goes through here.
    pub fn apply(&mut self, cmd: Command) {
        let doc = &mut self.doc;
        let view = &mut self.view;
        match cmd {
            Command::SetMedium(m, key) => {
                if m.validate().is_ok() {
                    doc.edit(key, |l| l.medium = m);
                }
            }
            Command::SetLight(light, key) => {
                if light.validate().is_ok() {
                    doc.edit(key, |l| l.light = light.normalized());
                }
            }
            Command::SetGrid(g, key) => {
                if g.validate().is_ok() {
                    doc.edit(key, |l| l.grid = g);
                }
            }
            Command::SetCamera(c, key) => {
                if c.validate().is_ok() {
                    doc.edit(key, |l| l.camera = c);
                }
            }
            Command::SetExposure(e, key) => {
                if Exposure::STOPS.check(e as f64).is_ok() {
                    doc.edit(key, |l| l.exposure = e);
                }
            }
            Command::ResetCamera => {
                let c = doc.scene.camera;
                doc.edit(None, |l| l.camera = c);
            }
            Command::Undo => doc.undo(),
            Command::Redo => doc.redo(),
            Command::SetView(v) => view.mode = v,
            Command::SetMethod(m) => {
                let m = match m {
                    Method::Raymarch { steps, jitter } => {
                        let spec = Baseline::STEPS;
                        let steps = (steps as f64).clamp(spec.min, spec.max) as u32;
                        view.raymarch_steps = steps;
                        Method::Raymarch { steps, jitter }
                    }
                    m => m,
                };
                view.method = m;
            }
            Command::SetShadowMap(s) => {
                if Baseline::SHADOW_MAP.check(s as f64).is_ok() {
                    view.shadow_map = s;
                }
            }
            Command::SetSurfaceShadows(from) => view.surface_shadows = from,
            Command::SetShadowVolume(volume) => view.shadow_volume = volume,
            Command::SetAdaptivePixels(on) => view.adaptive_pixels = on,
            Command::SetRenderScale(s) => view.render_scale = s.clamp(0.1, 1.0),
            Command::SetCameraMode(m) => view.camera.mode = m,
            Command::SetExposureMode(m) => view.exposure_mode = m,
            Command::SetScatterExposure(e) => {
                view.scatter_exposure = e.clamp(Exposure::STOPS.min as f32, Exposure::STOPS.max as f32)
            }
            Command::ShowInspector(v) => view.inspector.visible = v,
            Command::SetInspectorMode(m) => view.inspector.mode = m,
            Command::SetSlicePlane(p) => view.inspector.slice_plane = p,
            Command::SetFollowHover(f) => view.inspector.follow_hover = f,
            Command::LayoutViewport(rect, ppp) => {
                view.layout.rect = Some(rect);
                view.layout.pixels_per_point = ppp;
            }
            Command::HoverViewport(c) => view.layout.hover_cell = c,
            Command::HoverInspector(c) => view.layout.inspector_cell = c,
            Command::DragLight(on) => view.layout.dragging_light = on,
            Command::RequestFrame { interactive } => self.request_frame(interactive),
            Command::LoadPreset(path) => {
                doc.history.break_merge();
                self.load_preset(&path);
            }
            Command::SavePreset => match doc.preset_path.clone() {
                Some(p) => self.save_preset(&p),
                None => self.apply(Command::SavePresetAsDialog),
            },
            Command::SavePresetAs { path, overwrite } => {
                if path.exists() && !overwrite {
                    // Never replace a file silently: ask (the modal sends overwrite: true).
                    self.session.confirm_overwrite = Some(path);
                } else {
                    self.session.confirm_overwrite = None;
                    self.save_preset(&path);
                }
            }
            Command::CancelOverwrite => self.session.confirm_overwrite = None,
            Command::OpenScene(path) => {
                let ctx = self.ctx.clone();
                match self.jobs.load_scene(path.clone(), move || ctx.request_repaint()) {
                    Ok(()) => self.session.info(format!("loading {} …", path.display())),
                    Err(e) => self.session.error(format!("could not start loading {}: {e}", path.display())),
                }
            }
            Command::Screenshot(path) => self.screenshot(&path),
            Command::ExportInspector(path) => match self.panels.inspector.export(&path) {
                Ok(()) => self.session.info(format!("inspector picture saved to {}", path.display())),
                Err(e) => self.session.error(format!("could not export the inspector picture: {e}")),
            },
            Command::OpenSceneDialog => self.open_dialog(DialogPurpose::OpenScene),
            Command::OpenPresetDialog => self.open_dialog(DialogPurpose::OpenPreset),
            Command::SavePresetAsDialog => self.open_dialog(DialogPurpose::SavePresetAs),
            Command::ScreenshotDialog => self.open_dialog(DialogPurpose::Screenshot),
            Command::ExportInspectorDialog => self.open_dialog(DialogPurpose::ExportInspector),
            Command::StartAccuracy { width } => self.start_accuracy(width),
            Command::CancelAccuracy => match &self.jobs.accuracy {
                Accuracy::Running(j) => j.cancel(),
                Accuracy::Capturing { .. } => {
                    self.jobs.accuracy = Accuracy::Idle;
                    self.session.info("accuracy check cancelled");
                }
                Accuracy::Idle => {}
            },
            Command::ReloadShaders => {
                let r = &mut self.jobs.render;
                r.job.reload(self.jobs.shaders.clone());
                r.reloads_pending += 1;
                r.compiling.get_or_insert_with(Instant::now);
                self.meter.event("reload", serde_json::json!("requested"));
            }
            Command::DismissMessages => self.session.messages.clear(),
            Command::Quit => self.ctx.send_viewport_cmd(egui::ViewportCommand::Close),
            Command::Job(e) => self.job_event(e),
        }
    }

    /// Sends the worker the current state when it changed (a new generation), or when only the
    /// interactivity changed (the pointer came up: the full frame of the same state).
    fn request_frame(&mut self, interactive: bool) {
        let Some((width, height)) = self.view.render_size() else { return };
        let (doc, view) = (&self.doc, &self.view);
        let content = RenderContent {
            // The exposure is applied at display time: changing it renders nothing.
            look: Look { exposure: 0.0, ..doc.look },
            surface_only: view.mode == ViewMode::Surface,
            method: view.method,
            shadow_map: view.shadow_map,
            surface_shadows: view.surface_shadows,
            shadow_volume: view.shadow_volume,
            adaptive_pixels: view.adaptive_pixels,
            width,
            height,
            scene_generation: doc.scene_generation,
            shader_epoch: self.jobs.render.shader_epoch,
            grids: view.inspector.visible,
        };
        let forcing = self.meter.forcing_frames();
        let r = &mut self.jobs.render;
        // Measuring: a new frame as soon as the last one is on screen.
        let again = forcing && r.shown.as_ref().is_some_and(|p| p.generation == r.generation && p.quality.is_full());
        let changed = r.content.as_ref() != Some(&content) || again;
        if changed {
            r.generation += 1;
            r.content = Some(content.clone());
        } else if interactive == r.interactive {
            return;
        }
        r.interactive = interactive;
        r.job.submit(FrameRequest {
            generation: r.generation,
            scene: doc.scene.clone(),
            scene_generation: content.scene_generation,
            look: content.look,
            surface_only: content.surface_only,
            width,
            height,
            method: content.method,
            shadow_map: content.shadow_map,
            surface_shadows: content.surface_shadows,
            shadow_volume: content.shadow_volume,
            adaptive_pixels: content.adaptive_pixels,
            interactive,
            progressive: !forcing,
            grids: content.grids,
        });
    }

    fn job_event(&mut self, e: JobEvent) {
        match e {
            JobEvent::Render(e) => self.render_event(e),
            JobEvent::SceneLoaded(path, Ok(scene)) => self.scene_loaded(path, scene),
            JobEvent::SceneLoaded(_, Err(e)) => {
                self.jobs.scene_load = None;
                self.session.error(format!("scene not opened: {e}"));
            }
            JobEvent::ShadersChanged => self.apply(Command::ReloadShaders),
            JobEvent::DialogClosed(_, None, true) => self.session.error(
                "no file dialog could be shown (it needs the XDG desktop portal or zenity); drop the file on the \
                 window instead",
            ),
            // Cancelled.
            JobEvent::DialogClosed(_, None, false) => {}
            JobEvent::DialogClosed(purpose, Some(p), _) => self.apply(match purpose {
                DialogPurpose::OpenScene => Command::OpenScene(p),
                DialogPurpose::OpenPreset => Command::LoadPreset(p),
                // The portal's own dialog asks before replacing; ask anyway (it may not).
                DialogPurpose::SavePresetAs => Command::SavePresetAs { path: p, overwrite: false },
                DialogPurpose::Screenshot => Command::Screenshot(p),
                DialogPurpose::ExportInspector => Command::ExportInspector(p),
            }),
            JobEvent::AccuracyFinished(r) => {
                match r {
                    Some(r) => self.jobs.accuracy_result = Some(r),
                    None => self.session.info("accuracy check cancelled"),
                }
                self.jobs.accuracy = Accuracy::Idle;
            }
        }
    }

    fn render_event(&mut self, e: RenderEvent) {
        let r = &mut self.jobs.render;
        match e {
            RenderEvent::Started(Ok(dev)) => {
                if let Some(e) = &dev.startup_error {
                    r.shader_error.get_or_insert_with(|| e.clone());
                }
                self.meter.event("started", serde_json::json!(dev.adapter));
                r.device = Some(dev);
            }
            RenderEvent::Started(Err(e)) => self.session.error(format!("the renderer could not start: {e}")),
            RenderEvent::Stopped(e) => {
                r.compiling = None;
                r.reloads_pending = 0;
                self.session.error(format!("the renderer stopped ({e}); the last picture stays. Restart the editor."));
            }
            RenderEvent::Frame(Ok(p)) => {
                self.meter.picture(&p);
                r.frames += 1;
                r.full_frames += p.quality.is_full() as u64;
                if r.log.len() >= 256 {
                    r.log.remove(0);
                }
                r.log.push((p.generation, p.quality.is_full(), p.look.medium.density));
                if p.grids.is_some() {
                    r.grids = p.grids.clone();
                }
                r.failure = None;
                r.shown = Some(p);
            }
            RenderEvent::Frame(Err(f)) => r.failure = Some(f),
            RenderEvent::Reloaded(result) => {
                r.reloads_pending = r.reloads_pending.saturating_sub(1);
                if r.reloads_pending == 0 {
                    r.compiling = None;
                }
                match result {
                    Ok((display, ms)) => {
                        if let Some(res) =
                            self.render_state.renderer.write().callback_resources.get_mut::<ViewportResources>()
                        {
                            res.display = display;
                        }
                        r.shader_epoch += 1;
                        r.reload_ms = Some(ms);
                        let fixed = r.shader_error.take().is_some();
                        self.meter.event("reloaded", serde_json::json!(ms));
                        if fixed {
                            self.session.info("shaders fixed and reloaded");
                        }
                    }
                    Err(e) => {
                        // The previous pipelines keep drawing; the error stays over the viewport.
                        self.meter.event("reload_error", serde_json::json!(e));
                        r.shader_error = Some(e);
                    }
                }
            }
            RenderEvent::Captured(id, Ok(images)) => {
                let ctx = self.ctx.clone();
                self.jobs.captured(id, images, move || ctx.request_repaint());
            }
            RenderEvent::Captured(_, Err(e)) => {
                self.jobs.accuracy = Accuracy::Idle;
                self.session.error(format!("accuracy check not started: {e}"));
            }
        }
    }

    fn load_preset(&mut self, path: &Path) {
        match Preset::load(path) {
            Ok(p) => {
                let mut s = self.doc.composed();
                p.apply(&mut s);
                let exposure = p.exposure.unwrap_or(self.doc.look.exposure);
                let (medium, grid) = (s.medium, s.grid);
                self.doc.edit(None, |l| {
                    l.medium = medium;
                    l.grid = grid;
                    l.exposure = exposure;
                });
                self.doc.preset_path = Some(path.to_path_buf());
                self.panels.presets.typed = p.name.clone().unwrap_or_default();
                self.session.recent.add_preset(path);
                self.session.remember_recent();
                self.session.info(format!("preset {} loaded", path.display()));
            }
            // The look stays as it was; the message names the file and the field.
            Err(e) => self.session.error(format!("preset refused: {e}")),
        }
    }

    fn save_preset(&mut self, path: &Path) {
        let s = self.doc.composed();
        let typed = self.panels.presets.typed.trim().to_string();
        let name =
            if typed.is_empty() { path.file_stem().map(|s| s.to_string_lossy().to_string()) } else { Some(typed) };
        let preset = Preset::from_scene(&s, name.as_deref(), self.doc.look.exposure);
        match preset.save(path) {
            Ok(()) => {
                self.doc.preset_path = Some(path.to_path_buf());
                self.panels.presets.invalidate();
                self.session.recent.add_preset(path);
                self.session.remember_recent();
                self.session.info(format!("preset saved to {}", path.display()));
            }
            Err(e) => self.session.error(format!("preset not saved: {e}")),
        }
    }

    /// A loaded scene replaces the document (its own look; the exposure stays; a new history).
    fn scene_loaded(&mut self, path: PathBuf, scene: Scene) {
        self.jobs.scene_load = None;
        self.ctx.send_viewport_cmd(egui::ViewportCommand::Title(format!("epivox — {}", scene.name)));
        self.doc.replace_scene(scene);
        self.jobs.render.grids = None;
        self.view.layout.hover_cell = None;
        self.view.layout.inspector_cell = None;
        self.jobs.accuracy = Accuracy::Idle;
        self.jobs.accuracy_result = None;
        self.session.recent.add_scene(&path);
        self.session.remember_recent();
        self.session.info(format!("opened {} ({} triangles)", path.display(), self.doc.scene.triangle_count()));
    }

    fn open_dialog(&mut self, purpose: DialogPurpose) {
        let start = match purpose {
            DialogPurpose::OpenPreset | DialogPurpose::SavePresetAs => Some(self.session.presets_dir.clone()),
            _ => std::env::current_dir().ok(),
        };
        let ctx = self.ctx.clone();
        self.jobs.dialogs.start(purpose, start, move || ctx.request_repaint());
    }

    /// Saves the picture on screen as shown (the image and exposure the viewport uses).
    fn screenshot(&mut self, path: &Path) {
        let Some(p) = self.jobs.render.shown.clone() else {
            self.session.error("screenshot failed: nothing rendered yet");
            return;
        };
        let img = if self.view.mode == ViewMode::Scattered { &p.scatter } else { &p.hdr };
        let exposure = self.view.shown_exposure(self.doc.look.exposure, p.stats.scatter_mean, p.stats.scatter_p99);
        match img.write_png(path, exposure) {
            Ok(()) => self.session.info(format!("screenshot saved to {}", path.display())),
            Err(e) => self.session.error(format!("screenshot failed: {e}")),
        }
    }

    /// Asks the worker for the GPU image of the current view at the check's size; the reference
    /// starts when it arrives.
    fn start_accuracy(&mut self, width: u32) {
        let (vw, vh) = self.jobs.render.shown.as_ref().map(|p| (p.width, p.height)).unwrap_or((4, 3));
        let width = width.max(8);
        let height = ((width as f64 * vh as f64 / vw.max(1) as f64).round() as u32).max(8);
        let scene = std::sync::Arc::new(self.doc.composed());
        let generation = self.doc.scene_generation;
        self.jobs.start_capture(scene, generation, width, height, self.view.method);
        self.accuracy_started += 1;
    }
}

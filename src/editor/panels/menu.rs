//! The menu bar, the status bar, and the question before a file is replaced.

use super::{Command, Panel, PanelCtx};
use eframe::egui;

#[derive(Default)]
pub struct MenuBar;

impl Panel for MenuBar {
    fn name(&self) -> &'static str {
        "Menu"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let recent = &cx.session.recent;
        let doc = cx.doc;
        egui::MenuBar::new().ui(ui, |ui| {
            ui.menu_button("File", |ui| {
                if ui.button("Open scene…").clicked() {
                    out.push(Command::OpenSceneDialog);
                }
                ui.menu_button("Recent scenes", |ui| {
                    if recent.scenes.is_empty() {
                        ui.label("none yet");
                    }
                    for p in &recent.scenes {
                        if ui.button(p.display().to_string()).clicked() {
                            out.push(Command::OpenScene(p.clone()));
                        }
                    }
                });
                ui.menu_button("Recent presets", |ui| {
                    if recent.presets.is_empty() {
                        ui.label("none yet");
                    }
                    for p in &recent.presets {
                        if ui.button(p.display().to_string()).clicked() {
                            out.push(Command::LoadPreset(p.clone()));
                        }
                    }
                });
                ui.separator();
                if ui.button("Open preset…").clicked() {
                    out.push(Command::OpenPresetDialog);
                }
                if ui.add_enabled(doc.preset_path.is_some(), egui::Button::new("Save preset")).clicked() {
                    out.push(Command::SavePreset);
                }
                if ui.button("Save preset as…").clicked() {
                    out.push(Command::SavePresetAsDialog);
                }
                ui.separator();
                if ui.button("Screenshot of the viewport…").clicked() {
                    out.push(Command::ScreenshotDialog);
                }
                if ui.button("Export inspector picture…").clicked() {
                    out.push(Command::ExportInspectorDialog);
                }
                ui.separator();
                if ui.button("Quit").clicked() {
                    out.push(Command::Quit);
                }
            });
            ui.menu_button("Edit", |ui| {
                if ui.add_enabled(doc.history.can_undo(), egui::Button::new("Undo")).clicked() {
                    out.push(Command::Undo);
                }
                if ui.add_enabled(doc.history.can_redo(), egui::Button::new("Redo")).clicked() {
                    out.push(Command::Redo);
                }
                if ui.button("Reset camera").clicked() {
                    out.push(Command::ResetCamera);
                }
                if ui.button("Reload shaders (F5)").clicked() {
                    out.push(Command::ReloadShaders);
                }
            });
            ui.separator();
            ui.label(
                egui::RichText::new(format!("{} · {} triangles", doc.scene.name, doc.scene.triangle_count())).weak(),
            );
            if let Some(p) = &doc.preset_path {
                let name = p.file_name().map(|n| n.to_string_lossy()).unwrap_or_default();
                ui.label(egui::RichText::new(format!("preset {name}")).weak());
            }
        });
    }
}

#[derive(Default)]
pub struct StatusBar;

impl Panel for StatusBar {
    fn name(&self) -> &'static str {
        "Status"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let messages = &cx.session.messages;
        ui.horizontal_wrapped(|ui| {
            let jobs = cx.jobs;
            let place = match (&jobs.watcher, jobs.shaders.dir()) {
                (Some(w), _) => format!("watching {}", w.dir().display()),
                (None, Some(d)) => d.display().to_string(),
                (None, None) => "embedded shaders".into(),
            };
            ui.label(egui::RichText::new(place).small().weak());
            if jobs.scene_load.is_some() {
                ui.spinner();
            }
            if !messages.is_empty() && ui.small_button("clear").clicked() {
                out.push(Command::DismissMessages);
            }
        });
        for m in messages.iter().rev().take(3) {
            if m.error {
                ui.colored_label(ui.visuals().error_fg_color, &m.text);
            } else {
                ui.label(&m.text);
            }
        }
    }
}

/// Asks before replacing an existing file (the answer is a command).
pub fn overwrite_modal(ctx: &egui::Context, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
    let Some(path) = cx.session.confirm_overwrite.clone() else { return };
    egui::Modal::new(egui::Id::unique("epivox-overwrite")).show(ctx, |ui| {
        ui.label(format!("{} already exists. Replace it?", path.display()));
        ui.horizontal(|ui| {
            if ui.button("Replace").clicked() {
                out.push(Command::SavePresetAs { path: path.clone(), overwrite: true });
            }
            if ui.button("Cancel").clicked() {
                out.push(Command::CancelOverwrite);
            }
        });
    });
}

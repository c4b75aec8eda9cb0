//! The Presets panel: the preset folder's looks, load and save.

use super::Command;
use crate::editor::files::list_presets;
use eframe::egui;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

#[derive(Default)]
pub struct PresetsPanel {
    /// Name typed for "Save as new preset".
    pub typed: String,
    list: Vec<PathBuf>,
    listed: Option<(PathBuf, Instant)>,
}

/// A file name from a typed preset name: letters, digits, `-` and `_` kept, the rest dashes.
pub fn file_name_for(name: &str) -> Option<String> {
    let stem: String = name
        .trim()
        .chars()
        .map(|c| if c.is_alphanumeric() || c == '-' || c == '_' { c.to_ascii_lowercase() } else { '-' })
        .collect();
    let stem = stem.trim_matches('-').to_string();
    (!stem.is_empty()).then(|| format!("{stem}.toml"))
}

impl PresetsPanel {
    /// Reads the folder again on the next frame (after a save).
    pub fn invalidate(&mut self) {
        self.listed = None;
    }

    /// Re-reads the folder at most every two seconds (a preset saved elsewhere shows up).
    fn refresh(&mut self, dir: &Path) {
        let fresh = self.listed.as_ref().is_some_and(|(d, t)| d == dir && t.elapsed() < Duration::from_secs(2));
        if !fresh {
            self.list = list_presets(dir);
            self.listed = Some((dir.to_path_buf(), Instant::now()));
        }
    }

    fn draw(&mut self, ui: &mut egui::Ui, dir: &Path, current: Option<&Path>, out: &mut Vec<Command>) {
        self.refresh(dir);
        ui.label(egui::RichText::new(format!("{}", dir.display())).small());
        ui.horizontal_wrapped(|ui| {
            for p in &self.list {
                let stem = p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
                let selected = current.is_some_and(|c| c == p);
                if ui.selectable_label(selected, &stem).on_hover_text(p.display().to_string()).clicked() {
                    out.push(Command::LoadPreset(p.clone()));
                }
            }
            if self.list.is_empty() {
                ui.label("no presets in this folder");
            }
        });
        ui.horizontal(|ui| {
            if ui.button("Open…").clicked() {
                out.push(Command::OpenPresetDialog);
            }
            let save = ui.add_enabled(current.is_some(), egui::Button::new("Save"));
            let save = match current {
                Some(c) => save.on_hover_text(format!("Overwrite {}", c.display())),
                None => save.on_disabled_hover_text("No preset loaded yet: use Save as"),
            };
            if save.clicked() {
                out.push(Command::SavePreset);
            }
            if ui.button("Save as…").clicked() {
                out.push(Command::SavePresetAsDialog);
            }
        });
        ui.horizontal(|ui| {
            ui.add(egui::TextEdit::singleline(&mut self.typed).hint_text("new preset name").desired_width(140.0));
            let file = file_name_for(&self.typed);
            let r = ui.add_enabled(file.is_some(), egui::Button::new("Save to folder"));
            if let Some(f) = &file {
                let r = r.on_hover_text(format!("Write {}", dir.join(f).display()));
                if r.clicked() {
                    out.push(Command::SavePresetAs { path: dir.join(f), overwrite: false });
                }
            }
        });
    }
}

impl super::Panel for PresetsPanel {
    fn name(&self) -> &'static str {
        "Presets"
    }
    fn show(&mut self, ui: &mut egui::Ui, cx: &super::PanelCtx<'_>, out: &mut Vec<Command>) {
        self.draw(ui, &cx.session.presets_dir, cx.doc.preset_path.as_deref(), out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn typed_names_become_safe_file_names() {
        assert_eq!(file_name_for("Morning Haze").as_deref(), Some("morning-haze.toml"));
        assert_eq!(file_name_for("../etc/passwd").as_deref(), Some("etc-passwd.toml"));
        assert_eq!(file_name_for("  "), None);
    }
}

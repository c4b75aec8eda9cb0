//! The toolbar above the viewport: view mode, method and its settings, exposure (automatic for the
//! scattered light alone), pixel share, camera mode, inspector, undo/redo, screenshot.

use super::{Command, Panel, PanelCtx};
use crate::editor::camera::CameraMode;
use crate::editor::command::merge_key;
use crate::editor::view::{ExposureMode, ViewMode};
use crate::params::{Baseline, Exposure};
use crate::render::{Method, SurfaceShadows};
use eframe::egui;

#[derive(Default)]
pub struct Toolbar;

/// The method as the toolbar names it.
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

/// Shadow-map sizes offered: powers of two within [`Baseline::SHADOW_MAP`] and the adapter's
/// largest texture.
fn shadow_map_sizes(texture_side: u32) -> Vec<u32> {
    let spec = Baseline::SHADOW_MAP;
    let top = (spec.max as u32).min(texture_side.max(spec.min as u32));
    (0..32).map(|i| 1u32 << i).filter(|s| *s >= spec.min as u32 && *s <= top).collect()
}

/// One row of the toolbar: a horizontal strip that scrolls sideways where the window is too narrow.
fn row(ui: &mut egui::Ui, id: &str, add: impl FnOnce(&mut egui::Ui)) {
    egui::ScrollArea::horizontal().id_salt(id).auto_shrink([false, true]).show(ui, |ui| {
        ui.horizontal(add);
    });
}

impl Panel for Toolbar {
    fn name(&self) -> &'static str {
        "Toolbar"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let view = cx.view;
        // Two fixed rows (not wrapped): the viewport below keeps its size whatever the toolbar
        // shows (a resize would render again). A window too narrow for a row scrolls it sideways
        // (its scroll bar floats over it, taking no height).
        row(ui, "toolbar-view", |ui| {
            for (mode, label) in ViewMode::ALL {
                if ui.selectable_label(view.mode == mode, label).on_hover_text(mode.doc()).clicked()
                    && view.mode != mode
                {
                    out.push(Command::SetView(mode));
                }
            }
            ui.separator();
            self.method(ui, cx, out);
        });
        row(ui, "toolbar-frame", |ui| {
            self.exposure(ui, cx, out);
            ui.separator();
            let mut scale = view.render_scale;
            egui::ComboBox::new("render-scale", "")
                .selected_text(format!("{}% pixels", (scale * 100.0).round()))
                .show_ui(ui, |ui| {
                    for s in [1.0f32, 0.75, 0.5, 0.25] {
                        ui.selectable_value(&mut scale, s, format!("{}% pixels", (s * 100.0).round()));
                    }
                })
                .response
                .on_hover_text("The share of the viewport's pixels a full-quality frame renders");
            if scale != view.render_scale {
                out.push(Command::SetRenderScale(scale));
            }
            let mode = view.camera.mode;
            if ui
                .selectable_label(mode == CameraMode::Orbit, "orbit")
                .on_hover_text("Drag: orbit · right/middle or Shift+drag: pan · wheel: dolly")
                .clicked()
            {
                out.push(Command::SetCameraMode(CameraMode::Orbit));
            }
            if ui
                .selectable_label(mode == CameraMode::Fly, "fly")
                .on_hover_text("Drag: look · W A S D Q E: move · wheel: forward/back")
                .clicked()
            {
                out.push(Command::SetCameraMode(CameraMode::Fly));
            }
            let mut insp = view.inspector.visible;
            if ui.toggle_value(&mut insp, "inspector").changed() {
                out.push(Command::ShowInspector(insp));
            }
            let h = &cx.doc.history;
            if ui.add_enabled(h.can_undo(), egui::Button::new("Undo")).clicked() {
                out.push(Command::Undo);
            }
            if ui.add_enabled(h.can_redo(), egui::Button::new("Redo")).clicked() {
                out.push(Command::Redo);
            }
            if ui.button("Screenshot…").on_hover_text("Save the viewport's picture as PNG").clicked() {
                out.push(Command::ScreenshotDialog);
            }
        });
    }
}

impl Toolbar {
    fn method(&self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let view = cx.view;
        let methods = [Method::Vsv, Method::Cartesian, Method::Raymarch { steps: view.raymarch_steps, jitter: true }];
        egui::ComboBox::new("method", "method").selected_text(method_label(&view.method)).show_ui(ui, |ui| {
            for m in methods {
                let same = std::mem::discriminant(&m) == std::mem::discriminant(&view.method);
                if ui.selectable_label(same, method_label(&m)).clicked() {
                    out.push(Command::SetMethod(m));
                }
            }
        });
        if let Method::Raymarch { steps, jitter } = view.method {
            let spec = Baseline::STEPS;
            let mut s = steps;
            let r = ui
                .add(egui::Slider::new(&mut s, spec.min as u32..=spec.max as u32).logarithmic(true).text(spec.name))
                .on_hover_text(spec.doc);
            if r.changed() {
                out.push(Command::SetMethod(Method::Raymarch { steps: s, jitter }));
            }
        }
        let side =
            cx.jobs.render.device.as_ref().map(|d| d.limits.texture_side).unwrap_or(Baseline::SHADOW_MAP.max as u32);
        let mut size = view.shadow_map;
        // A VSV frame with its shadows from the grid draws no map: the size is kept for later.
        let unused = view.method == Method::Vsv && view.surface_shadows == SurfaceShadows::Grid;
        ui.add_enabled_ui(!unused, |ui| {
            egui::ComboBox::new("shadow-map", "shadow map")
                .selected_text(format!("{size}²"))
                .show_ui(ui, |ui| {
                    for s in shadow_map_sizes(side) {
                        ui.selectable_value(&mut size, s, format!("{s}² {}", Baseline::SHADOW_MAP.unit));
                    }
                })
                .response
                .on_hover_text(Baseline::SHADOW_MAP.doc)
                .on_disabled_hover_text("not drawn: VSV's surface shadows come from the grid");
        });
        if size != view.shadow_map {
            out.push(Command::SetShadowMap(size));
        }
        if matches!(view.method, Method::Vsv | Method::Cartesian) {
            // Where the surfaces' shadows come from: one choice of three (grid shadows are VSV's).
            let vsv = view.method == Method::Vsv;
            let mut pick = view.surface_shadows;
            egui::ComboBox::new("surface-shadows", "shadows")
                // (Narrow: the row must fit a 1200-point window, `tests/editor.rs`, the toolbar test.)
                .width(52.0)
                .selected_text(pick.label())
                .show_ui(ui, |ui| {
                    for kind in SurfaceShadows::ALL {
                        if kind != SurfaceShadows::Grid || vsv {
                            ui.selectable_value(&mut pick, kind, kind.label()).on_hover_text(kind.doc());
                        }
                    }
                })
                .response
                .on_hover_text(pick.doc());
            if pick != view.surface_shadows {
                out.push(Command::SetSurfaceShadows(pick));
            }
        }
        if matches!(view.method, Method::Vsv | Method::Cartesian) {
            let mut on = view.adaptive_pixels;
            let r = ui.checkbox(&mut on, "adaptive pixels").on_hover_text(
                "Integrate every fourth pixel along the epipolar lines, then the pixels between from their \
                 neighbours on the line where those agree (faster, as accurate); off: every pixel integrated",
            );
            if r.changed() {
                out.push(Command::SetAdaptivePixels(on));
            }
        }
    }

    /// The look's exposure; in the scattered-only view its own, automatic by default.
    fn exposure(&self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let view = cx.view;
        let range = Exposure::STOPS.min as f32..=Exposure::STOPS.max as f32;
        let suffix = format!(" {}", Exposure::STOPS.unit);
        if view.mode != ViewMode::Scattered {
            let mut e = cx.doc.look.exposure;
            let r = ui
                .add(egui::Slider::new(&mut e, range).text("exposure").suffix(suffix))
                .on_hover_text(Exposure::STOPS.doc);
            if r.changed() {
                out.push(Command::SetExposure(e, merge_key(&r)));
            }
            return;
        }
        let mut mode = view.exposure_mode;
        egui::ComboBox::new("scatter-exposure", "")
            .selected_text(mode.label())
            .show_ui(ui, |ui| {
                for (m, label) in ExposureMode::ALL {
                    ui.selectable_value(&mut mode, m, label);
                }
            })
            .response
            .on_hover_text(
                "How the scattered light alone is exposed: from its own mean or 99th percentile, or by hand",
            );
        let shown = cx.jobs.render.shown.as_ref().map(|p| (p.stats.scatter_mean, p.stats.scatter_p99));
        let auto = shown.map(|(m, p)| view.shown_exposure(cx.doc.look.exposure, m, p)).unwrap_or(view.scatter_exposure);
        if mode != view.exposure_mode {
            out.push(Command::SetExposureMode(mode));
            if mode == ExposureMode::Manual {
                // Start from what was on screen: switching to manual does not jump.
                out.push(Command::SetScatterExposure(auto));
            }
        }
        let mut e = if view.exposure_mode == ExposureMode::Manual { view.scatter_exposure } else { auto };
        let r = ui.add_enabled(
            view.exposure_mode == ExposureMode::Manual,
            egui::Slider::new(&mut e, range).text("exposure").suffix(suffix),
        );
        if r.changed() {
            out.push(Command::SetScatterExposure(e));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shadow_map_sizes_stay_in_the_spec_and_the_adapter() {
        let s = shadow_map_sizes(8192);
        assert_eq!(s.first(), Some(&(Baseline::SHADOW_MAP.min as u32)));
        assert_eq!(s.last(), Some(&8192));
        assert!(s.contains(&Baseline::default().shadow_map));
    }
}

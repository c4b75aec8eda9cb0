//! The Accuracy panel: starts the reference check, shows its progress with a cancel button, then
//! the relative RMSE and a difference image.

use super::{Command, Panel, PanelCtx};
use crate::editor::document::Look;
use crate::editor::jobs::accuracy::AccuracyResult;
use crate::editor::jobs::Accuracy;
use eframe::egui;

pub struct AccuracyPanel {
    /// Width of the reference image (the height follows the viewport's aspect).
    pub width: u32,
    diff: Option<(egui::TextureHandle, usize)>,
}

impl Default for AccuracyPanel {
    fn default() -> Self {
        AccuracyPanel { width: 96, diff: None }
    }
}

impl Panel for AccuracyPanel {
    fn name(&self) -> &'static str {
        "Accuracy"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let result = cx.jobs.accuracy_result.as_deref();
        // The look changed since the result was measured.
        let look = cx.doc.look;
        let stale = result.is_some_and(|r| Look::of(&r.scene, look.exposure) != look);
        self.draw(ui, &cx.jobs.accuracy, result, stale, out);
    }
}

impl AccuracyPanel {
    fn draw(
        &mut self,
        ui: &mut egui::Ui,
        job: &Accuracy,
        result: Option<&AccuracyResult>,
        stale: bool,
        out: &mut Vec<Command>,
    ) {
        ui.label(
            egui::RichText::new(
                "Renders the exact CPU reference of this view at a reduced size in the background, then compares the \
                 current method with it. Editing goes on meanwhile.",
            )
            .small(),
        );
        match job {
            Accuracy::Capturing { width, height, method_label, .. } => {
                ui.horizontal(|ui| {
                    ui.spinner();
                    if ui.button("Cancel").clicked() {
                        out.push(Command::CancelAccuracy);
                    }
                });
                ui.label(format!("taking the GPU image {width}×{height} of {method_label} …"));
            }
            Accuracy::Running(j) => {
                ui.horizontal(|ui| {
                    ui.add(egui::ProgressBar::new(j.progress()).show_percentage().desired_width(160.0));
                    if ui.button("Cancel").clicked() {
                        out.push(Command::CancelAccuracy);
                    }
                });
                ui.label(format!("reference {}×{} of {} …", j.width, j.height, j.method_label));
            }
            Accuracy::Idle => {
                ui.horizontal(|ui| {
                    egui::ComboBox::new("accuracy-width", "reference size")
                        .selected_text(format!("{} px wide", self.width))
                        .show_ui(ui, |ui| {
                            for w in [48u32, 96, 160, 256] {
                                ui.selectable_value(&mut self.width, w, format!("{w} px wide"));
                            }
                        });
                    if ui.button("Measure accuracy").clicked() {
                        out.push(Command::StartAccuracy { width: self.width });
                    }
                });
            }
        }
        let Some(r) = result else { return };
        let fmt = |s: &Result<crate::metrics::ErrorStats, String>| match s {
            Ok(s) => format!("rel. RMSE {:.2}% · PSNR {:.1} dB · max {:.3e}", s.rel_rmse * 100.0, s.psnr, s.max_abs),
            Err(e) => e.clone(),
        };
        if stale {
            ui.colored_label(ui.visuals().warn_fg_color, "measured for an earlier look");
        }
        ui.label(format!("{} at {}×{} (reference {:.1} s):", r.method_label, r.width, r.height, r.seconds));
        ui.label(format!("scattered light: {}", fmt(&r.scatter)));
        ui.label(format!("final image: {}", fmt(&r.hdr)));
        let key = r.diff_rgba.as_ptr() as usize;
        if self.diff.as_ref().is_none_or(|(_, k)| *k != key) {
            let img = egui::ColorImage::from_rgba_unmultiplied([r.width as usize, r.height as usize], &r.diff_rgba);
            self.diff = Some((ui.ctx().load_texture("epivox-accuracy-diff", img, egui::TextureOptions::NEAREST), key));
        }
        if let Some((t, _)) = &self.diff {
            let w = ui.available_width().min(320.0);
            let h = w * r.height as f32 / r.width.max(1) as f32;
            ui.image((t.id(), egui::vec2(w, h)));
            ui.label(
                egui::RichText::new(format!(
                    "scattered light, GPU − reference: red brighter, blue darker; full colour = {:.3e} (sqrt scale)",
                    r.diff_scale
                ))
                .small(),
            );
        }
    }
}

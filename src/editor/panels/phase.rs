//! The Phase panel: the phase function's type, its parameter (only where it has one), and a live
//! polar plot of p(theta).

use super::{spec_slider, Command};
use crate::params::{Medium, Phase};
use eframe::egui;
use egui_plot::{Line, Plot, PlotPoints};

#[derive(Default)]
pub struct PhasePanel {
    /// Plot log10(1 + 4 pi p) instead of p: strongly forward lobes stay readable.
    pub log_radius: bool,
}

impl PhasePanel {
    fn draw(&mut self, ui: &mut egui::Ui, m: &Medium, out: &mut Vec<Command>) {
        let phase = m.phase;
        let mut kind = phase.id();
        egui::ComboBox::from_label("phase function").selected_text(phase.kind_name()).show_ui(ui, |ui| {
            for (i, name) in Phase::KINDS.iter().enumerate() {
                ui.selectable_value(&mut kind, i as u32, *name);
            }
        });
        // Keep the asymmetry when switching between lobed kinds; a fresh lobe starts mildly forward.
        // (clamped into the new kind's range: Schlick's is narrower).
        let g_now = if phase.has_g() { phase.g() } else { 0.3 };
        if kind != phase.id() {
            if let Some(p) = Phase::of_kind(kind, g_now) {
                let spec = p.g_spec();
                let g = (g_now as f64).clamp(spec.min, spec.max) as f32;
                if let Some(p) = Phase::of_kind(kind, g) {
                    out.push(Command::SetMedium(Medium { phase: p, ..*m }, None));
                }
            }
        }
        if phase.has_g() {
            let mut g = phase.g();
            let (r, k) = spec_slider(ui, &mut g, phase.g_spec(), "g (asymmetry)");
            if let (true, Some(p)) = (r.changed(), Phase::of_kind(phase.id(), g)) {
                out.push(Command::SetMedium(Medium { phase: p, ..*m }, k));
            }
        }
        ui.checkbox(&mut self.log_radius, "log radius");
        let iso = 1.0 / (4.0 * std::f64::consts::PI);
        let radius = |p: f64| if self.log_radius { (1.0 + p / iso).log10() } else { p };
        let curve = |f: &dyn Fn(f64) -> f64| -> Vec<[f64; 2]> {
            (0..=360)
                .map(|i| {
                    let th = (i as f64).to_radians();
                    let r = radius(f(th.cos()));
                    [r * th.cos(), r * th.sin()]
                })
                .collect()
        };
        let lobe = curve(&|c| phase.eval(c));
        let circle = curve(&|_| iso);
        Plot::new("phase-polar")
            .data_aspect(1.0)
            .height(170.0)
            .allow_drag(false)
            .allow_zoom(false)
            .allow_scroll(false)
            .show_axes([false, false])
            .show(ui, |p| {
                p.line(Line::new("isotropic", PlotPoints::from(circle)).color(egui::Color32::from_gray(110)));
                p.line(
                    Line::new(phase.kind_name(), PlotPoints::from(lobe)).color(egui::Color32::from_rgb(255, 170, 60)),
                );
            });
        ui.label(
            egui::RichText::new(format!(
                "p(θ) in 1/sr, light travelling to the right (θ = 0 forward): p(0°) = {:.4}, p(90°) = {:.4}, p(180°) = {:.4}",
                phase.eval(1.0),
                phase.eval(0.0),
                phase.eval(-1.0)
            ))
            .small(),
        );
    }
}

impl super::Panel for PhasePanel {
    fn name(&self) -> &'static str {
        "Phase function"
    }
    fn show(&mut self, ui: &mut egui::Ui, cx: &super::PanelCtx<'_>, out: &mut Vec<Command>) {
        self.draw(ui, &cx.doc.look.medium, out);
    }
}

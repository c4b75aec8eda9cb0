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

/// The phase function of kind `index` in [`Phase::KINDS`] with asymmetry `g` where it has one.
pub fn phase_of_kind(index: usize, g: f32) -> Phase {
    match index {
        0 => Phase::Isotropic,
        1 => Phase::HenyeyGreenstein { g },
        2 => Phase::Schlick { g },
        3 => Phase::CornetteShanks { g },
        _ => Phase::Rayleigh,
    }
}

fn has_g(p: &Phase) -> bool {
    matches!(p, Phase::HenyeyGreenstein { .. } | Phase::Schlick { .. } | Phase::CornetteShanks { .. })
}

impl PhasePanel {
    pub fn show(&mut self, ui: &mut egui::Ui, m: &Medium, out: &mut Vec<Command>) {
        let phase = m.phase;
        let mut kind = phase.id() as usize;
        egui::ComboBox::from_label("phase function").selected_text(Phase::KINDS[kind]).show_ui(ui, |ui| {
            for (i, name) in Phase::KINDS.iter().enumerate() {
                ui.selectable_value(&mut kind, i, *name);
            }
        });
        // Keep the asymmetry when switching between lobed kinds; a fresh lobe starts mildly forward.
        // (clamped into the new kind's range: Schlick's is narrower).
        let g_now = if has_g(&phase) { phase.g() } else { 0.3 };
        if kind != phase.id() as usize {
            let spec = phase_of_kind(kind, g_now).g_spec();
            let g = (g_now as f64).clamp(spec.min, spec.max) as f32;
            out.push(Command::SetMedium(Medium { phase: phase_of_kind(kind, g), ..*m }, None));
        }
        if has_g(&phase) {
            let mut g = phase.g();
            let (r, k) = spec_slider(ui, &mut g, phase.g_spec(), "g (asymmetry)");
            if r.changed() {
                out.push(Command::SetMedium(Medium { phase: phase_of_kind(kind, g), ..*m }, k));
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
                    Line::new(Phase::KINDS[kind], PlotPoints::from(lobe)).color(egui::Color32::from_rgb(255, 170, 60)),
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

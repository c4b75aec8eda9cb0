//! The Medium panel: scattering and absorption per channel, or the same medium as extinction,
//! albedo and colours; the density multiplier; derived lengths.

use super::{rgb_sliders, spec_slider, Command};
use crate::params::{Medium, Spec};
use eframe::egui;
use glam::Vec3;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum MediumView {
    /// sigma_s and sigma_a per channel.
    #[default]
    Coefficients,
    /// Extinction (strength and colour) and albedo (strength and colour).
    AlbedoExtinction,
}

/// The medium as the artist's four knobs: `sigma_t = extinction * extinction_colour`,
/// `sigma_s = sigma_t * albedo * albedo_colour` (per channel), `sigma_a = sigma_t - sigma_s`.
/// Colours have their largest channel at 1, so the scalars carry the strength. This is a bijection
/// for a non-zero medium; for a zero one the colours are kept from before.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlbedoExtinction {
    pub extinction: f32,
    pub extinction_colour: Vec3,
    pub albedo: f32,
    pub albedo_colour: Vec3,
}

fn split(v: Vec3, fallback: Vec3) -> (f32, Vec3) {
    let m = v.max_element();
    if m > 0.0 {
        (m, v / m)
    } else {
        (0.0, fallback)
    }
}

impl AlbedoExtinction {
    pub fn from_medium(m: &Medium, previous: &AlbedoExtinction) -> AlbedoExtinction {
        let t = m.scattering + m.absorption;
        let (extinction, extinction_colour) = split(t, previous.extinction_colour);
        let per_channel = Vec3::select(t.cmpgt(Vec3::ZERO), m.scattering / t.max(Vec3::splat(1e-30)), Vec3::ZERO);
        let (albedo, albedo_colour) = if extinction > 0.0 {
            split(per_channel, previous.albedo_colour)
        } else {
            (previous.albedo, previous.albedo_colour)
        };
        AlbedoExtinction { extinction, extinction_colour, albedo, albedo_colour }
    }

    /// Writes back scattering and absorption (density and phase untouched).
    pub fn to_medium(self, m: &Medium) -> Medium {
        let t = self.extinction_colour * self.extinction;
        let a = (self.albedo_colour * self.albedo).clamp(Vec3::ZERO, Vec3::ONE);
        let s = t * a;
        Medium { scattering: s, absorption: (t - s).max(Vec3::ZERO), ..*m }
    }
}

impl Default for AlbedoExtinction {
    fn default() -> Self {
        AlbedoExtinction { extinction: 0.0, extinction_colour: Vec3::ONE, albedo: 0.9, albedo_colour: Vec3::ONE }
    }
}

pub struct MediumPanel {
    pub view: MediumView,
    /// Edit the three channels together.
    pub linked: bool,
    last: AlbedoExtinction,
}

impl Default for MediumPanel {
    fn default() -> Self {
        MediumPanel { view: MediumView::Coefficients, linked: false, last: AlbedoExtinction::default() }
    }
}

/// Ranges of the derived knobs, from the coefficients' specs.
const EXTINCTION: Spec = Spec {
    name: "extinction",
    unit: Medium::SCATTERING.unit,
    min: 0.0,
    max: Medium::SCATTERING.max + Medium::ABSORPTION.max,
    doc: "Extinction sigma_t = sigma_s + sigma_a of the strongest channel: how fast light is lost per unit length.",
};
const ALBEDO: Spec = Spec {
    name: "albedo",
    unit: "",
    min: 0.0,
    max: 1.0,
    doc: "Single-scattering albedo sigma_s / sigma_t of the brightest channel: 1 scatters everything, 0 absorbs.",
};

impl MediumPanel {
    /// `scene_size`: the scene's bounding diameter, for the optical depth shown.
    fn draw(&mut self, ui: &mut egui::Ui, m: &Medium, scene_size: f32, out: &mut Vec<Command>) {
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.view, MediumView::Coefficients, "σs / σa");
            ui.selectable_value(&mut self.view, MediumView::AlbedoExtinction, "albedo / extinction");
            if self.view == MediumView::Coefficients {
                ui.checkbox(&mut self.linked, "grey").on_hover_text("Edit the three channels together");
            }
        });
        match self.view {
            MediumView::Coefficients => {
                if let Some((v, k)) = rgb_sliders(ui, m.scattering, &Medium::SCATTERING, "scattering", self.linked) {
                    out.push(Command::SetMedium(Medium { scattering: v, ..*m }, k));
                }
                if let Some((v, k)) = rgb_sliders(ui, m.absorption, &Medium::ABSORPTION, "absorption", self.linked) {
                    out.push(Command::SetMedium(Medium { absorption: v, ..*m }, k));
                }
            }
            MediumView::AlbedoExtinction => {
                let ae = AlbedoExtinction::from_medium(m, &self.last);
                self.last = ae;
                let mut e = ae;
                let (r, k) = spec_slider(ui, &mut e.extinction, &EXTINCTION, "extinction");
                let mut changed = r.changed().then_some(k);
                ui.horizontal(|ui| {
                    let mut c = e.extinction_colour.to_array();
                    if egui::color_picker::color_edit_button_rgb(ui, &mut c).changed() {
                        e.extinction_colour = split(Vec3::from_array(c), e.extinction_colour).1;
                        changed = Some(None);
                    }
                    ui.label("extinction colour");
                });
                let (r, k) = spec_slider(ui, &mut e.albedo, &ALBEDO, "albedo");
                if r.changed() {
                    changed = Some(k);
                }
                ui.horizontal(|ui| {
                    let mut c = e.albedo_colour.to_array();
                    if egui::color_picker::color_edit_button_rgb(ui, &mut c).changed() {
                        e.albedo_colour = split(Vec3::from_array(c), e.albedo_colour).1;
                        changed = Some(None);
                    }
                    ui.label("colour (albedo per channel)");
                });
                if let Some(k) = changed {
                    self.last = e;
                    out.push(Command::SetMedium(e.to_medium(m), k));
                }
            }
        }
        let mut d = m.density;
        let (r, k) = spec_slider(ui, &mut d, &Medium::DENSITY, "density");
        if r.changed() {
            out.push(Command::SetMedium(Medium { density: d, ..*m }, k));
        }
        let t = m.sigma_t();
        let mfp = |x: f32| if x > 0.0 { format!("{:.3}", 1.0 / x) } else { "∞".into() };
        ui.label(
            egui::RichText::new(format!(
                "σt = ({:.4}, {:.4}, {:.4}) 1/unit · mean free path ({}, {}, {}) unit · optical depth across the scene {:.2}",
                t.x,
                t.y,
                t.z,
                mfp(t.x),
                mfp(t.y),
                mfp(t.z),
                t.max_element() * scene_size
            ))
            .small(),
        );
    }
}

impl super::Panel for MediumPanel {
    fn name(&self) -> &'static str {
        "Medium"
    }
    fn show(&mut self, ui: &mut egui::Ui, cx: &super::PanelCtx<'_>, out: &mut Vec<Command>) {
        let size = cx.doc.bounds.radius() * 2.0;
        self.draw(ui, &cx.doc.look.medium, size, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn albedo_extinction_round_trips() {
        let m = Medium {
            scattering: Vec3::new(0.02, 0.05, 0.1),
            absorption: Vec3::new(0.3, 0.01, 0.0),
            ..Medium::default()
        };
        let ae = AlbedoExtinction::from_medium(&m, &AlbedoExtinction::default());
        let back = ae.to_medium(&m);
        assert!((back.scattering - m.scattering).abs().max_element() < 1e-6, "{back:?}");
        assert!((back.absorption - m.absorption).abs().max_element() < 1e-6, "{back:?}");
        // A clear medium keeps the colours it had.
        let clear = Medium { scattering: Vec3::ZERO, absorption: Vec3::ZERO, ..m };
        let z = AlbedoExtinction::from_medium(&clear, &ae);
        assert_eq!(z.albedo_colour, ae.albedo_colour);
        assert_eq!(z.extinction, 0.0);
    }
}

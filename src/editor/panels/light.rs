//! The Light panel: type, position or direction, colour, intensity, radius.

use super::{spec_slider, Command};
use crate::params::{Light, Spec};
use crate::scene::Aabb;
use eframe::egui;
use glam::Vec3;

#[derive(Default)]
pub struct LightPanel;

/// Converts a light to the other type, keeping its brightness at the scene's centre roughly equal
/// (as `epivox render --light-pos/--light-dir` do).
pub fn convert(light: &Light, to_point: bool, bounds: &Aabb) -> Light {
    match (*light, to_point) {
        (Light::Directional { direction, irradiance }, true) => {
            let r = bounds.radius().max(1e-3);
            let d = direction.normalize_or(Vec3::Y);
            let dist = r * 1.5;
            Light::Point { position: bounds.center() + d * dist, intensity: irradiance * dist * dist, radius: 0.0 }
        }
        (Light::Point { position, intensity, .. }, false) => {
            let to = position - bounds.center();
            let dist = to.length().max(1e-3);
            Light::Directional { direction: to.normalize_or(Vec3::Y), irradiance: intensity / (dist * dist) }
        }
        (l, _) => l,
    }
}

/// Edits a colour-times-strength value (intensity or irradiance): the strength is the brightest
/// channel, the colour the value over it.
fn power_editor(ui: &mut egui::Ui, v: Vec3, spec: &Spec, label: &str) -> Option<(Vec3, super::MergeKey)> {
    let mut out = None;
    let strength = v.max_element();
    let colour = if strength > 0.0 { v / strength } else { Vec3::ONE };
    let mut s = strength;
    let (r, k) = spec_slider(ui, &mut s, spec, label);
    if r.changed() {
        out = Some((colour * s, k));
    }
    ui.horizontal(|ui| {
        let mut c = colour.to_array();
        if egui::color_picker::color_edit_button_rgb(ui, &mut c).changed() {
            let c = Vec3::from_array(c);
            let c = if c.max_element() > 0.0 { c / c.max_element() } else { Vec3::ONE };
            out = Some((c * strength, None));
        }
        ui.label("colour");
    });
    out
}

impl LightPanel {
    fn draw(&mut self, ui: &mut egui::Ui, light: &Light, bounds: &Aabb, out: &mut Vec<Command>) {
        let mut point = light.is_point();
        ui.horizontal(|ui| {
            ui.selectable_value(&mut point, true, "point");
            ui.selectable_value(&mut point, false, "directional");
        });
        if point != light.is_point() {
            out.push(Command::SetLight(convert(light, point, bounds), None));
            return;
        }
        let speed = (bounds.radius() * 0.005).max(1e-4) as f64;
        match *light {
            Light::Point { position, intensity, radius } => {
                ui.horizontal(|ui| {
                    ui.label("position").on_hover_text(Light::POSITION.doc);
                    let mut p = position.to_array();
                    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                        let r = ui.add(
                            egui::DragValue::new(&mut p[i])
                                .speed(speed)
                                .range(Light::POSITION.min..=Light::POSITION.max)
                                .prefix(format!("{axis} ")),
                        );
                        if r.changed() {
                            out.push(Command::SetLight(
                                Light::Point { position: Vec3::from_array(p), intensity, radius },
                                super::super::command::merge_key(&r),
                            ));
                        }
                    }
                    ui.label(Light::POSITION.unit);
                });
                if let Some((v, k)) = power_editor(ui, intensity, &Light::INTENSITY, "intensity") {
                    out.push(Command::SetLight(Light::Point { position, intensity: v, radius }, k));
                }
                let mut r = radius;
                let (resp, k) = spec_slider(ui, &mut r, &Light::RADIUS, "radius");
                if resp.changed() {
                    out.push(Command::SetLight(Light::Point { position, intensity, radius: r }, k));
                }
            }
            Light::Directional { direction, irradiance } => {
                let d = direction.normalize_or(Vec3::Y);
                let mut elevation = d.y.clamp(-1.0, 1.0).asin().to_degrees();
                let mut azimuth = d.x.atan2(d.z).to_degrees();
                let r1 = ui.add(egui::Slider::new(&mut azimuth, -180.0..=180.0).text("azimuth").suffix("°"));
                let r2 = ui.add(egui::Slider::new(&mut elevation, -90.0..=90.0).text("elevation").suffix("°"));
                if r1.changed() || r2.changed() {
                    let (a, e) = (azimuth.to_radians(), elevation.to_radians());
                    let dir = Vec3::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos());
                    let k = if r1.changed() {
                        super::super::command::merge_key(&r1)
                    } else {
                        super::super::command::merge_key(&r2)
                    };
                    out.push(Command::SetLight(Light::Directional { direction: dir, irradiance }, k));
                }
                ui.horizontal(|ui| {
                    ui.label("toward the light").on_hover_text(Light::DIRECTION.doc);
                    let mut v = d.to_array();
                    for (i, axis) in ["x", "y", "z"].iter().enumerate() {
                        let r = ui.add(
                            egui::DragValue::new(&mut v[i])
                                .speed(0.01)
                                .range(Light::DIRECTION.min..=Light::DIRECTION.max)
                                .prefix(format!("{axis} ")),
                        );
                        if r.changed() && Vec3::from_array(v).length() > 1e-6 {
                            out.push(Command::SetLight(
                                Light::Directional { direction: Vec3::from_array(v).normalize(), irradiance },
                                super::super::command::merge_key(&r),
                            ));
                        }
                    }
                });
                if let Some((v, k)) = power_editor(ui, irradiance, &Light::IRRADIANCE, "irradiance") {
                    out.push(Command::SetLight(Light::Directional { direction, irradiance: v }, k));
                }
            }
        }
        ui.label(egui::RichText::new("Drag the light's handle in the viewport to move it.").small());
    }
}

impl super::Panel for LightPanel {
    fn name(&self) -> &'static str {
        "Light"
    }
    fn show(&mut self, ui: &mut egui::Ui, cx: &super::PanelCtx<'_>, out: &mut Vec<Command>) {
        self.draw(ui, &cx.doc.look.light, &cx.doc.bounds, out);
    }
}

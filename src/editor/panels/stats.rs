//! The Stats panel: GPU time per pass, frame times, grid memory, the fitted grid ranges and what
//! the frame left out.

use super::bytes;
use crate::editor::viewport::FrameReport;
use crate::render::{FrameSetup, Method};
use eframe::egui;

#[derive(Default)]
pub struct StatsPanel;

/// Lines saying what the fitted frame leaves out (DESIGN section 6), from its setup.
pub fn savings(setup: &FrameSetup, point_light: bool) -> Vec<String> {
    let m = &setup.mapping;
    let mut v = Vec::new();
    if matches!(setup.method, Method::Raymarch { .. }) {
        v.push("no grid: voxelize, scan and integrate are replaced by ray marching".into());
        return v;
    }
    if m.phi_wraps {
        v.push("planes: the epipole is on screen, planes go all the way round".into());
    } else {
        v.push(format!(
            "planes: only the {:.1}° wedge that crosses the screen ({:.0}% of the circle)",
            m.phi_span.to_degrees(),
            m.phi_span / std::f64::consts::TAU * 100.0
        ));
    }
    v.push(format!(
        "rays: γ from {:.2}° to {:.2}° ({:.0}% of 0–180°)",
        m.gamma_lo.to_degrees(),
        m.gamma_hi.to_degrees(),
        (m.gamma_hi - m.gamma_lo) / std::f64::consts::PI * 100.0
    ));
    if point_light {
        v.push(format!(
            "bins: ψ from {:.2}° to {:.2}° (where casters can be; outside is lit)",
            m.z_lo.to_degrees(),
            m.z_hi.to_degrees()
        ));
    } else {
        v.push(format!("bins: distance from the axis {:.3} to {:.3} unit; no scatter table (directional light)", m.z_lo, m.z_hi));
    }
    v
}

impl StatsPanel {
    pub fn show(&mut self, ui: &mut egui::Ui, report: Option<&FrameReport>, ui_frame_ms: f64, grid_bytes: u64, adapter: &str, timestamps: bool, point_light: bool) {
        ui.label(egui::RichText::new(adapter).small());
        ui.label(format!("UI frame: {ui_frame_ms:.1} ms"));
        let Some(r) = report else {
            ui.label("no frame rendered yet");
            return;
        };
        ui.label(format!("last render: {}×{}, {:.1} ms wall (record + GPU + readback of timestamps)", r.width, r.height, r.render_ms));
        let info = match &r.result {
            Ok(info) => Some(info),
            Err(e) => {
                ui.colored_label(ui.visuals().error_fg_color, e);
                r.last_good.as_ref().map(|g| &g.info)
            }
        };
        let Some(info) = info else { return };
        if info.timings.is_empty() {
            ui.label(if timestamps { "no GPU timings for this frame" } else { "no GPU timings: the adapter has no encoder timestamps" });
        } else {
            egui::Grid::new("stats-passes").num_columns(2).striped(true).show(ui, |ui| {
                for t in &info.timings {
                    ui.label(t.pass);
                    ui.label(format!("{:8.3} ms", t.ms));
                    ui.end_row();
                }
                ui.strong("GPU total");
                ui.strong(format!("{:8.3} ms", info.timings.iter().map(|t| t.ms).sum::<f64>()));
                ui.end_row();
            });
        }
        ui.label(format!("grid memory: {} (+ the same again while the inspector keeps the geometry grid)", bytes(grid_bytes)));
        for line in savings(&info.setup, point_light) {
            ui.label(egui::RichText::new(line).small());
        }
    }
}

//! The Stats panel: GPU time per pass, frame times, grid memory, the fitted grid ranges and what
//! the frame left out.

use super::{bytes, Command, Panel, PanelCtx};
use crate::editor::jobs::render::{Picture, Quality};
use crate::render::{FrameSetup, Method, PruneReport};
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
        v.push(format!(
            "bins: distance from the axis {:.3} to {:.3} unit; no scatter table (directional light)",
            m.z_lo, m.z_hi
        ));
    }
    v
}

/// Lines from the renderer's own account of what it kept and dropped.
pub fn prune_lines(p: &PruneReport, point_light: bool) -> Vec<String> {
    let unit = if point_light { "°" } else { " unit" };
    let mut v = vec![
        format!("passes: {}", p.passes.iter().map(|p| p.label()).collect::<Vec<_>>().join(" › ")),
        format!("shaders specialised to: {}", p.variant),
    ];
    if !p.reused.is_empty() {
        v.push(format!(
            "from the previous frame (only the medium or the light's power changed): {}",
            p.reused.iter().map(|p| p.label()).collect::<Vec<_>>().join(" › ")
        ));
    }
    let voxelize = crate::render::Pass::Voxelize;
    if !p.passes.contains(&voxelize) && !p.reused.contains(&voxelize) {
        v.push("no grid this frame".into());
        return v;
    }
    if !p.enabled {
        v.push("fitting the work to the frame is off".into());
    }
    v.push(format!("planes: over {:.1}° of 360°", p.planes_span_deg));
    v.push(format!(
        "rays: γ {:.1}°–{:.1}°, {:.0}% of the plane × ray cells (those the pixels read)",
        p.rays_gamma_deg[0],
        p.rays_gamma_deg[1],
        p.plane_ray_cells * 100.0
    ));
    v.push(format!(
        "bins: z {:.3}–{:.3}{unit} (casters {:.3}–{:.3}{unit}), {} words per ray",
        p.bins_z[0], p.bins_z[1], p.bins_z_casters[0], p.bins_z_casters[1], p.words_per_ray
    ));
    let t = &p.triangles;
    v.push(format!(
        "triangles voxelized: {} of {} (dropped {} outside the view, {} beyond the visible depth, {} solids' faces away from the light, {} hidden from the light)",
        t.kept, p.triangles_total, t.culled_view, t.culled_depth, t.culled_back, t.culled_hidden
    ));
    v
}

/// Which picture is on screen, in words (the Stats panel and the viewport's marker).
pub fn quality_line(p: &Picture) -> String {
    match p.quality {
        Quality::Full => format!("full quality: {}×{} pixels, grid {}", p.width, p.height, p.grid),
        Quality::Preview(s) => format!(
            "preview ({:.0}% of the pixels): {}×{} pixels, grid {}; full quality follows when the input stops",
            (s * s * 100.0).max(1.0),
            p.width,
            p.height,
            p.grid
        ),
    }
}

impl Panel for StatsPanel {
    fn name(&self) -> &'static str {
        "Stats"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, _out: &mut Vec<Command>) {
        let r = &cx.jobs.render;
        let look = &cx.doc.look;
        let point_light = look.light.is_point();
        let Some(dev) = &r.device else {
            ui.label("starting the renderer…");
            return;
        };
        if dev.software {
            ui.colored_label(
                ui.visuals().warn_fg_color,
                "Software driver: a full frame takes seconds. Previews follow the hand while you drag; a smaller \
                 grid (Grid) or fewer pixels (toolbar) makes the full frame come sooner.",
            );
        }
        ui.label(
            egui::RichText::new(format!(
                "{}{}",
                dev.adapter,
                if dev.shared_queue { " · renders on the window's queue" } else { " · own device and queue" }
            ))
            .small(),
        );
        ui.label(format!("UI frame: {:.1} ms", cx.ui_frame_ms));
        if let Some(f) = &r.failure {
            ui.colored_label(ui.visuals().error_fg_color, &f.error);
        }
        let Some(p) = &r.shown else {
            ui.label("no frame rendered yet");
            return;
        };
        ui.label(format!("on screen: {}", quality_line(p)));
        ui.label(format!(
            "rendered in {:.1} ms ({:.1} ms with read-back, statistics and upload){}",
            p.render_ms,
            p.total_ms,
            if r.job.in_flight() { " · rendering the next…" } else { "" }
        ));
        let info = &p.info;
        if info.timings.is_empty() {
            ui.label(if dev.timestamps {
                "no GPU timings for this frame"
            } else {
                "no GPU timings: the adapter has no encoder timestamps"
            });
        } else {
            egui::Grid::new("stats-passes").num_columns(2).striped(true).show(ui, |ui| {
                for t in &info.timings {
                    ui.label(t.pass.label());
                    ui.label(format!("{:8.3} ms", t.ms));
                    ui.end_row();
                }
                ui.strong("GPU total");
                ui.strong(format!("{:8.3} ms", info.timings.iter().map(|t| t.ms).sum::<f64>()));
                ui.end_row();
            });
        }
        ui.label(format!(
            "grid memory: {} (+ the same again while the inspector keeps the geometry grid)",
            bytes(look.grid.bytes())
        ));
        let lines = match &p.prune {
            Some(pr) => prune_lines(pr, point_light),
            None => savings(&info.setup, point_light),
        };
        for line in lines {
            ui.label(egui::RichText::new(line).small());
        }
        if let Some(ms) = r.reload_ms {
            ui.label(egui::RichText::new(format!("last shader reload compiled in {ms:.0} ms")).small());
        }
    }
}

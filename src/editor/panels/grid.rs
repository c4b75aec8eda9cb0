//! The Grid panel: planes, rays, bins, bin spacing, how VSV keeps its shadow volume, and the memory
//! the volume takes against what the adapter allows.

use super::{bytes, spec_slider, Command};
use crate::params::{BinSpacing, Grid};
use crate::render::ShadowVolume;
use eframe::egui;

#[derive(Default)]
pub struct GridPanel;

/// What the adapter allows.
#[derive(Debug, Clone, Copy)]
pub struct GridLimits {
    /// Largest storage buffer binding (bytes).
    pub buffer_bytes: u64,
    /// Largest 2-D texture side (the voxelization target is planes x rays).
    pub texture_side: u32,
}

impl GridPanel {
    fn draw(
        &mut self,
        ui: &mut egui::Ui,
        grid: &Grid,
        volume: ShadowVolume,
        limits: Option<GridLimits>,
        out: &mut Vec<Command>,
    ) {
        let mut g = *grid;
        let mut changed = None;
        for (value, spec, label) in [(&mut g.planes, Grid::PLANES, "planes"), (&mut g.rays, Grid::RAYS, "rays")] {
            let mut v = *value as f32;
            let (r, k) = spec_slider(ui, &mut v, &spec, label);
            if r.changed() {
                *value = v.round() as u32;
                changed = Some(k);
            }
        }
        let mut b = g.bins;
        let r = ui
            .add(
                egui::Slider::new(&mut b, Grid::BINS.min as u32..=Grid::BINS.max as u32)
                    .step_by(32.0)
                    .text("bins")
                    .suffix(format!(" {}", Grid::BINS.unit)),
            )
            .on_hover_text(Grid::BINS.doc);
        if r.changed() {
            g.bins = (b / 32).max(1) * 32;
            changed = Some(super::super::command::merge_key(&r));
        }
        ui.horizontal(|ui| {
            ui.label("bin spacing");
            ui.selectable_value(&mut g.spacing, BinSpacing::UniformAngle, "uniform angle")
                .on_hover_text("Equal steps of the angle at the light: equal weight per bin in a clear medium");
            ui.selectable_value(&mut g.spacing, BinSpacing::UniformCosine, "uniform cosine")
                .on_hover_text("Equal steps of cos(psi), the paper's choice");
        });
        if g.spacing != grid.spacing {
            changed = Some(None);
        }
        if let Some(k) = changed {
            if g != *grid {
                out.push(Command::SetGrid(g, k));
            }
        }
        let mut pick = volume;
        ui.horizontal(|ui| {
            ui.label("volume");
            for kind in ShadowVolume::ALL {
                ui.selectable_value(&mut pick, kind, kind.label()).on_hover_text(kind.doc());
            }
        });
        if pick != volume {
            out.push(Command::SetShadowVolume(pick));
        }
        let need = volume.bytes(grid);
        let Some(limits) = limits else {
            ui.label(egui::RichText::new(format!("{} = {}", grid, bytes(need))).small());
            return;
        };
        let over = need > limits.buffer_bytes || grid.planes.max(grid.rays) > limits.texture_side;
        let text = format!(
            "{} = {} (the adapter allows {} per buffer, {} texels per side)",
            grid,
            bytes(need),
            bytes(limits.buffer_bytes),
            limits.texture_side
        );
        if over {
            ui.colored_label(ui.visuals().error_fg_color, format!("{text}: too large, the last picture stays"));
        } else {
            ui.label(egui::RichText::new(text).small());
        }
    }
}

impl super::Panel for GridPanel {
    fn name(&self) -> &'static str {
        "Grid"
    }
    fn show(&mut self, ui: &mut egui::Ui, cx: &super::PanelCtx<'_>, out: &mut Vec<Command>) {
        let limits = cx.jobs.render.device.as_ref().map(|d| d.limits);
        self.draw(ui, &cx.doc.look.grid, cx.view.shadow_volume, limits, out);
    }
}

//! The epipolar-grid inspector: the voxel grid of the last full-quality frame as pictures beside
//! the viewport (see [`pictures`]), linked to it by hover (see [`linking`]).

pub mod linking;
pub mod pictures;

pub use linking::{cell_of_pixel, pixel_of_cell};
pub use pictures::{GridSnapshot, InspectorMode};

use super::{Command, Panel, PanelCtx};
use crate::editor::display::{FlatPicture, PictureCallback, PictureSlot};
use crate::editor::jobs::render::INSPECT_LIMIT;
use crate::render::Method;
use eframe::egui;
use eframe::egui_wgpu;
use pictures::{export_png, grid_image, slice_image, surface_bins};
use std::path::Path;
use std::sync::Arc;

/// The inspector's pictures (caches of the last snapshot) and where it drew them. They are drawn
/// by the display's fast path ([`PictureCallback`]), not as egui images: on the software driver
/// egui's shader made them about a quarter of every repaint.
#[derive(Default)]
pub struct InspectorPanel {
    grid_img: Option<Arc<FlatPicture>>,
    slice_img: Option<Arc<FlatPicture>>,
    /// (snapshot generation, mode) the grid picture shows; it does not depend on the slice, which
    /// changes with every pointer move while the slice follows it.
    grid_key: Option<(u64, InspectorMode)>,
    /// (snapshot generation, slice plane, layer marked) the slice shows.
    slice_key: Option<(u64, u32, Option<u32>)>,
    /// Where the grid picture was drawn (points).
    pub grid_rect: Option<egui::Rect>,
}

impl InspectorPanel {
    /// Rebuilds a picture when what it shows changed.
    fn refresh(&mut self, s: &GridSnapshot, mode: InspectorMode, plane: u32) {
        if self.grid_key != Some((s.generation, mode)) {
            self.grid_key = Some((s.generation, mode));
            self.grid_img = grid_image(s, mode).map(FlatPicture::new);
        }
        let layer = match mode {
            InspectorMode::Layer(k) => Some(k),
            _ => None,
        };
        if self.slice_key != Some((s.generation, plane, layer)) {
            self.slice_key = Some((s.generation, plane, layer));
            let depth = s.tracer.as_ref().map(|t| surface_bins(&s.setup, t, plane));
            self.slice_img = Some(FlatPicture::new(slice_image(s, plane, depth.as_deref(), layer)));
        }
    }

    /// Exports the current pictures.
    pub fn export(&self, path: &Path) -> Result<(), String> {
        let g = self.grid_img.as_ref().ok_or("the inspector has no picture yet")?;
        export_png(&g.image, self.slice_img.as_ref().map(|p| &p.image), path)
    }

    fn controls(&self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, bins: u32, out: &mut Vec<Command>) {
        let mode = cx.view.inspector.mode;
        ui.horizontal_wrapped(|ui| {
            ui.strong("Epipolar grid");
            let mut m = mode;
            egui::ComboBox::new("inspector-mode", "shows").selected_text(m.label()).show_ui(ui, |ui| {
                let k = match m {
                    InspectorMode::Layer(k) => k,
                    _ => bins / 2,
                };
                for choice in [InspectorMode::ShadowCount, InspectorMode::GeometryCount, InspectorMode::Layer(k)] {
                    ui.selectable_value(&mut m, choice, choice.label());
                }
            });
            if let InspectorMode::Layer(k) = &mut m {
                let mut v = (*k).min(bins - 1);
                ui.add(egui::Slider::new(&mut v, 0..=bins - 1).text("bin"))
                    .on_hover_text("The layer shown: one bin (z) of the geometry grid and the shadow volume");
                *k = v;
            }
            if m != mode {
                out.push(Command::SetInspectorMode(m));
            }
            if ui.button("Export PNG…").on_hover_text("The grid picture and the slice, side by side").clicked() {
                out.push(Command::ExportInspectorDialog);
            }
        });
    }
}

impl Panel for InspectorPanel {
    fn name(&self) -> &'static str {
        "Inspector"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let iv = cx.view.inspector;
        let snapshot = cx.jobs.render.grids.clone();
        let look_grid = cx.doc.look.grid;
        let bins = snapshot.as_ref().map(|s| s.grid.bins).unwrap_or(look_grid.bins);
        self.controls(ui, cx, bins, out);
        if look_grid.bytes() > INSPECT_LIMIT {
            ui.colored_label(
                ui.visuals().warn_fg_color,
                format!(
                    "the {} grid ({}) is too large to inspect live; the inspector reads grids up to {}",
                    look_grid,
                    super::bytes(look_grid.bytes()),
                    super::bytes(INSPECT_LIMIT)
                ),
            );
        }
        let Some(s) = snapshot else {
            ui.label("no grid yet");
            return;
        };
        let g = s.grid;
        let plane = iv.slice_plane.min(g.planes - 1);
        ui.horizontal(|ui| {
            let mut p = plane;
            ui.add(egui::Slider::new(&mut p, 0..=g.planes - 1).text("slice plane"));
            if p != plane {
                out.push(Command::SetSlicePlane(p));
            }
            let mut follow = iv.follow_hover;
            if ui.checkbox(&mut follow, "follow pointer").changed() {
                out.push(Command::SetFollowHover(follow));
            }
        });
        if matches!(cx.view.method, Method::Raymarch { .. }) {
            ui.label("The ray-marching baseline uses no grid: this is the grid of an earlier frame.");
        }
        if iv.mode == InspectorMode::GeometryCount && s.geometry.is_none() {
            ui.label("The geometry grid was not kept for this frame.");
        }
        // A full frame that reused the volume of the one before shows the same grid.
        let older = cx.jobs.render.shown.as_ref().is_some_and(|p| {
            p.generation != s.generation && !(p.quality.is_full() && p.info.reused.iter().any(|p| p.makes_volume()))
        });
        if older {
            ui.label(egui::RichText::new("(the grid of the last full-quality frame)").small().weak());
        }
        self.refresh(&s, iv.mode, plane);
        let hovered = self.pictures(ui, &s, plane, cx.view.layout.hover_cell, cx.view.layout.inspector_cell);
        ui.label(
            egui::RichText::new(format!(
                "{} planes × {} rays × {} bins; slice: plane {} (rays down, bins across; orange geometry, grey shadow, \
                 white surface)",
                g.planes, g.rays, g.bins, plane
            ))
            .small(),
        );
        if hovered != cx.view.layout.inspector_cell {
            out.push(Command::HoverInspector(hovered));
        }
    }
}

impl InspectorPanel {
    /// Draws the grid picture and the slice; returns the cell under the pointer.
    fn pictures(
        &mut self,
        ui: &mut egui::Ui,
        s: &GridSnapshot,
        plane: u32,
        viewport_cell: Option<(f64, f64)>,
        last_hover: Option<(f64, f64)>,
    ) -> Option<(f64, f64)> {
        let g = s.grid;
        // Both pictures have the rays down. Side by side they share that axis; in a narrow column
        // they are stacked instead. Take whichever layout shows the grid picture larger.
        // The room left in the column (its clip rectangle: a wide row of controls can stretch the
        // ui's own rectangle, and the pictures would then change size from frame to frame).
        let clip = ui.clip_rect();
        let avail = egui::vec2(clip.right() - ui.cursor().left(), clip.bottom() - ui.cursor().top());
        let size = |img: &Option<Arc<FlatPicture>>| {
            img.as_ref().map(|p| egui::vec2(p.image.size[0] as f32, p.image.size[1] as f32))
        };
        let gs = size(&self.grid_img).unwrap_or(egui::vec2(1.0, 1.0));
        let ss = size(&self.slice_img).unwrap_or(egui::vec2(1.0, 1.0));
        let room = egui::vec2(avail.x - 12.0, avail.y - 30.0).max(egui::vec2(64.0, 64.0));
        let side = {
            // Widths as if both were as tall as the room (the slice at least half as wide as the
            // grid picture, however few its bins), squeezed to the room's width.
            let wg = room.y * gs.x / gs.y;
            let ws = (room.y * ss.x / ss.y).max(wg * 0.5);
            let scale = (room.x / (wg + ws)).min(1.0);
            (egui::vec2(wg, room.y) * scale, egui::vec2(ws, room.y) * scale)
        };
        let stacked = {
            let g_h = (room.x * gs.y / gs.x).min(room.y * 0.6);
            (egui::vec2(g_h * gs.x / gs.y, g_h), egui::vec2(room.x, (room.y - g_h - 8.0).max(48.0)))
        };
        let stack = stacked.0.x * stacked.0.y > side.0.x * side.0.y;
        let (gsize, ssize) = if stack { stacked } else { side };
        let layout = if stack {
            egui::Layout::top_down(egui::Align::Min)
        } else {
            egui::Layout::left_to_right(egui::Align::Min)
        };
        let mut hovered = None;
        let stroke = egui::Stroke::new(1.0, egui::Color32::from_rgb(80, 255, 120));
        ui.with_layout(layout, |ui| {
            if let Some(p) = &self.grid_img {
                let r = picture(ui, PictureSlot::InspectorGrid, p, gsize);
                let rect = r.rect;
                self.grid_rect = Some(rect);
                if let Some(pos) = r.hover_pos() {
                    let x = ((pos.x - rect.left()) / rect.width() * g.planes as f32) as f64;
                    let y = ((pos.y - rect.top()) / rect.height() * g.rays as f32) as f64;
                    hovered = Some((x, y));
                }
                // The slice is drawn after this picture: its hover is last frame's.
                if let Some((x, y)) = hovered.or(last_hover).or(viewport_cell) {
                    let px = rect.left() + x as f32 / g.planes as f32 * rect.width();
                    let py = rect.top() + y as f32 / g.rays as f32 * rect.height();
                    ui.painter().vline(px, rect.y_range(), stroke);
                    ui.painter().hline(rect.x_range(), py, stroke);
                }
                r.on_hover_text(match hovered {
                    Some((x, y)) => format!("plane {}, ray {}", x as u32, y as u32),
                    None => String::new(),
                });
            }
            if let Some(p) = &self.slice_img {
                let r = picture(ui, PictureSlot::InspectorSlice, p, ssize);
                let rect = r.rect;
                if let Some(pos) = r.hover_pos() {
                    let y = ((pos.y - rect.top()) / rect.height() * g.rays as f32) as f64;
                    hovered = Some((plane as f64 + 0.5, y));
                }
                if let Some((x, y)) = hovered.or(viewport_cell) {
                    if x as u32 == plane {
                        let py = rect.top() + y as f32 / g.rays as f32 * rect.height();
                        ui.painter().hline(rect.x_range(), py, stroke);
                    }
                }
            }
        });
        hovered
    }
}

/// Allocates `size` and draws `p` over it (the display's fast path); hover is sensed as on an image.
fn picture(ui: &mut egui::Ui, slot: PictureSlot, p: &Arc<FlatPicture>, size: egui::Vec2) -> egui::Response {
    let (rect, response) = ui.allocate_exact_size(size, egui::Sense::hover());
    if ui.is_rect_visible(rect) {
        ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, PictureCallback { slot, picture: p.clone() }));
    }
    response
}

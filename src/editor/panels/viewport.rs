//! The viewport: shows the newest finished picture (never waits for one), turns drags, wheel and
//! keys into camera and light commands, and draws the overlays: the light's handle, the inspector
//! cell's view ray and epipolar line, which picture is on screen (preview or full quality), a
//! "compiling" marker during a shader reload, and errors over the last good picture.

use super::inspector::{cell_of_pixel, pixel_of_cell, GridSnapshot};
use super::{Command, Panel, PanelCtx};
use crate::editor::camera::{drag_light, light_handle};
use crate::editor::command::gesture_key;
use crate::editor::display::{Shown, ViewportCallback};
use crate::editor::jobs::render::Quality;
use crate::editor::view::ViewMode;
use eframe::egui;
use eframe::egui_wgpu;

#[derive(Default)]
pub struct ViewportPanel;

const HANDLE: egui::Color32 = egui::Color32::from_rgb(255, 220, 90);
const LINK: egui::Color32 = egui::Color32::from_rgb(80, 255, 120);

impl Panel for ViewportPanel {
    fn name(&self) -> &'static str {
        "Viewport"
    }

    fn show(&mut self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, out: &mut Vec<Command>) {
        let rect = ui.available_rect_before_wrap();
        let response = ui.allocate_rect(rect, egui::Sense::click_and_drag());
        let ppp = ui.ctx().pixels_per_point();
        let layout = &cx.view.layout;
        if layout.rect != Some(rect) || layout.pixels_per_point != ppp {
            out.push(Command::LayoutViewport(rect, ppp));
        }
        let render = &cx.jobs.render;
        if let Some(p) = &render.shown {
            let shown = if cx.view.mode == ViewMode::Scattered { Shown::Scatter } else { Shown::Hdr };
            let exposure = cx.view.shown_exposure(cx.doc.look.exposure, p.stats.scatter_mean, p.stats.scatter_p99);
            let cb = ViewportCallback { images: p.display.clone(), shown, exposure };
            ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, cb));
        }
        self.gestures(ui, cx, &response, rect, out);
        let painter = ui.painter_at(rect);
        let look = &cx.doc.look;
        if let Some(h) = light_handle(&look.camera, rect, &look.light) {
            let hot = response.hover_pos().is_some_and(|p| p.distance(h) < 14.0) || layout.dragging_light;
            painter.circle_stroke(h, if hot { 10.0 } else { 7.0 }, egui::Stroke::new(2.0, HANDLE));
            painter.circle_filled(h, 2.5, HANDLE);
        }
        // Hover linking maps through the grid the inspector shows (the last full frame's).
        let grids = render.grids.as_deref();
        let cell = match (grids, response.hover_pos()) {
            (Some(g), Some(p)) => {
                let px = ((p.x - rect.left()) / rect.width()) as f64 * g.setup.width as f64 - 0.5;
                let py = ((p.y - rect.top()) / rect.height()) as f64 * g.setup.height as f64 - 0.5;
                cell_of_pixel(&g.setup, &g.camera, px, py)
            }
            _ => None,
        };
        if cell != layout.hover_cell {
            out.push(Command::HoverViewport(cell));
        }
        if let (Some((x, _)), true) = (cell, cx.view.inspector.follow_hover) {
            if x as u32 != cx.view.inspector.slice_plane {
                out.push(Command::SetSlicePlane(x as u32));
            }
        }
        if let (Some(g), Some((x, y))) = (grids, layout.inspector_cell) {
            draw_cell_highlight(&painter, rect, g, x, y);
        }
        self.markers(ui, cx, rect);
    }
}

impl ViewportPanel {
    /// The light's handle first, then the camera.
    fn gestures(
        &self,
        ui: &egui::Ui,
        cx: &PanelCtx<'_>,
        response: &egui::Response,
        rect: egui::Rect,
        out: &mut Vec<Command>,
    ) {
        let look = &cx.doc.look;
        let mut dragging_light = cx.view.layout.dragging_light;
        if response.drag_started() {
            let handle = light_handle(&look.camera, rect, &look.light);
            dragging_light = match (handle, response.interact_pointer_pos()) {
                (Some(h), Some(p)) => h.distance(p) < 14.0,
                _ => false,
            } || ui.input(|i| i.modifiers.alt);
            out.push(Command::DragLight(dragging_light));
        }
        if dragging_light && response.dragged() {
            let d = response.drag_delta();
            if d != egui::Vec2::ZERO {
                let l = drag_light(&look.camera, &look.light, d, rect.height());
                out.push(Command::SetLight(l, Some(gesture_key(response, response.id.with("light")))));
            }
        } else if let Some(c) = cx.view.camera.handle(ui, response, &look.camera, cx.doc.bounds.radius(), rect.height())
        {
            // Wheel and keys (no press) merge by a key without the press: one step per burst.
            let key = if response.dragged() {
                gesture_key(response, response.id.with("camera"))
            } else {
                response.id.with("camera-wheel")
            };
            out.push(Command::SetCamera(c, Some(key)));
        }
        if response.drag_stopped() && dragging_light {
            out.push(Command::DragLight(false));
        }
    }

    /// Which picture is on screen, a reload compiling, errors, a file hovering over the window.
    fn markers(&self, ui: &mut egui::Ui, cx: &PanelCtx<'_>, rect: egui::Rect) {
        let render = &cx.jobs.render;
        let painter = ui.painter_at(rect);
        let small = egui::FontId::proportional(12.0);
        let mut y = rect.top() + 6.0;
        let mut tag = |text: &str, colour: egui::Color32| {
            let galley = painter.layout_no_wrap(text.to_string(), small.clone(), colour);
            let r = egui::Rect::from_min_size(egui::pos2(rect.right() - galley.size().x - 14.0, y), galley.size())
                .expand2(egui::vec2(5.0, 2.0));
            painter.rect_filled(r, 3.0, egui::Color32::from_black_alpha(170));
            painter.galley(r.min + egui::vec2(5.0, 2.0), galley, colour);
            y = r.bottom() + 4.0;
        };
        match render.shown.as_ref().map(|p| p.quality) {
            None => {
                painter.text(
                    rect.center(),
                    egui::Align2::CENTER_CENTER,
                    if render.device.is_none() { "starting the renderer…" } else { "rendering…" },
                    egui::FontId::proportional(16.0),
                    egui::Color32::GRAY,
                );
            }
            Some(Quality::Preview(s)) => tag(
                &format!("preview · {:.0}% of the pixels", (s * s * 100.0).max(1.0)),
                egui::Color32::from_rgb(255, 200, 90),
            ),
            Some(Quality::Full) => {}
        }
        if render.compiling.is_some() {
            tag("compiling shaders…", egui::Color32::from_rgb(150, 200, 255));
        }
        let mut lines = Vec::new();
        if let Some(e) = &render.shader_error {
            lines.push(format!("shader error (the last good shaders keep running): {e}"));
        }
        if let Some(f) = &render.failure {
            lines.push(format!("render error (the last picture stays): {}", f.error));
        }
        if !lines.is_empty() {
            let mut child = ui.new_child(
                egui::UiBuilder::new().max_rect(rect.shrink(8.0)).layout(egui::Layout::top_down(egui::Align::LEFT)),
            );
            egui::Frame::popup(child.style()).fill(egui::Color32::from_black_alpha(200)).show(&mut child, |ui| {
                for l in &lines {
                    ui.colored_label(egui::Color32::from_rgb(255, 120, 100), l);
                }
            });
        }
        if ui.input(|i| !i.raw.hovered_files.is_empty()) {
            painter.rect_filled(rect, 0.0, egui::Color32::from_black_alpha(140));
            painter.text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "drop a scene or a preset",
                egui::FontId::proportional(20.0),
                egui::Color32::WHITE,
            );
        }
    }
}

/// Marks the view ray of grid cell (plane `x`, ray `y`) and its plane's epipolar line.
fn draw_cell_highlight(painter: &egui::Painter, rect: egui::Rect, g: &GridSnapshot, x: f64, y: f64) {
    let (w, h) = (g.setup.width as f64, g.setup.height as f64);
    let to_screen = |(px, py): (f64, f64)| {
        egui::pos2(
            rect.left() + ((px + 0.5) / w) as f32 * rect.width(),
            rect.top() + ((py + 0.5) / h) as f32 * rect.height(),
        )
    };
    let stroke = egui::Stroke::new(1.0, LINK);
    let n = 96;
    let mut line = Vec::new();
    for i in 0..=n {
        let ray = i as f64 / n as f64 * g.grid.rays as f64;
        match pixel_of_cell(&g.setup, &g.camera, x, ray) {
            Some(p) => line.push(to_screen(p)),
            None => {
                if line.len() > 1 {
                    painter.add(egui::Shape::line(std::mem::take(&mut line), stroke));
                }
                line.clear();
            }
        }
    }
    if line.len() > 1 {
        painter.add(egui::Shape::line(line, stroke));
    }
    if let Some(p) = pixel_of_cell(&g.setup, &g.camera, x, y) {
        painter.circle_stroke(to_screen(p), 6.0, egui::Stroke::new(2.0, LINK));
    }
}

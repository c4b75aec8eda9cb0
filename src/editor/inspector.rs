//! The epipolar-grid inspector: the voxel grid of the last frame as pictures beside the viewport.
//!
//! - The grid picture has the planes across and the rays down. Each texel shows how many of the
//!   ray's bins are filled — in the geometry grid (voxelized surfaces, before the scan) or in the
//!   shadow volume (after the prefix-OR scan) — or whether one chosen bin is filled.
//! - The slice shows one plane with its rays down and its bins across: geometry voxels, shadowed
//!   voxels, and the depth of each ray's first surface.
//!
//! Hover linking: a viewport pixel's plane and ray come from the frame's [`GridMapping`]; an
//! inspector texel's view direction from [`EpipolarFrame::dir`], projected into the viewport.

use crate::params::Grid;
use crate::reference::Tracer;
use crate::render::{FrameSetup, Method};
use crate::scene::{Camera, Scene};
use eframe::egui;
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;

/// What the grid picture shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum InspectorMode {
    /// Filled bins per ray of the shadow volume (after the scan; the paper's figure 4).
    #[default]
    ShadowCount,
    /// Filled bins per ray of the geometry grid (before the scan; the paper's figure 2).
    GeometryCount,
    /// Whether one bin of the shadow volume is filled.
    ShadowBin(u32),
    /// Whether one bin of the geometry grid is filled.
    GeometryBin(u32),
}

impl InspectorMode {
    pub fn label(&self) -> &'static str {
        match self {
            InspectorMode::ShadowCount => "shadow volume: filled bins per ray",
            InspectorMode::GeometryCount => "geometry: filled bins per ray",
            InspectorMode::ShadowBin(_) => "shadow volume: one bin",
            InspectorMode::GeometryBin(_) => "geometry: one bin",
        }
    }
    fn geometry(&self) -> bool {
        matches!(self, InspectorMode::GeometryCount | InspectorMode::GeometryBin(_))
    }
}

/// The grid words of one frame, read back from the GPU.
pub struct GridSnapshot {
    pub generation: u64,
    pub grid: Grid,
    pub setup: FrameSetup,
    /// After the scan: `(ray * planes + plane) * words + word`.
    pub shadow: Vec<u32>,
    /// Before the scan, same layout (absent when it could not be kept).
    pub geometry: Option<Vec<u32>>,
}

impl GridSnapshot {
    fn words(&self, geometry: bool) -> Option<&[u32]> {
        if geometry {
            self.geometry.as_deref()
        } else {
            Some(&self.shadow)
        }
    }

    fn ray_words<'a>(&self, bits: &'a [u32], plane: u32, ray: u32) -> &'a [u32] {
        let w = self.grid.words() as usize;
        let i = (ray as usize * self.grid.planes as usize + plane as usize) * w;
        bits.get(i..i + w).unwrap_or(&[])
    }
}

/// A perceptual ramp (dark blue -> magenta -> orange -> pale yellow) for counts.
fn ramp(t: f32) -> egui::Color32 {
    const STOPS: [[f32; 3]; 5] =
        [[0.0, 0.0, 0.02], [0.23, 0.05, 0.45], [0.72, 0.2, 0.42], [0.98, 0.55, 0.1], [0.99, 1.0, 0.75]];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f32;
    let c = |k: usize| STOPS[i][k] + (STOPS[i + 1][k] - STOPS[i][k]) * f;
    egui::Color32::from_rgb((c(0) * 255.0) as u8, (c(1) * 255.0) as u8, (c(2) * 255.0) as u8)
}

/// Largest picture side; bigger grids are shown with every n-th plane/ray merged (maximum).
const MAX_SIDE: u32 = 1024;

/// The grid picture: planes across, rays down.
pub fn grid_image(s: &GridSnapshot, mode: InspectorMode) -> Option<egui::ColorImage> {
    let bits = s.words(mode.geometry())?;
    let g = s.grid;
    let step = g.planes.max(g.rays).div_ceil(MAX_SIDE).max(1);
    let (w, h) = (g.planes.div_ceil(step), g.rays.div_ceil(step));
    let mut img = egui::ColorImage::filled([w as usize, h as usize], egui::Color32::BLACK);
    for y in 0..h {
        for x in 0..w {
            let mut v: u32 = 0;
            for ray in y * step..((y + 1) * step).min(g.rays) {
                for plane in x * step..((x + 1) * step).min(g.planes) {
                    let words = s.ray_words(bits, plane, ray);
                    let n = match mode {
                        InspectorMode::ShadowCount | InspectorMode::GeometryCount => {
                            words.iter().map(|w| w.count_ones()).sum::<u32>()
                        }
                        InspectorMode::ShadowBin(k) | InspectorMode::GeometryBin(k) => {
                            words.get(k as usize / 32).map(|w| (w >> (k % 32)) & 1).unwrap_or(0)
                        }
                    };
                    v = v.max(n);
                }
            }
            let t = match mode {
                InspectorMode::ShadowCount | InspectorMode::GeometryCount => {
                    // sqrt: a few geometry voxels per ray must still show against a full shadow.
                    (v as f32 / g.bins as f32).sqrt()
                }
                _ => v as f32,
            };
            img[(x as usize, y as usize)] = if v == 0 { egui::Color32::from_gray(12) } else { ramp(0.15 + 0.85 * t) };
        }
    }
    Some(img)
}

/// The slice of one plane: rays down, bins across. Geometry voxels orange, shadowed voxels grey,
/// lit voxels dark, each ray's surface depth a white texel, bins beyond the view ray's end (where
/// `gamma + psi >= pi`) dark red.
pub fn slice_image(s: &GridSnapshot, plane: u32, surface_bins: Option<&[f32]>) -> egui::ColorImage {
    let g = s.grid;
    let plane = plane.min(g.planes - 1);
    let step = g.rays.div_ceil(MAX_SIDE).max(1);
    let h = g.rays.div_ceil(step);
    let mut img = egui::ColorImage::filled([g.bins as usize, h as usize], egui::Color32::BLACK);
    let m = &s.setup.mapping;
    let point = s.setup.frame.is_point();
    for y in 0..h {
        let ray = y * step;
        let shadow = s.ray_words(&s.shadow, plane, ray);
        let geo = s.geometry.as_deref().map(|b| s.ray_words(b, plane, ray));
        let gamma = m.gamma_of_ray(ray as f64 + 0.5);
        for k in 0..g.bins {
            let bit = |w: &[u32]| w.get(k as usize / 32).is_some_and(|w| (w >> (k % 32)) & 1 == 1);
            let beyond = point
                && s.setup.method != Method::Cartesian
                && gamma + m.z_of_bin(k as f64 + 0.5) >= std::f64::consts::PI;
            let c = if geo.is_some_and(bit) {
                egui::Color32::from_rgb(250, 150, 30)
            } else if bit(shadow) {
                egui::Color32::from_gray(95)
            } else if beyond {
                egui::Color32::from_rgb(40, 6, 6)
            } else {
                egui::Color32::from_gray(18)
            };
            img[(k as usize, y as usize)] = c;
        }
        if let Some(b) = surface_bins.and_then(|d| d.get(ray as usize)) {
            if b.is_finite() && *b >= 0.0 && (*b as u32) < g.bins {
                img[(*b as usize, y as usize)] = egui::Color32::WHITE;
            }
        }
    }
    img
}

/// For each ray of `plane`: the bin coordinate of its first surface (infinite for the sky or when
/// the surface lies beyond the bins).
pub fn surface_bins(setup: &FrameSetup, tracer: &Tracer, plane: u32) -> Vec<f32> {
    let m = &setup.mapping;
    let f = &setup.frame;
    let phi = m.phi_of_plane(plane as f64 + 0.5);
    (0..m.grid.rays)
        .map(|ray| {
            let gamma = m.gamma_of_ray(ray as f64 + 0.5);
            let dir = f.dir(phi, gamma);
            match tracer.first_hit(f.eye, dir, f64::INFINITY) {
                Some(hit) => m.bin_coord(f.z_of(gamma, hit.t)) as f32,
                None => f32::INFINITY,
            }
        })
        .collect()
}

/// The (plane, ray) of a viewport pixel (continuous coordinates), when it lies inside the grid.
pub fn cell_of_pixel(setup: &FrameSetup, camera: &Camera, px: f64, py: f64) -> Option<(f64, f64)> {
    if setup.method == Method::Cartesian {
        return None; // its grid is screen-aligned, not epipolar
    }
    let dir = camera.pixel_dir_f64(px, py, setup.width, setup.height);
    let m = &setup.mapping;
    let x = m.plane_coord(setup.frame.phi_of_dir(dir));
    let y = m.ray_coord(crate::epipolar::angle_between(setup.frame.axis, dir));
    let (p, r) = (m.grid.planes as f64, m.grid.rays as f64);
    (x >= 0.0 && x < p && y >= 0.0 && y < r).then_some((x, y))
}

/// The viewport pixel (continuous, in the frame's pixels) the view ray of `(plane, ray)` passes
/// through; `None` when it points away from the camera.
pub fn pixel_of_cell(setup: &FrameSetup, camera: &Camera, plane: f64, ray: f64) -> Option<(f64, f64)> {
    let m = &setup.mapping;
    let dir = setup.frame.dir(m.phi_of_plane(plane), m.gamma_of_ray(ray));
    pixel_of_dir(camera, dir, setup.width, setup.height)
}

/// Inverse of [`Camera::pixel_dir_f64`].
pub fn pixel_of_dir(camera: &Camera, dir: DVec3, width: u32, height: u32) -> Option<(f64, f64)> {
    let [r, u, f] = camera.basis_f64();
    let (r, u, f) = (DVec3::from(r), DVec3::from(u), DVec3::from(f));
    let z = dir.dot(f);
    if z <= 1e-9 {
        return None;
    }
    let th = ((camera.fov_y_deg as f64).to_radians() * 0.5).tan();
    let tw = th * width as f64 / height as f64;
    let nx = dir.dot(r) / z / tw;
    let ny = dir.dot(u) / z / th;
    Some(((nx + 1.0) * 0.5 * width as f64 - 0.5, (1.0 - ny) * 0.5 * height as f64 - 0.5))
}

/// Writes the grid picture and the slice side by side as one PNG.
pub fn export_png(grid: &egui::ColorImage, slice: Option<&egui::ColorImage>, path: &Path) -> Result<(), String> {
    let gap = 8usize;
    let (gw, gh) = (grid.size[0], grid.size[1]);
    let (sw, sh) = slice.map(|s| (s.size[0], s.size[1])).unwrap_or((0, 0));
    let w = gw + if slice.is_some() { gap + sw } else { 0 };
    let h = gh.max(sh);
    let mut out = image::RgbaImage::from_pixel(w as u32, h as u32, image::Rgba([0, 0, 0, 255]));
    let mut blit = |img: &egui::ColorImage, x0: usize| {
        for y in 0..img.size[1] {
            for x in 0..img.size[0] {
                let c = img[(x, y)];
                out.put_pixel((x0 + x) as u32, y as u32, image::Rgba([c.r(), c.g(), c.b(), 255]));
            }
        }
    };
    blit(grid, 0);
    if let Some(s) = slice {
        blit(s, gw + gap);
    }
    out.save(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// The inspector's state: what it shows and the last grid it read.
pub struct Inspector {
    pub visible: bool,
    pub mode: InspectorMode,
    pub slice_plane: u32,
    /// The slice follows the plane under the pointer in the viewport.
    pub follow_hover: bool,
    pub snapshot: Option<GridSnapshot>,
    pub error: Option<String>,
    grid_tex: Option<egui::TextureHandle>,
    slice_tex: Option<egui::TextureHandle>,
    grid_img: Option<egui::ColorImage>,
    slice_img: Option<egui::ColorImage>,
    tex_key: Option<(u64, InspectorMode, u32)>,
    tracer: Option<(u64, Arc<Tracer>)>,
    /// The (plane, ray) under the pointer in the inspector (drives the viewport highlight).
    pub hovered: Option<(f64, f64)>,
    /// Where the grid picture was drawn (points).
    pub grid_rect: Option<egui::Rect>,
}

impl Default for Inspector {
    fn default() -> Self {
        Inspector {
            visible: true,
            mode: InspectorMode::default(),
            slice_plane: 0,
            follow_hover: true,
            snapshot: None,
            error: None,
            grid_tex: None,
            slice_tex: None,
            grid_img: None,
            slice_img: None,
            tex_key: None,
            tracer: None,
            hovered: None,
            grid_rect: None,
        }
    }
}

impl Inspector {
    /// Replaces the grid (after a readback).
    pub fn set_snapshot(&mut self, s: GridSnapshot) {
        self.slice_plane = self.slice_plane.min(s.grid.planes - 1);
        self.snapshot = Some(s);
        self.tex_key = None;
        self.error = None;
    }

    pub fn snapshot_generation(&self) -> Option<u64> {
        self.snapshot.as_ref().map(|s| s.generation)
    }

    /// Rebuilds the pictures when the grid, the mode or the slice plane changed.
    fn refresh(&mut self, ctx: &egui::Context, scene: &Scene, scene_generation: u64) {
        let Some(s) = &self.snapshot else { return };
        let key = (s.generation, self.mode, self.slice_plane);
        if self.tex_key == Some(key) {
            return;
        }
        self.tex_key = Some(key);
        let tracer = match &self.tracer {
            Some((g, t)) if *g == scene_generation => t.clone(),
            _ => {
                let t = Arc::new(Tracer::new(scene));
                self.tracer = Some((scene_generation, t.clone()));
                t
            }
        };
        let depth = surface_bins(&s.setup, &tracer, self.slice_plane);
        self.grid_img = grid_image(s, self.mode);
        self.slice_img = Some(slice_image(s, self.slice_plane, Some(&depth)));
        let opts = egui::TextureOptions::NEAREST;
        match &self.grid_img {
            Some(img) => match &mut self.grid_tex {
                Some(t) => t.set(img.clone(), opts),
                None => self.grid_tex = Some(ctx.load_texture("epivox-inspector-grid", img.clone(), opts)),
            },
            None => self.grid_tex = None,
        }
        if let Some(img) = &self.slice_img {
            match &mut self.slice_tex {
                Some(t) => t.set(img.clone(), opts),
                None => self.slice_tex = Some(ctx.load_texture("epivox-inspector-slice", img.clone(), opts)),
            }
        }
    }

    /// Exports the current pictures.
    pub fn export(&self, path: &Path) -> Result<(), String> {
        let g = self.grid_img.as_ref().ok_or("the inspector has no picture yet")?;
        export_png(g, self.slice_img.as_ref(), path)
    }

    /// Draws the inspector. `viewport_cell` is the (plane, ray) under the pointer in the viewport.
    pub fn show(
        &mut self,
        ui: &mut egui::Ui,
        scene: &Scene,
        scene_generation: u64,
        viewport_cell: Option<(f64, f64)>,
        out: &mut Vec<super::Command>,
    ) {
        use super::Command;
        ui.horizontal_wrapped(|ui| {
            ui.strong("Epipolar grid");
            let mut mode = self.mode;
            let bins = self.snapshot.as_ref().map(|s| s.grid.bins).unwrap_or(scene.grid.bins);
            egui::ComboBox::new("inspector-mode", "shows").selected_text(mode.label()).show_ui(ui, |ui| {
                let k = match mode {
                    InspectorMode::ShadowBin(k) | InspectorMode::GeometryBin(k) => k,
                    _ => bins / 2,
                };
                for m in [
                    InspectorMode::ShadowCount,
                    InspectorMode::GeometryCount,
                    InspectorMode::ShadowBin(k),
                    InspectorMode::GeometryBin(k),
                ] {
                    ui.selectable_value(&mut mode, m, m.label());
                }
            });
            if let InspectorMode::ShadowBin(k) | InspectorMode::GeometryBin(k) = &mut mode {
                let mut v = (*k).min(bins - 1);
                ui.add(egui::Slider::new(&mut v, 0..=bins - 1).text("bin"));
                *k = v;
            }
            if mode != self.mode {
                out.push(Command::SetInspectorMode(mode));
            }
            if ui.button("Export PNG…").on_hover_text("The grid picture and the slice, side by side").clicked() {
                out.push(Command::ExportInspectorDialog);
            }
        });
        let Some(snapshot) = &self.snapshot else {
            ui.label(self.error.clone().unwrap_or_else(|| "no grid yet".into()));
            return;
        };
        let planes = snapshot.grid.planes;
        let (method, generation) = (snapshot.setup.method, snapshot.generation);
        ui.horizontal(|ui| {
            let mut p = self.slice_plane;
            ui.add(egui::Slider::new(&mut p, 0..=planes - 1).text("slice plane"));
            if p != self.slice_plane {
                out.push(Command::SetSlicePlane(p));
            }
            ui.checkbox(&mut self.follow_hover, "follow pointer");
        });
        if let Some(e) = &self.error {
            ui.colored_label(ui.visuals().warn_fg_color, e);
        }
        if matches!(method, Method::Raymarch { .. }) {
            ui.label("The ray-marching baseline uses no grid: this is the grid of an earlier frame.");
        }
        if self.mode.geometry() && snapshot.geometry.is_none() {
            ui.label("The geometry grid was not kept for this frame.");
        }
        let _ = generation;
        self.refresh(ui.ctx(), scene, scene_generation);
        let Some(snapshot) = &self.snapshot else { return };
        let g = snapshot.grid;
        // Both pictures have the rays down. Side by side they share that axis; in a narrow column
        // they are stacked instead. Take whichever layout shows the grid picture larger.
        let avail = ui.available_size();
        let gw = self.grid_img.as_ref().map(|i| i.size[0] as f32).unwrap_or(1.0);
        let gh = self.grid_img.as_ref().map(|i| i.size[1] as f32).unwrap_or(1.0);
        let sw = self.slice_img.as_ref().map(|i| i.size[0] as f32).unwrap_or(1.0);
        let sh = self.slice_img.as_ref().map(|i| i.size[1] as f32).unwrap_or(1.0);
        let room = egui::vec2(avail.x - 12.0, avail.y - 30.0).max(egui::vec2(64.0, 64.0));
        let side = {
            // Widths as if both were as tall as the room (the slice at least half as wide as the grid
            // picture, however few its bins), squeezed to the room's width.
            let wg = room.y * gw / gh;
            let ws = (room.y * sw / sh).max(wg * 0.5);
            let scale = (room.x / (wg + ws)).min(1.0);
            (egui::vec2(wg, room.y) * scale, egui::vec2(ws, room.y) * scale)
        };
        let stacked = {
            let g_h = (room.x * gh / gw).min(room.y * 0.6);
            let g = egui::vec2(g_h * gw / gh, g_h);
            (g, egui::vec2(room.x, (room.y - g_h - 8.0).max(48.0)))
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
            if let Some(t) = &self.grid_tex {
                let r = ui.add(egui::Image::new((t.id(), gsize)).sense(egui::Sense::hover()));
                let rect = r.rect;
                self.grid_rect = Some(rect);
                if let Some(pos) = r.hover_pos() {
                    let x = ((pos.x - rect.left()) / rect.width() * g.planes as f32) as f64;
                    let y = ((pos.y - rect.top()) / rect.height() * g.rays as f32) as f64;
                    hovered = Some((x, y));
                }
                // The slice is drawn after this picture: its hover is last frame's.
                let mark = hovered.or(self.hovered).or(viewport_cell);
                if let Some((x, y)) = mark {
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
            if let Some(t) = &self.slice_tex {
                let r = ui.add(egui::Image::new((t.id(), ssize)).sense(egui::Sense::hover()));
                let rect = r.rect;
                if let Some(pos) = r.hover_pos() {
                    let y = ((pos.y - rect.top()) / rect.height() * g.rays as f32) as f64;
                    hovered = Some((self.slice_plane as f64 + 0.5, y));
                }
                if let Some((x, y)) = hovered.or(viewport_cell) {
                    if x as u32 == self.slice_plane {
                        let py = rect.top() + y as f32 / g.rays as f32 * rect.height();
                        ui.painter().hline(rect.x_range(), py, stroke);
                    }
                }
            }
        });
        ui.label(
            egui::RichText::new(format!(
                "{} planes × {} rays × {} bins; slice: plane {} (rays down, bins across; orange geometry, grey shadow, white surface)",
                g.planes, g.rays, g.bins, self.slice_plane
            ))
            .small(),
        );
        self.hovered = hovered;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::FrameSetup;

    #[test]
    fn pixel_and_cell_round_trip() {
        let scene = crate::scene::builtin_scene();
        let setup = FrameSetup::new(&scene, 320, 200, Method::Vsv).unwrap();
        for (px, py) in [(10.0, 20.0), (160.0, 100.0), (300.0, 180.0)] {
            let (x, y) = cell_of_pixel(&setup, &scene.camera, px, py).expect("inside the grid");
            // The centre of a cell is within a cell of the pixel's ray; back to the pixel from the
            // exact coordinates.
            let (qx, qy) = pixel_of_cell(&setup, &scene.camera, x, y).unwrap();
            assert!((qx - px).abs() < 1e-3 && (qy - py).abs() < 1e-3, "{px},{py} -> {x},{y} -> {qx},{qy}");
        }
    }

    #[test]
    fn grid_picture_counts_bits() {
        let scene = crate::scene::builtin_scene();
        let setup = FrameSetup::new(&scene, 64, 64, Method::Vsv).unwrap();
        let grid = Grid { planes: 8, rays: 8, bins: 64, ..Grid::default() };
        let mut shadow = vec![0u32; 8 * 8 * 2];
        // plane 3, ray 5: all 64 bins; plane 0 ray 0: one bin.
        let i = (5 * 8 + 3) * 2;
        shadow[i] = u32::MAX;
        shadow[i + 1] = u32::MAX;
        shadow[0] = 1;
        let s = GridSnapshot { generation: 1, grid, setup, shadow, geometry: None };
        let img = grid_image(&s, InspectorMode::ShadowCount).unwrap();
        assert_eq!(img.size, [8, 8]);
        assert_eq!(img[(3, 5)], ramp(1.0));
        assert_eq!(img[(1, 1)], egui::Color32::from_gray(12));
        assert!(grid_image(&s, InspectorMode::GeometryCount).is_none());
        let bin = grid_image(&s, InspectorMode::ShadowBin(0)).unwrap();
        assert_ne!(bin[(0, 0)], egui::Color32::from_gray(12));
        let slice = slice_image(&s, 3, None);
        assert_eq!(slice.size, [64, 8]);
        assert_eq!(slice[(10, 5)], egui::Color32::from_gray(95));
    }
}

//! The inspector's pictures, built on the CPU from the grid words of one frame.
//!
//! - The grid picture has the planes across and the rays down: how many of each ray's bins are
//!   filled, in the geometry grid (before the scan) or the shadow volume (after it), or one
//!   *layer*: bin z of both grids at once.
//! - The slice shows one plane with its rays down and its bins across.
//!
//! Both use one colour code for voxels: geometry orange, shadowed grey, lit dark, beyond the view
//! ray's end dark red.

use crate::params::Grid;
use crate::reference::Tracer;
use crate::render::{FrameSetup, Method};
use crate::scene::Camera;
use eframe::egui;
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
    /// One bin z of both grids as a planes x rays image: geometry voxels over the shadow volume.
    Layer(u32),
}

impl InspectorMode {
    pub fn label(&self) -> &'static str {
        match self {
            InspectorMode::ShadowCount => "shadow volume: filled bins per ray",
            InspectorMode::GeometryCount => "geometry: filled bins per ray",
            InspectorMode::Layer(_) => "layer: one bin of both grids",
        }
    }
}

/// The grid words of one full-quality frame, read back from the GPU by the render worker, with
/// the count pictures (the slow ones: every word of the grid) built there too.
pub struct GridSnapshot {
    /// The render generation of the frame.
    pub generation: u64,
    pub grid: Grid,
    pub setup: FrameSetup,
    /// The frame's camera (hover linking maps through it).
    pub camera: Camera,
    /// After the scan, laid out as [`Grid::ray_offset`] says.
    pub shadow: Vec<u32>,
    /// Before the scan, same layout (absent when it could not be kept).
    pub geometry: Option<Vec<u32>>,
    /// The scene's triangles for the slice's surface depths (built once per scene, off the UI
    /// thread: a BVH of a large scene takes a while).
    pub tracer: Option<Arc<Tracer>>,
    /// [`InspectorMode::ShadowCount`] and [`InspectorMode::GeometryCount`].
    counts: [Option<egui::ColorImage>; 2],
}

impl GridSnapshot {
    /// The snapshot with its count pictures built (call off the UI thread).
    pub fn new(
        generation: u64,
        grid: Grid,
        setup: FrameSetup,
        camera: Camera,
        shadow: Vec<u32>,
        geometry: Option<Vec<u32>>,
    ) -> GridSnapshot {
        let mut s =
            GridSnapshot { generation, grid, setup, camera, shadow, geometry, tracer: None, counts: [None, None] };
        s.counts = [count_image(&s, false), count_image(&s, true)];
        s
    }

    fn ray_words<'a>(&self, bits: &'a [u32], plane: u32, ray: u32) -> &'a [u32] {
        let i = self.grid.ray_offset(plane, ray);
        bits.get(i..i + self.grid.words() as usize).unwrap_or(&[])
    }

    /// For a point light: the angle at the eye of each ray and at the light of each bin; a voxel
    /// lies past its view ray's end where they add up to pi or more. `None`: no voxel does.
    fn angles(&self) -> Option<(Vec<f64>, Vec<f64>)> {
        let m = &self.setup.mapping;
        (self.setup.frame.is_point() && self.setup.method != Method::Cartesian).then(|| {
            (
                (0..self.grid.rays).map(|y| m.gamma_of_ray(y as f64 + 0.5)).collect(),
                (0..self.grid.bins).map(|k| m.z_of_bin(k as f64 + 0.5)).collect(),
            )
        })
    }

    /// The colour of voxel (plane, ray, bin) in the shared code.
    fn voxel(&self, plane: u32, ray: u32, bin: u32, angles: &Option<(Vec<f64>, Vec<f64>)>) -> egui::Color32 {
        let bit = |w: &[u32]| w.get(bin as usize / 32).is_some_and(|w| (w >> (bin % 32)) & 1 == 1);
        let beyond = angles.as_ref().is_some_and(|(g, z)| {
            g.get(ray as usize).zip(z.get(bin as usize)).is_some_and(|(g, z)| g + z >= std::f64::consts::PI)
        });
        if self.geometry.as_deref().is_some_and(|b| bit(self.ray_words(b, plane, ray))) {
            GEOMETRY
        } else if bit(self.ray_words(&self.shadow, plane, ray)) {
            SHADOW
        } else if beyond {
            BEYOND
        } else {
            LIT
        }
    }
}

const GEOMETRY: egui::Color32 = egui::Color32::from_rgb(250, 150, 30);
const SHADOW: egui::Color32 = egui::Color32::from_gray(95);
const LIT: egui::Color32 = egui::Color32::from_gray(18);
const BEYOND: egui::Color32 = egui::Color32::from_rgb(40, 6, 6);
const EMPTY: egui::Color32 = egui::Color32::from_gray(12);
#[cfg(test)]
const WHITE: egui::Color32 = egui::Color32::WHITE;

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

/// Largest picture side; bigger grids are shown with every n-th plane/ray merged.
const MAX_SIDE: u32 = 1024;

/// Merged cells per picture texel, and the picture's size.
fn picture_size(g: Grid) -> (u32, u32, u32) {
    let step = g.planes.max(g.rays).div_ceil(MAX_SIDE).max(1);
    (step, g.planes.div_ceil(step), g.rays.div_ceil(step))
}

/// Filled bins per ray of one grid, the largest count of the merged cells per texel. `None`
/// for the geometry grid when the frame did not keep it.
fn count_image(s: &GridSnapshot, geometry: bool) -> Option<egui::ColorImage> {
    let bits = if geometry { s.geometry.as_deref()? } else { &s.shadow[..] };
    let g = s.grid;
    let (step, w, h) = picture_size(g);
    let mut img = egui::ColorImage::filled([w as usize, h as usize], EMPTY);
    for y in 0..h {
        for x in 0..w {
            let mut v = 0;
            for ray in y * step..((y + 1) * step).min(g.rays) {
                for plane in x * step..((x + 1) * step).min(g.planes) {
                    v = v.max(s.ray_words(bits, plane, ray).iter().map(|w| w.count_ones()).sum::<u32>());
                }
            }
            // sqrt: a few geometry voxels per ray must still show against a full shadow.
            if v > 0 {
                img[(x as usize, y as usize)] = ramp(0.15 + 0.85 * (v as f32 / g.bins as f32).sqrt());
            }
        }
    }
    Some(img)
}

/// The grid picture: planes across, rays down. `None` when the mode needs the geometry grid and
/// the frame did not keep it.
pub fn grid_image(s: &GridSnapshot, mode: InspectorMode) -> Option<egui::ColorImage> {
    match mode {
        InspectorMode::ShadowCount => s.counts[0].clone(),
        InspectorMode::GeometryCount => s.counts[1].clone(),
        InspectorMode::Layer(k) => {
            let g = s.grid;
            let (step, w, h) = picture_size(g);
            let angles = s.angles();
            let k = k.min(g.bins - 1);
            let mut img = egui::ColorImage::filled([w as usize, h as usize], egui::Color32::BLACK);
            for y in 0..h {
                for x in 0..w {
                    // Merged cells show their first cell (a layer is a section, not a sum).
                    img[(x as usize, y as usize)] = s.voxel(x * step, y * step, k, &angles);
                }
            }
            Some(img)
        }
    }
}

/// The slice of one plane: rays down, bins across, in the voxel colour code; each ray's surface
/// depth a white texel. With `layer`, that bin's column is marked (the layer shown beside it).
///
/// The slice follows the pointer, so it is rebuilt on the UI thread as the pointer moves: the
/// words of a ray are looked up once per row, not per voxel (the same colours as
/// [`GridSnapshot::voxel`], tested).
pub fn slice_image(s: &GridSnapshot, plane: u32, surface_bins: Option<&[f32]>, layer: Option<u32>) -> egui::ColorImage {
    let g = s.grid;
    let plane = plane.min(g.planes - 1);
    let step = g.rays.div_ceil(MAX_SIDE).max(1);
    let h = g.rays.div_ceil(step);
    let bins = g.bins as usize;
    let mut img = egui::ColorImage::filled([bins, h as usize], egui::Color32::BLACK);
    let angles = s.angles();
    let bit = |w: &[u32], k: usize| w.get(k / 32).is_some_and(|w| (w >> (k % 32)) & 1 == 1);
    for (y, row) in img.pixels.chunks_exact_mut(bins).enumerate() {
        let ray = y as u32 * step;
        let geometry = s.geometry.as_deref().map(|b| s.ray_words(b, plane, ray)).unwrap_or(&[]);
        let shadow = s.ray_words(&s.shadow, plane, ray);
        // Past the view ray's end where gamma + z >= pi (point light).
        let beyond = |k: usize| {
            angles.as_ref().is_some_and(|(g, z)| {
                g.get(ray as usize).zip(z.get(k)).is_some_and(|(g, z)| g + z >= std::f64::consts::PI)
            })
        };
        for (k, px) in row.iter_mut().enumerate() {
            let mut c = if bit(geometry, k) {
                GEOMETRY
            } else if bit(shadow, k) {
                SHADOW
            } else if beyond(k) {
                BEYOND
            } else {
                LIT
            };
            if layer == Some(k as u32) {
                // A light blue tint over whatever the voxel is.
                c = egui::Color32::from_rgb(c.r() / 2 + 40, c.g() / 2 + 90, c.b() / 2 + 127);
            }
            *px = c;
        }
        if let Some(b) = surface_bins.and_then(|d| d.get(ray as usize)) {
            if b.is_finite() && *b >= 0.0 && (*b as usize) < bins {
                row[*b as usize] = egui::Color32::WHITE;
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
    let mut png = Vec::new();
    out.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    crate::fsx::write_bytes_atomic(path, &png).map_err(|e| format!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot() -> GridSnapshot {
        let scene = crate::scene::builtin_scene();
        let setup = FrameSetup::new(&scene, 64, 64, Method::Vsv).unwrap();
        let grid = Grid { planes: 8, rays: 8, bins: 64, ..Grid::default() };
        let mut shadow = vec![0u32; 8 * 8 * 2];
        // plane 3, ray 5: all 64 bins; plane 0 ray 0: bin 0.
        let i = grid.ray_offset(3, 5);
        shadow[i] = u32::MAX;
        shadow[i + 1] = u32::MAX;
        shadow[0] = 1;
        // Geometry: plane 3, ray 5, bin 33.
        let mut geometry = vec![0u32; 8 * 8 * 2];
        geometry[i + 1] = 2;
        GridSnapshot::new(1, grid, setup, scene.camera, shadow, Some(geometry))
    }

    #[test]
    fn grid_picture_counts_bits() {
        let mut s = snapshot();
        let img = grid_image(&s, InspectorMode::ShadowCount).unwrap();
        assert_eq!(img.size, [8, 8]);
        assert_eq!(img[(3, 5)], ramp(1.0));
        assert_eq!(img[(1, 1)], EMPTY);
        assert_ne!(grid_image(&s, InspectorMode::GeometryCount).unwrap()[(3, 5)], EMPTY);
        s = GridSnapshot::new(1, s.grid, s.setup, s.camera, s.shadow, None);
        assert!(grid_image(&s, InspectorMode::GeometryCount).is_none());
    }

    #[test]
    fn a_layer_shows_one_bin_of_both_grids() {
        let s = snapshot();
        let at = |k| grid_image(&s, InspectorMode::Layer(k)).unwrap();
        assert_eq!(at(33)[(3, 5)], GEOMETRY, "geometry wins over shadow");
        assert_eq!(at(32)[(3, 5)], SHADOW);
        assert_eq!(at(0)[(0, 0)], SHADOW);
        assert_ne!(at(1)[(0, 0)], SHADOW);
        // The slice marks the layer's column, and shows the same voxels.
        let slice = slice_image(&s, 3, None, Some(33));
        assert_eq!(slice.size, [64, 8]);
        assert_eq!(slice[(10, 5)], SHADOW);
        assert_ne!(slice[(33, 5)], GEOMETRY, "the layer's column is tinted");
        assert_eq!(slice_image(&s, 3, None, None)[(33, 5)], GEOMETRY);
    }

    #[test]
    fn the_slice_shows_the_voxels_colours() {
        let mut s = snapshot();
        // Every word different (a fixed pseudo-random pattern), in both grids.
        let mut x = 0x9e37_79b9u32;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        s.shadow.iter_mut().for_each(|w| *w = next());
        s.geometry.iter_mut().flatten().for_each(|w| *w = next() & next());
        let surface: Vec<f32> = (0..8).map(|r| if r % 3 == 0 { f32::INFINITY } else { r as f32 * 7.0 }).collect();
        let angles = s.angles();
        for plane in 0..8 {
            let img = slice_image(&s, plane, Some(&surface), None);
            for ray in 0..8u32 {
                for k in 0..64u32 {
                    let want = if surface[ray as usize] == k as f32 { WHITE } else { s.voxel(plane, ray, k, &angles) };
                    assert_eq!(img[(k as usize, ray as usize)], want, "plane {plane} ray {ray} bin {k}");
                }
            }
        }
    }
}

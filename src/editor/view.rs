//! How the document is shown: view mode, method, camera controls, exposure of the scattered view,
//! the inspector's settings, and where the viewport lies. None of it is part of the look (not in
//! the undo history, not in presets). Only [`super::Editor::apply`] changes a [`View`].

use super::camera::CameraController;
use crate::params::Baseline;
use crate::render::{Method, ShadowVolume, SurfaceShadows};
use eframe::egui;

/// What the viewport shows ([`ViewMode::doc`] says it for each).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewMode {
    #[default]
    Final,
    Scattered,
    /// (Rendered with the medium's density at 0.)
    Surface,
}

impl ViewMode {
    pub const ALL: [(ViewMode, &'static str); 3] =
        [(ViewMode::Final, "Final"), (ViewMode::Scattered, "Scattered"), (ViewMode::Surface, "Surfaces")];

    pub fn label(self) -> &'static str {
        Self::ALL.iter().find(|(m, _)| *m == self).map(|(_, l)| *l).unwrap_or("?")
    }

    /// What the view shows, for a tooltip (the variants' docs).
    pub fn doc(self) -> &'static str {
        match self {
            ViewMode::Final => "The surfaces seen through the medium, plus the light it scatters",
            ViewMode::Scattered => "The light the medium scatters toward the eye, alone (exposed on its own)",
            ViewMode::Surface => "The surfaces without any medium",
        }
    }
}

/// How the scattered-only view is exposed. Scattered light alone is often a small fraction of
/// the final image, so at the look's exposure it can look black: by default it is exposed from
/// the image itself.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ExposureMode {
    /// The image's mean luminance maps to middle grey.
    #[default]
    AutoMean,
    /// The 99th percentile of the luminance maps to white (bright shafts keep their shape).
    AutoPercentile,
    /// [`View::scatter_exposure`], set by hand.
    Manual,
}

impl ExposureMode {
    pub const ALL: [(ExposureMode, &'static str); 3] = [
        (ExposureMode::AutoMean, "auto (mean)"),
        (ExposureMode::AutoPercentile, "auto (99th percentile)"),
        (ExposureMode::Manual, "manual"),
    ];

    pub fn label(self) -> &'static str {
        Self::ALL.iter().find(|(m, _)| *m == self).map(|(_, l)| *l).unwrap_or("?")
    }
}

/// What the inspector shows and where.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InspectorView {
    pub visible: bool,
    pub mode: super::InspectorMode,
    pub slice_plane: u32,
    /// The slice follows the plane under the pointer in the viewport.
    pub follow_hover: bool,
}

impl Default for InspectorView {
    fn default() -> Self {
        InspectorView { visible: true, mode: Default::default(), slice_plane: 0, follow_hover: true }
    }
}

/// The viewport's place on screen and what the pointer is over.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ViewportLayout {
    /// In points.
    pub rect: Option<egui::Rect>,
    pub pixels_per_point: f32,
    /// The (plane, ray) under the pointer in the viewport.
    pub hover_cell: Option<(f64, f64)>,
    /// The (plane, ray) under the pointer in the inspector's grid picture or slice.
    pub inspector_cell: Option<(f64, f64)>,
    /// A drag that began on the light's handle (or with Alt) moves the light, not the camera.
    pub dragging_light: bool,
}

impl ViewportLayout {
    /// The viewport in physical pixels: x, y, width, height.
    pub fn pixels(&self) -> [u32; 4] {
        let Some(r) = self.rect else { return [0; 4] };
        let p = self.pixels_per_point;
        [
            (r.left() * p).round() as u32,
            (r.top() * p).round() as u32,
            (r.width() * p).round() as u32,
            (r.height() * p).round() as u32,
        ]
    }
}

#[derive(Debug, Clone)]
pub struct View {
    pub mode: ViewMode,
    pub method: Method,
    /// Steps of the ray-marching baseline when it is picked ([`Baseline::STEPS`]).
    pub raymarch_steps: u32,
    /// Shadow-map texels per side (surface shadows, and the baseline's visibility).
    pub shadow_map: u32,
    /// Where the surfaces' shadows come from (`Renderer::surface_shadows`).
    pub surface_shadows: SurfaceShadows,
    /// How VSV keeps its shadow volume (`Renderer::shadow_volume`).
    pub shadow_volume: ShadowVolume,
    /// Integrate takes pixels from their neighbours along the epipolar lines, or integrates every
    /// pixel (`Renderer::adaptive_pixels`).
    pub adaptive_pixels: bool,
    /// Fraction of the viewport's pixels a full-quality frame has (1 = every pixel).
    pub render_scale: f32,
    pub camera: CameraController,
    pub exposure_mode: ExposureMode,
    /// The scattered view's exposure in [`ExposureMode::Manual`] (stops).
    pub scatter_exposure: f32,
    pub inspector: InspectorView,
    pub layout: ViewportLayout,
}

impl Default for View {
    fn default() -> Self {
        View {
            mode: ViewMode::Final,
            method: Method::Vsv,
            raymarch_steps: Baseline::default().steps,
            shadow_map: Baseline::default().shadow_map,
            surface_shadows: SurfaceShadows::default(),
            shadow_volume: ShadowVolume::default(),
            adaptive_pixels: true,
            render_scale: 1.0,
            camera: CameraController::default(),
            exposure_mode: ExposureMode::default(),
            scatter_exposure: 0.0,
            inspector: InspectorView::default(),
            layout: ViewportLayout::default(),
        }
    }
}

impl View {
    /// The exposure (stops) the viewport shows a picture at: the look's, or for the scattered
    /// light alone the one [`View::exposure_mode`] picks from the picture's statistics.
    pub fn shown_exposure(&self, look_exposure: f32, scatter_mean: f32, scatter_p99: f32) -> f32 {
        match self.mode {
            ViewMode::Scattered => auto_exposure(self.exposure_mode, scatter_mean, scatter_p99, self.scatter_exposure),
            _ => look_exposure,
        }
    }

    /// The size a full-quality frame renders at, from the viewport's size and the pixel share.
    pub fn render_size(&self) -> Option<(u32, u32)> {
        let r = self.layout.rect?;
        let k = self.layout.pixels_per_point * self.render_scale;
        Some((((r.width() * k).round() as u32).max(8), ((r.height() * k).round() as u32).max(8)))
    }
}

/// The exposure (stops) that shows an image whose luminance has this mean and 99th percentile.
pub fn auto_exposure(mode: ExposureMode, mean: f32, p99: f32, manual: f32) -> f32 {
    let range = crate::params::Exposure::STOPS;
    let stops = match mode {
        ExposureMode::Manual => return manual,
        // Middle grey (0.18) for the mean; the tone curve's knee (1.0) for the percentile.
        ExposureMode::AutoMean if mean > 0.0 && mean.is_finite() => (0.18 / mean).log2(),
        ExposureMode::AutoPercentile if p99 > 0.0 && p99.is_finite() => (1.0 / p99).log2(),
        _ => 0.0,
    };
    stops.clamp(range.min as f32, range.max as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_exposure_maps_the_statistic_and_stays_in_range() {
        assert!((auto_exposure(ExposureMode::AutoMean, 0.18 / 8.0, 1.0, 0.0) - 3.0).abs() < 1e-5);
        assert!((auto_exposure(ExposureMode::AutoPercentile, 0.1, 0.25, 0.0) - 2.0).abs() < 1e-5);
        assert_eq!(auto_exposure(ExposureMode::Manual, 0.1, 0.25, -1.5), -1.5);
        // A black image: no change rather than an infinite exposure.
        assert_eq!(auto_exposure(ExposureMode::AutoMean, 0.0, 0.0, 0.0), 0.0);
        assert_eq!(auto_exposure(ExposureMode::AutoMean, 1e-30, 0.0, 0.0), 20.0);
    }
}

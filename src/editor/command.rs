//! Commands: what panels, menus, shortcuts, viewport gestures and background jobs ask for. Only
//! [`super::Editor::apply`] acts on them.

use super::camera::CameraMode;
use super::jobs::JobEvent;
use super::panels::inspector::InspectorMode;
use super::view::{ExposureMode, ViewMode};
use crate::params::{Grid, Light, Medium};
use crate::render::{Method, ShadowVolume, SurfaceShadows};
use crate::scene::Camera;
use eframe::egui;
use std::path::PathBuf;

/// Edits carrying the same key one after another merge into one undo step (a drag). `None` never
/// merges (a click, a typed value).
pub type MergeKey = Option<egui::Id>;

/// The key for a widget's change: while it is being dragged, the widget's id together with the
/// moment the pointer was pressed (so two drags of the same slider are two undo steps); else `None`.
pub fn merge_key(r: &egui::Response) -> MergeKey {
    (r.dragged() || r.drag_stopped()).then(|| gesture_key(r, r.id))
}

/// `id` made unique to the current press of the pointer.
pub fn gesture_key(r: &egui::Response, id: egui::Id) -> egui::Id {
    let pressed = r.ctx.input(|i| i.pointer.press_start_time()).unwrap_or(0.0);
    id.with(pressed.to_bits())
}

#[derive(Debug)]
pub enum Command {
    // --- edits of the look (undoable) ---
    SetMedium(Medium, MergeKey),
    SetLight(Light, MergeKey),
    SetGrid(Grid, MergeKey),
    SetCamera(Camera, MergeKey),
    SetExposure(f32, MergeKey),
    /// Back to the scene's own camera.
    ResetCamera,
    Undo,
    Redo,
    // --- how the look is shown (not part of the look) ---
    SetView(ViewMode),
    SetMethod(Method),
    /// Shadow-map texels per side (surface shadows, and the ray-marching baseline's visibility).
    SetShadowMap(u32),
    /// Where the surfaces' shadows come from (`Renderer::surface_shadows`).
    SetSurfaceShadows(SurfaceShadows),
    /// How VSV keeps its shadow volume (`Renderer::shadow_volume`).
    SetShadowVolume(ShadowVolume),
    /// Integrate takes pixels from their neighbours along the epipolar lines (true) or integrates
    /// every pixel (`Renderer::adaptive_pixels`).
    SetAdaptivePixels(bool),
    /// Fraction of the viewport's pixels the renderer draws at (1 = every pixel).
    SetRenderScale(f32),
    SetCameraMode(CameraMode),
    /// How the scattered-only view is exposed.
    SetExposureMode(ExposureMode),
    /// The scattered-only view's exposure in manual mode (stops).
    SetScatterExposure(f32),
    ShowInspector(bool),
    SetInspectorMode(InspectorMode),
    SetSlicePlane(u32),
    SetFollowHover(bool),
    // --- the viewport and pointer (view state, from the layout and gestures) ---
    /// Where the viewport was laid out this frame (points) and the pixels per point.
    LayoutViewport(egui::Rect, f32),
    /// The grid cell under the pointer in the viewport.
    HoverViewport(Option<(f64, f64)>),
    /// The grid cell under the pointer in the inspector.
    HoverInspector(Option<(f64, f64)>),
    /// A drag in the viewport starts (true: it moves the light) or ends (false).
    DragLight(bool),
    /// Sends the render worker the current state, if it changed; `interactive` while input is
    /// in progress (previews only). Issued once per frame, after the other commands.
    RequestFrame {
        interactive: bool,
    },
    // --- files ---
    /// Load and apply a preset; a bad one is refused with a message and the look stays.
    LoadPreset(PathBuf),
    /// Save over the preset that was loaded or saved last.
    SavePreset,
    /// Save to a new file; if it exists and `overwrite` is false, ask first.
    SavePresetAs {
        path: PathBuf,
        overwrite: bool,
    },
    /// The overwrite question was answered "Cancel".
    CancelOverwrite,
    OpenScene(PathBuf),
    /// Save the viewport's current image (tone-mapped as shown) as PNG.
    Screenshot(PathBuf),
    /// Save the inspector's current picture as PNG.
    ExportInspector(PathBuf),
    OpenSceneDialog,
    OpenPresetDialog,
    SavePresetAsDialog,
    ScreenshotDialog,
    ExportInspectorDialog,
    // --- jobs ---
    StartAccuracy {
        width: u32,
    },
    CancelAccuracy,
    ReloadShaders,
    DismissMessages,
    /// Close the window.
    Quit,
    /// Something a background job delivered.
    Job(JobEvent),
}

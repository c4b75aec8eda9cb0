//! Commands: what panels, menus, shortcuts and viewport gestures ask for. Only
//! [`super::Editor::apply`] acts on them.

use super::inspector::InspectorMode;
use super::state::ViewMode;
use crate::params::{Grid, Light, Medium};
use crate::render::Method;
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

#[derive(Debug, Clone, PartialEq)]
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
    /// Fraction of the viewport's pixels the renderer draws at (1 = every pixel).
    SetRenderScale(f32),
    ShowInspector(bool),
    SetInspectorMode(InspectorMode),
    SetSlicePlane(u32),
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
}

//! The document: the scene being edited, its look, and the look's undo history.
//!
//! Only [`super::Editor::apply`] changes a [`Document`]; panels read it.

use super::command::MergeKey;
use crate::params::{Grid, Light, Medium};
use crate::scene::{Aabb, Camera, Scene};
use std::path::PathBuf;
use std::sync::Arc;

/// Everything an edit can change: what a preset or a scene file describes besides the meshes.
/// Undo and redo swap whole looks (a few hundred bytes), so every edit is undoable by construction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Look {
    pub camera: Camera,
    pub light: Light,
    pub medium: Medium,
    pub grid: Grid,
    /// Exposure of the displayed image, in stops.
    pub exposure: f32,
}

impl Look {
    pub fn of(scene: &Scene, exposure: f32) -> Look {
        Look { camera: scene.camera, light: scene.light, medium: scene.medium, grid: scene.grid, exposure }
    }

    /// Writes the look into `scene` (its meshes stay).
    pub fn apply_to(&self, scene: &mut Scene) {
        scene.camera = self.camera;
        scene.light = self.light;
        scene.medium = self.medium;
        scene.grid = self.grid;
    }
}

/// The scene, its look and history, and the preset the look was last loaded from or saved to.
#[derive(Debug)]
pub struct Document {
    /// The scene as loaded (its own camera, light, medium and grid; the look overrides them).
    pub scene: Arc<Scene>,
    /// The scene's bounds (panels and gestures size their steps by it; computed once per scene).
    pub bounds: Aabb,
    /// Bumped when another scene is opened (the renderer uploads geometry again).
    pub scene_generation: u64,
    pub look: Look,
    pub history: History,
    pub preset_path: Option<PathBuf>,
}

impl Document {
    pub fn new(scene: Scene, exposure: f32, preset_path: Option<PathBuf>) -> Document {
        let look = Look::of(&scene, exposure);
        let bounds = scene.bounds();
        Document { scene: Arc::new(scene), bounds, scene_generation: 1, look, history: History::default(), preset_path }
    }

    /// An undoable change of the look; a change that changes nothing leaves no history.
    pub fn edit(&mut self, key: MergeKey, f: impl FnOnce(&mut Look)) {
        let before = self.look;
        f(&mut self.look);
        if self.look != before {
            self.history.record(before, key);
        }
    }

    pub fn undo(&mut self) {
        if let Some(l) = self.history.undo(self.look) {
            self.look = l;
        }
    }

    pub fn redo(&mut self) {
        if let Some(l) = self.history.redo(self.look) {
            self.look = l;
        }
    }

    /// Another scene replaces this one: its own look (the exposure stays) and a fresh history
    /// (the old steps describe the old scene).
    pub fn replace_scene(&mut self, scene: Scene) {
        let exposure = self.look.exposure;
        self.look = Look::of(&scene, exposure);
        self.history.clear();
        self.bounds = scene.bounds();
        self.scene = Arc::new(scene);
        self.scene_generation += 1;
    }

    /// The scene with the current look written into it.
    pub fn composed(&self) -> Scene {
        let mut s = (*self.scene).clone();
        self.look.apply_to(&mut s);
        s
    }
}

/// Undo and redo stacks of looks.
///
/// A drag of one widget produces a change every frame; those merge into one undo step: an edit
/// carrying the same [`MergeKey`] as the edit just before it does not push a new entry, so the
/// entry on top still holds the look from before the drag began.
#[derive(Debug, Default)]
pub struct History {
    undo: Vec<Look>,
    redo: Vec<Look>,
    /// The merge key of the last recorded edit, cleared by anything else.
    last_key: MergeKey,
}

impl History {
    /// How many steps are kept.
    pub const LIMIT: usize = 500;

    /// Records that the look was `before` prior to an edit with `key`.
    pub fn record(&mut self, before: Look, key: MergeKey) {
        self.redo.clear();
        let merge = key.is_some() && key == self.last_key && !self.undo.is_empty();
        if !merge {
            self.undo.push(before);
            if self.undo.len() > Self::LIMIT {
                self.undo.remove(0);
            }
        }
        self.last_key = key;
    }

    /// Ends any merging run (called for every command that is not a merging edit).
    pub fn break_merge(&mut self) {
        self.last_key = None;
    }

    /// Returns the look to go back to, remembering `current` for redo.
    pub fn undo(&mut self, current: Look) -> Option<Look> {
        self.last_key = None;
        let prev = self.undo.pop()?;
        self.redo.push(current);
        Some(prev)
    }

    pub fn redo(&mut self, current: Look) -> Option<Look> {
        self.last_key = None;
        let next = self.redo.pop()?;
        self.undo.push(current);
        Some(next)
    }

    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }
    pub fn undo_len(&self) -> usize {
        self.undo.len()
    }

    /// Forgets everything (a different scene was opened).
    pub fn clear(&mut self) {
        *self = History::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn look(d: f32) -> Look {
        let mut s = crate::scene::builtin_scene();
        s.medium.density = d;
        Look::of(&s, 0.0)
    }

    #[test]
    fn merged_drag_is_one_step_and_redo_is_cleared_by_an_edit() {
        let mut h = History::default();
        let key = Some(eframe::egui::Id::unique("density"));
        // A drag 1 -> 2 -> 3: one entry holding 1.
        h.record(look(1.0), key);
        h.record(look(2.0), key);
        assert_eq!(h.undo_len(), 1);
        // Another widget: a new entry.
        h.record(look(3.0), None);
        assert_eq!(h.undo_len(), 2);
        let back = h.undo(look(4.0)).unwrap();
        assert_eq!(back.medium.density, 3.0);
        let back = h.undo(back).unwrap();
        assert_eq!(back.medium.density, 1.0);
        assert!(h.undo(back).is_none());
        let fwd = h.redo(back).unwrap();
        assert_eq!(fwd.medium.density, 3.0);
        h.record(fwd, None);
        assert!(!h.can_redo());
    }
}

//! Files around the editor: the preset folder, the recent-files list, and file dialogs that run on
//! their own threads (rfd through the XDG desktop portal; the UI never waits for them).

use std::path::{Path, PathBuf};
use std::sync::mpsc;

/// The folder listed in the Presets panel: `presets/` in the working directory, else the crate's.
pub fn default_presets_dir() -> PathBuf {
    let here = PathBuf::from("presets");
    if here.is_dir() {
        return here;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("presets")
}

/// `*.toml` files of `dir`, sorted by name.
pub fn list_presets(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "toml"))
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

/// Where the editor keeps its small state files.
pub fn default_config_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("EPIVOX_CONFIG_DIR") {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_CONFIG_HOME").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d).join("epivox"));
    }
    std::env::var_os("HOME").filter(|d| !d.is_empty()).map(|h| PathBuf::from(h).join(".config").join("epivox"))
}

/// Recently opened scenes and presets, newest first, kept in `recent.json` in the config folder.
#[derive(Debug, Default, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Recent {
    #[serde(default)]
    pub scenes: Vec<PathBuf>,
    #[serde(default)]
    pub presets: Vec<PathBuf>,
}

impl Recent {
    pub const MAX: usize = 10;

    pub fn load(dir: Option<&Path>) -> Recent {
        dir.and_then(|d| std::fs::read_to_string(d.join("recent.json")).ok())
            .and_then(|t| serde_json::from_str(&t).ok())
            .unwrap_or_default()
    }

    /// Writes the list whole or not at all (`fsx::write_atomic`). Failing to remember is
    /// not worth interrupting the user for; the caller logs it.
    pub fn save(&self, dir: Option<&Path>) -> std::io::Result<()> {
        let Some(dir) = dir else { return Ok(()) };
        std::fs::create_dir_all(dir)?;
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        crate::fsx::write_atomic(&dir.join("recent.json"), |w| std::io::Write::write_all(w, text.as_bytes()))
    }

    fn push(list: &mut Vec<PathBuf>, p: &Path) {
        let p = std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf());
        list.retain(|q| *q != p);
        list.insert(0, p);
        list.truncate(Self::MAX);
    }

    pub fn add_scene(&mut self, p: &Path) {
        Self::push(&mut self.scenes, p);
    }
    pub fn add_preset(&mut self, p: &Path) {
        Self::push(&mut self.presets, p);
    }
}

/// What a dialog was opened for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DialogPurpose {
    OpenScene,
    OpenPreset,
    SavePresetAs,
    Screenshot,
    ExportInspector,
}

/// File dialogs on background threads; results are polled each frame.
pub struct Dialogs {
    tx: mpsc::Sender<(DialogPurpose, Option<PathBuf>)>,
    rx: mpsc::Receiver<(DialogPurpose, Option<PathBuf>)>,
    pub open: Option<DialogPurpose>,
    opened_at: Option<std::time::Instant>,
}

impl Default for Dialogs {
    fn default() -> Self {
        let (tx, rx) = mpsc::channel();
        Dialogs { tx, rx, open: None, opened_at: None }
    }
}

impl Dialogs {
    /// Opens a dialog unless one is open already; `wake` is called when it closes.
    pub fn start(&mut self, purpose: DialogPurpose, start_dir: Option<PathBuf>, wake: impl Fn() + Send + 'static) {
        if self.open.is_some() {
            return;
        }
        self.open = Some(purpose);
        self.opened_at = Some(std::time::Instant::now());
        let tx = self.tx.clone();
        let spawned = std::thread::Builder::new().name("epivox-file-dialog".into()).spawn(move || {
            let mut d = rfd::AsyncFileDialog::new();
            if let Some(dir) = start_dir {
                d = d.set_directory(dir);
            }
            let picked = pollster::block_on(async move {
                match purpose {
                    DialogPurpose::OpenScene => d
                        .set_title("Open a scene")
                        .add_filter("scenes and meshes", &["gltf", "glb", "obj", "ply", "toml", "xml"])
                        .add_filter("all files", &["*"])
                        .pick_file()
                        .await
                        .map(|f| f.path().to_path_buf()),
                    DialogPurpose::OpenPreset => d
                        .set_title("Open a preset")
                        .add_filter("presets", &["toml"])
                        .pick_file()
                        .await
                        .map(|f| f.path().to_path_buf()),
                    DialogPurpose::SavePresetAs => d
                        .set_title("Save the preset as")
                        .add_filter("presets", &["toml"])
                        .set_file_name("look.toml")
                        .save_file()
                        .await
                        .map(|f| f.path().to_path_buf()),
                    DialogPurpose::Screenshot => d
                        .set_title("Save a screenshot")
                        .add_filter("PNG", &["png"])
                        .set_file_name("epivox.png")
                        .save_file()
                        .await
                        .map(|f| f.path().to_path_buf()),
                    DialogPurpose::ExportInspector => d
                        .set_title("Export the inspector picture")
                        .add_filter("PNG", &["png"])
                        .set_file_name("epivox-grid.png")
                        .save_file()
                        .await
                        .map(|f| f.path().to_path_buf()),
                }
            });
            let _ = tx.send((purpose, picked));
            wake();
        });
        if spawned.is_err() {
            self.open = None;
        }
    }

    /// A dialog that closed since the last call: its purpose, the chosen path (None: cancelled),
    /// and whether it came back so fast that no dialog can have been shown (no desktop portal and
    /// no zenity: rfd then returns nothing without a word).
    pub fn poll(&mut self) -> Option<(DialogPurpose, Option<PathBuf>, bool)> {
        let (purpose, path) = self.rx.try_recv().ok()?;
        self.open = None;
        let instant = self.opened_at.take().is_some_and(|t| t.elapsed() < std::time::Duration::from_millis(250));
        let failed = instant && path.is_none();
        Some((purpose, path, failed))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recent_list_round_trips_and_stays_short() {
        let dir = tempfile::tempdir().unwrap();
        let mut r = Recent::default();
        for i in 0..15 {
            r.add_scene(Path::new(&format!("/no/such/scene{i}.obj")));
        }
        r.add_scene(Path::new("/no/such/scene3.obj"));
        assert_eq!(r.scenes.len(), Recent::MAX);
        assert_eq!(r.scenes[0], Path::new("/no/such/scene3.obj"));
        r.save(Some(dir.path())).unwrap();
        assert_eq!(Recent::load(Some(dir.path())), r);
    }
}

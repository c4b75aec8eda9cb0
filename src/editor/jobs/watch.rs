//! Watches the shader folder and says, debounced, when a WGSL file changed.
//!
//! The *folder* is watched (recursively), not the files: editors that save by writing a temporary
//! file and renaming it over the original replace the inode, which a per-file watch would lose.
//! Events come in bursts (create, modify, rename, chmod), so they are collected until the folder has
//! been quiet for [`ShaderWatcher::DEBOUNCE`], then reported once.

use notify::{EventKind, RecursiveMode, Watcher};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::time::Duration;

pub struct ShaderWatcher {
    dir: PathBuf,
    /// Bumped once per debounced burst of changes.
    changes: Arc<AtomicU64>,
    seen: u64,
    _watcher: notify::RecommendedWatcher,
}

/// Does this event concern a shader? (Renames report the new name too, so `.wgsl` catches saves by
/// rename; a deleted file matters because the embedded copy takes its place.)
fn is_shader_event(e: &notify::Event) -> bool {
    let kind = matches!(e.kind, EventKind::Create(_) | EventKind::Modify(_) | EventKind::Remove(_) | EventKind::Any);
    kind && e.paths.iter().any(|p| p.extension().is_some_and(|x| x == "wgsl"))
}

impl ShaderWatcher {
    pub const DEBOUNCE: Duration = Duration::from_millis(150);

    /// Starts watching `dir`; `notify` is called (from the watcher's thread) after each burst,
    /// e.g. to wake the UI.
    pub fn new(dir: &Path, notify: impl Fn() + Send + 'static) -> notify::Result<ShaderWatcher> {
        let (tx, rx) = mpsc::channel::<()>();
        let mut watcher = notify::recommended_watcher(move |res: notify::Result<notify::Event>| {
            if let Ok(e) = res {
                if is_shader_event(&e) {
                    let _ = tx.send(());
                }
            }
        })?;
        watcher.watch(dir, RecursiveMode::Recursive)?;
        let changes = Arc::new(AtomicU64::new(0));
        let counter = changes.clone();
        std::thread::Builder::new()
            .name("epivox-shader-debounce".into())
            .spawn(move || {
                // Ends when the watcher (and with it the sender) is dropped.
                while rx.recv().is_ok() {
                    while rx.recv_timeout(Self::DEBOUNCE).is_ok() {}
                    counter.fetch_add(1, Ordering::SeqCst);
                    notify();
                }
            })
            .map_err(|e| notify::Error::generic(&e.to_string()))?;
        Ok(ShaderWatcher { dir: dir.to_path_buf(), changes, seen: 0, _watcher: watcher })
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// True once per burst of changes since the last call.
    pub fn take_changed(&mut self) -> bool {
        let now = self.changes.load(Ordering::SeqCst);
        let changed = now != self.seen;
        self.seen = now;
        changed
    }
}

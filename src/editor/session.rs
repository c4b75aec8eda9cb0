//! What the editor keeps around the document: where presets and settings live, the recent files,
//! the status bar's messages, and an open "replace the file?" question. Only
//! [`super::Editor::apply`] changes it.

use super::files::Recent;
use std::path::PathBuf;

/// A line in the status bar.
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    pub error: bool,
    pub text: String,
}

#[derive(Debug)]
pub struct Session {
    /// Listed in the Presets panel.
    pub presets_dir: PathBuf,
    /// Where `recent.json` lives (`None`: nowhere to keep it).
    pub config_dir: Option<PathBuf>,
    pub recent: Recent,
    /// Newest last.
    pub messages: Vec<Message>,
    /// The overwrite question is open for this path.
    pub confirm_overwrite: Option<PathBuf>,
}

impl Session {
    /// Messages kept for the status bar.
    const MESSAGES: usize = 6;

    pub fn new(presets_dir: PathBuf, config_dir: Option<PathBuf>) -> Session {
        let recent = Recent::load(config_dir.as_deref());
        Session { presets_dir, config_dir, recent, messages: Vec::new(), confirm_overwrite: None }
    }

    pub fn info(&mut self, text: impl Into<String>) {
        self.push(false, text.into());
    }

    pub fn error(&mut self, text: impl Into<String>) {
        self.push(true, text.into());
    }

    fn push(&mut self, error: bool, text: String) {
        if error {
            log::warn!("{text}");
        }
        self.messages.push(Message { error, text });
        if self.messages.len() > Self::MESSAGES {
            self.messages.remove(0);
        }
    }

    /// Writes the recent list. Failing to remember is not worth interrupting the user for: logged.
    pub fn remember_recent(&self) {
        if let Err(e) = self.recent.save(self.config_dir.as_deref()) {
            log::warn!("could not remember recent files: {e}");
        }
    }
}

//! `epivox edit` (and `epivox` with no arguments): the editor window.

use anyhow::{bail, Result};
use epivox::editor::{self, EditorOptions, RenderPriority};
use std::path::PathBuf;

#[derive(clap::Args, Default)]
pub struct EditArgs {
    /// A mesh (.gltf .glb .obj .ply), a folder of meshes or a Mitsuba scene, or a .toml scene file;
    /// the built-in scene when omitted.
    pub scene: Option<PathBuf>,
    /// A preset file applied at start (medium, grid, exposure).
    #[arg(long)]
    pub preset: Option<PathBuf>,
    /// The shader folder to use and watch for edits (default: $EPIVOX_SHADER_DIR, ./shaders, or
    /// the crate's shaders/; the embedded copies when none exists).
    #[arg(long)]
    pub shader_dir: Option<PathBuf>,
    /// Quit after N frames, rendering the viewport every frame, and print timings as JSON (tests).
    #[arg(long, hide = true)]
    pub quit_after_frames: Option<u32>,
    /// With --quit-after-frames: save a screenshot of the window as PNG before quitting (tests).
    #[arg(long, hide = true, requires = "quit_after_frames")]
    pub screenshot: Option<PathBuf>,
}

pub fn edit(args: EditArgs) -> Result<()> {
    // Warnings (wgpu validation, the file watcher, ...) reach stderr through `init_logging` in main.
    let measuring = args.quit_after_frames.is_some();
    let opts = EditorOptions {
        scene: args.scene,
        preset: args.preset,
        shader_dir: args.shader_dir,
        quit_after_frames: args.quit_after_frames,
        screenshot: args.screenshot,
        // Measuring renders back to back with no one at the window: nothing to yield to, and
        // under a test run's load an idle-priority render would wait for the other tests.
        render_priority: if measuring { RenderPriority::Lowered } else { RenderPriority::default() },
        ..EditorOptions::default()
    };
    let summary = editor::run(opts)?;
    if measuring {
        println!("{}", serde_json::to_string_pretty(&summary)?);
        if !summary.errors.is_empty() {
            bail!("the editor reported errors: {}", summary.errors.join("; "));
        }
    }
    Ok(())
}

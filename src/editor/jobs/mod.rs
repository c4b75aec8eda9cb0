//! The editor's background work: the render worker, the accuracy reference, the shader watcher,
//! scene loading and file dialogs. Each delivers through a channel and wakes the UI; [`Jobs::poll`]
//! turns what arrived into [`Command::Job`] events, which [`super::Editor::apply`] acts on like
//! any other command.

pub mod accuracy;
pub mod frame;
pub mod progressive;
pub mod render;
pub mod watch;

use super::command::Command;
use super::files::{DialogPurpose, Dialogs};
use crate::gpu::ShaderLibrary;
use crate::image::Image;
use crate::render::{Method, ShadowVolume, SurfaceShadows};
use crate::scene::{load_scene, Scene, SceneError};
use accuracy::{AccuracyJob, AccuracyResult};
use render::{DeviceInfo, FrameFailure, Picture, RenderEvent, RenderJob};
use std::path::PathBuf;
use std::sync::{mpsc, Arc};
use std::time::Instant;
use watch::ShaderWatcher;

/// What a background job delivered.
pub enum JobEvent {
    Render(RenderEvent),
    /// A scene finished loading, or why it did not.
    SceneLoaded(PathBuf, Result<Scene, String>),
    /// The watched shader folder changed (debounced).
    ShadersChanged,
    /// A file dialog closed: the chosen path (None: cancelled), and whether it came back too fast
    /// for any dialog to have been shown.
    DialogClosed(DialogPurpose, Option<PathBuf>, bool),
    /// The accuracy reference finished (None: cancelled or stopped).
    AccuracyFinished(Option<Box<AccuracyResult>>),
}

impl std::fmt::Debug for JobEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JobEvent::Render(e) => write!(f, "Render({e:?})"),
            JobEvent::SceneLoaded(p, r) => write!(f, "SceneLoaded({}, {})", p.display(), r.is_ok()),
            JobEvent::ShadersChanged => f.write_str("ShadersChanged"),
            JobEvent::DialogClosed(p, path, failed) => write!(f, "DialogClosed({p:?}, {path:?}, {failed})"),
            JobEvent::AccuracyFinished(r) => write!(f, "AccuracyFinished({})", r.is_some()),
        }
    }
}

/// The accuracy check: first the GPU image of the view (from the worker), then the reference.
pub enum Accuracy {
    Idle,
    /// Waiting for the worker's GPU image of this scene.
    Capturing {
        id: u64,
        scene: Arc<Scene>,
        width: u32,
        height: u32,
        method_label: String,
    },
    Running(AccuracyJob),
}

/// The render worker's state as the UI knows it.
pub struct RenderState {
    pub job: RenderJob,
    /// The worker's device, once it started.
    pub device: Option<DeviceInfo>,
    /// The latest request's generation, and what it was made from.
    pub generation: u64,
    pub content: Option<RenderContent>,
    /// Whether the latest request was interactive.
    pub interactive: bool,
    /// What is on screen (the newest picture delivered).
    pub shown: Option<Arc<Picture>>,
    /// The newest frame that failed, while no newer picture arrived.
    pub failure: Option<FrameFailure>,
    /// The grids of the newest full frame that read them (the inspector).
    pub grids: Option<Arc<super::panels::inspector::GridSnapshot>>,
    /// Every picture delivered: (generation, full, medium density), oldest first (tests; short).
    pub log: Vec<(u64, bool, f32)>,
    pub frames: u64,
    pub full_frames: u64,
    /// The shaders' version: bumped by every successful reload (the picture is drawn again).
    pub shader_epoch: u64,
    /// A reload is compiling since then.
    pub compiling: Option<Instant>,
    /// Reloads asked for and not answered yet (a save during a reload asks again).
    pub reloads_pending: u32,
    /// The last reload's (or start-up's) error, shown over the viewport until a reload succeeds.
    pub shader_error: Option<String>,
    /// How long the last successful reload compiled (ms).
    pub reload_ms: Option<f64>,
}

/// Everything in a request that decides the picture (not the exposure, not interactivity).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderContent {
    pub look: super::document::Look,
    pub surface_only: bool,
    pub method: Method,
    pub shadow_map: u32,
    pub surface_shadows: SurfaceShadows,
    pub shadow_volume: ShadowVolume,
    pub adaptive_pixels: bool,
    pub width: u32,
    pub height: u32,
    pub scene_generation: u64,
    pub shader_epoch: u64,
    pub grids: bool,
}

pub struct Jobs {
    pub render: RenderState,
    pub shaders: ShaderLibrary,
    pub watcher: Option<ShaderWatcher>,
    pub scene_load: Option<(PathBuf, mpsc::Receiver<Result<Scene, SceneError>>)>,
    pub accuracy: Accuracy,
    pub accuracy_result: Option<Box<AccuracyResult>>,
    pub dialogs: Dialogs,
    next_capture: u64,
}

impl Jobs {
    pub fn new(render: RenderJob, shaders: ShaderLibrary, watcher: Option<ShaderWatcher>) -> Jobs {
        Jobs {
            render: RenderState {
                job: render,
                device: None,
                generation: 0,
                content: None,
                interactive: false,
                shown: None,
                failure: None,
                grids: None,
                log: Vec::new(),
                frames: 0,
                full_frames: 0,
                shader_epoch: 0,
                compiling: None,
                reloads_pending: 0,
                shader_error: None,
                reload_ms: None,
            },
            shaders,
            watcher,
            scene_load: None,
            accuracy: Accuracy::Idle,
            accuracy_result: None,
            dialogs: Dialogs::default(),
            next_capture: 0,
        }
    }

    /// What arrived since the last frame, as commands. Taking from the channels is all it does.
    pub fn poll(&mut self) -> Vec<Command> {
        let mut out: Vec<JobEvent> = self.render.job.poll().into_iter().map(JobEvent::Render).collect();
        if self.watcher.as_mut().is_some_and(|w| w.take_changed()) {
            out.push(JobEvent::ShadersChanged);
        }
        if let Some((purpose, path, failed)) = self.dialogs.poll() {
            out.push(JobEvent::DialogClosed(purpose, path, failed));
        }
        if let Some((path, rx)) = &self.scene_load {
            match rx.try_recv() {
                Ok(r) => out.push(JobEvent::SceneLoaded(path.clone(), r.map_err(|e| e.to_string()))),
                Err(mpsc::TryRecvError::Empty) => {}
                Err(mpsc::TryRecvError::Disconnected) => {
                    out.push(JobEvent::SceneLoaded(path.clone(), Err("scene loading stopped unexpectedly".into())))
                }
            }
        }
        if let Accuracy::Running(job) = &self.accuracy {
            if let Some(done) = job.poll() {
                out.push(JobEvent::AccuracyFinished(done.map(Box::new)));
            }
        }
        out.into_iter().map(Command::Job).collect()
    }

    /// Starts loading `path` on a thread; `wake` when done.
    pub fn load_scene(&mut self, path: PathBuf, wake: impl Fn() + Send + 'static) -> std::io::Result<()> {
        let (tx, rx) = mpsc::channel();
        let p = path.clone();
        std::thread::Builder::new().name("epivox-scene-load".into()).spawn(move || {
            let _ = tx.send(load_scene(&p));
            wake();
        })?;
        self.scene_load = Some((path, rx));
        Ok(())
    }

    /// Asks the worker for the GPU images the accuracy check compares against.
    pub fn start_capture(&mut self, scene: Arc<Scene>, scene_generation: u64, width: u32, height: u32, method: Method) {
        self.next_capture += 1;
        let id = self.next_capture;
        self.render.job.capture(id, scene.clone(), scene_generation, width, height, method);
        self.accuracy = Accuracy::Capturing {
            id,
            scene,
            width,
            height,
            method_label: super::panels::toolbar::method_label(&method),
        };
    }

    /// The worker's images for capture `id` arrived: start the reference (unless cancelled).
    pub fn captured(&mut self, id: u64, images: (Image, Image), wake: impl Fn() + Send + Sync + 'static) {
        let Accuracy::Capturing { id: want, scene, width, height, method_label } = &self.accuracy else { return };
        if *want != id {
            return;
        }
        let (scatter, hdr) = images;
        let job = AccuracyJob::start(scene.clone(), *width, *height, scatter, hdr, method_label.clone(), wake);
        self.accuracy = Accuracy::Running(job);
    }

    pub fn accuracy_running(&self) -> bool {
        !matches!(self.accuracy, Accuracy::Idle)
    }

    /// Something moves without input (progress bars, spinners): keep repainting a little.
    pub fn animating(&self) -> bool {
        self.accuracy_running() || self.scene_load.is_some() || self.render.compiling.is_some()
    }
}

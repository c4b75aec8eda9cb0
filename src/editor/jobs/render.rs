//! The render job: a worker thread with its own wgpu device renders the newest request and hands
//! finished pictures to the UI thread, which never waits for a frame.
//!
//! - **Own device.** On the software driver every device has its own queue, executed by its own
//!   threads, so the window's frames are never queued behind a render that takes seconds
//!   (docs/editor.md has the measurements that decided this). Without a second device the worker
//!   renders on the window's.
//! - **Coalescing.** A request replaces the one waiting: the worker always takes the newest, so
//!   no queue of stale frames builds up during a drag.
//! - **Progressive.** A frame predicted to take longer than [`PREVIEW_BUDGET_MS`] is preceded by a
//!   preview with fewer pixels and a coarser grid (same method), sized from the measured times of
//!   recent frames ([`FrameTimes`]); the full frame follows once the request is no longer
//!   interactive (the pointer is up).
//! - **Reload** compiles the changed shaders here, not on the UI thread; the last good picture
//!   stays on screen meanwhile.
//!
//! Each delivery wakes the UI (`request_repaint`).

pub use super::frame::{
    DeviceInfo, FrameFailure, FrameRequest, ImageStats, Picture, Quality, RenderEvent, INSPECT_LIMIT,
};
use super::progressive::{scaled, work_units, FrameTimes, PREVIEW_BUDGET_MS};
use crate::editor::display::{DisplayImages, DisplayPipeline};
use crate::editor::panels::inspector::GridSnapshot;
use crate::editor::panels::GridLimits;
use crate::gpu::{GpuContext, ShaderLibrary};
use crate::render::{Method, Renderer, Variant};
use crate::scene::Scene;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

/// A one-off job, done before the next frame.
enum Task {
    Reload(ShaderLibrary),
    Capture { id: u64, scene: Arc<Scene>, scene_generation: u64, width: u32, height: u32, method: Method },
}

#[derive(Default)]
struct Slot {
    frame: Option<FrameRequest>,
    tasks: VecDeque<Task>,
    quit: bool,
}

#[derive(Default)]
struct Shared {
    slot: Mutex<Slot>,
    wake: Condvar,
    busy: AtomicBool,
    /// The worker ended (it panicked, or could not start).
    stopped: AtomicBool,
}

impl Shared {
    /// A frame or task is being worked on or waiting (never, once the worker has stopped).
    fn in_flight(&self) -> bool {
        !self.stopped.load(Ordering::SeqCst)
            && (self.busy.load(Ordering::SeqCst)
                || self.slot.lock().map(|s| s.frame.is_some() || !s.tasks.is_empty()).unwrap_or(false))
    }

    /// The window has gone (the handle was dropped) or the worker has stopped.
    fn over(&self) -> bool {
        self.stopped.load(Ordering::SeqCst) || self.slot.lock().map(|s| s.quit).unwrap_or(true)
    }
}

/// How the worker is set up (tests and measurements).
#[derive(Debug, Clone, Default)]
pub struct WorkerOptions {
    /// Render on the window's device instead of a second one (to measure the difference).
    pub shared_device: bool,
    /// Sleep this long before each frame (tests: a slow GPU on any machine).
    pub frame_delay: Option<Duration>,
    /// How the worker shares the CPU with the window.
    pub priority: RenderPriority,
}

/// How the render worker, and the driver threads its device starts (they inherit it), share the
/// CPU with the window. On the software driver both the window's painting and the render are CPU
/// work on the same cores; the window must come first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RenderPriority {
    /// Linux `SCHED_IDLE`: the render runs on CPU time nothing else wants, so a UI frame never
    /// waits behind it (a 3 s viewport drag on llvmpipe, 2 cores: UI frame p95 35–40 ms against
    /// 39–53 ms at nice 19 and 39–59 ms at nice 10, with as many previews; docs/editor.md). The
    /// price: while other programs keep every core busy, renders wait for them.
    #[default]
    Idle,
    /// Nice +10 (at most 19): a small share under contention. Tests use it: there the UI thread
    /// polls for the render while other tests load the same cores.
    Lowered,
}

impl RenderPriority {
    /// `EPIVOX_EDITOR_RENDER_PRIORITY=idle|lowered`, else `default`.
    pub fn from_env(default: RenderPriority) -> RenderPriority {
        match std::env::var("EPIVOX_EDITOR_RENDER_PRIORITY").as_deref() {
            Ok("idle") => RenderPriority::Idle,
            Ok("lowered") => RenderPriority::Lowered,
            _ => default,
        }
    }
}

/// What the worker needs from the window: its device (the pictures' textures live there), the
/// display shader's layout and the target format.
pub struct Window {
    pub gpu: GpuContext,
    pub layout: wgpu::BindGroupLayout,
    pub format: wgpu::TextureFormat,
}

/// The UI's handle on the worker.
pub struct RenderJob {
    shared: Arc<Shared>,
    rx: mpsc::Receiver<RenderEvent>,
}

impl RenderJob {
    /// Starts the worker. `wake` is called after every delivery (to repaint the UI).
    pub fn start(
        window: Window,
        lib: ShaderLibrary,
        opts: WorkerOptions,
        wake: impl Fn() + Send + 'static,
    ) -> std::io::Result<RenderJob> {
        let shared = Arc::new(Shared::default());
        let (tx, rx) = mpsc::channel();
        let s2 = shared.clone();
        if opts.priority == RenderPriority::Idle {
            starvation::guard(shared.clone());
        }
        std::thread::Builder::new().name("epivox-render".into()).spawn(move || {
            let send = |e: RenderEvent| {
                let _ = tx.send(e);
                wake();
            };
            // A panic (wgpu reports device errors outside error scopes by panicking) ends the
            // worker; the UI is told, keeps its last picture and stays usable.
            let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                if let Some(mut w) = Worker::open(window, &lib, opts, &send) {
                    w.run(&s2, &send);
                }
            }));
            s2.stopped.store(true, Ordering::SeqCst);
            if let Err(payload) = run {
                let what = payload
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic".into());
                send(RenderEvent::Stopped(what));
            }
        })?;
        Ok(RenderJob { shared, rx })
    }

    fn with_slot(&self, f: impl FnOnce(&mut Slot)) {
        // A poisoned lock means the worker panicked: nothing more will render; say nothing here
        // (the UI keeps its last picture).
        if let Ok(mut s) = self.shared.slot.lock() {
            f(&mut s);
            self.shared.wake.notify_one();
        }
    }

    /// Replaces the waiting request (if any) with `r`.
    pub fn submit(&self, r: FrameRequest) {
        self.with_slot(|s| s.frame = Some(r));
    }

    /// Rebuilds every pipeline from `lib` before the next frame.
    pub fn reload(&self, lib: ShaderLibrary) {
        self.with_slot(|s| s.tasks.push_back(Task::Reload(lib)));
    }

    /// Renders `scene` at `width x height` and reads both images back (the accuracy check).
    pub fn capture(&self, id: u64, scene: Arc<Scene>, scene_generation: u64, width: u32, height: u32, method: Method) {
        self.with_slot(|s| s.tasks.push_back(Task::Capture { id, scene, scene_generation, width, height, method }));
    }

    /// Everything delivered since the last call.
    pub fn poll(&self) -> Vec<RenderEvent> {
        self.rx.try_iter().collect()
    }

    /// A frame or task is being worked on or waiting (never, once the worker has stopped).
    pub fn in_flight(&self) -> bool {
        self.shared.in_flight()
    }
}

impl Drop for RenderJob {
    fn drop(&mut self) {
        // The worker ends after what it is doing; nobody waits for it.
        self.with_slot(|s| s.quit = true);
    }
}

enum Job {
    Task(Task),
    Frame(FrameRequest),
}

/// Shadow-map texels per side of the preview renderer (coarser shadows of surfaces, like the rest
/// of a preview).
const PREVIEW_SHADOW_MAP: u32 = 512;

/// Lowers the calling thread's priority (see [`RenderPriority`]). Threads it starts inherit it —
/// the software driver's, created with the worker's device — so on a CPU shared with the driver
/// the UI thread comes first and the renderer takes the rest.
fn lower_priority(priority: RenderPriority) {
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on the calling thread (on Linux `who = 0` with PRIO_PROCESS, and
    // pid 0 for sched_setscheduler, are the calling thread; both settings are per thread).
    // getpriority returns -1 both as a value and on error: either way the result is a valid nice
    // value. A failed SCHED_IDLE leaves the nice value in force.
    unsafe {
        let now = libc::getpriority(libc::PRIO_PROCESS, 0);
        libc::setpriority(libc::PRIO_PROCESS, 0, (now + 10).min(19));
        if priority == RenderPriority::Idle {
            let param = libc::sched_param { sched_priority: 0 };
            if libc::sched_setscheduler(0, libc::SCHED_IDLE, &param) != 0 {
                log::warn!("the render worker could not take SCHED_IDLE; it runs at nice +10");
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = priority;
}

/// The price of [`RenderPriority::Idle`] is that a render waits while other programs keep every
/// core busy (measured: with two busy loops on two cores, no picture at all in a minute). A guard
/// thread at normal priority watches the worker's threads while a frame is waiting or in flight;
/// when they get (almost) no CPU for two seconds it moves them to the normal policy at nice +10
/// ([`RenderPriority::Lowered`]) for the rest of the session, and says so in the log.
mod starvation {
    use super::Shared;
    use std::sync::Arc;
    use std::time::Duration;

    /// Half-seconds in flight with (almost) no CPU before the worker is promoted.
    const STARVED_TICKS: u32 = 4;
    /// CPU time (clock ticks, 1/100 s) below which a half-second counts as starved.
    const MIN_PROGRESS: u64 = 2;

    pub fn guard(shared: Arc<Shared>) {
        #[cfg(target_os = "linux")]
        let _ = std::thread::Builder::new().name("epivox-render-guard".into()).spawn(move || {
            let mut last = idle_threads(|_| {}).1;
            let mut starved = 0;
            while !shared.over() {
                std::thread::sleep(Duration::from_millis(500));
                let now = idle_threads(|_| {}).1;
                let waiting = shared.in_flight();
                starved = if waiting && now.saturating_sub(last) < MIN_PROGRESS { starved + 1 } else { 0 };
                last = now;
                if starved >= STARVED_TICKS {
                    let (n, _) = idle_threads(promote);
                    log::warn!(
                        "the render worker got almost no CPU for 2 s while a frame waited (other programs \
                         keep the cores busy, or a long GPU wait): its {n} threads now run at nice +10 \
                         instead of idle priority"
                    );
                    return;
                }
            }
        });
        #[cfg(not(target_os = "linux"))]
        let _ = shared;
    }

    /// Calls `f` on every thread of this process that runs under SCHED_IDLE (only the worker and
    /// the driver threads it started do); returns their number and their CPU time in clock ticks.
    #[cfg(target_os = "linux")]
    fn idle_threads(f: impl Fn(i32)) -> (usize, u64) {
        let Ok(dir) = std::fs::read_dir("/proc/self/task") else { return (0, 0) };
        let mut n = 0;
        let mut ticks = 0;
        for tid in dir.flatten().filter_map(|e| e.file_name().to_str().and_then(|t| t.parse::<i32>().ok())) {
            // SAFETY: a query of another thread's policy; an ended thread gives -1.
            if unsafe { libc::sched_getscheduler(tid) } != libc::SCHED_IDLE {
                continue;
            }
            n += 1;
            // utime and stime: fields 14 and 15 of stat, 12th and 13th after the ")" that ends
            // the thread's name (which may itself hold spaces).
            if let Ok(stat) = std::fs::read_to_string(format!("/proc/self/task/{tid}/stat")) {
                if let Some((_, rest)) = stat.rsplit_once(')') {
                    let fields: Vec<&str> = rest.split_whitespace().collect();
                    for i in [11, 12] {
                        ticks += fields.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
                    }
                }
            }
            f(tid);
        }
        (n, ticks)
    }

    #[cfg(target_os = "linux")]
    fn promote(tid: i32) {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: changes the policy of a thread of this process; its nice value (+10, set
        // before SCHED_IDLE) stays.
        unsafe { libc::sched_setscheduler(tid, libc::SCHED_OTHER, &param) };
    }
}

/// A renderer and what it was given.
struct Lane {
    renderer: Renderer,
    scene_generation: Option<u64>,
    keep_geometry: bool,
    /// Shaders it still has to be rebuilt from (a reload reaches the full-quality renderer when it
    /// is next needed, after the preview has shown the new shaders).
    stale: Option<ShaderLibrary>,
    /// The shader variant whose pipelines have run (been compiled by the driver) since the last
    /// (re)build.
    warm: Option<Variant>,
    /// The size and the time (ms, with read-back and upload) of its last frame that took
    /// everything before Integrate from the frame before (a medium edit).
    edit_ms: Option<((u32, u32), f64)>,
}

impl Lane {
    fn new(gpu: &GpuContext, lib: &ShaderLibrary) -> Result<Lane, crate::gpu::GpuError> {
        Ok(Lane {
            renderer: Renderer::new(gpu.clone(), lib)?,
            scene_generation: None,
            keep_geometry: false,
            stale: None,
            warm: None,
            edit_ms: None,
        })
    }

    /// Brings the renderer up to date: pending shaders, the scene's geometry, the geometry grid.
    fn prepare(&mut self, scene: &Scene, generation: u64, keep_geometry: bool) -> Result<(), String> {
        if let Some(lib) = self.stale.take() {
            self.renderer.reload(&lib).map_err(|e| e.to_string())?;
            self.warm = None;
        }
        if self.scene_generation != Some(generation) {
            self.renderer.set_scene(scene);
            self.scene_generation = Some(generation);
        }
        if keep_geometry != self.keep_geometry {
            self.renderer.set_keep_geometry_grid(keep_geometry);
            self.keep_geometry = keep_geometry;
        }
        Ok(())
    }
}

/// Whether a frame of `r` at `quality` keeps the grids for the inspector (full frames of a grid
/// method while the inspector is shown, grids within its limit).
fn keeps_grids(r: &FrameRequest, quality: Quality) -> bool {
    quality.is_full() && r.grids && !matches!(r.method, Method::Raymarch { .. }) && r.look.grid.bytes() <= INSPECT_LIMIT
}

/// Writes what `r` asks for into the worker's copy of its scene: the look, `grid` (the look's or a
/// preview's), no medium for the surfaces alone.
fn write_request(scene: &mut Scene, r: &FrameRequest, grid: crate::params::Grid) {
    r.look.apply_to(scene);
    scene.grid = grid;
    if r.surface_only {
        scene.medium.density = 0.0;
    }
}

/// The worker: two renderers on its device, one for previews (its sizes and a smaller shadow
/// map stay allocated between previews) and one for full frames (created on first use).
struct Worker {
    gpu: GpuContext,
    /// The shaders the renderers run (the embedded ones when the folder did not build at start).
    lib: ShaderLibrary,
    preview: Lane,
    full: Option<Lane>,
    window: Window,
    opts: WorkerOptions,
    times: FrameTimes,
    /// The last generation delivered, and whether at full quality.
    delivered: Option<(u64, bool)>,
    /// The scene with the current look written in, per scene generation.
    scene: Option<(u64, Scene)>,
    /// The scene's BVH for the inspector's surface depths, per scene generation.
    tracer: Option<(u64, Arc<crate::reference::Tracer>)>,
}

impl Worker {
    fn open(window: Window, lib: &ShaderLibrary, opts: WorkerOptions, send: &dyn Fn(RenderEvent)) -> Option<Worker> {
        lower_priority(opts.priority);
        let (gpu, shared_queue) = if opts.shared_device {
            (window.gpu.clone(), true)
        } else {
            match GpuContext::headless() {
                Ok(g) => (g, false),
                Err(e) => {
                    log::warn!("no second GPU device ({e}); rendering on the window's");
                    (window.gpu.clone(), true)
                }
            }
        };
        let (preview, lib, startup_error) = match Lane::new(&gpu, lib) {
            Ok(l) => (l, lib.clone(), None),
            // Broken shaders on disk at start-up: run on the embedded copies and say why, so the
            // editor opens and picks the folder up again once the file is fixed.
            Err(e) if lib.dir().is_some() => match Lane::new(&gpu, &ShaderLibrary::embedded()) {
                Ok(l) => (l, ShaderLibrary::embedded(), Some(e.to_string())),
                Err(e) => {
                    send(RenderEvent::Started(Err(e.to_string())));
                    return None;
                }
            },
            Err(e) => {
                send(RenderEvent::Started(Err(e.to_string())));
                return None;
            }
        };
        let l = gpu.device.limits();
        let software = gpu.info.device_type == wgpu::DeviceType::Cpu;
        send(RenderEvent::Started(Ok(DeviceInfo {
            adapter: gpu.adapter_name(),
            software,
            timestamps: gpu.timestamps,
            limits: GridLimits { buffer_bytes: crate::gpu::max_binding(&l), texture_side: l.max_texture_dimension_2d },
            shared_queue,
            startup_error,
        })));
        Some(Worker {
            gpu,
            lib,
            preview,
            full: None,
            window,
            opts,
            times: FrameTimes::new(software),
            delivered: None,
            scene: None,
            tracer: None,
        })
    }

    fn next(shared: &Shared) -> Option<Job> {
        let mut s = shared.slot.lock().ok()?;
        loop {
            if s.quit {
                return None;
            }
            if let Some(t) = s.tasks.pop_front() {
                shared.busy.store(true, Ordering::SeqCst);
                return Some(Job::Task(t));
            }
            if let Some(r) = s.frame.take() {
                shared.busy.store(true, Ordering::SeqCst);
                return Some(Job::Frame(r));
            }
            s = shared.wake.wait(s).ok()?;
        }
    }

    fn run(&mut self, shared: &Shared, send: &dyn Fn(RenderEvent)) {
        while let Some(job) = Self::next(shared) {
            match job {
                Job::Task(Task::Reload(lib)) => send(RenderEvent::Reloaded(self.reload(&lib))),
                Job::Task(Task::Capture { id, scene, scene_generation, width, height, method }) => {
                    let out = self.full_lane().and_then(|lane| {
                        lane.prepare(&scene, scene_generation, false)?;
                        lane.renderer.render(&scene, width, height, method).map_err(|e| e.to_string())
                    });
                    send(RenderEvent::Captured(id, out.map(|o| (o.scatter, o.hdr))));
                }
                Job::Frame(r) => {
                    if let Some(again) = self.frame(&r, send) {
                        // Refine: unless a newer request arrived meanwhile, this one comes back
                        // for its full frame.
                        if let Ok(mut s) = shared.slot.lock() {
                            s.frame.get_or_insert(again);
                        }
                    }
                }
            }
            shared.busy.store(false, Ordering::SeqCst);
        }
    }

    /// The full-quality renderer, created on first use.
    fn full_lane(&mut self) -> Result<&mut Lane, String> {
        if self.full.is_none() {
            self.full = Some(Lane::new(&self.gpu, &self.lib).map_err(|e| e.to_string())?);
        }
        self.full.as_mut().ok_or_else(|| "no renderer".to_string())
    }

    /// Compiles the changed shaders for the display and the preview renderer now (the new picture
    /// comes from them first); the full-quality renderer follows before its next frame.
    fn reload(&mut self, lib: &ShaderLibrary) -> Result<(DisplayPipeline, f64), String> {
        let t0 = Instant::now();
        // Built before anything is swapped, so a broken display.wgsl leaves all as it was.
        let display = DisplayPipeline::new(&self.window.gpu, lib, &self.window.layout, self.window.format)
            .map_err(|e| e.to_string())?;
        self.preview.renderer.reload(lib).map_err(|e| e.to_string())?;
        self.preview.warm = None;
        if let Some(full) = &mut self.full {
            full.stale = Some(lib.clone());
        }
        self.lib = lib.clone();
        // The new shaders may draw differently: the next request renders even if already drawn.
        self.delivered = None;
        Ok((display, t0.elapsed().as_secs_f64() * 1e3))
    }

    /// Renders what `r` still needs; returns it when a full frame should follow its preview.
    fn frame(&mut self, r: &FrameRequest, send: &dyn Fn(RenderEvent)) -> Option<FrameRequest> {
        let done = self.delivered.filter(|(g, _)| *g == r.generation).map(|(_, full)| full);
        if done == Some(true) || (done == Some(false) && r.interactive) {
            return None;
        }
        let units = work_units(r.width, r.height, r.look.grid, r.method);
        if done.is_none()
            && r.progressive
            && self.times.wants_preview(r.method, r.interactive, units, PREVIEW_BUDGET_MS)
            && !self.full_frame_is_an_edit(r)
        {
            let s =
                self.times.preview_scale(r.width, r.height, r.look.grid, r.method, r.interactive, PREVIEW_BUDGET_MS);
            let delivered = self.render(r, Quality::Preview(s), send);
            return (delivered && !r.interactive).then(|| r.clone());
        }
        self.render(r, Quality::Full, send);
        None
    }

    /// Whether the full-quality renderer would render `r` by taking everything before Integrate
    /// from its last frame (only the medium or the light's power changed since) and its last such
    /// frame at this size took less than the preview budget allows: then the full frame comes at
    /// once, also while a medium slider is dragged, instead of a coarser preview.
    fn full_frame_is_an_edit(&mut self, r: &FrameRequest) -> bool {
        let (Some(full), Some((generation, scene))) = (&self.full, self.scene.as_mut()) else { return false };
        let fits = full.edit_ms.is_some_and(|(size, ms)| size == (r.width, r.height) && ms <= PREVIEW_BUDGET_MS * 1.5);
        // What Lane::prepare and set_shadow_map_size would change first.
        let same_lane = full.stale.is_none()
            && full.scene_generation == Some(r.scene_generation)
            && full.keep_geometry == keeps_grids(r, Quality::Full)
            && full.renderer.shadow_map_size() == r.shadow_map
            && full.renderer.surface_shadows == r.surface_shadows
            && full.renderer.shadow_volume == r.shadow_volume;
        if !fits || !same_lane || *generation != r.scene_generation {
            return false;
        }
        write_request(scene, r, r.look.grid);
        full.renderer.would_reuse(scene, r.width, r.height, r.method)
    }

    /// Renders `r` at `quality` and delivers it; false when it failed.
    fn render(&mut self, r: &FrameRequest, quality: Quality, send: &dyn Fn(RenderEvent)) -> bool {
        let t0 = Instant::now();
        if let Some(d) = self.opts.frame_delay {
            std::thread::sleep(d);
        }
        let fail = |this: &mut Worker, error: String| {
            // Not retried at full quality: the same look fails the same way.
            this.delivered = Some((r.generation, true));
            send(RenderEvent::Frame(Err(FrameFailure { generation: r.generation, error })));
            false
        };
        // The scene with this look, kept between frames (no clone per edit).
        if self.scene.as_ref().is_none_or(|(g, _)| *g != r.scene_generation) {
            self.scene = Some((r.scene_generation, (*r.scene).clone()));
        }
        let (width, height, grid) = match quality {
            Quality::Full => (r.width, r.height, r.look.grid),
            Quality::Preview(s) => scaled(r.width, r.height, r.look.grid, s),
        };
        let keep = keeps_grids(r, quality);
        if quality.is_full() {
            if let Err(e) = self.full_lane() {
                return fail(self, e);
            }
        }
        let (shadow_map, lane) = match (quality, self.full.as_mut()) {
            (Quality::Full, Some(l)) => (r.shadow_map, l),
            (Quality::Full, None) => return fail(self, "no renderer".into()),
            (Quality::Preview(_), _) => (r.shadow_map.min(PREVIEW_SHADOW_MAP), &mut self.preview),
        };
        let Some((_, scene)) = self.scene.as_mut() else { return false };
        write_request(scene, r, grid);
        let scene = &*scene;
        if let Err(e) = lane.prepare(scene, r.scene_generation, keep) {
            return fail(self, e);
        }
        if let Err(e) = lane.renderer.set_shadow_map_size(shadow_map) {
            return fail(self, e.to_string());
        }
        lane.renderer.surface_shadows = r.surface_shadows;
        lane.renderer.shadow_volume = r.shadow_volume;
        lane.renderer.adaptive_pixels = r.adaptive_pixels;
        let out = match lane.renderer.render(scene, width, height, r.method) {
            Ok(o) => o,
            Err(e) => return fail(self, e.to_string()),
        };
        let render_ms = t0.elapsed().as_secs_f64() * 1e3;
        let info = out.info();
        let renderer = &lane.renderer;
        let prune = renderer.prune_report(&info).ok();
        // A frame that reused the last one's volume has the grids the window already holds.
        let fresh_grids = keep && !info.reused.iter().any(|p| p.makes_volume());
        let grids = fresh_grids.then(|| renderer.read_grid().ok()).flatten().map(|shadow| {
            let geometry = renderer.read_geometry_grid().ok().filter(|g| g.len() as u64 == grid.bytes() / 4);
            let tracer = match &self.tracer {
                Some((g, t)) if *g == r.scene_generation => t.clone(),
                _ => Arc::new(crate::reference::Tracer::new(scene)),
            };
            self.tracer = Some((r.scene_generation, tracer.clone()));
            let mut s = GridSnapshot::new(r.generation, grid, info.setup, r.look.camera, shadow, geometry);
            s.tracer = Some(tracer);
            Arc::new(s)
        });
        let stats = ImageStats::of(&out.hdr, &out.scatter);
        let display = Arc::new(DisplayImages::upload(&self.window.gpu, &self.window.layout, &out.hdr, &out.scatter));
        let total_ms = t0.elapsed().as_secs_f64() * 1e3;
        // A frame that ran a pipeline for the first time also paid the driver's compilation
        // (seconds on llvmpipe): it says nothing about the next frame's time.
        let warm = lane.warm == Some(info.variant);
        lane.warm = Some(info.variant);
        if info.reused_all_before_volume() {
            lane.edit_ms = Some(((width, height), total_ms));
        }
        // Nor does one that took the shadow map, the surfaces and the volume from the frame before.
        if warm && !info.reused_all_before_volume() {
            self.times.record(r.method, r.interactive, work_units(width, height, grid, r.method), total_ms);
        }
        self.delivered = Some((r.generation, quality.is_full()));
        send(RenderEvent::Frame(Ok(Arc::new(Picture {
            generation: r.generation,
            quality,
            width,
            height,
            grid,
            method: r.method,
            look: r.look,
            camera: r.look.camera,
            info,
            prune,
            render_ms,
            total_ms,
            stats,
            hdr: out.hdr,
            scatter: out.scatter,
            display,
            grids,
        }))));
        true
    }
}

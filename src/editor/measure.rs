//! Measuring the editor, not editing: the UI frame time shown in Stats, the scripted run of
//! `--quit-after-frames` (render full frames back to back, screenshot, quit, print a summary), and
//! a trace of every UI frame and delivered picture for `scripts/measure_editor.py`
//! (`EPIVOX_EDITOR_TRACE=FILE`, JSON lines).

use super::jobs::render::{Picture, Quality};
use super::RunSummary;
use eframe::egui;
use std::io::Write;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// `--quit-after-frames`: render full frames back to back, then screenshot, then close.
pub struct QuitPlan {
    pub frames_left: u32,
    pub screenshot: Option<PathBuf>,
    screenshot_requested: bool,
    /// Filled by the integration's screenshot callback.
    shot: Arc<Mutex<Option<Arc<egui::ColorImage>>>>,
    closing: bool,
}

/// Seconds since the Unix epoch (the trace's clock, shared with the measuring script).
fn now_unix() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map(|d| d.as_secs_f64()).unwrap_or(0.0)
}

/// One UI frame, as the trace records it.
#[derive(serde::Serialize)]
pub struct FrameLine {
    pub t: f64,
    /// Time spent in `Editor::ui` (ms).
    pub ui_ms: f64,
    /// Since the previous UI frame began (ms).
    pub gap_ms: f64,
    pub interactive: bool,
    pub latest: u64,
    pub shown: Option<u64>,
    pub shown_full: bool,
    pub in_flight: bool,
    pub epoch: u64,
    pub compiling: bool,
    pub shader_error: bool,
    pub viewport_px: [u32; 4],
}

#[derive(Default)]
pub struct Meter {
    /// Smoothed time between UI frames (ms).
    pub ui_frame_ms: f64,
    last_ui: Option<Instant>,
    frame_start: Option<Instant>,
    gap_ms: f64,
    pub quit: Option<QuitPlan>,
    full_ms: Vec<f64>,
    render_ms: Vec<f64>,
    gpu_ms: Vec<f64>,
    last_full: Option<Instant>,
    pub summary: Option<Arc<Mutex<RunSummary>>>,
    trace: Option<std::io::BufWriter<std::fs::File>>,
}

impl Meter {
    pub fn new(quit_after_frames: Option<u32>, screenshot: Option<PathBuf>) -> Meter {
        let trace = std::env::var_os("EPIVOX_EDITOR_TRACE").and_then(|p| match std::fs::File::create(&p) {
            Ok(f) => Some(std::io::BufWriter::new(f)),
            Err(e) => {
                log::warn!("EPIVOX_EDITOR_TRACE={}: {e}", PathBuf::from(&p).display());
                None
            }
        });
        Meter {
            quit: quit_after_frames.map(|n| QuitPlan {
                frames_left: n.max(1),
                screenshot,
                screenshot_requested: false,
                shot: Arc::default(),
                closing: false,
            }),
            trace,
            ..Meter::default()
        }
    }

    /// Measuring full frames back to back (previews off, a new frame after each one).
    pub fn forcing_frames(&self) -> bool {
        self.quit.as_ref().is_some_and(|q| q.frames_left > 0)
    }

    pub fn begin_frame(&mut self) {
        let now = Instant::now();
        if let Some(t) = self.last_ui {
            self.gap_ms = (now - t).as_secs_f64() * 1e3;
            self.ui_frame_ms =
                if self.ui_frame_ms == 0.0 { self.gap_ms } else { self.ui_frame_ms * 0.9 + self.gap_ms * 0.1 };
        }
        self.last_ui = Some(now);
        self.frame_start = Some(now);
    }

    /// A picture arrived.
    pub fn picture(&mut self, p: &Picture) {
        if let Some(t) = &mut self.trace {
            let line = serde_json::json!({
                "t": now_unix(),
                "picture": p.generation,
                "full": p.quality.is_full(),
                "scale": match p.quality { Quality::Full => 1.0, Quality::Preview(s) => s },
                "size": [p.width, p.height],
                "grid": p.grid.to_string(),
                "render_ms": p.render_ms,
                "total_ms": p.total_ms,
                "passes_ms": p.info.timings.iter().map(|t| (t.pass.to_string(), t.ms)).collect::<std::collections::BTreeMap<_, _>>(),
            });
            let _ = writeln!(t, "{line}");
        }
        if !p.quality.is_full() {
            return;
        }
        let now = Instant::now();
        if let Some(t) = self.last_full {
            self.full_ms.push((now - t).as_secs_f64() * 1e3);
        }
        self.last_full = Some(now);
        self.render_ms.push(p.render_ms);
        self.gpu_ms.push(p.info.timings.iter().map(|t| t.ms).sum());
        if let Some(q) = &mut self.quit {
            q.frames_left = q.frames_left.saturating_sub(1);
        }
    }

    /// Any other event worth a line in the trace.
    pub fn event(&mut self, name: &str, value: serde_json::Value) {
        if let Some(t) = &mut self.trace {
            let _ = writeln!(t, "{}", serde_json::json!({ "t": now_unix(), name: value }));
        }
    }

    pub fn end_frame(&mut self, line: impl FnOnce(f64, f64) -> FrameLine) {
        let ui_ms = self.frame_start.map(|t| t.elapsed().as_secs_f64() * 1e3).unwrap_or(0.0);
        if let Some(t) = &mut self.trace {
            if let Ok(text) = serde_json::to_string(&line(ui_ms, self.gap_ms)) {
                let _ = writeln!(t, "{text}");
                let _ = t.flush();
            }
        }
    }

    /// After the measured frames: request the window's screenshot, save it, and return true once
    /// the window should close (errors go to `errors`).
    pub fn quit_step(&mut self, ctx: &egui::Context, errors: &mut Vec<String>) -> bool {
        let Some(q) = &mut self.quit else { return false };
        if q.frames_left > 0 || q.closing {
            return false;
        }
        if let Some(path) = q.screenshot.clone() {
            if !q.screenshot_requested {
                q.screenshot_requested = true;
                let (slot, c) = (q.shot.clone(), ctx.clone());
                ctx.request_screenshot(move |image| {
                    if let Ok(mut s) = slot.lock() {
                        *s = Some(image);
                    }
                    c.request_repaint();
                });
                ctx.request_repaint();
                return false;
            }
            let Some(image) = q.shot.lock().ok().and_then(|mut s| s.take()) else {
                ctx.request_repaint();
                return false;
            };
            let [w, h] = image.size;
            let rgba: Vec<u8> = image.pixels.iter().flat_map(|c| c.to_array()).collect();
            match ::image::RgbaImage::from_raw(w as u32, h as u32, rgba).map(|img| img.save(&path)) {
                Some(Ok(())) => {}
                Some(Err(e)) => errors.push(format!("{}: {e}", path.display())),
                None => errors.push("screenshot has the wrong size".into()),
            }
        }
        q.closing = true;
        true
    }

    /// Fills the summary `run` prints.
    pub fn write_summary(&self, mut s: RunSummary) {
        let Some(sink) = &self.summary else { return };
        let mean = |v: &[f64]| {
            // The first frames include start-up (pipeline creation, first upload).
            let v = if v.len() > 4 { &v[2..] } else { v };
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        s.frames = self.render_ms.len() as u32;
        s.frame_ms_mean = mean(&self.full_ms);
        s.render_ms_mean = mean(&self.render_ms);
        s.gpu_ms_mean = mean(&self.gpu_ms);
        s.screenshot = self.quit.as_ref().and_then(|q| q.screenshot.clone());
        if let Ok(mut out) = sink.lock() {
            *out = s;
        }
    }
}

//! The accuracy check: the exact CPU reference of the current view at a reduced size, rendered row
//! by row on a background thread (progress and cancel between rows), then compared with the GPU
//! image of the same view and size.

use crate::image::Image;
use crate::metrics::{self, ErrorStats};
use crate::reference::{Reference, ReferenceOptions, Tracer};
use crate::scene::Scene;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Instant;

/// The reference's settings for the check: fewer visibility samples and a looser quadrature
/// tolerance than `epivox render --method reference`, so that a preview takes seconds; both are
/// still far below the grid's own error (percent level).
pub fn check_options() -> ReferenceOptions {
    ReferenceOptions { samples: 128, tolerance: 1e-4, progress: false, ..Default::default() }
}

/// The reference images.
pub struct ReferenceResult {
    pub scatter: Image,
    pub hdr: Image,
    pub seconds: f64,
}

/// A running reference render.
pub struct AccuracyJob {
    pub width: u32,
    pub height: u32,
    /// GPU images of the same view, taken when the job started.
    pub gpu_scatter: Image,
    pub gpu_hdr: Image,
    /// The look the job measures (the result is stale once the look differs).
    pub scene: Arc<Scene>,
    pub method_label: String,
    cancel: Arc<AtomicBool>,
    rows_done: Arc<AtomicU32>,
    rx: mpsc::Receiver<Option<ReferenceResult>>,
}

/// A finished check.
pub struct AccuracyResult {
    pub width: u32,
    pub height: u32,
    pub scatter: Result<ErrorStats, String>,
    pub hdr: Result<ErrorStats, String>,
    /// Signed difference GPU - reference of the scattered light, as sRGB8 RGBA (red: GPU brighter,
    /// blue: darker), scaled so that `diff_scale` is full colour.
    pub diff_rgba: Vec<u8>,
    pub diff_scale: f64,
    pub seconds: f64,
    pub scene: Arc<Scene>,
    pub method_label: String,
}

impl AccuracyJob {
    /// Starts the reference for `scene` at `width x height` on a thread; `wake` is called on every
    /// finished row (to repaint the progress bar) and at the end.
    pub fn start(
        scene: Arc<Scene>,
        width: u32,
        height: u32,
        gpu_scatter: Image,
        gpu_hdr: Image,
        method_label: String,
        wake: impl Fn() + Send + Sync + 'static,
    ) -> AccuracyJob {
        let cancel = Arc::new(AtomicBool::new(false));
        let rows_done = Arc::new(AtomicU32::new(0));
        let (tx, rx) = mpsc::channel();
        let (sc, c2, r2) = (scene.clone(), cancel.clone(), rows_done.clone());
        let spawned = std::thread::Builder::new().name("epivox-accuracy".into()).spawn(move || {
            let t0 = Instant::now();
            let tracer = Tracer::new(&sc);
            let r = Reference::new(&sc, &tracer, check_options());
            let eye = sc.camera.eye.as_dvec3();
            let mut scatter = Image::new(width, height);
            let mut hdr = Image::new(width, height);
            for py in 0..height {
                if c2.load(Ordering::Relaxed) {
                    let _ = tx.send(None);
                    wake();
                    return;
                }
                let row: Vec<_> = (0..width)
                    .into_par_iter()
                    .map(|px| r.shade_ray(eye, sc.camera.pixel_dir_f64(px as f64, py as f64, width, height)))
                    .collect();
                for (px, s) in row.iter().enumerate() {
                    let f = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32];
                    scatter.set(px as u32, py, f(s.scatter));
                    hdr.set(px as u32, py, f(s.hdr));
                }
                r2.fetch_add(1, Ordering::Relaxed);
                wake();
            }
            let _ = tx.send(Some(ReferenceResult { scatter, hdr, seconds: t0.elapsed().as_secs_f64() }));
            wake();
        });
        if spawned.is_err() {
            cancel.store(true, Ordering::Relaxed);
        }
        AccuracyJob { width, height, gpu_scatter, gpu_hdr, scene, method_label, cancel, rows_done, rx }
    }

    /// Fraction done, 0..1.
    pub fn progress(&self) -> f32 {
        self.rows_done.load(Ordering::Relaxed) as f32 / self.height.max(1) as f32
    }

    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    /// `Some(None)` when cancelled, `Some(Some(result))` when done, `None` while running.
    pub fn poll(&self) -> Option<Option<AccuracyResult>> {
        match self.rx.try_recv() {
            Ok(Some(r)) => Some(Some(self.finish(r))),
            Ok(None) => Some(None),
            Err(mpsc::TryRecvError::Empty) => None,
            Err(mpsc::TryRecvError::Disconnected) => Some(None),
        }
    }

    fn finish(&self, r: ReferenceResult) -> AccuracyResult {
        let scatter = metrics::compare(&self.gpu_scatter, &r.scatter).map_err(|e| e.to_string());
        let hdr = metrics::compare(&self.gpu_hdr, &r.hdr).map_err(|e| e.to_string());
        let (diff_rgba, diff_scale) = difference_image(&self.gpu_scatter, &r.scatter);
        AccuracyResult {
            width: self.width,
            height: self.height,
            scatter,
            hdr,
            diff_rgba,
            diff_scale,
            seconds: r.seconds,
            scene: self.scene.clone(),
            method_label: self.method_label.clone(),
        }
    }
}

impl Drop for AccuracyJob {
    fn drop(&mut self) {
        // A replaced or abandoned job stops at its next row.
        self.cancel();
    }
}

/// Signed luminance difference `a - b` as RGBA8: red where `a` is brighter, blue where darker, black
/// where equal; full colour at the largest absolute difference (returned).
pub fn difference_image(a: &Image, b: &Image) -> (Vec<u8>, f64) {
    let lum = |p: &[f32; 3]| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64;
    let d: Vec<f64> = a.pixels.iter().zip(&b.pixels).map(|(x, y)| lum(x) - lum(y)).collect();
    let scale = d.iter().filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
    let mut out = Vec::with_capacity(d.len() * 4);
    for v in d {
        let t = if scale > 0.0 && v.is_finite() { (v / scale).clamp(-1.0, 1.0) } else { 0.0 };
        let c = (t.abs().sqrt() * 255.0) as u8; // sqrt: small differences stay visible
        if !v.is_finite() {
            out.extend_from_slice(&[255, 0, 255, 255]); // magenta: NaN or inf
        } else if t >= 0.0 {
            out.extend_from_slice(&[c, c / 5, 0, 255]);
        } else {
            out.extend_from_slice(&[0, c / 3, c, 255]);
        }
    }
    (out, scale)
}

//! The reference images on disk, keyed by everything they depend on.
//!
//! A reference render takes minutes at 1024², so `epivox bench` renders it once per scene, view,
//! medium and size and keeps the result. The key is a 128-bit FNV-1a hash of the *data* (never of a
//! file name or a modification time): every mesh's vertices and triangles, the camera, the light, the
//! medium, the image size, the reference's options and the reference renderer's own source code, so
//! that editing the reference also invalidates what it rendered before. The grid is not part of it:
//! the reference has none.
//!
//! Files, under the cache folder: `ref-<key>.scatter.exr`, `ref-<key>.hdr.exr` (lossless float
//! OpenEXR) and `ref-<key>.json` (what was rendered, for people).

use super::BenchError;
use crate::image::Image;
use crate::reference::{self, ReferenceOptions};
use crate::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The reference renderer's source: part of the key, so that a change to it re-renders.
const REFERENCE_SOURCE: [&str; 3] = [
    include_str!("../reference/mod.rs"),
    include_str!("../reference/quadrature.rs"),
    include_str!("../reference/tracer.rs"),
];

/// 128-bit FNV-1a: stable across Rust versions and platforms (std's hashers promise neither).
pub struct KeyHasher(u128);

impl Default for KeyHasher {
    fn default() -> Self {
        KeyHasher(0x6c62272e07bb014262b821756295c58d)
    }
}

impl KeyHasher {
    const PRIME: u128 = 0x0000000001000000000000000000013B;

    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u128;
            self.0 = self.0.wrapping_mul(Self::PRIME);
        }
    }
    pub fn u64(&mut self, v: u64) {
        self.bytes(&v.to_le_bytes());
    }
    pub fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
    /// A length-prefixed string, so that ("ab", "c") and ("a", "bc") differ.
    pub fn str(&mut self, s: &str) {
        self.u64(s.len() as u64);
        self.bytes(s.as_bytes());
    }
    pub fn hex(&self) -> String {
        format!("{:032x}", self.0)
    }
}

/// The cache key of the reference of `scene` at `width x height`.
pub fn reference_key(scene: &Scene, width: u32, height: u32, opts: &ReferenceOptions) -> String {
    let mut h = KeyHasher::default();
    h.str("epivox reference v1");
    for src in REFERENCE_SOURCE {
        h.str(src);
    }
    h.u64(scene.meshes.len() as u64);
    for m in &scene.meshes {
        h.u64(m.positions.len() as u64);
        for p in &m.positions {
            h.f32s(&p.to_array());
        }
        h.u64(m.triangles.len() as u64);
        for t in &m.triangles {
            for i in t {
                h.bytes(&i.to_le_bytes());
            }
        }
        h.f32s(&m.albedo.to_array());
    }
    // serde_json writes each f32 as its shortest round-tripping decimal: a faithful, stable text of
    // every field (and of fields added later).
    let json = |v: serde_json::Result<String>| v.unwrap_or_else(|e| format!("unserialisable: {e}"));
    h.str(&json(serde_json::to_string(&scene.camera)));
    h.str(&json(serde_json::to_string(&scene.light)));
    h.str(&json(serde_json::to_string(&scene.medium)));
    // Derived data the reference uses, computed by code outside it that may change.
    let mb = scene.medium_bounds();
    h.f32s(&mb.min.to_array());
    h.f32s(&mb.max.to_array());
    h.u64(width as u64);
    h.u64(height as u64);
    h.u64(opts.samples as u64);
    h.u64(opts.tolerance.to_bits());
    h.u64(opts.bisection.to_bits());
    h.u64(opts.max_splits as u64);
    h.hex()
}

/// Whether [`cached_reference`] found the images or rendered them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CacheStatus {
    /// Read from the cache.
    Hit,
    /// Rendered now (taking this many seconds) and stored.
    Rendered { seconds: f64 },
}

/// A reference image pair and where it came from.
#[derive(Debug, Clone)]
pub struct CachedReference {
    pub key: String,
    pub scatter: Image,
    pub hdr: Image,
    pub status: CacheStatus,
    pub path: PathBuf,
}

/// The reference of `scene` from `dir`, rendering and storing it when it is not there yet.
pub fn cached_reference(
    scene: &Scene,
    width: u32,
    height: u32,
    opts: &ReferenceOptions,
    dir: &Path,
) -> Result<CachedReference, BenchError> {
    let key = reference_key(scene, width, height, opts);
    let scatter_path = dir.join(format!("ref-{key}.scatter.exr"));
    let hdr_path = dir.join(format!("ref-{key}.hdr.exr"));
    if scatter_path.is_file() && hdr_path.is_file() {
        // A damaged or foreign file is not an error: render again over it.
        if let (Ok(scatter), Ok(hdr)) = (Image::read_exr(&scatter_path), Image::read_exr(&hdr_path)) {
            if (scatter.width, scatter.height, hdr.width, hdr.height) == (width, height, width, height) {
                return Ok(CachedReference { key, scatter, hdr, status: CacheStatus::Hit, path: scatter_path });
            }
        }
    }
    std::fs::create_dir_all(dir).map_err(|source| BenchError::Io { op: "create", path: dir.to_path_buf(), source })?;
    let started = Instant::now();
    let r = reference::render(scene, width, height, opts);
    let seconds = started.elapsed().as_secs_f64();
    r.scatter.write_exr(&scatter_path)?;
    r.hdr.write_exr(&hdr_path)?;
    let meta = serde_json::json!({
        "scene": scene.name,
        "source": scene.source.as_ref().map(|p| p.display().to_string()),
        "width": width,
        "height": height,
        "triangles": scene.triangle_count(),
        "camera": scene.camera,
        "light": scene.light,
        "medium": scene.medium,
        "samples": opts.samples,
        "tolerance": opts.tolerance,
        "seconds": seconds,
        "unconverged_pixels": r.stats.unconverged,
    });
    let meta_path = dir.join(format!("ref-{key}.json"));
    let text = serde_json::to_string_pretty(&meta).unwrap_or_default();
    std::fs::write(&meta_path, text).map_err(|source| BenchError::Io { op: "write", path: meta_path, source })?;
    Ok(CachedReference {
        key,
        scatter: r.scatter,
        hdr: r.hdr,
        status: CacheStatus::Rendered { seconds },
        path: scatter_path,
    })
}

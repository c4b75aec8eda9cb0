//! WGSL sources: read from a shader folder on disk when there is one (so edits take effect without a
//! rebuild), with the copies embedded in the binary as the fallback, so `epivox` runs from anywhere.
//!
//! A line `#import name` pulls in `shaders/name.wgsl` (once per module). Every composed module is
//! validated with naga before wgpu sees it, so an error names the file, line and column.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// The shaders shipped in the binary, by file name.
pub const EMBEDDED: &[(&str, &str)] = &[
    ("common.wgsl", include_str!("../../shaders/common.wgsl")),
    ("surface.wgsl", include_str!("../../shaders/surface.wgsl")),
    ("surface_cull.wgsl", include_str!("../../shaders/surface_cull.wgsl")),
    ("shadow_map.wgsl", include_str!("../../shaders/shadow_map.wgsl")),
    ("shadow_cull.wgsl", include_str!("../../shaders/shadow_cull.wgsl")),
    ("shadow_pyramid.wgsl", include_str!("../../shaders/shadow_pyramid.wgsl")),
    ("voxelize.wgsl", include_str!("../../shaders/voxelize.wgsl")),
    ("scan.wgsl", include_str!("../../shaders/scan.wgsl")),
    ("scan_words.wgsl", include_str!("../../shaders/scan_words.wgsl")),
    ("scan_columns.wgsl", include_str!("../../shaders/scan_columns.wgsl")),
    ("hit_bounds.wgsl", include_str!("../../shaders/hit_bounds.wgsl")),
    ("scatter_table.wgsl", include_str!("../../shaders/scatter_table.wgsl")),
    ("integrate.wgsl", include_str!("../../shaders/integrate.wgsl")),
    ("composite.wgsl", include_str!("../../shaders/composite.wgsl")),
    ("exact_shadows.wgsl", include_str!("../../shaders/exact_shadows.wgsl")),
    ("display.wgsl", include_str!("../../shaders/display.wgsl")),
    ("ranges.wgsl", include_str!("../../shaders/ranges.wgsl")),
    ("shadow_fit.wgsl", include_str!("../../shaders/shadow_fit.wgsl")),
    ("cull.wgsl", include_str!("../../shaders/cull.wgsl")),
    ("triangle_bounds.wgsl", include_str!("../../shaders/triangle_bounds.wgsl")),
    ("plane_segment.wgsl", include_str!("../../shaders/plane_segment.wgsl")),
    ("shadow_lookup.wgsl", include_str!("../../shaders/shadow_lookup.wgsl")),
    ("hidden.wgsl", include_str!("../../shaders/hidden.wgsl")),
    ("workgroup_scan.wgsl", include_str!("../../shaders/workgroup_scan.wgsl")),
    ("raymarch.wgsl", include_str!("../../shaders/raymarch.wgsl")),
];

/// The files that only declare things for others to `#import` (validated through their users).
pub const IMPORTED_ONLY: &[&str] = &[
    "common.wgsl",
    "triangle_bounds.wgsl",
    "plane_segment.wgsl",
    "shadow_lookup.wgsl",
    "hidden.wgsl",
    "workgroup_scan.wgsl",
];

/// A shader that failed to load, compose or validate.
#[derive(Debug, Clone, thiserror::Error)]
pub enum ShaderError {
    #[error("shader '{0}' does not exist (neither on disk nor embedded)")]
    Missing(String),
    #[error("{file}: cannot read: {message}")]
    Io { file: String, message: String },
    #[error("{file}:{line}:{column}: {message}")]
    Invalid { file: String, line: u32, column: u32, message: String },
}

/// Where a composed module came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ShaderSource {
    Disk(PathBuf),
    Embedded,
}

/// Loads and composes WGSL.
#[derive(Debug, Clone)]
pub struct ShaderLibrary {
    dir: Option<PathBuf>,
}

impl Default for ShaderLibrary {
    fn default() -> Self {
        Self::new(None)
    }
}

impl ShaderLibrary {
    /// Uses `dir` when given; otherwise `$EPIVOX_SHADER_DIR`, then `./shaders` and the crate's own
    /// `shaders/` folder when they exist; otherwise only the embedded copies.
    pub fn new(dir: Option<PathBuf>) -> ShaderLibrary {
        let dir = dir.or_else(|| std::env::var_os("EPIVOX_SHADER_DIR").map(PathBuf::from)).or_else(|| {
            [PathBuf::from("shaders"), Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders")]
                .into_iter()
                .find(|d| d.join("common.wgsl").is_file())
        });
        ShaderLibrary { dir }
    }

    /// Only the embedded copies.
    pub fn embedded() -> ShaderLibrary {
        ShaderLibrary { dir: None }
    }

    pub fn dir(&self) -> Option<&Path> {
        self.dir.as_deref()
    }

    /// The text of one file (disk first, then embedded).
    pub fn file(&self, name: &str) -> Result<(String, ShaderSource), ShaderError> {
        if let Some(dir) = &self.dir {
            let p = dir.join(name);
            if p.is_file() {
                return std::fs::read_to_string(&p)
                    .map(|s| (s, ShaderSource::Disk(p.clone())))
                    .map_err(|e| ShaderError::Io { file: p.display().to_string(), message: e.to_string() });
            }
        }
        EMBEDDED
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, s)| (s.to_string(), ShaderSource::Embedded))
            .ok_or_else(|| ShaderError::Missing(name.to_string()))
    }

    /// Composes `name` with its imports, returning the source and, for error messages, which file
    /// each output line came from.
    pub fn compose(&self, name: &str) -> Result<(String, Vec<(String, u32)>), ShaderError> {
        let mut out = String::new();
        let mut lines = Vec::new();
        let mut seen = HashSet::new();
        self.compose_into(name, &mut out, &mut lines, &mut seen)?;
        Ok((out, lines))
    }

    fn compose_into(
        &self,
        name: &str,
        out: &mut String,
        lines: &mut Vec<(String, u32)>,
        seen: &mut HashSet<String>,
    ) -> Result<(), ShaderError> {
        if !seen.insert(name.to_string()) {
            return Ok(());
        }
        let (text, _) = self.file(name)?;
        for (i, line) in text.lines().enumerate() {
            if let Some(rest) = line.trim_start().strip_prefix("#import ") {
                let dep = format!("{}.wgsl", rest.trim());
                self.compose_into(&dep, out, lines, seen)?;
            } else {
                out.push_str(line);
                out.push('\n');
                lines.push((name.to_string(), i as u32 + 1));
            }
        }
        Ok(())
    }

    /// Composes and validates `name`, returning naga's module for reflection and the source.
    pub fn validate(&self, name: &str) -> Result<(naga::Module, String), ShaderError> {
        let (src, lines) = self.compose(name)?;
        let locate = |offset: usize| -> (String, u32, u32) {
            let line_idx = src[..offset.min(src.len())].matches('\n').count();
            let col = offset - src[..offset.min(src.len())].rfind('\n').map(|p| p + 1).unwrap_or(0) + 1;
            let (file, line) = lines.get(line_idx).cloned().unwrap_or((name.to_string(), line_idx as u32 + 1));
            (file, line, col as u32)
        };
        let module = naga::front::wgsl::parse_str(&src).map_err(|e| {
            let (file, line, column) = e
                .labels()
                .next()
                .map(|(s, _)| locate(s.to_range().map(|r| r.start).unwrap_or(0)))
                .unwrap_or((name.to_string(), 0, 0));
            ShaderError::Invalid { file, line, column, message: e.message().to_string() }
        })?;
        let mut v = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all());
        v.validate(&module).map_err(|e| {
            let (file, line, column) = e
                .spans()
                .next()
                .and_then(|(s, _)| s.to_range())
                .map(|r| locate(r.start))
                .unwrap_or((name.to_string(), 0, 0));
            ShaderError::Invalid { file, line, column, message: format!("{}", e.as_inner()) }
        })?;
        Ok((module, src))
    }

    /// Validates and creates the wgpu module, with wgpu's run-time checks but its loop bounding
    /// ([`RUNTIME_CHECKS`]).
    pub fn module(&self, device: &wgpu::Device, name: &str) -> Result<wgpu::ShaderModule, ShaderError> {
        let (_, src) = self.validate(name)?;
        let desc = wgpu::ShaderModuleDescriptor { label: Some(name), source: wgpu::ShaderSource::Wgsl(src.into()) };
        // SAFETY: RUNTIME_CHECKS leaves out only the loop bounding, whose contract is that no
        // shader loops forever. The shaders are the project's own or the user's edits of them
        // (never code from elsewhere), and its counter would not stop a runaway loop either: it
        // breaks after 2^64 iterations.
        Ok(unsafe { device.create_shader_module_trusted(desc, RUNTIME_CHECKS) })
    }
}

/// The run-time checks wgpu puts into every module: all of them (bounds, integer division) but the
/// loop bounding, a 64-bit counter that naga adds to every loop so that a driver may not treat an
/// endless loop as unreachable. On llvmpipe that counter is a few vector instructions in every
/// iteration of every loop; without it the classroom's frame took 1.2% less (Voxelize 3.5%, the
/// million-triangle room's 6%; docs/results.md, session 39); the classroom's images the same to
/// the bit, the room's within 5e-6.
pub const RUNTIME_CHECKS: wgpu::ShaderRuntimeChecks =
    wgpu::ShaderRuntimeChecks { force_loop_bounding: false, ..wgpu::ShaderRuntimeChecks::checked() };

// Only the loop bounding is left out: the checks that keep a shader's reads and writes inside its
// arrays and its divisions defined stay (an edited shader may index past an array).
const _: () = assert!(RUNTIME_CHECKS.bounds_checks && RUNTIME_CHECKS.int_div_checks);

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shipped shader composes and passes naga's validator (no GPU needed).
    #[test]
    fn every_embedded_shader_validates() {
        let lib = ShaderLibrary::embedded();
        for (name, _) in EMBEDDED {
            if IMPORTED_ONLY.contains(name) {
                continue; // a module of declarations, validated through its users
            }
            if let Err(e) = lib.validate(name) {
                panic!("{e}");
            }
        }
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let dir = tempfile::tempdir().unwrap();
        for (name, src) in EMBEDDED {
            std::fs::write(dir.path().join(name), src).unwrap();
        }
        let broken = "#import common\n\nfn f() -> f32 {\n    return undefined_name;\n}\n";
        std::fs::write(dir.path().join("scan.wgsl"), broken).unwrap();
        let lib = ShaderLibrary::new(Some(dir.path().to_path_buf()));
        let err = lib.validate("scan.wgsl").unwrap_err().to_string();
        assert!(err.starts_with("scan.wgsl:4:12"), "{err}");
    }
}

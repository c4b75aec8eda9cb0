//! Scene loaders: glTF 2.0 (`.gltf`/`.glb`), Wavefront OBJ, PLY, Mitsuba 0.6 / Mitsuba 3 scene folders
//! (`scene.xml`), plain folders of meshes, and the project's own `*.scene.toml` files.
//!
//! Every loader produces a [`Loaded`] (meshes in world space plus whatever camera, light and emitters
//! the file had); [`finish`] fills in what is missing from the scene's bounds and validates the result.
//! The rules are written down for users in `docs/scene-format.md`; keep the two in step.

mod gltf_file;
mod mitsuba;
mod obj_file;
mod ply_file;
pub(super) mod primitives;
mod scene_file;

use super::{Aabb, Camera, Mesh, Scene};
use crate::params::{unit_direction, Grid, Light, Medium, ParamError, Phase};
use glam::{Mat4, Vec3};
use std::path::{Path, PathBuf};

/// Why a scene could not be loaded. Every message starts with the file it is about.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The path does not exist.
    #[error("{}: no such file or directory", .path.display())]
    NotFound { path: PathBuf },
    /// The path, or a folder or link on the way to it, is a loop of symbolic links.
    #[error("{}: a loop of symbolic links", .path.display())]
    SymlinkLoop { path: PathBuf },
    /// The file exists but could not be read.
    #[error("{}: cannot read: {source}", .path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The extension names no format this crate reads.
    #[error(
        "{}: unsupported extension '{ext}' (expected .gltf .glb .obj .ply .toml .xml or a folder)",
        .path.display()
    )]
    UnsupportedExtension { path: PathBuf, ext: String },
    /// The file is not well-formed in its format (syntax, structure, unknown fields).
    #[error("{}: not a valid {format} file: {message}", .path.display())]
    Parse { path: PathBuf, format: &'static str, message: String },
    /// Well-formed, but asks for something this loader does not do (e.g. `format = 7`).
    #[error("{}: {message}", .path.display())]
    Unsupported { path: PathBuf, message: String },
    /// The loaded scene cannot be rendered (no triangles, non-finite vertices, degenerate camera,
    /// parameters out of range).
    #[error("{}: {source}", .path.display())]
    Invalid {
        path: PathBuf,
        #[source]
        source: ParamError,
    },
    /// A file referenced by a scene file (a mesh of a `.scene.toml`, a shape of a `scene.xml`) failed.
    #[error("{}: {context}: {source}", .path.display())]
    Referenced {
        path: PathBuf,
        context: String,
        #[source]
        source: Box<SceneError>,
    },
}

impl SceneError {
    /// The file the error is about (the outermost one for [`SceneError::Referenced`]).
    pub fn path(&self) -> &Path {
        match self {
            SceneError::NotFound { path }
            | SceneError::SymlinkLoop { path }
            | SceneError::Io { path, .. }
            | SceneError::UnsupportedExtension { path, .. }
            | SceneError::Parse { path, .. }
            | SceneError::Unsupported { path, .. }
            | SceneError::Invalid { path, .. }
            | SceneError::Referenced { path, .. } => path,
        }
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> SceneError {
        if source.kind() == std::io::ErrorKind::NotFound {
            SceneError::NotFound { path: path.to_path_buf() }
        } else if is_symlink_loop(&source) {
            SceneError::SymlinkLoop { path: path.to_path_buf() }
        } else {
            SceneError::Io { path: path.to_path_buf(), source }
        }
    }

    pub(crate) fn parse(path: &Path, format: &'static str, message: impl std::fmt::Display) -> SceneError {
        SceneError::Parse { path: path.to_path_buf(), format, message: message.to_string() }
    }

    pub(crate) fn unsupported(path: &Path, message: impl Into<String>) -> SceneError {
        SceneError::Unsupported { path: path.to_path_buf(), message: message.into() }
    }

    pub(crate) fn referenced(path: &Path, context: impl Into<String>, source: SceneError) -> SceneError {
        SceneError::Referenced { path: path.to_path_buf(), context: context.into(), source: Box::new(source) }
    }
}

/// `ELOOP`: `io::ErrorKind::FilesystemLoop` is not stable yet.
fn is_symlink_loop(e: &std::io::Error) -> bool {
    #[cfg(any(target_os = "linux", target_os = "android"))]
    const ELOOP: i32 = 40;
    #[cfg(not(any(target_os = "linux", target_os = "android")))]
    const ELOOP: i32 = 62; // macOS and the BSDs
    cfg!(unix) && e.raw_os_error() == Some(ELOOP)
}

/// What loading did besides building the scene, for the command line's summary.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LoadSummary {
    /// Every file read: the scene file (or the folder's files), the meshes it references, MTL
    /// libraries, external glTF buffers. Outputs must never be written over one of these.
    pub files: Vec<PathBuf>,
    /// Zero-area triangles dropped at load ([`Mesh::drop_degenerate`]).
    pub degenerate_triangles: usize,
}

/// Diffuse albedo of surfaces whose file gives no usable colour.
pub(crate) const DEFAULT_ALBEDO: Vec3 = Vec3::splat(0.7);

/// Irradiance (W/m^2) of a directional light whose file gives none (Mitsuba's `sun`/`sunsky`).
pub(crate) const DEFAULT_SUN_IRRADIANCE: f32 = 3.0;

/// Irradiance (W/m^2) the default point light delivers at the centre of the scene.
const DEFAULT_POINT_IRRADIANCE: f32 = 3.0;

/// Intensity of a light made from an emissive surface without a physical radiance:
/// `EMISSIVE_K * diag^2` W/sr, `diag` being the diagonal of the scene's (core) bounds.
const EMISSIVE_K: f32 = 0.5;

/// Default medium: `Medium::default()` (sigma_s 0.1, sigma_a 0.01, HG g = 0.3) with
/// `density = MEDIUM_DENSITY_PER_DIAG / diag`, i.e. sigma_s = 1/diag: an optical thickness of about
/// 1.1 across the scene's diagonal, visible but far from opaque.
const MEDIUM_DENSITY_PER_DIAG: f32 = 10.0;

/// A camera as far as a file specifies it; [`finish`] fills the gaps.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct CameraSpec {
    pub eye: Option<Vec3>,
    pub target: Option<Vec3>,
    /// Viewing direction, when the file gives one instead of a target (glTF, Mitsuba).
    pub dir: Option<Vec3>,
    pub up: Option<Vec3>,
    pub fov_y_deg: Option<f32>,
    pub near: Option<f32>,
    pub far: Option<f32>,
}

impl CameraSpec {
    fn transformed(self, m: Mat4) -> CameraSpec {
        CameraSpec {
            eye: self.eye.map(|p| m.transform_point3(p)),
            target: self.target.map(|p| m.transform_point3(p)),
            dir: self.dir.map(|d| m.transform_vector3(d)),
            up: self.up.map(|d| m.transform_vector3(d)),
            ..self
        }
    }
}

/// A light as far as a file specifies it; [`finish`] fills the gaps.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum LightSpec {
    Point {
        position: Option<Vec3>,
        intensity: Option<Vec3>,
        radius: f32,
    },
    /// `direction` points toward the light.
    Directional {
        direction: Vec3,
        irradiance: Option<Vec3>,
    },
}

impl LightSpec {
    fn transformed(self, m: Mat4) -> LightSpec {
        match self {
            LightSpec::Point { position, intensity, radius } => {
                LightSpec::Point { position: position.map(|p| m.transform_point3(p)), intensity, radius }
            }
            LightSpec::Directional { direction, irradiance } => {
                LightSpec::Directional { direction: m.transform_vector3(direction), irradiance }
            }
        }
    }
}

impl From<Light> for LightSpec {
    fn from(l: Light) -> Self {
        match l {
            Light::Point { position, intensity, radius } => {
                LightSpec::Point { position: Some(position), intensity: Some(intensity), radius }
            }
            Light::Directional { direction, irradiance } => {
                LightSpec::Directional { direction, irradiance: Some(irradiance) }
            }
        }
    }
}

/// A medium as far as a scene file specifies it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct MediumSpec {
    pub scattering: Option<Vec3>,
    pub absorption: Option<Vec3>,
    pub density: Option<f32>,
    pub phase: Option<Phase>,
}

/// An emissive surface, removed from the casters and turned into a point light when the scene has
/// no explicit light.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Emitter {
    pub name: String,
    /// World-space triangles of the surface.
    pub triangles: Vec<[Vec3; 3]>,
    /// Colour of the emission; only its chromaticity is used when `radiance` is `None`.
    pub color: Vec3,
    /// Physical radiance (W/(m^2 sr) per channel) when the file gives one (Mitsuba area emitters).
    pub radiance: Option<Vec3>,
    /// Place the light in front of the surface along its normal (one-sided Mitsuba emitters);
    /// otherwise straight below its centroid (glTF/OBJ, whose winding is not trustworthy).
    pub along_normal: bool,
    /// Exact centre and radius for spherical emitters.
    pub sphere: Option<(Vec3, f32)>,
    /// Albedo, should the surface be kept as geometry after all (a file with an explicit light).
    pub albedo: Vec3,
}

impl Emitter {
    /// The surface as an ordinary mesh (used when an explicit light makes it plain geometry).
    pub(crate) fn into_mesh(self) -> Mesh {
        let positions: Vec<Vec3> = self.triangles.iter().flatten().copied().collect();
        let triangles = (0..self.triangles.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        Mesh { name: self.name, positions, triangles, albedo: self.albedo }
    }

    fn transformed(mut self, m: Mat4) -> Emitter {
        for t in &mut self.triangles {
            for p in t.iter_mut() {
                *p = m.transform_point3(*p);
            }
        }
        // A sphere under a general transform is no longer a sphere; keep only its centre.
        self.sphere = self.sphere.map(|(c, r)| {
            let s = m.transform_vector3(Vec3::X).length();
            (m.transform_point3(c), r * s)
        });
        self
    }

    /// (area, area-weighted centroid, sum of area vectors).
    fn moments(&self) -> (f32, Vec3, Vec3) {
        let mut area = 0.0f32;
        let mut centroid = Vec3::ZERO;
        let mut normal = Vec3::ZERO;
        for [a, b, c] in &self.triangles {
            let n = (*b - *a).cross(*c - *a);
            let ar = 0.5 * n.length();
            if !ar.is_finite() {
                continue;
            }
            area += ar;
            centroid += (*a + *b + *c) / 3.0 * ar;
            normal += n * 0.5;
        }
        if area > 0.0 {
            centroid /= area;
        } else if let Some([a, b, c]) = self.triangles.first() {
            centroid = (*a + *b + *c) / 3.0;
        }
        (area, centroid, normal)
    }

    fn area(&self) -> f32 {
        if let Some((_, r)) = self.sphere {
            return 4.0 * std::f32::consts::PI * r * r;
        }
        self.moments().0
    }

    /// Relative power, used to pick one emitter when there are several.
    fn power(&self) -> f32 {
        luminance(self.radiance.unwrap_or(self.color)) * self.area()
    }
}

/// What one file contributes: meshes in world space and whatever else it specifies.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Loaded {
    pub meshes: Vec<Mesh>,
    pub camera: Option<CameraSpec>,
    pub light: Option<LightSpec>,
    pub emitters: Vec<Emitter>,
    pub medium: Option<MediumSpec>,
    pub grid: Option<Grid>,
    /// Scene name given by the file itself.
    pub name: Option<String>,
    /// Every file read so far (see [`LoadSummary::files`]).
    pub files: Vec<PathBuf>,
}

impl Loaded {
    /// Adds another file's contents: meshes and emitters are concatenated, the first camera and
    /// light win.
    pub(crate) fn merge(&mut self, other: Loaded) {
        self.meshes.extend(other.meshes);
        self.emitters.extend(other.emitters);
        self.files.extend(other.files);
        self.camera = self.camera.or(other.camera);
        self.light = self.light.or(other.light);
        self.medium = self.medium.or(other.medium);
        self.grid = self.grid.or(other.grid);
    }

    /// Applies an affine transform to everything positional.
    pub(crate) fn transform(&mut self, m: Mat4) {
        for mesh in &mut self.meshes {
            mesh.transform(m);
        }
        self.camera = self.camera.map(|c| c.transformed(m));
        self.light = self.light.map(|l| l.transformed(m));
        self.emitters = std::mem::take(&mut self.emitters).into_iter().map(|e| e.transformed(m)).collect();
    }
}

/// Loads a scene from a glTF/GLB, OBJ, PLY, `*.scene.toml` or Mitsuba `scene.xml` file, or from a
/// folder (its `scene.xml`, else every mesh file in it).
///
/// Whatever the file lacks is filled in from the scene's bounds (see `docs/scene-format.md`), and the
/// result is validated: an `Ok` scene is renderable.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with_summary(path).map(|(scene, _)| scene)
}

/// [`load_scene`], also saying which files were read and what was dropped.
pub fn load_scene_with_summary(path: &Path) -> Result<(Scene, LoadSummary), SceneError> {
    let meta = std::fs::metadata(path).map_err(|e| SceneError::io(path, e))?;
    let (loaded, name) = if meta.is_dir() {
        let xml = path.join("scene.xml");
        if xml.is_file() {
            (mitsuba::load(&xml)?, dir_name(path))
        } else {
            (load_folder(path)?, dir_name(path))
        }
    } else {
        let ext = extension(path);
        let name = scene_name(path);
        let loaded = match ext.as_str() {
            "toml" => scene_file::load(path)?,
            "xml" => mitsuba::load(path)?,
            _ => load_mesh_file(path)?,
        };
        (loaded, name)
    };
    let name = loaded.name.clone().unwrap_or(name);
    finish(path, name, loaded)
}

/// Loads one mesh file (glTF/GLB, OBJ, PLY), the unit a scene file or folder is made of.
pub(crate) fn load_mesh_file(path: &Path) -> Result<Loaded, SceneError> {
    let ext = extension(path);
    match ext.as_str() {
        "gltf" | "glb" => gltf_file::load(path),
        "obj" => obj_file::load(path, obj_file::Materials::FromMtl),
        "ply" => ply_file::load(path),
        _ => {
            if !path.exists() {
                return Err(SceneError::NotFound { path: path.to_path_buf() });
            }
            Err(SceneError::UnsupportedExtension {
                path: path.to_path_buf(),
                ext: if ext.is_empty() { "(none)".into() } else { format!(".{ext}") },
            })
        }
    }
}

/// Lower-case extension without the dot ("" when there is none).
pub(crate) fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).unwrap_or_default()
}

fn dir_name(path: &Path) -> String {
    let canon = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
    canon.file_name().and_then(|n| n.to_str()).unwrap_or("scene").to_string()
}

/// File stem, without a trailing `.scene` (`room.scene.toml` -> `room`).
fn scene_name(path: &Path) -> String {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scene");
    stem.strip_suffix(".scene").unwrap_or(stem).to_string()
}

/// A folder without `scene.xml`: every `.gltf .glb .obj .ply` in it (not recursive), sorted by name.
fn load_folder(dir: &Path) -> Result<Loaded, SceneError> {
    let entries = std::fs::read_dir(dir).map_err(|e| SceneError::io(dir, e))?;
    let mut files: Vec<PathBuf> = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| SceneError::io(dir, e))?;
        let p = entry.path();
        if !matches!(extension(&p).as_str(), "gltf" | "glb" | "obj" | "ply") {
            continue;
        }
        // A mesh file that cannot even be looked at (a link loop, a dangling link) is an error
        // naming it, not a silently missing part of the scene.
        match std::fs::metadata(&p) {
            Ok(m) if m.is_file() => files.push(p),
            Ok(_) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(SceneError::unsupported(&p, "a symbolic link to nothing"));
            }
            Err(e) => return Err(SceneError::io(&p, e)),
        }
    }
    files.sort();
    if files.is_empty() {
        return Err(SceneError::unsupported(dir, "the folder has no scene.xml and no .gltf .glb .obj or .ply file"));
    }
    use rayon::prelude::*;
    let parts: Vec<Result<Loaded, SceneError>> = files.par_iter().map(|f| load_mesh_file(f)).collect();
    let mut out = Loaded::default();
    for (file, part) in files.iter().zip(parts) {
        let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("?").to_string();
        out.merge(part.map_err(|e| SceneError::referenced(dir, name, e))?);
    }
    Ok(out)
}

/// Rec. 709 luminance.
pub(crate) fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

fn diag(b: &Aabb) -> f32 {
    if b.is_empty() {
        0.0
    } else {
        b.extent().length()
    }
}

/// The scene's bounds without "ground planes": meshes of at most 16 triangles whose bounds are more
/// than 4 times larger (diagonal) than everything else together. The classroom's 220 m floor plane
/// would otherwise set the medium's density and the default light for a 10 m room.
pub(crate) fn core_bounds(meshes: &[Mesh]) -> Aabb {
    super::bounds_without_backdrops(meshes, diag, |m| {
        log::info!("mesh '{}' treated as a ground plane for the scene's default sizes", m.name)
    })
}

/// Builds a point light from an emissive surface; `None` when the surface is degenerate.
///
/// The light sits in front of the surface (along its normal, or straight down) by 2% of the scene's
/// height (at least 0.2% of its diagonal), but never more than half the emitter's own size, so that it
/// stays inside lamp shades.
fn emitter_light(e: &Emitter, height: f32, core_diag: f32) -> Option<Light> {
    let heuristic = || {
        let c = e.color.max(Vec3::ZERO);
        let m = c.max_element();
        let chroma = if m > 0.0 && m.is_finite() { c / m } else { Vec3::ONE };
        chroma * EMISSIVE_K * core_diag * core_diag
    };
    if let Some((center, radius)) = e.sphere {
        let intensity = match e.radiance {
            Some(l) => l * std::f32::consts::PI * radius * radius,
            None => heuristic(),
        };
        return center.is_finite().then_some(Light::Point { position: center, intensity, radius: radius.max(0.0) });
    }
    let (area, centroid, normal) = e.moments();
    if !centroid.is_finite() {
        return None;
    }
    let mut eb = Aabb::EMPTY;
    for t in &e.triangles {
        for p in t {
            eb.grow(*p);
        }
    }
    let offset = (0.02 * height).min(0.5 * eb.radius());
    let dir = if e.along_normal && normal.length() > 0.0 { normal.normalize() } else { -Vec3::Y };
    let intensity = match e.radiance {
        // A Lambertian emitter of radiance L and area A radiates pi L A watts; spread over the
        // sphere that is L A / 4 W/sr.
        Some(l) => l * area / 4.0,
        None => heuristic(),
    };
    Some(Light::Point { position: centroid + dir * offset, intensity, radius: 0.0 })
}

/// Fills in what the file lacks, validates and builds the [`Scene`].
pub(crate) fn finish(path: &Path, name: String, loaded: Loaded) -> Result<(Scene, LoadSummary), SceneError> {
    let Loaded { mut meshes, camera, light, mut emitters, medium, grid, files, .. } = loaded;
    if light.is_some() {
        // An explicit light wins: emissive surfaces stay ordinary geometry.
        meshes.extend(std::mem::take(&mut emitters).into_iter().map(Emitter::into_mesh));
    }
    let degenerate: usize = meshes.iter_mut().map(Mesh::drop_degenerate).sum();
    if degenerate > 0 {
        log::info!("{}: {degenerate} zero-area triangles dropped", path.display());
    }
    meshes.retain(|m| !m.triangles.is_empty());
    let invalid = |source: ParamError| SceneError::Invalid { path: path.to_path_buf(), source };

    // Geometry first: nothing below may be computed from NaN bounds.
    let probe = Scene {
        name: name.clone(),
        source: Some(path.to_path_buf()),
        meshes,
        camera: Camera::default(),
        light: Light::default(),
        medium: Medium::default(),
        grid: Grid::default(),
    };
    if probe.triangle_count() == 0 {
        let dropped = match degenerate {
            0 => String::new(),
            n => format!(" ({n} zero-area triangles dropped)"),
        };
        return Err(invalid(ParamError::Invalid(format!("the scene has no triangles{dropped}"))));
    }
    probe.validate().map_err(invalid)?;
    let meshes = probe.meshes;

    let full = meshes.iter().fold(Aabb::EMPTY, |b, m| b.union(&m.bounds()));
    let core = core_bounds(&meshes);
    let full_diag = diag(&full).max(1e-6);
    let core_diag = diag(&core).max(1e-6);
    let center = core.center();

    // Camera.
    let framing = Camera::framing(&full);
    let spec = camera.unwrap_or_default();
    let eye = spec.eye.or_else(|| spec.target.map(|t| t + (framing.eye - framing.target))).unwrap_or(framing.eye);
    let target = match (spec.target, spec.dir) {
        (Some(t), _) => t,
        (None, Some(d)) => {
            let d = unit_direction("camera direction", d).map_err(invalid)?;
            let focus = d.dot(center - eye).max(0.1 * core.radius()).max(1e-6);
            eye + d * focus
        }
        (None, None) if spec.eye.is_some() => full.center(),
        (None, None) => framing.target,
    };
    let up = match spec.up {
        Some(u) => unit_direction("camera up", u).map_err(invalid)?,
        None => Vec3::Y,
    };
    let near = spec.near.unwrap_or(1e-3 * core_diag);
    let far = spec.far.unwrap_or_else(|| ((eye - full.center()).length() + 4.0 * full_diag).max(near * 10.0));
    let camera = Camera { eye, target, up, fov_y_deg: spec.fov_y_deg.unwrap_or(framing.fov_y_deg), near, far };

    // Light.
    let height = full.extent().y.max(0.1 * full_diag);
    let default_position = center + Vec3::new(0.2, 0.9, 0.3) * core.radius();
    let light = match light {
        Some(LightSpec::Point { position, intensity, radius }) => {
            let position = position.unwrap_or(default_position);
            let d2 = (position - center).length_squared().max(1e-12);
            Light::Point {
                position,
                intensity: intensity.unwrap_or(Vec3::splat(DEFAULT_POINT_IRRADIANCE * d2)),
                radius,
            }
        }
        Some(LightSpec::Directional { direction, irradiance }) => Light::Directional {
            direction: unit_direction("light direction", direction).map_err(invalid)?,
            irradiance: irradiance.unwrap_or(Vec3::splat(DEFAULT_SUN_IRRADIANCE)),
        },
        None => {
            let best = emitters
                .iter()
                .filter_map(|e| emitter_light(e, height, core_diag).map(|l| (e, l)))
                .max_by(|a, b| a.0.power().total_cmp(&b.0.power()));
            match best {
                Some((e, l)) => {
                    if emitters.len() > 1 {
                        log::info!(
                            "{}: {} emissive surfaces; the light is placed at the brightest, '{}'",
                            path.display(),
                            emitters.len(),
                            e.name
                        );
                    }
                    l
                }
                None => {
                    let d2 = (default_position - center).length_squared();
                    Light::Point {
                        position: default_position,
                        intensity: Vec3::splat(DEFAULT_POINT_IRRADIANCE * d2),
                        radius: 0.0,
                    }
                }
            }
        }
    };

    // Medium.
    let medium = {
        let spec = medium.unwrap_or_default();
        let base = Medium::default();
        let explicit = spec.scattering.is_some() || spec.absorption.is_some();
        let density = spec.density.unwrap_or(if explicit {
            1.0
        } else {
            (MEDIUM_DENSITY_PER_DIAG / core_diag).min(Medium::DENSITY.max as f32)
        });
        Medium {
            scattering: spec.scattering.unwrap_or(base.scattering),
            absorption: spec.absorption.unwrap_or(base.absorption),
            density,
            phase: spec.phase.unwrap_or(base.phase),
        }
    };

    let scene =
        Scene { name, source: Some(path.to_path_buf()), meshes, camera, light, medium, grid: grid.unwrap_or_default() };
    scene.validate().map_err(invalid)?;
    Ok((scene, LoadSummary { files, degenerate_triangles: degenerate }))
}

/// Row-major 4x4 (16 numbers) or 3x3 (9 numbers) matrix text, as Mitsuba writes it.
pub(crate) fn parse_floats(text: &str) -> Result<Vec<f32>, String> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f32>().map_err(|_| format!("'{s}' is not a number")))
        .collect()
}

/// Triangulates a polygon given as vertex indices as a fan around its first vertex.
pub(crate) fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    for i in 2..poly.len() {
        out.push([poly[0], poly[i - 1], poly[i]]);
    }
}

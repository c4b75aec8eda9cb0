//! The project's own scene file, `NAME.scene.toml` (format 1). Documented in `docs/scene-format.md`.

use super::{extension, load_mesh_file, primitives, CameraSpec, LightSpec, Loaded, MediumSpec, SceneError};
use crate::params::{de, Grid, Phase};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Deserializer};
use std::path::Path;

const FORMAT: &str = "scene (TOML)";

/// The only format version this build reads.
pub const FORMAT_VERSION: i64 = 1;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    #[allow(dead_code)] // checked before deserializing, see `load`
    format: i64,
    name: Option<String>,
    #[serde(default)]
    mesh: Vec<toml::Spanned<MeshEntry>>,
    camera: Option<CameraEntry>,
    light: Option<LightEntry>,
    medium: Option<MediumEntry>,
    grid: Option<Grid>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshEntry {
    file: Option<String>,
    builtin: Option<String>,
    name: Option<String>,
    #[serde(default, deserialize_with = "de::opt_vec3")]
    translate: Option<Vec3>,
    #[serde(default, deserialize_with = "de::opt_vec3")]
    rotate_deg: Option<Vec3>,
    scale: Option<Splat>,
    albedo: Option<Splat>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraEntry {
    #[serde(default, deserialize_with = "de::opt_vec3")]
    eye: Option<Vec3>,
    #[serde(default, deserialize_with = "de::opt_vec3")]
    target: Option<Vec3>,
    #[serde(default, deserialize_with = "de::opt_vec3")]
    up: Option<Vec3>,
    fov_y_deg: Option<f32>,
    near: Option<f32>,
    far: Option<f32>,
}

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "kebab-case", deny_unknown_fields)]
enum LightEntry {
    Point {
        #[serde(default, deserialize_with = "de::opt_vec3")]
        position: Option<Vec3>,
        intensity: Option<Splat>,
        radius: Option<f32>,
    },
    Directional {
        #[serde(deserialize_with = "de::vec3")]
        direction: Vec3,
        irradiance: Option<Splat>,
    },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumEntry {
    scattering: Option<Splat>,
    absorption: Option<Splat>,
    density: Option<f32>,
    /// Strict: a known type, `g` exactly where the type has one ([`Phase::from_fields`]).
    #[serde(default, deserialize_with = "de::opt_phase")]
    phase: Option<Phase>,
}

/// A number (all three channels) or `[x, y, z]`.
#[derive(Debug, Clone, Copy)]
struct Splat(Vec3);

impl<'de> Deserialize<'de> for Splat {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Splat;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Splat, E> {
                Ok(Splat(Vec3::splat(v as f32)))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Splat, E> {
                Ok(Splat(Vec3::splat(v as f32)))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Splat, E> {
                Ok(Splat(Vec3::splat(v as f32)))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Splat, A::Error> {
                let mut v = [0.0f32; 3];
                for (i, x) in v.iter_mut().enumerate() {
                    *x = seq.next_element()?.ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                if seq.next_element::<f32>()?.is_some() {
                    return Err(serde::de::Error::invalid_length(4, &self));
                }
                Ok(Splat(Vec3::from(v)))
            }
        }
        d.deserialize_any(V)
    }
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset.min(text.len())).map_or(1, |t| t.matches('\n').count() + 1)
}

fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> SceneError {
    let message = e.message().trim().to_string();
    match e.span() {
        Some(span) => {
            let line = line_of(text, span.start);
            let col = span.start - text.get(..span.start).and_then(|t| t.rfind('\n')).map_or(0, |i| i + 1) + 1;
            SceneError::parse(path, FORMAT, format!("line {line}, column {col}: {message}"))
        }
        None => SceneError::parse(path, FORMAT, message),
    }
}

/// Model matrix `T * Rz * Ry * Rx * S`: scale, then rotate about X, Y, Z (world axes), then translate.
fn model_matrix(e: &MeshEntry) -> Mat4 {
    let r = e.rotate_deg.unwrap_or(Vec3::ZERO) * (std::f32::consts::PI / 180.0);
    Mat4::from_translation(e.translate.unwrap_or(Vec3::ZERO))
        * Mat4::from_rotation_z(r.z)
        * Mat4::from_rotation_y(r.y)
        * Mat4::from_rotation_x(r.x)
        * Mat4::from_scale(e.scale.map_or(Vec3::ONE, |s| s.0))
}

pub(crate) fn load(path: &Path) -> Result<Loaded, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    let text = String::from_utf8(bytes).map_err(|_| SceneError::parse(path, FORMAT, "not UTF-8 text"))?;

    // The version first, so that a newer file fails on its version rather than on a new field.
    let table: toml::Table = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    match table.get("format") {
        None => return Err(SceneError::parse(path, FORMAT, "missing `format = 1` (the scene file version)")),
        Some(toml::Value::Integer(FORMAT_VERSION)) => {}
        Some(other) => {
            return Err(SceneError::unsupported(
                path,
                format!("format = {other} is not supported (expected {FORMAT_VERSION})"),
            ))
        }
    }
    let file: SceneFile = toml::from_str(&text).map_err(|e| toml_error(path, &text, &e))?;
    let dir = path.parent().unwrap_or(Path::new("."));

    // Meshes (files in parallel).
    let entries: Vec<(usize, MeshEntry)> =
        file.mesh.into_iter().map(|s| (line_of(&text, s.span().start), s.into_inner())).collect();
    use rayon::prelude::*;
    let parts: Vec<Result<Loaded, SceneError>> =
        entries.par_iter().enumerate().map(|(i, (line, e))| mesh_entry(path, dir, i, *line, e)).collect();
    let mut out = Loaded { files: vec![path.to_path_buf()], ..Loaded::default() };
    for part in parts {
        out.merge(part?);
    }

    if let Some(c) = file.camera {
        out.camera = Some(CameraSpec {
            eye: c.eye,
            target: c.target,
            dir: None,
            up: c.up,
            fov_y_deg: c.fov_y_deg,
            near: c.near,
            far: c.far,
        });
    }
    if let Some(l) = file.light {
        out.light = Some(match l {
            LightEntry::Point { position, intensity, radius } => {
                LightSpec::Point { position, intensity: intensity.map(|s| s.0), radius: radius.unwrap_or(0.0) }
            }
            LightEntry::Directional { direction, irradiance } => {
                LightSpec::Directional { direction, irradiance: irradiance.map(|s| s.0) }
            }
        });
    }
    if let Some(m) = file.medium {
        out.medium = Some(MediumSpec {
            scattering: m.scattering.map(|s| s.0),
            absorption: m.absorption.map(|s| s.0),
            density: m.density,
            phase: m.phase,
        });
    }
    out.grid = file.grid;
    out.name = file.name;
    Ok(out)
}

fn mesh_entry(path: &Path, dir: &Path, index: usize, line: usize, e: &MeshEntry) -> Result<Loaded, SceneError> {
    let ctx = format!("line {line}: mesh {}", index + 1);
    let invalid = |msg: String| SceneError::parse(path, FORMAT, format!("{ctx}: {msg}"));
    let albedo = e.albedo.map(|a| a.0);
    let mut loaded = match (&e.file, &e.builtin) {
        (Some(file), None) => {
            let full = dir.join(file);
            if matches!(extension(&full).as_str(), "toml" | "xml") || full.is_dir() {
                return Err(invalid(format!(
                    "'{file}' is a scene, not a mesh (expected a .gltf .glb .obj or .ply file)"
                )));
            }
            let mut l = load_mesh_file(&full).map_err(|err| SceneError::referenced(path, ctx.clone(), err))?;
            if let Some(name) = &e.name {
                let single = l.meshes.len() == 1;
                for m in &mut l.meshes {
                    m.name = if single { name.clone() } else { format!("{name}/{}", m.name) };
                }
            }
            l
        }
        (None, Some(kind)) => {
            let name = e.name.clone().unwrap_or_else(|| kind.clone());
            let a = albedo.unwrap_or(super::DEFAULT_ALBEDO);
            let mesh = match kind.as_str() {
                "box" => primitives::cube(&name, 0.5, a),
                "plane" => {
                    let mut m = primitives::rectangle(&name, a);
                    m.transform(
                        Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2) * Mat4::from_scale(Vec3::splat(0.5)),
                    );
                    m
                }
                "sphere" => primitives::sphere(&name, Vec3::ZERO, 0.5, 24, 48, a),
                other => {
                    return Err(invalid(format!(
                        "unknown builtin '{other}' (expected \"box\", \"plane\" or \"sphere\")"
                    )))
                }
            };
            Loaded { meshes: vec![mesh], ..Loaded::default() }
        }
        (Some(_), Some(_)) => return Err(invalid("give either `file` or `builtin`, not both".into())),
        (None, None) => {
            return Err(invalid("needs `file = \"...\"` or `builtin = \"box\" | \"plane\" | \"sphere\"`".into()))
        }
    };
    let m = model_matrix(e);
    if !m.is_finite() {
        return Err(invalid("translate, rotate_deg and scale must be finite".into()));
    }
    loaded.transform(m);
    if let Some(a) = albedo {
        for mesh in &mut loaded.meshes {
            mesh.albedo = a;
        }
    }
    Ok(loaded)
}

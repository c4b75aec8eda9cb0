//! Presets: a look (medium, optionally grid and exposure) in a short, human-readable TOML file.
//!
//! ```toml
//! format = 1
//! name = "thin haze"
//! [medium]
//! scattering = [0.02, 0.02, 0.025]
//! absorption = [0.002, 0.002, 0.002]
//! density = 1.0
//! phase = { type = "henyey-greenstein", g = 0.6 }
//! ```
//! Only the fields a look needs are written; the rest keep the scene's values. Unknown fields,
//! other format versions and out-of-range values are refused with a message naming the field.
//!
//! [`Preset::from_scene`] captures a look and [`Preset::save`] writes it atomically
//! ([`crate::fsx`]), so a crash never leaves half a preset behind.

use crate::params::{de, Grid, Medium, ParamError, Phase};
use crate::scene::Scene;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The preset format this build reads and writes.
pub const FORMAT: u32 = 1;

#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    #[error("{path}: cannot read: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("{path}: format = {found} is not supported (this build reads format {FORMAT})")]
    Version { path: PathBuf, found: u32 },
    #[error("{path}: {source}")]
    Invalid { path: PathBuf, source: ParamError },
    #[error("{path}: cannot write: {source}")]
    Write { path: PathBuf, source: std::io::Error },
}

/// The medium fields a preset may set; absent ones keep the current value.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumPatch {
    /// Exactly three numbers (so is `absorption`).
    #[serde(default, deserialize_with = "de::opt_vec3", skip_serializing_if = "Option::is_none")]
    pub scattering: Option<Vec3>,
    #[serde(default, deserialize_with = "de::opt_vec3", skip_serializing_if = "Option::is_none")]
    pub absorption: Option<Vec3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density: Option<f32>,
    /// A known type with `g` exactly where the type has one, and no other key.
    #[serde(default, deserialize_with = "de::opt_phase", skip_serializing_if = "Option::is_none")]
    pub phase: Option<Phase>,
}

/// A preset file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Preset {
    pub format: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub medium: Option<MediumPatch>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<Grid>,
    /// Exposure in stops for the displayed image.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub exposure: Option<f32>,
}

impl Preset {
    /// Reads and validates a preset without applying it.
    pub fn load(path: &Path) -> Result<Preset, PresetError> {
        let text = std::fs::read_to_string(path).map_err(|source| PresetError::Io { path: path.into(), source })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Preset, PresetError> {
        // Check the version first so that a newer file says so instead of listing unknown fields.
        let raw: toml::Table =
            toml::from_str(text).map_err(|e| PresetError::Parse { path: path.into(), message: e.to_string() })?;
        match raw.get("format") {
            Some(toml::Value::Integer(v)) if *v == FORMAT as i64 => {}
            Some(toml::Value::Integer(v)) => {
                return Err(PresetError::Version { path: path.into(), found: (*v).clamp(0, u32::MAX as i64) as u32 })
            }
            _ => {
                return Err(PresetError::Parse {
                    path: path.into(),
                    message: format!("missing `format = {FORMAT}` (the preset format version)"),
                })
            }
        }
        let p: Preset =
            toml::from_str(text).map_err(|e| PresetError::Parse { path: path.into(), message: e.to_string() })?;
        // Validate the result of applying it to defaults: catches every out-of-range field.
        let mut m = Medium::default();
        p.apply_medium(&mut m);
        m.validate().map_err(|source| PresetError::Invalid { path: path.into(), source })?;
        if let Some(g) = &p.grid {
            g.validate().map_err(|source| PresetError::Invalid { path: path.into(), source })?;
        }
        if let Some(e) = p.exposure {
            crate::params::Exposure::STOPS
                .check(e as f64)
                .map_err(|source| PresetError::Invalid { path: path.into(), source })?;
        }
        Ok(p)
    }

    fn apply_medium(&self, m: &mut Medium) {
        if let Some(mp) = &self.medium {
            if let Some(v) = mp.scattering {
                m.scattering = v;
            }
            if let Some(v) = mp.absorption {
                m.absorption = v;
            }
            if let Some(v) = mp.density {
                m.density = v;
            }
            if let Some(v) = mp.phase {
                m.phase = v;
            }
        }
    }

    /// Applies the preset to a scene (medium and grid).
    pub fn apply(&self, scene: &mut Scene) {
        self.apply_medium(&mut scene.medium);
        if let Some(g) = self.grid {
            scene.grid = g;
        }
    }

    /// The look of `scene` as a preset: the whole medium, the grid when it is not the default one,
    /// and the exposure when it is not 0 (a preset holds only what the look needs).
    pub fn from_scene(scene: &Scene, name: Option<&str>, exposure: f32) -> Preset {
        let m = &scene.medium;
        Preset {
            format: FORMAT,
            name: name.map(str::to_string).filter(|n| !n.trim().is_empty()),
            medium: Some(MediumPatch {
                scattering: Some(m.scattering),
                absorption: Some(m.absorption),
                density: Some(m.density),
                phase: Some(m.phase),
            }),
            grid: (scene.grid != Grid::default()).then_some(scene.grid),
            exposure: (exposure != 0.0).then_some(exposure),
        }
    }

    /// The preset as TOML text, written by hand so that numbers keep their short `f32` spelling
    /// (`0.1`, not `0.10000000149011612`) and the phase function stays on one line.
    pub fn to_toml(&self) -> String {
        fn num(v: f32) -> String {
            let s = format!("{v}");
            if s.contains(['.', 'e', 'E']) || !v.is_finite() {
                s
            } else {
                format!("{s}.0") // keep it a TOML float
            }
        }
        fn rgb(v: Vec3) -> String {
            format!("[{}, {}, {}]", num(v.x), num(v.y), num(v.z))
        }
        let string = |s: &str| toml::Value::String(s.to_string()).to_string();
        let mut out = format!("format = {}\n", self.format);
        if let Some(n) = &self.name {
            out += &format!("name = {}\n", string(n));
        }
        if let Some(e) = self.exposure {
            out += &format!("exposure = {}\n", num(e));
        }
        if let Some(m) = &self.medium {
            out += "\n[medium]\n";
            if let Some(v) = m.scattering {
                out += &format!("scattering = {}\n", rgb(v));
            }
            if let Some(v) = m.absorption {
                out += &format!("absorption = {}\n", rgb(v));
            }
            if let Some(v) = m.density {
                out += &format!("density = {}\n", num(v));
            }
            if let Some(p) = m.phase {
                let kind = string(p.kind_name());
                out += &if p.has_g() {
                    format!("phase = {{ type = {kind}, g = {} }}\n", num(p.g()))
                } else {
                    format!("phase = {{ type = {kind} }}\n")
                };
            }
        }
        if let Some(g) = &self.grid {
            let spacing = match g.spacing {
                crate::params::BinSpacing::UniformAngle => "uniform-angle",
                crate::params::BinSpacing::UniformCosine => "uniform-cosine",
            };
            out += &format!(
                "\n[grid]\nplanes = {}\nrays = {}\nbins = {}\nspacing = {}\n",
                g.planes,
                g.rays,
                g.bins,
                string(spacing)
            );
        }
        out
    }

    /// Writes the preset to `path` atomically (`fsx::write_atomic`: a temporary file beside it,
    /// flushed, then renamed over it). An existing `path` is replaced — callers that must not
    /// overwrite (Save As) check first and ask. The text is parsed back before anything is written,
    /// so a preset that this build could not read again is never written.
    pub fn save(&self, path: &Path) -> Result<(), PresetError> {
        let text = self.to_toml();
        Self::parse(&text, path)?;
        crate::fsx::write_bytes_atomic(path, text.as_bytes())
            .map_err(|source| PresetError::Write { path: path.into(), source })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<Preset, PresetError> {
        Preset::parse(s, Path::new("look.toml"))
    }

    #[test]
    fn good_preset_applies() {
        let p = parse("format = 1\n[medium]\ndensity = 2.0\nphase = { type = \"rayleigh\" }\n").unwrap();
        let mut m = Medium::default();
        p.apply_medium(&mut m);
        assert_eq!(m.density, 2.0);
        assert_eq!(m.phase, Phase::Rayleigh);
        assert_eq!(m.scattering, Medium::default().scattering);
    }

    #[test]
    fn bad_presets_name_the_problem() {
        let e = parse("format = 2\n").unwrap_err().to_string();
        assert!(e.contains("look.toml") && e.contains("format = 2"), "{e}");
        let e = parse("format = 1\n[medium]\ndensty = 2.0\n").unwrap_err().to_string();
        assert!(e.contains("densty"), "{e}");
        let e = parse("format = 1\n[medium]\nscattering = [-1, 0, 0]\n").unwrap_err().to_string();
        assert!(e.contains("scattering") && e.contains("out of range"), "{e}");
        let e = parse("[medium]\n").unwrap_err().to_string();
        assert!(e.contains("format"), "{e}");
        let e = parse("format = 1\n[grid]\nbins = 33\n").unwrap_err().to_string();
        assert!(e.contains("multiple of 32"), "{e}");
    }

    #[test]
    fn save_and_load_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let mut scene = crate::scene::builtin_scene();
        scene.medium = Medium {
            scattering: Vec3::new(0.1, 0.25, 0.3333),
            absorption: Vec3::new(0.0, 1.0, 1e-5),
            density: 2.0,
            phase: Phase::CornetteShanks { g: -0.35 },
        };
        scene.grid = Grid { planes: 512, rays: 256, bins: 64, spacing: crate::params::BinSpacing::UniformCosine };
        let p = Preset::from_scene(&scene, Some("my \"look\""), 1.5);
        let path = dir.path().join("look.toml");
        p.save(&path).unwrap();
        let back = Preset::load(&path).unwrap();
        assert_eq!(back, p);
        let mut other = crate::scene::builtin_scene();
        back.apply(&mut other);
        assert_eq!(other.medium, scene.medium);
        assert_eq!(other.grid, scene.grid);
        assert_eq!(back.exposure, Some(1.5));
        // Short numbers stay short, and no temporary file is left behind.
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("scattering = [0.1, 0.25, 0.3333]"), "{text}");
        assert!(text.contains("density = 2.0"), "{text}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        // Default grid and zero exposure are left out.
        let q = Preset::from_scene(&crate::scene::builtin_scene(), None, 0.0);
        assert!(q.grid.is_none() == (crate::scene::builtin_scene().grid == Grid::default()));
        assert_eq!(q.exposure, None);
    }

    #[test]
    fn save_refuses_invalid_and_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("look.toml");
        std::fs::write(&path, "format = 1\n").unwrap();
        let mut p = Preset::from_scene(&crate::scene::builtin_scene(), None, 0.0);
        p.medium.as_mut().unwrap().density = Some(-1.0);
        let e = p.save(&path).unwrap_err().to_string();
        assert!(e.contains("density"), "{e}");
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "format = 1\n");
        let e = p.save(&dir.path().join("no/such/dir/x.toml"));
        assert!(e.is_err());
    }

    #[test]
    fn shipped_presets_load() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("presets");
        let mut n = 0;
        for entry in std::fs::read_dir(&dir).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|e| e == "toml") {
                Preset::load(&p).unwrap_or_else(|e| panic!("{e}"));
                n += 1;
            }
        }
        assert!(n >= 5, "only {n} presets shipped");
    }
}

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

use crate::params::{Grid, Medium, ParamError, Phase};
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
}

/// The medium fields a preset may set; absent ones keep the current value.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumPatch {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scattering: Option<Vec3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub absorption: Option<Vec3>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density: Option<f32>,
    #[serde(skip_serializing_if = "Option::is_none")]
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
            crate::params::Exposure::STOPS.check(e as f64).map_err(|source| PresetError::Invalid { path: path.into(), source })?;
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

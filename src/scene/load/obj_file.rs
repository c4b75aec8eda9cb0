//! Wavefront OBJ via `tobj`.
//!
//! Read: positions and faces (polygons triangulated as fans by `tobj`), one [`Mesh`] per object /
//! group / material run, the MTL diffuse colour `Kd` as albedo. A material named `light` or with a
//! non-zero `Ke` marks an emissive surface (see [`super::Emitter`]). Ignored: normals, texture
//! coordinates, textures, points and lines.

use super::{Emitter, Loaded, SceneError, DEFAULT_ALBEDO};
use crate::scene::Mesh;
use glam::Vec3;
use std::io::BufReader;
use std::path::Path;

const FORMAT: &str = "OBJ";

/// Where the albedo comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Materials {
    /// The OBJ's own MTL files (a missing MTL is a warning).
    FromMtl,
    /// A fixed albedo; MTL files are not read (Mitsuba ignores them too).
    Fixed(Vec3),
}

pub(crate) fn load(path: &Path, materials: Materials) -> Result<Loaded, SceneError> {
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut reader = BufReader::with_capacity(1 << 16, file);
    let options = tobj::LoadOptions { single_index: false, triangulate: true, ignore_points: true, ignore_lines: true };
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let (models, mtl) = tobj::load_obj_buf(&mut reader, &options, |mtl: &Path| match materials {
        Materials::FromMtl => {
            let mtl_path = dir.join(mtl);
            let result = tobj::load_mtl(&mtl_path);
            if let Err(e) = &result {
                log::warn!("{}: material library {}: {e}; using grey", path.display(), mtl_path.display());
            }
            result
        }
        Materials::Fixed(_) => Ok(Default::default()),
    })
    .map_err(|e| SceneError::parse(path, FORMAT, e))?;
    let mtl = mtl.unwrap_or_default();

    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("obj");
    let mut out = Loaded::default();
    let many = models.len() > 1;
    for model in models {
        let m = model.mesh;
        let name = match (many, model.name.is_empty()) {
            (false, _) => stem.to_string(),
            (true, true) => format!("{stem}/unnamed"),
            (true, false) => format!("{stem}/{}", model.name),
        };
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])).collect();
        let triangles: Vec<[u32; 3]> = m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let material = m.material_id.and_then(|i| mtl.get(i));
        let (albedo, emissive) = match materials {
            Materials::Fixed(a) => (a, None),
            Materials::FromMtl => {
                let albedo = material
                    .and_then(|mat| mat.diffuse)
                    .map(Vec3::from)
                    .filter(|a| a.is_finite())
                    .map(|a| a.clamp(Vec3::ZERO, Vec3::ONE))
                    .unwrap_or(DEFAULT_ALBEDO);
                let emissive = material.and_then(|mat| {
                    let ke = mat.emissive.map(Vec3::from).filter(|k| k.is_finite() && k.max_element() > 0.0);
                    match ke {
                        Some(k) => Some(k),
                        None => mat.name.eq_ignore_ascii_case("light").then_some(Vec3::ONE),
                    }
                });
                (albedo, emissive)
            }
        };
        match emissive {
            Some(color) => {
                let n = positions.len();
                let tri = |t: &[u32; 3]| -> Option<[Vec3; 3]> {
                    let get = |i: u32| positions.get(i as usize).copied();
                    Some([get(t[0])?, get(t[1])?, get(t[2])?])
                };
                let tris: Option<Vec<[Vec3; 3]>> = triangles.iter().map(tri).collect();
                let Some(tris) = tris else {
                    return Err(SceneError::parse(
                        path,
                        FORMAT,
                        format!("object '{name}' indexes past its {n} vertices"),
                    ));
                };
                out.emitters.push(Emitter {
                    name,
                    triangles: tris,
                    color,
                    radiance: None,
                    along_normal: false,
                    sphere: None,
                    albedo,
                });
            }
            None => out.meshes.push(Mesh { name, positions, triangles, albedo }),
        }
    }
    Ok(out)
}

//! Wavefront OBJ via `tobj`.
//!
//! Read: positions and faces (polygons triangulated as fans by `tobj`), one [`Mesh`] per object /
//! group / material run, the MTL diffuse colour `Kd` as albedo. A material named `light` or with a
//! non-zero `Ke` marks an emissive surface (see [`super::Emitter`]). Ignored: normals, texture
//! coordinates, textures, points and lines.

use super::{Emitter, Loaded, SceneError, DEFAULT_ALBEDO};
use crate::scene::Mesh;
use glam::Vec3;
use std::io::{self, BufRead, BufReader, Read};
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
    let mut reader = PositionsOnly::new(BufReader::with_capacity(1 << 16, file));
    let options = tobj::LoadOptions { single_index: false, triangulate: true, ignore_points: true, ignore_lines: true };
    let dir = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let mtl_files = std::cell::RefCell::new(Vec::new());
    let (models, mtl) = tobj::load_obj_buf(&mut reader, &options, |mtl: &Path| match materials {
        Materials::FromMtl => {
            let mtl_path = dir.join(mtl);
            mtl_files.borrow_mut().push(mtl_path.clone());
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
    let mut out = Loaded { files: vec![path.to_path_buf()], ..Loaded::default() };
    out.files.extend(mtl_files.into_inner());
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
                // Out of [0, 1] or NaN is refused by the scene's validation, naming the mesh.
                let albedo = material.and_then(|mat| mat.diffuse).map(Vec3::from).unwrap_or(DEFAULT_ALBEDO);
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

/// The OBJ stream as `tobj` sees it: without normals and texture coordinates (`vn`, `vt`, `vp`
/// lines become empty, face corners `v/vt/vn` become `v`). They are not used, and `tobj` overflows
/// on out-of-range normal or texture indices instead of failing. Line numbers are kept.
struct PositionsOnly<R> {
    inner: R,
    line: Vec<u8>,
    out: Vec<u8>,
    pos: usize,
}

impl<R: BufRead> PositionsOnly<R> {
    fn new(inner: R) -> Self {
        PositionsOnly { inner, line: Vec::new(), out: Vec::new(), pos: 0 }
    }
}

/// Appends `line` to `out` as [`PositionsOnly`] passes it on.
fn positions_only(line: &[u8], out: &mut Vec<u8>) {
    let body = line.trim_ascii_start();
    let keyword_end = body.iter().position(|b| b.is_ascii_whitespace()).unwrap_or(body.len());
    let newline: &[u8] = if line.ends_with(b"\n") { b"\n" } else { b"" };
    match &body[..keyword_end] {
        b"vn" | b"vt" | b"vp" => out.extend_from_slice(newline),
        b"f" => {
            out.push(b'f');
            for corner in body[keyword_end..].split(|b| b.is_ascii_whitespace()).filter(|c| !c.is_empty()) {
                out.push(b' ');
                out.extend_from_slice(corner.split(|&b| b == b'/').next().unwrap_or(corner));
            }
            out.extend_from_slice(newline);
        }
        _ => out.extend_from_slice(line),
    }
}

impl<R: BufRead> BufRead for PositionsOnly<R> {
    fn fill_buf(&mut self) -> io::Result<&[u8]> {
        while self.pos >= self.out.len() {
            self.line.clear();
            self.out.clear();
            self.pos = 0;
            if self.inner.read_until(b'\n', &mut self.line)? == 0 {
                break;
            }
            positions_only(&self.line, &mut self.out);
        }
        Ok(&self.out[self.pos..])
    }

    fn consume(&mut self, n: usize) {
        self.pos = (self.pos + n).min(self.out.len());
    }
}

impl<R: BufRead> Read for PositionsOnly<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let avail = self.fill_buf()?;
        let n = avail.len().min(buf.len());
        buf[..n].copy_from_slice(&avail[..n]);
        self.consume(n);
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_and_texture_coordinates_are_left_out() {
        let text = "v 0 0 0\nvn 0 1 0\n  vt 0.5 0.5\nf 1/1/1 2//-11  3/4\r\nfoo bar\nf 1 2 3";
        let mut out = String::new();
        PositionsOnly::new(text.as_bytes()).read_to_string(&mut out).unwrap();
        assert_eq!(out, "v 0 0 0\n\n\nf 1 2 3\nfoo bar\nf 1 2 3");
    }
}

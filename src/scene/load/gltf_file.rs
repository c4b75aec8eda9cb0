//! glTF 2.0 (`.gltf` with external or embedded buffers, `.glb`).
//!
//! Read: the default scene's node tree (world matrices applied), TRIANGLES / TRIANGLE_STRIP /
//! TRIANGLE_FAN primitives, the base colour factor as albedo, the first perspective camera, the first
//! KHR_lights_punctual light, emissive materials (see [`super::Emitter`]). Ignored: textures, normals,
//! skins, morph targets, animations, images (never decoded).

use super::{CameraSpec, Emitter, LightSpec, Loaded, SceneError};
use crate::params::{Light, ParamError};
use crate::scene::Mesh;
use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::path::Path;

const FORMAT: &str = "glTF";

pub(crate) fn load(path: &Path) -> Result<Loaded, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    let (document, blob) = parse(path, &bytes)?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut files = vec![path.to_path_buf()];
    // Check external buffers first: the crate's error does not name a missing file, and it panics
    // on a relative URI whose percent-decoding is not UTF-8.
    for b in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = b.source() {
            if uri.contains(':') {
                continue;
            }
            let bad = |why: &str| SceneError::parse(path, FORMAT, format!("buffer {}: '{uri}': {why}", b.index()));
            let file = percent_decode(uri).ok_or_else(|| bad("not a valid URI"))?;
            if !base.join(&file).is_file() {
                return Err(bad("no such file or directory"));
            }
            files.push(base.join(&file));
        }
    }
    let buffers =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| gltf::import_buffers(&document, Some(base), blob)))
            .map_err(|_| SceneError::parse(path, FORMAT, "buffer: unreadable"))?
            .map_err(|e| SceneError::parse(path, FORMAT, format!("buffer: {e}")))?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b.0[..]).collect();

    // The default scene, else the first, else every root node.
    let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    if let Some(flag) = is_child.get_mut(c.index()) {
                        *flag = true;
                    }
                }
            }
            document.nodes().filter(|n| !is_child.get(n.index()).copied().unwrap_or(false)).collect()
        }
    };

    let mut walker = Walker {
        path,
        buffers: &buffers,
        visited: vec![false; document.nodes().len()],
        out: Loaded { files, ..Loaded::default() },
        emissive_found: false,
    };
    // Explicit stack (depth-first, children in order) so that deep trees cannot overflow.
    let mut stack: Vec<(gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        let Some(seen) = walker.visited.get_mut(node.index()) else { continue };
        if *seen {
            log::warn!("{}: node {} is reachable twice (not a tree); visited once", path.display(), node.index());
            continue;
        }
        *seen = true;
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        walker.node(&node, world)?;
        let children: Vec<gltf::Node> = node.children().collect();
        for c in children.into_iter().rev() {
            stack.push((c, world));
        }
    }
    Ok(walker.out)
}

/// Parses and validates the document. `gltf-json`'s validation indexes accessors without checking
/// (a POSITION index out of range panics), so those indices are checked first, and the rest runs
/// under `catch_unwind` as a last resort.
fn parse(path: &Path, bytes: &[u8]) -> Result<(gltf::Document, Option<Vec<u8>>), SceneError> {
    let guarded = |f: &dyn Fn() -> Result<gltf::Gltf, gltf::Error>| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
            .map_err(|_| SceneError::parse(path, FORMAT, "malformed document"))?
            .map_err(|e| SceneError::parse(path, FORMAT, e))
    };
    // The crate subtracts the header's size from a GLB's declared length unchecked.
    if let Some(length) = bytes.strip_prefix(b"glTF").and_then(|b| b.get(4..8)) {
        let length = u32::from_le_bytes([length[0], length[1], length[2], length[3]]);
        if length < 12 {
            return Err(SceneError::parse(
                path,
                FORMAT,
                format!("GLB header: length {length} is shorter than the header"),
            ));
        }
    }
    let raw = guarded(&|| gltf::Gltf::from_slice_without_validation(bytes))?;
    let root = raw.document.into_json();
    for (mi, mesh) in root.meshes.iter().enumerate() {
        for prim in &mesh.primitives {
            for index in prim.attributes.values() {
                if index.value() >= root.accessors.len() {
                    return Err(SceneError::parse(
                        path,
                        FORMAT,
                        format!("mesh {mi}: attribute accessor {} does not exist", index.value()),
                    ));
                }
            }
        }
    }
    let document = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| gltf::Document::from_json(root)))
        .map_err(|_| SceneError::parse(path, FORMAT, "malformed document"))?
        .map_err(|e| SceneError::parse(path, FORMAT, e))?;
    Ok((document, raw.blob))
}

struct Walker<'a> {
    path: &'a Path,
    buffers: &'a [&'a [u8]],
    visited: Vec<bool>,
    out: Loaded,
    emissive_found: bool,
}

impl Walker<'_> {
    fn node(&mut self, node: &gltf::Node, world: Mat4) -> Result<(), SceneError> {
        let name = node.name().map(str::to_string).unwrap_or_else(|| format!("node{}", node.index()));
        if let Some(mesh) = node.mesh() {
            let mesh_name = mesh.name().map(str::to_string).unwrap_or(name.clone());
            for (pi, prim) in mesh.primitives().enumerate() {
                // Several primitives: tell them apart by material name (else by index).
                let prim_name = match (mesh.primitives().len() > 1, prim.material().name()) {
                    (false, _) => mesh_name.clone(),
                    (true, Some(m)) => format!("{mesh_name}/{m}"),
                    (true, None) => format!("{mesh_name}#{pi}"),
                };
                self.primitive(&prim, &prim_name, world)?;
            }
        }
        if self.out.camera.is_none() {
            if let Some(cam) = node.camera() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => {
                        self.out.camera = Some(CameraSpec {
                            eye: Some(world.transform_point3(Vec3::ZERO)),
                            target: None,
                            dir: Some(world.transform_vector3(-Vec3::Z)),
                            up: Some(world.transform_vector3(Vec3::Y)),
                            fov_y_deg: Some(p.yfov().to_degrees()),
                            near: (p.znear() > 0.0).then_some(p.znear()),
                            far: p.zfar(),
                        });
                    }
                    gltf::camera::Projection::Orthographic(_) => {
                        log::warn!("{}: orthographic camera '{name}' ignored", self.path.display());
                    }
                }
            }
        }
        if self.out.light.is_none() {
            if let Some(light) = node.light() {
                // Colour and intensity separately: two negatives would multiply to a positive power.
                let bad = |e: ParamError| {
                    SceneError::parse(self.path, FORMAT, format!("light '{}' of node '{name}': {e}", light.index()))
                };
                let color = Vec3::from(light.color());
                if !(color.is_finite() && color.min_element() >= 0.0) {
                    return Err(bad(ParamError::Invalid(format!("color = {color} must be finite and >= 0"))));
                }
                Light::INTENSITY.check(light.intensity() as f64).map_err(bad)?;
                let power = color * light.intensity();
                use gltf::khr_lights_punctual::Kind;
                self.out.light = Some(match light.kind() {
                    Kind::Directional => {
                        LightSpec::Directional { direction: world.transform_vector3(Vec3::Z), irradiance: Some(power) }
                    }
                    Kind::Point => LightSpec::Point {
                        position: Some(world.transform_point3(Vec3::ZERO)),
                        intensity: Some(power),
                        radius: 0.0,
                    },
                    Kind::Spot { .. } => {
                        log::warn!("{}: spot light '{name}' treated as a point light", self.path.display());
                        LightSpec::Point {
                            position: Some(world.transform_point3(Vec3::ZERO)),
                            intensity: Some(power),
                            radius: 0.0,
                        }
                    }
                });
            }
        }
        Ok(())
    }

    fn primitive(&mut self, prim: &gltf::Primitive, name: &str, world: Mat4) -> Result<(), SceneError> {
        let mode = prim.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            log::warn!("{}: primitive '{name}' is {mode:?}, not triangles; skipped", self.path.display());
            return Ok(());
        }
        let bad = |what: String| SceneError::parse(self.path, FORMAT, format!("mesh '{name}': {what}"));
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            log::warn!("{}: primitive '{name}' has no POSITION; skipped", self.path.display());
            return Ok(());
        };
        let positions = read_positions(&pos_acc, self.buffers).map_err(|e| bad(format!("POSITION: {e}")))?;
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => read_indices(&acc, self.buffers).map_err(|e| bad(format!("indices: {e}")))?,
            None => (0..positions.len() as u32).collect(),
        };
        let mut triangles = Vec::with_capacity(indices.len() / 3);
        match mode {
            Mode::TriangleStrip => {
                for i in 2..indices.len() {
                    let (a, b, c) = (indices[i - 2], indices[i - 1], indices[i]);
                    triangles.push(if i % 2 == 0 { [a, b, c] } else { [b, a, c] });
                }
            }
            Mode::TriangleFan => super::fan(&indices, &mut triangles),
            _ => triangles.extend(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]])),
        }
        let n = positions.len() as u32;
        if let Some(t) = triangles.iter().find(|t| t.iter().any(|&i| i >= n)) {
            return Err(bad(format!("triangle {t:?} indexes past its {n} vertices")));
        }
        let positions: Vec<Vec3> = positions.into_iter().map(|p| world.transform_point3(p)).collect();

        let material = prim.material();
        let base = material.pbr_metallic_roughness().base_color_factor();
        // Out of [0, 1] or NaN is refused by the scene's validation, naming the mesh.
        let albedo = Vec3::new(base[0], base[1], base[2]);
        let emissive = Vec3::from(material.emissive_factor());
        let named_light = material.name().is_some_and(|m| m.eq_ignore_ascii_case("light"));
        if named_light || emissive.max_element() > 0.0 {
            if !self.emissive_found {
                log::info!(
                    "{}: emissive material '{}' becomes the light (if the file has no punctual light)",
                    self.path.display(),
                    material.name().unwrap_or("?")
                );
                self.emissive_found = true;
            }
            self.out.emitters.push(Emitter {
                name: name.to_string(),
                triangles: triangles
                    .iter()
                    .map(|t| [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]])
                    .collect(),
                color: if emissive.max_element() > 0.0 { emissive } else { Vec3::ONE },
                radiance: None,
                along_normal: false,
                sphere: None,
                albedo,
            });
            return Ok(());
        }
        self.out.meshes.push(Mesh { name: name.to_string(), positions, triangles, albedo });
        Ok(())
    }
}

/// The bytes of an accessor's elements: (data, stride, element size).
type Elements<'b> = (&'b [u8], usize, usize);

/// The bytes an accessor's elements live in, bounds-checked; `None` for an accessor without data.
fn accessor_bytes<'b>(acc: &gltf::Accessor, buffers: &[&'b [u8]]) -> Result<Option<Elements<'b>>, String> {
    let comp = match acc.data_type() {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    };
    let elem = comp * acc.dimensions().multiplicity();
    let Some(view) = acc.view() else { return Ok(None) };
    let buf = buffers.get(view.buffer().index()).ok_or("buffer missing")?;
    let view_bytes = buf
        .get(view.offset()..view.offset().saturating_add(view.length()))
        .ok_or_else(|| format!("buffer view {} lies outside its buffer", view.index()))?;
    let stride = view.stride().unwrap_or(elem).max(elem);
    let count = acc.count();
    if count == 0 {
        return Ok(Some((&[], stride, elem)));
    }
    let need = acc
        .offset()
        .checked_add(stride.checked_mul(count - 1).ok_or("accessor too large")?)
        .and_then(|v| v.checked_add(elem))
        .ok_or("accessor too large")?;
    let data = view_bytes.get(acc.offset()..need).ok_or_else(|| {
        format!("accessor {} reads past its buffer view ({need} > {} bytes)", acc.index(), view.length())
    })?;
    Ok(Some((data, stride, elem)))
}

fn component(data: &[u8], ty: DataType, normalized: bool) -> f32 {
    let b = |i: usize| data.get(i).copied().unwrap_or(0);
    match ty {
        DataType::F32 => f32::from_le_bytes([b(0), b(1), b(2), b(3)]),
        DataType::U32 => u32::from_le_bytes([b(0), b(1), b(2), b(3)]) as f32,
        DataType::U16 => {
            let v = u16::from_le_bytes([b(0), b(1)]) as f32;
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([b(0), b(1)]) as f32;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = b(0) as f32;
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I8 => {
            let v = b(0) as i8 as f32;
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
    }
}

fn read_positions(acc: &gltf::Accessor, buffers: &[&[u8]]) -> Result<Vec<Vec3>, String> {
    if acc.dimensions() != Dimensions::Vec3 {
        return Err(format!("expected VEC3, found {:?}", acc.dimensions()));
    }
    if acc.sparse().is_some() {
        return read_sparse_positions(acc, buffers);
    }
    let ty = acc.data_type();
    let comp = acc.size() / 3;
    match accessor_bytes(acc, buffers)? {
        None => Ok(vec![Vec3::ZERO; bufferless_count(acc)?]),
        Some((data, stride, _)) => Ok((0..acc.count())
            .map(|i| {
                let e = &data[i * stride..];
                Vec3::new(
                    component(e, ty, acc.normalized()),
                    component(e.get(comp..).unwrap_or(&[]), ty, acc.normalized()),
                    component(e.get(2 * comp..).unwrap_or(&[]), ty, acc.normalized()),
                )
            })
            .collect()),
    }
}

/// Element count of an accessor without data (all zeros), bounded so that a bogus count cannot
/// exhaust memory.
fn bufferless_count(acc: &gltf::Accessor) -> Result<usize, String> {
    const MAX: usize = 1 << 26;
    if acc.count() > MAX {
        return Err(format!("accessor {} has {} elements but no data", acc.index(), acc.count()));
    }
    Ok(acc.count())
}

/// Sparse accessors go through the `gltf` crate's reader, guarded against its panics on bad data.
fn read_sparse_positions(acc: &gltf::Accessor, buffers: &[&[u8]]) -> Result<Vec<Vec3>, String> {
    if acc.data_type() != DataType::F32 {
        return Err("sparse POSITION must be FLOAT".into());
    }
    if acc.view().is_none() {
        bufferless_count(acc)?;
    } else {
        accessor_bytes(acc, buffers)?;
    }
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        gltf::accessor::Iter::<[f32; 3]>::new(acc.clone(), |b: gltf::Buffer| buffers.get(b.index()).copied())
            .map(|it| it.map(Vec3::from).collect::<Vec<_>>())
    }));
    match result {
        Ok(Some(v)) => Ok(v),
        _ => Err("malformed sparse accessor".into()),
    }
}

fn read_indices(acc: &gltf::Accessor, buffers: &[&[u8]]) -> Result<Vec<u32>, String> {
    if acc.dimensions() != Dimensions::Scalar {
        return Err(format!("expected SCALAR, found {:?}", acc.dimensions()));
    }
    if acc.sparse().is_some() {
        return Err("sparse index accessors are not supported".into());
    }
    let ty = acc.data_type();
    let Some((data, stride, _)) = accessor_bytes(acc, buffers)? else {
        return Ok(vec![0; bufferless_count(acc)?]);
    };
    let b = |i: usize| data.get(i).copied().unwrap_or(0);
    (0..acc.count())
        .map(|i| {
            let o = i * stride;
            match ty {
                DataType::U8 => Ok(b(o) as u32),
                DataType::U16 => Ok(u16::from_le_bytes([b(o), b(o + 1)]) as u32),
                DataType::U32 => Ok(u32::from_le_bytes([b(o), b(o + 1), b(o + 2), b(o + 3)])),
                other => Err(format!("index component type {other:?} is not allowed")),
            }
        })
        .collect()
}

/// `%XX` decoding of a relative URI; `None` when the result is not UTF-8 or an escape is broken.
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

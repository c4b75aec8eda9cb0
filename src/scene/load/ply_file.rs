//! PLY (ASCII, binary little and big endian) via `ply-rs-bw`.
//!
//! Read: element `vertex` properties `x y z` (any scalar type), element `face` list
//! `vertex_indices` or `vertex_index` (any integer type; polygons triangulated as fans). Ignored:
//! every other element and property (normals, colours, confidence, ...). Albedo is 0.7 grey.

use super::{Loaded, SceneError, DEFAULT_ALBEDO};
use crate::scene::Mesh;
use glam::Vec3;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{PropertyAccess, PropertyAccessResult};
use std::io::{BufReader, Read};
use std::path::Path;

const FORMAT: &str = "PLY";

#[derive(Default)]
struct Vertex {
    p: [f64; 3],
}

impl Vertex {
    fn set(&mut self, name: &str, v: f64) -> PropertyAccessResult {
        let i = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        self.p[i] = v;
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Vertex::default()
    }
    fn set_char(&mut self, n: &str, v: i8) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_uchar(&mut self, n: &str, v: u8) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_short(&mut self, n: &str, v: i16) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_ushort(&mut self, n: &str, v: u16) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_int(&mut self, n: &str, v: i32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_uint(&mut self, n: &str, v: u32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_float(&mut self, n: &str, v: f32) -> PropertyAccessResult {
        self.set(n, v as f64)
    }
    fn set_double(&mut self, n: &str, v: f64) -> PropertyAccessResult {
        self.set(n, v)
    }
}

/// A face's vertex list; `bad` records a negative index.
#[derive(Default)]
struct Face {
    idx: Vec<u32>,
    bad: bool,
}

impl Face {
    fn is_indices(name: &str) -> bool {
        name == "vertex_indices" || name == "vertex_index"
    }
    fn set<T: TryInto<u32> + Copy>(&mut self, name: &str, v: Vec<T>) -> PropertyAccessResult {
        if !Face::is_indices(name) {
            return PropertyAccessResult::Ignored;
        }
        self.idx.clear();
        for x in v {
            match x.try_into() {
                Ok(i) => self.idx.push(i),
                Err(_) => self.bad = true,
            }
        }
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Face::default()
    }
    fn set_list_char(&mut self, n: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uchar(&mut self, n: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_short(&mut self, n: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_ushort(&mut self, n: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_int(&mut self, n: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_uint(&mut self, n: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(n, v)
    }
    fn set_list_float(&mut self, n: &str, _v: Vec<f32>) -> PropertyAccessResult {
        if Face::is_indices(n) {
            PropertyAccessResult::UnsupportedType
        } else {
            PropertyAccessResult::Ignored
        }
    }
    fn set_list_double(&mut self, n: &str, _v: Vec<f64>) -> PropertyAccessResult {
        self.set_list_float(n, Vec::new())
    }
}

/// Elements we do not read.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

pub(crate) fn load(path: &Path) -> Result<Loaded, SceneError> {
    let file = std::fs::File::open(path).map_err(|e| SceneError::io(path, e))?;
    let mut reader = Reader::new(BufReader::with_capacity(1 << 16, file));
    let bad = |e: &dyn std::fmt::Display| {
        SceneError::parse(path, FORMAT, e.to_string().split_whitespace().collect::<Vec<_>>().join(" "))
    };
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| bad(&e))?;

    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut saw_vertex = false;
    for (name, def) in &header.elements {
        match name.as_str() {
            "vertex" => {
                for c in ["x", "y", "z"] {
                    if !def.properties.contains_key(c) {
                        return Err(bad(&format!("element 'vertex' has no property '{c}'")));
                    }
                }
                let verts =
                    Parser::<Vertex>::new().read_payload_for_element(&mut reader, def, &header).map_err(|e| bad(&e))?;
                positions = verts.iter().map(|v| Vec3::new(v.p[0] as f32, v.p[1] as f32, v.p[2] as f32)).collect();
                saw_vertex = true;
            }
            "face" => {
                if !def.properties.keys().any(|k| Face::is_indices(k)) {
                    return Err(bad(&"element 'face' has no list 'vertex_indices' or 'vertex_index'"));
                }
                let faces =
                    Parser::<Face>::new().read_payload_for_element(&mut reader, def, &header).map_err(|e| bad(&e))?;
                triangles.reserve(faces.len());
                for (i, f) in faces.iter().enumerate() {
                    if f.bad {
                        return Err(bad(&format!("face {i} has a negative vertex index")));
                    }
                    if f.idx.len() < 3 {
                        // Typically a vertex line read as a face: the header's counts are wrong.
                        return Err(bad(&format!(
                            "face {i} has {} vertices (a face needs at least 3; does the header's vertex \
                             count match the data?)",
                            f.idx.len()
                        )));
                    }
                    super::fan(&f.idx, &mut triangles);
                }
            }
            _ => {
                Parser::<Skip>::new().read_payload_for_element(&mut reader, def, &header).map_err(|e| bad(&e))?;
            }
        }
    }
    if !saw_vertex {
        return Err(bad(&"no 'vertex' element"));
    }
    // Data beyond the last element means the header's counts are lower than the file's contents
    // (ASCII: anything but white space; binary: any byte).
    let ascii = header.encoding == ply_rs_bw::ply::Encoding::Ascii;
    let mut extra = 0u64;
    let mut buf = [0u8; 1 << 12];
    let inner = reader.get_mut();
    loop {
        let n = inner.read(&mut buf).map_err(|e| SceneError::io(path, e))?;
        if n == 0 {
            break;
        }
        extra += buf[..n].iter().filter(|b| !ascii || !b.is_ascii_whitespace()).count() as u64;
    }
    if extra > 0 {
        let counts: Vec<String> = header.elements.iter().map(|(n, d)| format!("{} {n}", d.count)).collect();
        return Err(bad(&format!(
            "the file holds more data than its header declares ({}): {extra} {} left over",
            counts.join(", "),
            if ascii { "characters" } else { "bytes" }
        )));
    }
    let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("ply").to_string();
    Ok(Loaded {
        meshes: vec![Mesh { name, positions, triangles, albedo: DEFAULT_ALBEDO }],
        files: vec![path.to_path_buf()],
        ..Loaded::default()
    })
}

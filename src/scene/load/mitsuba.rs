//! Mitsuba 0.6 and Mitsuba 3 scene descriptions (`scene.xml`).
//!
//! Read: `<default>` parameters (`$name` substitution), `<shape>` of type `obj`, `ply`, `rectangle`,
//! `disk`, `cube`, `sphere` with their `toWorld`/`to_world` transforms and the diffuse reflectance of
//! their BSDF (by `<ref id>` or nested), the first `<sensor>` (perspective/thinlens: `fov` with
//! `fovAxis`/`fov_axis` and the film size, or `focalLength`; `toWorld` matrix or `lookat`;
//! near/far clip), the first light-like top-level `<emitter>` (`sun`/`sunsky` with a sun direction,
//! `directional`, `point`, `spot`) and area emitters nested in shapes. Ignored: integrators,
//! samplers, textures, other BSDF parameters, `<include>`, shape groups and instances.

use super::obj_file::Materials;
use super::{
    obj_file, parse_floats, ply_file, primitives, CameraSpec, Emitter, LightSpec, Loaded, SceneError, DEFAULT_ALBEDO,
};
use crate::scene::Mesh;
use glam::{Mat3, Mat4, Vec3};
use roxmltree::Node;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

const FORMAT: &str = "Mitsuba XML";

/// Parsing context: the file, its folder and the `<default>` values.
struct Ctx<'a, 'input> {
    path: &'a Path,
    dir: PathBuf,
    defaults: Vec<(String, String)>,
    bsdfs: HashMap<&'a str, Node<'a, 'input>>,
}

/// One shape to load; files are loaded in parallel.
enum Job {
    File { file: PathBuf, kind: &'static str, to_world: Mat4, albedo: Vec3, name: String, emission: Option<Vec3> },
    Built { mesh: Mesh, emission: Option<Vec3>, sphere: Option<(Vec3, f32)> },
}

pub(crate) fn load(xml_path: &Path) -> Result<Loaded, SceneError> {
    let bytes = std::fs::read(xml_path).map_err(|e| SceneError::io(xml_path, e))?;
    let text = String::from_utf8(bytes).map_err(|_| SceneError::parse(xml_path, FORMAT, "not UTF-8 text"))?;
    let doc = roxmltree::Document::parse(&text).map_err(|e| SceneError::parse(xml_path, FORMAT, e))?;
    let root = doc.root_element();
    if root.tag_name().name() != "scene" {
        return Err(SceneError::parse(
            xml_path,
            FORMAT,
            format!("the root element is <{}>, expected <scene>", root.tag_name().name()),
        ));
    }
    let mut ctx = Ctx {
        path: xml_path,
        dir: xml_path.parent().unwrap_or(Path::new(".")).to_path_buf(),
        defaults: Vec::new(),
        bsdfs: HashMap::new(),
    };
    for d in root.children().filter(|n| n.has_tag_name("default")) {
        if let (Some(n), Some(v)) = (d.attribute("name"), d.attribute("value")) {
            ctx.defaults.push((n.to_string(), v.to_string()));
        }
    }
    // Longest names first, so that `$resx` is not replaced by the value of `$res`.
    ctx.defaults.sort_by_key(|(n, _)| std::cmp::Reverse(n.len()));
    for b in root.descendants().filter(|n| n.has_tag_name("bsdf")) {
        if let Some(id) = b.attribute("id") {
            ctx.bsdfs.entry(id).or_insert(b);
        }
    }
    ctx.check_refs(root)?;

    let mut out = Loaded { files: vec![xml_path.to_path_buf()], ..Loaded::default() };
    let mut jobs = Vec::new();
    for (i, node) in root.children().filter(|n| n.is_element()).enumerate() {
        match node.tag_name().name() {
            "shape" => {
                if let Some(job) = ctx.shape(node, i)? {
                    jobs.push(job);
                }
            }
            "sensor" if out.camera.is_none() => out.camera = ctx.sensor(node)?,
            "emitter" if out.light.is_none() => out.light = ctx.emitter(node)?,
            "include" | "shapegroup" => {
                log::warn!("{}: <{}> is not supported; ignored", xml_path.display(), node.tag_name().name());
            }
            _ => {}
        }
    }

    use rayon::prelude::*;
    let parts: Vec<Result<Loaded, SceneError>> = jobs.into_par_iter().map(|job| ctx.run(job)).collect();
    for part in parts {
        out.merge(part?);
    }
    Ok(out)
}

impl<'a, 'input> Ctx<'a, 'input> {
    fn err(&self, node: Node, message: impl std::fmt::Display) -> SceneError {
        let pos = node.document().text_pos_at(node.range().start);
        SceneError::parse(self.path, FORMAT, format!("line {}: {message}", pos.row))
    }

    /// Every `<ref id>` names an element of the file, and no element reaches itself through refs
    /// (Mitsuba refuses both; following them would silently fall back to grey).
    fn check_refs(&self, root: Node<'a, 'input>) -> Result<(), SceneError> {
        let mut ids: HashMap<&str, Node> = HashMap::new();
        for n in root.descendants().filter(|n| n.is_element() && !n.has_tag_name("ref")) {
            if let Some(id) = n.attribute("id") {
                ids.entry(id).or_insert(n);
            }
        }
        for r in root.descendants().filter(|n| n.has_tag_name("ref")) {
            match r.attribute("id") {
                None => return Err(self.err(r, "<ref> without an id")),
                Some(id) if !ids.contains_key(id) => {
                    return Err(self.err(r, format!("<ref id=\"{id}\"> refers to nothing (no element has that id)")))
                }
                Some(_) => {}
            }
        }
        // Depth-first over the id graph (an element -> the ids its refs name), iteratively.
        #[derive(Clone, Copy, PartialEq)]
        enum Mark {
            Open,
            Done,
        }
        let refs_of = |n: Node<'a, 'input>| -> Vec<(&'a str, Node<'a, 'input>)> {
            n.descendants().filter(|c| c.has_tag_name("ref")).filter_map(|c| Some((c.attribute("id")?, c))).collect()
        };
        let mut mark: HashMap<&str, Mark> = HashMap::new();
        let mut starts: Vec<&str> = ids.keys().copied().collect();
        starts.sort_unstable();
        for start in starts {
            if mark.contains_key(start) {
                continue;
            }
            // (id, its refs, next ref to follow)
            let mut stack = vec![(start, refs_of(ids[start]), 0usize)];
            mark.insert(start, Mark::Open);
            while let Some(top) = stack.last_mut() {
                let Some(&(next, node)) = top.1.get(top.2) else {
                    mark.insert(top.0, Mark::Done);
                    stack.pop();
                    continue;
                };
                top.2 += 1;
                match mark.get(next) {
                    Some(Mark::Done) => {}
                    Some(Mark::Open) => {
                        let from = stack.iter().position(|(id, ..)| *id == next).unwrap_or(0);
                        let mut chain: Vec<&str> = stack[from..].iter().map(|(id, ..)| *id).collect();
                        chain.push(next);
                        return Err(self.err(
                            node,
                            format!("<ref id=\"{next}\"> makes a cycle of references: {}", chain.join(" -> ")),
                        ));
                    }
                    None => {
                        mark.insert(next, Mark::Open);
                        let refs = refs_of(ids[next]);
                        stack.push((next, refs, 0));
                    }
                }
            }
        }
        Ok(())
    }

    /// Attribute value with `$name` defaults substituted.
    fn attr(&self, node: Node, key: &str) -> Option<String> {
        let v = node.attribute(key)?;
        if !v.contains('$') {
            return Some(v.to_string());
        }
        let mut v = v.to_string();
        for (name, value) in &self.defaults {
            v = v.replace(&format!("${name}"), value);
        }
        Some(v)
    }

    /// The child element carrying property `names` (any spelling).
    fn prop<'n>(&self, node: Node<'n, 'input>, names: &[&str]) -> Option<Node<'n, 'input>> {
        node.children().filter(|c| c.is_element()).find(|c| c.attribute("name").is_some_and(|n| names.contains(&n)))
    }

    fn float(&self, node: Node, names: &[&str]) -> Result<Option<f32>, SceneError> {
        let Some(p) = self.prop(node, names) else { return Ok(None) };
        let v = self.attr(p, "value").unwrap_or_default();
        v.trim().parse::<f32>().map(Some).map_err(|_| self.err(p, format!("'{v}' is not a number")))
    }

    fn string(&self, node: Node, names: &[&str]) -> Option<String> {
        self.prop(node, names).and_then(|p| self.attr(p, "value"))
    }

    /// A 3-vector from `x y z` attributes or `value="x, y, z"`; missing attributes take `default`.
    fn vector(&self, node: Node, default: f32) -> Result<Vec3, SceneError> {
        if let Some(v) = self.attr(node, "value") {
            let f = parse_floats(&v).map_err(|e| self.err(node, e))?;
            return match f.len() {
                1 => Ok(Vec3::splat(f[0])),
                3 => Ok(Vec3::new(f[0], f[1], f[2])),
                n => Err(self.err(node, format!("expected 1 or 3 numbers, found {n}"))),
            };
        }
        let mut out = Vec3::splat(default);
        for (i, k) in ["x", "y", "z"].iter().enumerate() {
            if let Some(s) = self.attr(node, k) {
                out[i] = s.trim().parse::<f32>().map_err(|_| self.err(node, format!("{k}='{s}' is not a number")))?;
            }
        }
        Ok(out)
    }

    fn vec3_attr(&self, node: Node, key: &str) -> Result<Option<Vec3>, SceneError> {
        let Some(s) = self.attr(node, key) else { return Ok(None) };
        let f = parse_floats(&s).map_err(|e| self.err(node, e))?;
        if f.len() != 3 {
            return Err(self.err(node, format!("{key}: expected 3 numbers, found {}", f.len())));
        }
        Ok(Some(Vec3::new(f[0], f[1], f[2])))
    }

    /// An RGB value from `<rgb>`, `<srgb>`, `<spectrum>` or `<float>`; `None` for what cannot be
    /// reduced to a constant colour (textures, blackbody).
    fn spectrum(&self, node: Node) -> Option<Vec3> {
        let v = self.attr(node, "value")?;
        let v = v.trim();
        let rgb = |v: &str| -> Option<Vec3> {
            if let Some(hex) = v.strip_prefix('#') {
                let n = u32::from_str_radix(hex, 16).ok().filter(|_| hex.len() == 6)?;
                let c = |s: u32| ((n >> s) & 0xff) as f32 / 255.0;
                return Some(Vec3::new(c(16), c(8), c(0)));
            }
            let f = parse_floats(v).ok()?;
            match f.len() {
                1 => Some(Vec3::splat(f[0])),
                3 => Some(Vec3::new(f[0], f[1], f[2])),
                _ => None,
            }
        };
        let c = match node.tag_name().name() {
            "rgb" | "float" => rgb(v)?,
            "srgb" => {
                let c = rgb(v)?;
                let lin = |x: f32| if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) };
                Vec3::new(lin(c.x), lin(c.y), lin(c.z))
            }
            "spectrum" => {
                if v.contains(':') {
                    // "wavelength:value, ..." pairs: their mean value, grey.
                    let vals: Vec<f32> = v
                        .split(',')
                        .filter_map(|p| p.split(':').nth(1))
                        .filter_map(|x| x.trim().parse().ok())
                        .collect();
                    if vals.is_empty() {
                        return None;
                    }
                    Vec3::splat(vals.iter().sum::<f32>() / vals.len() as f32)
                } else {
                    rgb(v)?
                }
            }
            _ => return None,
        };
        c.is_finite().then_some(c)
    }

    /// A `<transform>` element: its children composed in order (each applied after the previous).
    fn transform(&self, node: Node) -> Result<Mat4, SceneError> {
        let mut m = Mat4::IDENTITY;
        for op in node.children().filter(|c| c.is_element()) {
            let t = match op.tag_name().name() {
                "matrix" => {
                    let v = self.attr(op, "value").unwrap_or_default();
                    let f = parse_floats(&v).map_err(|e| self.err(op, e))?;
                    match f.len() {
                        16 => Mat4::from_cols_slice(&f).transpose(),
                        9 => Mat4::from_mat3(Mat3::from_cols_slice(&f).transpose()),
                        n => return Err(self.err(op, format!("a matrix needs 16 or 9 numbers, found {n}"))),
                    }
                }
                "translate" => Mat4::from_translation(self.vector(op, 0.0)?),
                "scale" => Mat4::from_scale(self.vector(op, 1.0)?),
                "rotate" => {
                    let axis = match self.vec3_attr(op, "axis")? {
                        Some(a) => a,
                        None => self.vector(op, 0.0)?,
                    };
                    let angle: f32 = self
                        .attr(op, "angle")
                        .unwrap_or_default()
                        .trim()
                        .parse()
                        .map_err(|_| self.err(op, "rotate needs a numeric angle"))?;
                    let axis = axis.try_normalize().ok_or_else(|| self.err(op, "rotate needs a non-zero axis"))?;
                    Mat4::from_axis_angle(axis, angle.to_radians())
                }
                "lookat" => {
                    let origin = self.vec3_attr(op, "origin")?.unwrap_or(Vec3::ZERO);
                    let target = self.vec3_attr(op, "target")?.unwrap_or(Vec3::Z);
                    let up = self.vec3_attr(op, "up")?.unwrap_or(Vec3::Y);
                    let dir =
                        (target - origin).try_normalize().ok_or_else(|| self.err(op, "lookat: origin = target"))?;
                    let left = up
                        .cross(dir)
                        .try_normalize()
                        .ok_or_else(|| self.err(op, "lookat: up is parallel to the view"))?;
                    let new_up = dir.cross(left);
                    Mat4::from_cols(left.extend(0.0), new_up.extend(0.0), dir.extend(0.0), origin.extend(1.0))
                }
                other => {
                    log::warn!("{}: transform <{other}> ignored", self.path.display());
                    Mat4::IDENTITY
                }
            };
            m = t * m;
        }
        if !m.is_finite() {
            return Err(self.err(node, "the transform is not finite"));
        }
        Ok(m)
    }

    fn to_world(&self, node: Node) -> Result<Mat4, SceneError> {
        // The last one wins when a shape repeats it (the classroom does, with identical values).
        match node.children().rev().find(|c| c.is_element() && c.has_tag_name("transform")) {
            Some(t) => self.transform(t),
            None => Ok(Mat4::IDENTITY),
        }
    }

    /// Diffuse reflectance of a BSDF, looking through wrappers (`twosided`, `mask`, `bumpmap`, refs).
    fn bsdf_albedo(&self, node: Node, depth: u32) -> Option<Vec3> {
        if depth > 8 {
            return None;
        }
        if node.has_tag_name("ref") {
            let b = self.bsdfs.get(node.attribute("id")?)?;
            return self.bsdf_albedo(*b, depth + 1);
        }
        const NAMES: [&str; 5] =
            ["reflectance", "diffuseReflectance", "diffuse_reflectance", "base_color", "baseColor"];
        if let Some(p) = self.prop(node, &NAMES) {
            return self.spectrum(p);
        }
        node.children()
            .filter(|c| c.has_tag_name("bsdf") || c.has_tag_name("ref"))
            .find_map(|c| self.bsdf_albedo(c, depth + 1))
    }

    fn shape_albedo(&self, shape: Node) -> Vec3 {
        shape
            .children()
            .filter(|c| c.has_tag_name("bsdf") || c.has_tag_name("ref"))
            .find_map(|c| self.bsdf_albedo(c, 0))
            // Out of [0, 1] is refused by the scene's validation, naming the shape.
            .unwrap_or(DEFAULT_ALBEDO)
    }

    fn shape(&self, node: Node, index: usize) -> Result<Option<Job>, SceneError> {
        let ty = node.attribute("type").unwrap_or("");
        let to_world = self.to_world(node)?;
        let albedo = self.shape_albedo(node);
        // `Some(ZERO)` marks an area emitter whose power is unknown (estimated later).
        let emission = match node.children().find(|c| c.has_tag_name("emitter")) {
            Some(e) if e.attribute("type") == Some("area") => {
                let r = self.prop(e, &["radiance"]).and_then(|p| self.spectrum(p));
                if let Some(r) = r {
                    crate::params::Light::RADIANCE.check_rgb(r).map_err(|err| self.err(e, err))?;
                }
                if r.is_none() {
                    log::warn!(
                        "{}: area emitter without a constant radiance; its power is estimated",
                        self.path.display()
                    );
                }
                Some(r.unwrap_or(Vec3::ZERO))
            }
            Some(e) => {
                log::warn!(
                    "{}: emitter type '{}' on a shape ignored",
                    self.path.display(),
                    e.attribute("type").unwrap_or("?")
                );
                None
            }
            None => None,
        };
        let name = node.attribute("id").map(str::to_string);
        let label = |what: &str| name.clone().unwrap_or_else(|| format!("{what}{index}"));
        let built = |mut mesh: Mesh| {
            mesh.transform(to_world);
            Job::Built { mesh, emission, sphere: None }
        };
        Ok(Some(match ty {
            "obj" | "ply" => {
                let Some(file) = self.string(node, &["filename"]) else {
                    return Err(self.err(node, format!("<shape type=\"{ty}\"> has no filename")));
                };
                Job::File {
                    file: self.dir.join(&file),
                    kind: if ty == "obj" { "obj" } else { "ply" },
                    to_world,
                    albedo,
                    name: name.clone().unwrap_or(file),
                    emission,
                }
            }
            "rectangle" => built(primitives::rectangle(&label("rectangle"), albedo)),
            "disk" => built(primitives::disk(&label("disk"), 48, albedo)),
            "cube" => built(primitives::cube(&label("cube"), 1.0, albedo)),
            "sphere" => {
                let center = match self.prop(node, &["center"]) {
                    Some(p) => self.vector(p, 0.0)?,
                    None => Vec3::ZERO,
                };
                let radius = self.float(node, &["radius"])?.unwrap_or(1.0);
                if !(radius > 0.0 && radius.is_finite()) {
                    return Err(self.err(node, format!("sphere radius = {radius} must be > 0")));
                }
                let mut mesh = primitives::sphere(&label("sphere"), center, radius, 24, 48, albedo);
                mesh.transform(to_world);
                let c = to_world.transform_point3(center);
                let r = radius * to_world.transform_vector3(Vec3::X).length();
                Job::Built { mesh, emission, sphere: Some((c, r)) }
            }
            other => {
                log::warn!("{}: <shape type=\"{other}\"> is not supported; skipped", self.path.display());
                return Ok(None);
            }
        }))
    }

    fn run(&self, job: Job) -> Result<Loaded, SceneError> {
        let (mut loaded, emission, sphere) = match job {
            Job::File { file, kind, to_world, albedo, name, emission } => {
                let mut l = match kind {
                    "obj" => obj_file::load(&file, Materials::Fixed(albedo)),
                    _ => ply_file::load(&file),
                }
                .map_err(|e| SceneError::referenced(self.path, format!("shape '{name}'"), e))?;
                let single = l.meshes.len() == 1;
                for m in &mut l.meshes {
                    m.albedo = albedo;
                    m.name = if single { name.clone() } else { format!("{name}/{}", m.name) };
                }
                l.transform(to_world);
                (l, emission, None)
            }
            Job::Built { mesh, emission, sphere } => {
                (Loaded { meshes: vec![mesh], ..Loaded::default() }, emission, sphere)
            }
        };
        if let Some(r) = emission {
            let meshes = std::mem::take(&mut loaded.meshes);
            let name = meshes.first().map(|m| m.name.clone()).unwrap_or_default();
            let albedo = meshes.first().map(|m| m.albedo).unwrap_or(DEFAULT_ALBEDO);
            let triangles = meshes
                .iter()
                .flat_map(|m| {
                    m.triangles.iter().filter_map(|t| {
                        Some([
                            *m.positions.get(t[0] as usize)?,
                            *m.positions.get(t[1] as usize)?,
                            *m.positions.get(t[2] as usize)?,
                        ])
                    })
                })
                .collect();
            let known = r.max_element() > 0.0;
            loaded.emitters.push(Emitter {
                name,
                triangles,
                color: if known { r } else { Vec3::ONE },
                radiance: known.then_some(r),
                along_normal: true,
                sphere,
                albedo,
            });
        }
        Ok(loaded)
    }

    fn sensor(&self, node: Node) -> Result<Option<CameraSpec>, SceneError> {
        let ty = node.attribute("type").unwrap_or("");
        if !matches!(ty, "perspective" | "thinlens") {
            log::warn!("{}: sensor type '{ty}' is not supported; the camera is framed instead", self.path.display());
            return Ok(None);
        }
        let m = self.to_world(node)?;
        let (mut w, mut h) = (768.0f32, 576.0f32);
        if let Some(film) = node.children().find(|c| c.has_tag_name("film")) {
            let int = |names: &[&str]| -> Result<Option<f32>, SceneError> {
                let Some(p) = self.prop(film, names) else { return Ok(None) };
                let v = self.attr(p, "value").unwrap_or_default();
                v.trim().parse::<f32>().map(Some).map_err(|_| self.err(p, format!("'{v}' is not a number")))
            };
            w = int(&["width"])?.unwrap_or(w);
            h = int(&["height"])?.unwrap_or(h);
        }
        if !(w > 0.0 && h > 0.0) {
            return Err(self.err(node, "the film size must be positive"));
        }
        let (fov, axis) = match self.float(node, &["fov"])? {
            Some(f) => (f, self.string(node, &["fovAxis", "fov_axis"]).unwrap_or_else(|| "x".into())),
            None => {
                let f = match self.string(node, &["focalLength", "focal_length"]) {
                    Some(s) => s
                        .trim()
                        .trim_end_matches("mm")
                        .parse::<f32>()
                        .map_err(|_| self.err(node, format!("focal length '{s}' is not a number")))?,
                    None => 50.0,
                };
                // 35 mm film equivalent, measured along the diagonal (as Mitsuba does).
                ((36.0f32.hypot(24.0) / (2.0 * f)).atan().to_degrees() * 2.0, "diagonal".into())
            }
        };
        let t = (fov.to_radians() * 0.5).tan();
        let ty_half = match axis.as_str() {
            "x" => t * h / w,
            "y" => t,
            "diagonal" => t * h / w.hypot(h),
            "smaller" => {
                if w < h {
                    t * h / w
                } else {
                    t
                }
            }
            "larger" => {
                if w > h {
                    t * h / w
                } else {
                    t
                }
            }
            other => return Err(self.err(node, format!("unknown fov axis '{other}'"))),
        };
        Ok(Some(CameraSpec {
            eye: Some(m.transform_point3(Vec3::ZERO)),
            target: None,
            dir: Some(m.transform_vector3(Vec3::Z)),
            up: Some(m.transform_vector3(Vec3::Y)),
            fov_y_deg: Some(2.0 * ty_half.atan().to_degrees()),
            near: self.float(node, &["nearClip", "near_clip"])?,
            far: self.float(node, &["farClip", "far_clip"])?,
        }))
    }

    fn emitter(&self, node: Node) -> Result<Option<LightSpec>, SceneError> {
        let ty = node.attribute("type").unwrap_or("");
        let m = self.to_world(node)?;
        let spectrum = |names: &[&str]| self.prop(node, names).and_then(|p| self.spectrum(p));
        Ok(match ty {
            "sun" | "sunsky" => match self.prop(node, &["sunDirection", "sun_direction"]) {
                Some(p) => Some(LightSpec::Directional {
                    direction: m.transform_vector3(self.vector(p, 0.0)?),
                    irradiance: None,
                }),
                None => {
                    log::warn!(
                        "{}: {ty} without a sun direction (time/place are not evaluated); ignored",
                        self.path.display()
                    );
                    None
                }
            },
            "directional" => {
                let travel = match self.prop(node, &["direction"]) {
                    Some(p) => self.vector(p, 0.0)?,
                    None => m.transform_vector3(Vec3::Z),
                };
                Some(LightSpec::Directional { direction: -travel, irradiance: spectrum(&["irradiance"]) })
            }
            "point" | "spot" => {
                if ty == "spot" {
                    log::warn!("{}: spot light treated as a point light", self.path.display());
                }
                let position = match self.prop(node, &["position"]) {
                    Some(p) => self.vector(p, 0.0)?,
                    None => m.transform_point3(Vec3::ZERO),
                };
                Some(LightSpec::Point { position: Some(position), intensity: spectrum(&["intensity"]), radius: 0.0 })
            }
            other => {
                log::warn!("{}: emitter type '{other}' ignored", self.path.display());
                None
            }
        })
    }
}

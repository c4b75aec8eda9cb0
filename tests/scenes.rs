//! Scene loading: the shared third-party scenes, the built-in scene, the example scene file, and
//! malformed input (every failure must be an error naming the file and the problem, never a panic).
//!
//! The shared scenes are read from `../shared/scenes` beside the repository (or from
//! `$EPIVOX_SHARED_SCENES`); when that folder is missing those tests print a note and pass.

use epivox::scene::{builtin_scene, load_scene, Aabb, Scene};
use epivox::{Grid, Light, Phase};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;

fn shared(rel: &str) -> Option<PathBuf> {
    let root = std::env::var_os("EPIVOX_SHARED_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes"));
    let p = root.join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("note: {} not found; test skipped", p.display());
        None
    }
}

fn load_timed(path: &Path) -> Scene {
    let t = Instant::now();
    let scene = load_scene(path).unwrap_or_else(|e| panic!("{e}"));
    eprintln!(
        "{}: {} meshes, {} triangles, loaded in {:.1} ms",
        path.display(),
        scene.meshes.len(),
        scene.triangle_count(),
        t.elapsed().as_secs_f64() * 1e3
    );
    scene
}

fn close(a: Vec3, b: Vec3, tol: f32) -> bool {
    (a - b).length() <= tol
}

fn forward(s: &Scene) -> Vec3 {
    (s.camera.target - s.camera.eye).normalize()
}

/// True when the open segment `a -> b` crosses a triangle of the scene (brute force).
fn occluded(s: &Scene, a: Vec3, b: Vec3) -> bool {
    let d = b - a;
    s.world_triangles().any(|([p0, p1, p2], _)| {
        let (e1, e2) = (p1 - p0, p2 - p0);
        let h = d.cross(e2);
        let det = e1.dot(h);
        if det.abs() < 1e-12 {
            return false;
        }
        let f = 1.0 / det;
        let s0 = a - p0;
        let u = f * s0.dot(h);
        let q = s0.cross(e1);
        let v = f * d.dot(q);
        let t = f * e2.dot(q);
        (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 1e-4 && t < 1.0 - 1e-4
    })
}

// ---------------------------------------------------------------------------------------------
// Shared scenes
// ---------------------------------------------------------------------------------------------

#[test]
fn cornell_box_gltf() {
    let Some(p) = shared("cornell_box/CornellBox-Original.gltf") else { return };
    let s = load_timed(&p);
    // 32 triangles minus the 2 of the emissive `Light` quad, which became the light.
    assert_eq!(s.triangle_count(), 30);
    assert_eq!(s.name, "CornellBox-Original");
    // One mesh per primitive, named by material; the `Light` quad is gone.
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    assert!(names.contains(&"CornellBox-Original/leftWall"), "{names:?}");
    assert!(!names.iter().any(|n| n.ends_with("/Light")), "{names:?}");
    let b = s.bounds();
    // The node's +90 degree rotation about X makes the box Y-up: floor at 0, ceiling at 1.99.
    assert!(close(b.min, Vec3::new(-1.02, 0.0, -1.04), 0.01), "{b:?}");
    assert!(close(b.max, Vec3::new(1.0, 1.99, 0.99), 0.01), "{b:?}");
    let Light::Point { position, intensity, radius } = s.light else { panic!("{:?}", s.light) };
    // Just under the light quad (y = 1.98), 2% of the height below it, inside the box.
    assert!(close(position, Vec3::new(-0.005, 1.94, -0.03), 0.02), "{position}");
    assert!(b.contains(position));
    assert!(intensity.min_element() > 0.0 && radius == 0.0);
    // The framed camera looks into the open (+Z) side.
    assert!(s.camera.eye.z > b.max.z && forward(&s).z < 0.0);
    s.validate().unwrap();
}

#[test]
fn stanford_bunny_ply() {
    let Some(p) = shared("stanford_bunny/bun_zipper.ply") else { return };
    let s = load_timed(&p);
    assert_eq!(s.triangle_count(), 69_451);
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.meshes[0].positions.len(), 35_947);
    let b = s.bounds();
    assert!(close(b.min, Vec3::new(-0.0947, 0.0330, -0.0619), 1e-3), "{b:?}");
    assert!(close(b.max, Vec3::new(0.0610, 0.1873, 0.0588), 1e-3), "{b:?}");
    // Defaults: framed camera outside the bunny, point light above it, medium scaled to its size.
    assert!(!b.contains(s.camera.eye));
    let Light::Point { position, .. } = s.light else { panic!() };
    assert!(position.y > b.max.y);
    let diag = b.extent().length();
    assert!((s.medium.sigma_s().x * diag - 1.0).abs() < 0.05, "{:?}", s.medium);
}

#[test]
fn stanford_bunny_folder_loads_every_ply() {
    let Some(p) = shared("stanford_bunny") else { return };
    let s = load_timed(&p);
    assert_eq!(s.name, "stanford_bunny");
    assert_eq!(s.meshes.len(), 4);
    assert_eq!(s.triangle_count(), 69_451 + 16_301 + 3_851 + 948);
    // Sorted by file name.
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["bun_zipper", "bun_zipper_res2", "bun_zipper_res3", "bun_zipper_res4"]);
}

#[test]
fn japanese_classroom_mitsuba() {
    let Some(p) = shared("japanese_classroom") else { return };
    let t = Instant::now();
    let s = load_timed(&p);
    assert!(t.elapsed().as_secs_f64() < 10.0, "loading took {:?}", t.elapsed());
    assert_eq!(s.name, "japanese_classroom");
    // 103 832 in the files, of which 2 have zero area and are dropped at load.
    assert_eq!(s.triangle_count(), 103_830);
    assert_eq!(s.meshes.len(), 79);
    // Sun: directional, toward the sun, default irradiance.
    let Light::Directional { direction, irradiance } = s.light else { panic!("{:?}", s.light) };
    assert!(close(direction, Vec3::new(-0.865804, 0.416766, -0.276929), 1e-5), "{direction}");
    assert_eq!(irradiance, Vec3::splat(3.0));
    // Camera from the toWorld matrix: eye = translation, forward = third column, up = second.
    let c = s.camera;
    assert!(close(c.eye, Vec3::new(-1.69049, 1.27158, 5.88653), 1e-4), "{c:?}");
    assert!(close(forward(&s), Vec3::new(0.151294, 0.0283071, -0.988083), 1e-4), "{c:?}");
    assert!(close(c.up.normalize(), Vec3::new(-0.00428443, 0.999599, 0.027981), 1e-4), "{c:?}");
    // fov 60 is horizontal (fovAxis x) at 1280 x 720.
    let expect = 2.0 * ((30.0f32).to_radians().tan() * 720.0 / 1280.0).atan().to_degrees();
    assert!((c.fov_y_deg - expect).abs() < 1e-3, "{} vs {expect}", c.fov_y_deg);
    assert!((c.fov_y_deg - 35.98).abs() < 0.01);
    // The shapes' toWorld transforms are applied: Mesh035 (the ground) is scaled by 11.6517.
    let ground = s.meshes.iter().find(|m| m.name == "models/Mesh035.obj").unwrap().bounds();
    assert!((ground.max.x - 9.510313 * 11.6517).abs() < 1e-2, "{ground:?}");
    // ... and Mesh049 is moved down by 0.0734223.
    let boxes = s.meshes.iter().find(|m| m.name == "models/Mesh049.obj").unwrap().bounds();
    assert!((boxes.min.y - 0.2771177).abs() < 1e-4, "{boxes:?}");
    // Materials: the walls' diffuse reflectance.
    let wall = s.meshes.iter().find(|m| m.name == "models/Mesh036.obj").unwrap();
    assert!(close(wall.albedo, Vec3::new(0.654071, 0.67408, 0.8), 1e-5));
    // The camera sits inside the classroom, with sane clip planes.
    assert!(c.near > 0.0 && c.near < 0.1 && c.far > 100.0);
}

#[test]
fn veach_bidir_room_mitsuba3() {
    let Some(p) = shared("veach_bidir_room") else { return };
    let s = load_timed(&p);
    // The 12 OBJ files; the two `rectangle` area emitters are not geometry.
    assert_eq!(s.triangle_count(), 11_540);
    assert_eq!(s.meshes.len(), 12);
    // `$resx`/`$resy` defaults give a square film, so fov 35 (x) is also the vertical fov.
    let c = s.camera;
    assert!((c.fov_y_deg - 35.0).abs() < 1e-3, "{c:?}");
    assert!(close(c.eye, Vec3::new(16.2155, 4.05167, 0.0114864), 1e-4));
    assert!(close(forward(&s), Vec3::new(-0.999977, -0.00467011, -0.00502464), 1e-4));
    // The brighter of the two emitters (radiance x area) becomes a point light just in front of it:
    // the small lamp on the wall, (12048, 8606, 6196) x 0.0185 / 4 W/sr.
    let Light::Point { position, intensity, .. } = s.light else { panic!("{:?}", s.light) };
    assert!(close(position, Vec3::new(-2.69082, 5.10417, -3.77057), 0.15), "{position}");
    assert!(close(intensity, Vec3::new(55.7, 39.8, 28.6), 0.5), "{intensity}");
    // Inside the room (8 x 8 x 8).
    assert!(Aabb { min: Vec3::new(-4.0, 0.0, -4.0), max: Vec3::splat(4.0) + Vec3::Y * 4.0 }.contains(position));
    // Materials by reference: the wood.
    let wood = s.meshes.iter().find(|m| m.name == "Wood").unwrap();
    assert!(close(wood.albedo, Vec3::new(0.32963, 0.257976, 0.150292), 1e-5));
}

// ---------------------------------------------------------------------------------------------
// Built-in and example scenes
// ---------------------------------------------------------------------------------------------

#[test]
fn builtin_scene_is_a_closed_room_lit_through_a_window() {
    let s = builtin_scene();
    s.validate().unwrap();
    assert_eq!(s.name, "built-in");
    assert!(s.source.is_none());
    assert_eq!(s, builtin_scene(), "deterministic");
    let n = s.triangle_count();
    assert!((2_000..20_000).contains(&n), "{n} triangles");
    let interior = Aabb { min: Vec3::new(-4.0, 0.0, -4.0), max: Vec3::new(4.0, 4.0, 4.0) };
    let outer = Aabb { min: interior.min - Vec3::splat(0.2), max: interior.max + Vec3::splat(0.2) };
    assert!(
        s.bounds().min.cmpge(outer.min - Vec3::splat(1e-4)).all()
            && s.bounds().max.cmple(outer.max + Vec3::splat(1e-4)).all()
    );
    let Light::Point { position, radius, intensity } = s.light else { panic!("{:?}", s.light) };
    assert!(!outer.contains(position), "the light must be outside the room: {position}");
    assert_eq!(radius, 0.0);
    assert!(intensity.min_element() > 0.0);
    assert!(interior.contains(s.camera.eye) && interior.contains(s.camera.target));
    // Light reaches the room through a pane of the window (between bars, above the crossbar) ...
    assert!(!occluded(&s, position, Vec3::new(4.1, 3.0, -0.25)));
    // ... but not through the walls or the ceiling.
    for p in [Vec3::new(0.0, 2.0, 3.9), Vec3::new(3.9, 1.0, 3.0), Vec3::new(0.0, 3.9, 0.0), Vec3::new(3.9, 2.0, -3.0)] {
        assert!(occluded(&s, position, p), "{p} is lit directly");
    }
    // The light itself is hidden from the camera.
    assert!(occluded(&s, position, s.camera.eye));
    assert!(!s.medium.is_clear());
}

#[test]
fn example_scene_file_loads() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/example.scene.toml");
    let s = load_timed(&p);
    assert_eq!(s.name, "grating");
    let names: Vec<&str> = s.meshes.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["plane", "grating", "sphere"]);
    assert_eq!(s.camera.eye, Vec3::new(5.0, 0.9, 4.0));
    assert_eq!(s.camera.fov_y_deg, 45.0);
    assert_eq!(s.light, Light::Point { position: Vec3::new(0.4, 4.6, 0.2), intensity: Vec3::splat(60.0), radius: 0.0 });
    assert_eq!(s.medium.scattering, Vec3::splat(0.08));
    assert_eq!(s.medium.density, 1.0);
    assert_eq!(s.medium.phase, Phase::HenyeyGreenstein { g: 0.3 });
    assert_eq!(s.grid, Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() });
    // The grating (2 rails + 5 slats = 7 boxes) is raised to y = 2.2 and keeps the given albedo.
    let g = &s.meshes[1];
    assert_eq!(g.triangles.len(), 7 * 12);
    assert_eq!(g.albedo, Vec3::splat(0.3));
    assert!((g.bounds().min.y - 2.2).abs() < 1e-5);
    // The plane is 10 x 10 at y = 0.
    let b = s.meshes[0].bounds();
    assert!(close(b.min, Vec3::new(-5.0, 0.0, -5.0), 1e-5) && close(b.max, Vec3::new(5.0, 0.0, 5.0), 1e-5), "{b:?}");
}

// ---------------------------------------------------------------------------------------------
// Small synthetic files in every format
// ---------------------------------------------------------------------------------------------

fn write(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

fn tmp() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// Base64 without padding issues, for glTF data URIs.
fn base64(bytes: &[u8]) -> String {
    const T: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= c.len() {
                s.push(T[(n >> (18 - 6 * i)) as usize & 63] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// One triangle (positions f32 + u16 indices) as a glTF buffer.
fn triangle_buffer(p: [[f32; 3]; 3]) -> (String, usize) {
    let mut bytes = Vec::new();
    for v in p.iter().flatten() {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    (format!("data:application/octet-stream;base64,{}", base64(&bytes)), bytes.len())
}

fn gltf_json(extra_nodes: &str, materials: &str, extensions: &str, uri: &str, len: usize) -> String {
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0{extra_nodes_idx}]}}],
  "nodes": [{{"mesh": 0, "translation": [0, 0, -5], "name": "tri"}}{extra_nodes}],
  "meshes": [{{"name": "tri", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "materials": [{materials}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}},
    {{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
    {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}
  ],
  "buffers": [{{"byteLength": {len}, "uri": "{uri}"}}]{extensions}
}}"#,
        extra_nodes_idx = if extra_nodes.is_empty() { "" } else { ", 1, 2" },
    )
}

#[test]
fn gltf_transforms_camera_and_punctual_light() {
    let d = tmp();
    let (uri, len) = triangle_buffer([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let nodes = r#", {"camera": 0, "translation": [0, 1, 3]},
        {"translation": [0, 4, 0], "extensions": {"KHR_lights_punctual": {"light": 0}}}"#;
    let ext = r#",
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 50}}],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "color": [1, 0.5, 0.5], "intensity": 10}]}}"#;
    let mat = r#"{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1]}}"#;
    let p = write(d.path(), "one.gltf", gltf_json(nodes, mat, ext, &uri, len).as_bytes());
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.triangle_count(), 1);
    assert_eq!(s.meshes[0].positions[1], Vec3::new(1.0, 0.0, -5.0));
    assert_eq!(s.meshes[0].albedo, Vec3::new(0.8, 0.1, 0.1));
    assert_eq!(s.camera.eye, Vec3::new(0.0, 1.0, 3.0));
    assert!(close(forward(&s), -Vec3::Z, 1e-6));
    assert!((s.camera.fov_y_deg - 0.8f32.to_degrees()).abs() < 1e-4);
    assert_eq!((s.camera.near, s.camera.far), (0.05, 50.0));
    assert_eq!(
        s.light,
        Light::Point { position: Vec3::new(0.0, 4.0, 0.0), intensity: Vec3::new(10.0, 5.0, 5.0), radius: 0.0 }
    );
}

#[test]
fn gltf_emissive_material_becomes_the_light() {
    let d = tmp();
    let (uri, len) = triangle_buffer([[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [0.0, 2.0, 1.0]]);
    // Two primitives of the same buffer: an emissive one and a plain one.
    let json = gltf_json("", r#"{"name": "lamp", "emissiveFactor": [1, 1, 0.5]}"#, "", &uri, len).replace(
        r#""primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]"#,
        r#""primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}, {"attributes": {"POSITION": 0}, "indices": 1, "material": 1}]"#,
    ).replace(r#"{"name": "lamp", "emissiveFactor": [1, 1, 0.5]}"#, r#"{"name": "lamp", "emissiveFactor": [1, 1, 0.5]}, {"name": "plain"}"#);
    let p = write(d.path(), "lamp.gltf", json.as_bytes());
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.triangle_count(), 1, "the emissive triangle is not a caster");
    let Light::Point { position, intensity, .. } = s.light else { panic!() };
    // Below the emitter's centroid (0, 2, -5 - 1/3) along -Y; colour follows the emission.
    assert!((position.x).abs() < 1e-5 && position.y < 2.0 && (position.z + 5.0 + 1.0 / 3.0).abs() < 1e-4, "{position}");
    assert!((intensity.z / intensity.x - 0.5).abs() < 1e-5);
}

#[test]
fn obj_with_mtl_quads_and_missing_mtl() {
    let d = tmp();
    write(d.path(), "m.mtl", b"newmtl blue\nKd 0.1 0.2 0.9\n");
    let obj = b"mtllib m.mtl\no quad\nusemtl blue\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let p = write(d.path(), "quad.obj", obj);
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(s.meshes[0].albedo, Vec3::new(0.1, 0.2, 0.9));
    // A missing MTL is only a warning: grey.
    let p = write(d.path(), "nomtl.obj", b"mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.meshes[0].albedo, Vec3::splat(0.7));
}

#[test]
fn ply_binary_and_polygons() {
    let d = tmp();
    // Little endian, double coordinates, int indices, an extra property and a quad.
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
    for v in [[0.0f64, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
        b.push(255);
    }
    b.push(4);
    for i in [0i32, 1, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let p = write(d.path(), "quad.ply", &b);
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.triangle_count(), 2);
    assert_eq!(s.meshes[0].positions[2], Vec3::new(1.0, 1.0, 0.0));
    // Big endian, float coordinates, `vertex_index`, uint indices.
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar uint vertex_index\nend_header\n".to_vec();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]] {
        for c in v {
            b.extend_from_slice(&c.to_be_bytes());
        }
    }
    b.push(3);
    for i in [0u32, 1, 2] {
        b.extend_from_slice(&i.to_be_bytes());
    }
    let p = write(d.path(), "tri.ply", &b);
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.triangle_count(), 1);
    assert_eq!(s.meshes[0].positions[2], Vec3::new(0.0, 0.0, 1.0));
}

#[test]
fn mitsuba_lookat_fov_axis_point_light_and_primitives() {
    let d = tmp();
    write(d.path(), "tri.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let xml = r#"<scene version="3.0.0">
  <default name="h" value="600"/>
  <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.2, 0.3, 0.4"/></bsdf>
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <string name="fov_axis" value="y"/>
    <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="800"/><integer name="height" value="$h"/></film>
  </sensor>
  <shape type="obj"><string name="filename" value="tri.obj"/>
    <transform name="to_world"><scale value="2"/><translate x="1"/></transform>
    <ref id="grey"/></shape>
  <shape type="cube"><transform name="to_world"><scale value="0.5"/></transform></shape>
  <shape type="sphere"><point name="center" x="0" y="3" z="0"/><float name="radius" value="0.25"/>
    <emitter type="area"><rgb name="radiance" value="10"/></emitter></shape>
  <emitter type="point"><point name="position" value="0, 5, 0"/><rgb name="intensity" value="7, 8, 9"/></emitter>
</scene>"#;
    let p = write(d.path(), "scene.xml", xml.as_bytes());
    // Loaded through its folder.
    let s = load_scene(d.path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.camera.eye, Vec3::new(0.0, 0.0, 5.0));
    assert!(close(forward(&s), -Vec3::Z, 1e-6));
    assert!((s.camera.fov_y_deg - 50.0).abs() < 1e-4);
    // Scale then translate: (1, 0, 0) -> (3, 0, 0).
    let tri = s.meshes.iter().find(|m| m.name == "tri.obj").unwrap();
    assert_eq!(tri.positions[1], Vec3::new(3.0, 0.0, 0.0));
    assert_eq!(tri.albedo, Vec3::new(0.2, 0.3, 0.4));
    // The explicit point light wins; the emissive sphere stays geometry.
    assert_eq!(
        s.light,
        Light::Point { position: Vec3::new(0.0, 5.0, 0.0), intensity: Vec3::new(7.0, 8.0, 9.0), radius: 0.0 }
    );
    assert_eq!(s.meshes.len(), 3);
    assert_eq!(s.triangle_count(), 1 + 12 + s.meshes[2].triangles.len());
    // The file itself loads the same.
    assert_eq!(load_scene(&p).unwrap().triangle_count(), s.triangle_count());

    // Without the point light the sphere emitter becomes the light, at its centre with its radius.
    let xml2 = xml.replace(r#"<emitter type="point"><point name="position" value="0, 5, 0"/><rgb name="intensity" value="7, 8, 9"/></emitter>"#, "");
    let p2 = write(d.path(), "sphere_lit.xml", xml2.as_bytes());
    let s2 = load_scene(&p2).unwrap_or_else(|e| panic!("{e}"));
    let Light::Point { position, intensity, radius } = s2.light else { panic!() };
    assert_eq!(position, Vec3::new(0.0, 3.0, 0.0));
    assert_eq!(radius, 0.25);
    // pi L r^2 = the power (pi L 4 pi r^2) over 4 pi sr.
    assert!((intensity.x - std::f32::consts::PI * 10.0 * 0.0625).abs() < 1e-4, "{intensity}");
    assert_eq!(s2.meshes.len(), 2);
}

#[test]
fn scene_file_defaults_and_builtins() {
    let d = tmp();
    let p = write(
        d.path(),
        "minimal.scene.toml",
        b"format = 1\n[[mesh]]\nbuiltin = \"box\"\n[[mesh]]\nbuiltin = \"sphere\"\ntranslate = [0, 2, 0]\nscale = [1, 2, 1]\n",
    );
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.name, "minimal");
    assert_eq!(s.meshes.len(), 2);
    let b = s.bounds();
    assert!(close(b.min, Vec3::splat(-0.5), 1e-5) && close(b.max, Vec3::new(0.5, 3.0, 0.5), 1e-5), "{b:?}");
    // Camera framed, point light above, medium scaled, grid default, near/far from the bounds.
    assert!(!b.contains(s.camera.eye));
    let Light::Point { position, .. } = s.light else { panic!() };
    assert!(position.y > b.center().y);
    assert_eq!(s.grid, Grid::default());
    let diag = b.extent().length();
    assert!((s.camera.near - 1e-3 * diag).abs() < 1e-6);
    assert!((s.medium.sigma_s().x * diag - 1.0).abs() < 1e-4);

    // A directional light and a partial camera (eye only: looks at the centre).
    let p = write(
        d.path(),
        "sun.scene.toml",
        b"format = 1\n[[mesh]]\nbuiltin = \"plane\"\n[camera]\neye = [0, 3, 3]\n[light]\ntype = \"directional\"\ndirection = [0, 2, 0]\n",
    );
    let s = load_scene(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.camera.target, Vec3::ZERO);
    assert_eq!(s.light, Light::Directional { direction: Vec3::Y, irradiance: Vec3::splat(3.0) });
}

// ---------------------------------------------------------------------------------------------
// Bad input: an error naming the file and the problem, never a panic
// ---------------------------------------------------------------------------------------------

#[track_caller]
fn expect_err(path: &Path, needles: &[&str]) -> String {
    let msg = match load_scene(path) {
        Ok(s) => panic!("{} loaded ({} triangles) but should fail", path.display(), s.triangle_count()),
        Err(e) => e.to_string(),
    };
    eprintln!("{msg}");
    let file = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(file), "message does not name {file}: {msg}");
    for n in needles {
        assert!(msg.contains(n), "message lacks {n:?}: {msg}");
    }
    msg
}

#[test]
fn missing_file_and_unsupported_extension() {
    let d = tmp();
    expect_err(&d.path().join("nope.ply"), &["no such file or directory"]);
    expect_err(&d.path().join("nope.xyz"), &["no such file or directory"]);
    let p = write(d.path(), "points.xyz", b"1 2 3\n");
    expect_err(&p, &["unsupported extension '.xyz'", ".gltf .glb .obj .ply .toml"]);
    let p = write(d.path(), "noext", b"");
    expect_err(&p, &["unsupported extension"]);
    let empty = d.path().join("empty_folder");
    std::fs::create_dir(&empty).unwrap();
    expect_err(&empty, &["no scene.xml"]);
}

#[test]
fn malformed_gltf() {
    let d = tmp();
    expect_err(&write(d.path(), "bad.gltf", b"{ this is not json"), &["not a valid glTF file"]);
    expect_err(
        &write(d.path(), "bad.glb", b"glTF\x02\x00\x00\x00\xff\xff\xff\xff garbage"),
        &["not a valid glTF file"],
    );
    expect_err(&write(d.path(), "empty.gltf", b""), &["not a valid glTF file"]);
    // Well-formed JSON whose accessor reads past its buffer.
    let (uri, _) = triangle_buffer([[0.0; 3]; 3]);
    let json =
        gltf_json("", "{}", "", &uri, 44).replace(r#""count": 3, "type": "VEC3""#, r#""count": 300, "type": "VEC3""#);
    expect_err(&write(d.path(), "overrun.gltf", json.as_bytes()), &["glTF"]);
    // A buffer that is not there.
    let json = gltf_json("", "{}", "", "missing.bin", 44);
    expect_err(
        &write(d.path(), "nobin.gltf", json.as_bytes()),
        &["not a valid glTF file", "'missing.bin': no such file"],
    );
    // NaN positions.
    let (uri, len) = triangle_buffer([[f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let json = gltf_json("", "{}", "", &uri, len);
    expect_err(&write(d.path(), "nan.gltf", json.as_bytes()), &["non-finite vertex"]);
}

#[test]
fn malformed_obj() {
    let d = tmp();
    expect_err(&write(d.path(), "bad.obj", b"v 1 2\nf 1 2 3\n"), &["not a valid OBJ file"]);
    expect_err(&write(d.path(), "range.obj", b"v 0 0 0\nv 1 0 0\nf 1 2 9\n"), &["not a valid OBJ file"]);
    expect_err(&write(d.path(), "garbage.obj", b"f a b c\n"), &["not a valid OBJ file"]);
    expect_err(&write(d.path(), "nan.obj", b"v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), &["non-finite vertex"]);
    expect_err(&write(d.path(), "inf.obj", b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n"), &["non-finite vertex"]);
    expect_err(&write(d.path(), "points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n"), &["the scene has no triangles"]);
    expect_err(&write(d.path(), "binary.obj", &[0xff, 0xfe, 0x00, 0x80, 0x0a]), &["OBJ"]);
}

#[test]
fn malformed_ply() {
    let d = tmp();
    expect_err(&write(d.path(), "bad.ply", b"not a ply at all\n"), &["not a valid PLY file"]);
    let header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
    expect_err(&write(d.path(), "short.ply", format!("{header}0 0 0\n1 0 0\n").as_bytes()), &["not a valid PLY file"]);
    expect_err(
        &write(d.path(), "word.ply", format!("{header}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n").as_bytes()),
        &["not a valid PLY file"],
    );
    // ASCII PLY has no NaN literal: a parse error. A binary NaN is read, then rejected.
    expect_err(
        &write(d.path(), "nan.ply", format!("{header}nan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n").as_bytes()),
        &["Line 10"],
    );
    let mut b = header.replace("ascii", "binary_little_endian").into_bytes();
    for c in [f32::NAN, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&c.to_le_bytes());
    }
    b.push(3);
    for i in [0i32, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    expect_err(&write(d.path(), "nan_binary.ply", &b), &["non-finite vertex", "index 0"]);
    expect_err(
        &write(d.path(), "range.ply", format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n").as_bytes()),
        &["past its 3 vertices"],
    );
    expect_err(
        &write(d.path(), "negative.ply", format!("{header}0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n").as_bytes()),
        &["negative"],
    );
    let no_faces = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
    expect_err(&write(d.path(), "empty.ply", no_faces.as_bytes()), &["the scene has no triangles"]);
    let no_z = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n0 0\n";
    expect_err(&write(d.path(), "noz.ply", no_z.as_bytes()), &["no property 'z'"]);
    // Binary data cut short.
    let bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n\x00\x00";
    expect_err(&write(d.path(), "cut.ply", bin), &["not a valid PLY file"]);
}

#[test]
fn malformed_scene_files() {
    let d = tmp();
    write(d.path(), "tri.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let mesh = "[[mesh]]\nfile = \"tri.obj\"\n";
    expect_err(&write(d.path(), "syntax.scene.toml", b"format = = 1\n"), &["not a valid scene (TOML) file", "line 1"]);
    expect_err(
        &write(d.path(), "unknown.scene.toml", format!("format = 1\nfoo = 2\n{mesh}").as_bytes()),
        &["line 2", "unknown field `foo`"],
    );
    expect_err(
        &write(d.path(), "unknown_cam.scene.toml", format!("format = 1\n{mesh}[camera]\nfov = 30.0\n").as_bytes()),
        &["line 5", "unknown field `fov`"],
    );
    expect_err(
        &write(d.path(), "unknown_mesh.scene.toml", b"format = 1\n[[mesh]]\nfile = \"tri.obj\"\nrotate = [0, 1, 0]\n"),
        &["unknown field `rotate`"],
    );
    expect_err(
        &write(
            d.path(),
            "unknown_phase.scene.toml",
            format!("format = 1\n{mesh}[medium]\nphase = {{ type = \"henyey-greenstein\", g = 0.5, k = 1 }}\n")
                .as_bytes(),
        ),
        &["unknown field `k`"],
    );
    expect_err(
        &write(d.path(), "bad_light.scene.toml", format!("format = 1\n{mesh}[light]\ntype = \"area\"\n").as_bytes()),
        &["unknown variant `area`"],
    );
    expect_err(
        &write(d.path(), "v7.scene.toml", format!("format = 7\n{mesh}").as_bytes()),
        &["format = 7 is not supported (expected 1)"],
    );
    expect_err(&write(d.path(), "noversion.scene.toml", mesh.as_bytes()), &["format = 1"]);
    expect_err(
        &write(
            d.path(),
            "eye.scene.toml",
            format!("format = 1\n{mesh}[camera]\neye = [1, 2, 3]\ntarget = [1, 2, 3]\n").as_bytes(),
        ),
        &["degenerate camera", "eye and target coincide"],
    );
    expect_err(
        &write(
            d.path(),
            "up.scene.toml",
            format!("format = 1\n{mesh}[camera]\neye = [0, 5, 0]\ntarget = [0, 0, 0]\n").as_bytes(),
        ),
        &["degenerate camera", "parallel"],
    );
    expect_err(
        &write(d.path(), "range.scene.toml", format!("format = 1\n{mesh}[medium]\nscattering = -1.0\n").as_bytes()),
        &["scattering = -1 is out of range"],
    );
    expect_err(
        &write(d.path(), "grid.scene.toml", format!("format = 1\n{mesh}[grid]\nbins = 33\n").as_bytes()),
        &["multiple of 32"],
    );
    expect_err(&write(d.path(), "nomesh.scene.toml", b"format = 1\n"), &["the scene has no triangles"]);
    let msg = expect_err(
        &write(d.path(), "missing.scene.toml", b"format = 1\n[[mesh]]\nfile = \"gone.ply\"\n"),
        &["line 2: mesh 1", "gone.ply", "no such file or directory"],
    );
    assert!(msg.starts_with(&d.path().join("missing.scene.toml").display().to_string()), "{msg}");
    expect_err(
        &write(d.path(), "nested.scene.toml", b"format = 1\n[[mesh]]\nfile = \"unknown.scene.toml\"\n"),
        &["is a scene, not a mesh"],
    );
    expect_err(
        &write(d.path(), "both.scene.toml", b"format = 1\n[[mesh]]\nfile = \"tri.obj\"\nbuiltin = \"box\"\n"),
        &["not both"],
    );
    expect_err(
        &write(d.path(), "cone.scene.toml", b"format = 1\n[[mesh]]\nbuiltin = \"cone\"\n"),
        &["unknown builtin 'cone'"],
    );
    expect_err(
        &write(d.path(), "scale.scene.toml", b"format = 1\n[[mesh]]\nbuiltin = \"box\"\nscale = [1, 2]\n"),
        &["array of 3 numbers"],
    );
    expect_err(&write(d.path(), "bytes.scene.toml", &[0x66, 0xff, 0xfe]), &["not UTF-8"]);
}

#[test]
fn malformed_mitsuba() {
    let d = tmp();
    expect_err(&write(d.path(), "bad.xml", b"<scene><shape type=\"obj\"></scene>"), &["not a valid Mitsuba XML file"]);
    expect_err(&write(d.path(), "root.xml", b"<notascene/>"), &["expected <scene>"]);
    expect_err(
        &write(
            d.path(),
            "missing.xml",
            b"<scene><shape type=\"obj\"><string name=\"filename\" value=\"gone.obj\"/></shape></scene>",
        ),
        &["shape 'gone.obj'", "no such file or directory"],
    );
    expect_err(&write(d.path(), "nofile.xml", b"<scene><shape type=\"obj\"/></scene>"), &["line 1", "has no filename"]);
    expect_err(
        &write(d.path(), "matrix.xml", b"<scene><shape type=\"cube\"><transform name=\"toWorld\"><matrix value=\"1 2 3\"/></transform></shape></scene>"),
        &["16 or 9 numbers"],
    );
    expect_err(&write(d.path(), "empty.xml", b"<scene/>"), &["the scene has no triangles"]);
}

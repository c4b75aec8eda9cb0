//! Issue 12: nothing a user's file or flag can do crashes, hangs, lies or destroys. One test per
//! finding (docs/robustness.md has the table). None needs a GPU: the command-line cases either fail
//! before rendering or render a few pixels with the CPU reference.

use epivox::preset::Preset;
use epivox::scene::{load_scene, load_scene_with_summary};
use epivox::{Image, Light};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn epivox(args: &[&str], envs: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_epivox"));
    c.args(args).env_remove("RUST_LOG");
    for (k, v) in envs {
        c.env(k, v);
    }
    c.output().expect("run epivox")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs a command that must fail without a panic; returns its stderr.
#[track_caller]
fn fails(args: &[&str]) -> String {
    let o = epivox(args, &[]);
    let err = stderr(&o);
    assert!(!o.status.success(), "{args:?} succeeded; stderr: {err}");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    err
}

fn write(dir: &Path, name: &str, content: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A tiny scene the CPU reference renders in well under a second.
fn tiny_scene(dir: &Path) -> PathBuf {
    write(dir, "tri.obj", TRI);
    write(
        dir,
        "tiny.scene.toml",
        "format = 1\n[[mesh]]\nfile = \"tri.obj\"\n[camera]\neye = [0.3, 0.3, 2]\ntarget = [0.3, 0.3, 0]\n\
         [light]\ntype = \"point\"\nposition = [0.3, 1.5, 1]\nintensity = 5\n",
    )
}

/// Renders `scene` with the reference at 4x4 pixels, 8 samples per ray, plus `extra` flags.
fn reference_render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args =
        vec!["render", s(scene), "--method", "reference", "--size", "4x4", "--samples", "8", "--out", s(out)];
    args.extend_from_slice(extra);
    epivox(&args, &[])
}

#[track_caller]
fn load_err(path: &Path, needles: &[&str]) -> String {
    let msg = match load_scene(path) {
        Ok(s) => {
            panic!("{} loaded ({} triangles, light {:?}) but should fail", path.display(), s.triangle_count(), s.light)
        }
        Err(e) => e.to_string(),
    };
    let file = path.file_name().unwrap().to_str().unwrap();
    assert!(msg.contains(file), "the message does not name {file}: {msg}");
    for n in needles {
        assert!(msg.contains(n), "the message lacks {n:?}: {msg}");
    }
    msg
}

// ---------------------------------------------------------------------------------------------
// Item 2: zero-area triangles are dropped at load and counted
// ---------------------------------------------------------------------------------------------

#[test]
fn zero_area_triangles_are_dropped_and_counted() {
    let d = tempfile::tempdir().unwrap();
    // Two good triangles; a repeated corner, three collinear corners, one point thrice.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 1 1 0\nf 1 2 3\nf 2 5 3\nf 1 1 3\nf 1 2 4\nf 5 5 5\n";
    let p = write(d.path(), "mixed.obj", obj);
    let (scene, summary) = load_scene_with_summary(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.triangle_count(), 2);
    assert_eq!(summary.degenerate_triangles, 3);
    assert!(summary.files.iter().any(|f| f.ends_with("mixed.obj")), "{:?}", summary.files);
    // A thin but real triangle stays: height 1e-4 over a length of 1.
    let p = write(d.path(), "thin.obj", "v 0 0 0\nv 1 0 0\nv 0.5 0.0001 0\nf 1 2 3\n");
    assert_eq!(load_scene_with_summary(&p).unwrap().1.degenerate_triangles, 0);
    // Only zero-area triangles: no triangles, and the message says why.
    let p = write(d.path(), "flat.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\nf 1 1 1\n");
    load_err(&p, &["no triangles", "2 zero-area triangles dropped"]);
    // 10 000 copies of a degenerate triangle cost nothing to render: they are gone at load.
    let mut many = String::from(TRI);
    many.push_str(&"f 1 1 2\n".repeat(10_000));
    let p = write(d.path(), "many.obj", many);
    let (scene, summary) = load_scene_with_summary(&p).unwrap();
    assert_eq!((scene.triangle_count(), summary.degenerate_triangles), (1, 10_000));
    // The command line reports the count.
    let out = d.path().join("o.png");
    let o = reference_render(&p, &out, &["--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).expect("stdout is one JSON object");
    assert_eq!(j["degenerate_triangles_dropped"], 10_000);
    assert_eq!(j["triangles"], 1);
    let o = reference_render(&p, &out, &[]);
    assert!(stderr(&o).contains("10000 zero-area dropped"), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// Item 3: every numeric flag has a documented range
// ---------------------------------------------------------------------------------------------

#[test]
fn numeric_flags_are_range_checked_by_name() {
    let out = std::env::temp_dir().join("epivox-robustness-never.png");
    let out = s(&out);
    let cases: &[(&[&str], &str)] = &[
        (&["--samples", "4294967295", "--method", "reference"], "--samples"),
        (&["--samples", "0", "--method", "reference"], "samples = 0 is out of range"),
        (&["--samples", "1"], "out of range [2, 65536]"),
        (&["--samples", "-3"], "-3"),
        (&["--steps", "0"], "steps = 0 is out of range"),
        (&["--steps", "65536"], "--steps"),
        (&["--shadow-map", "16"], "shadow-map = 16 is out of range"),
        (&["--size", "20000x4"], "size = 20000 is out of range"),
        (&["--size", "4x0"], "height"),
        (&["--fov", "179"], "fov_y_deg = 179 is out of range"),
        (&["--fov", "nan"], "--fov"),
        (&["--exposure", "-21"], "exposure = -21 is out of range"),
    ];
    for (flags, needle) in cases {
        let mut args = vec!["render", "--out", out];
        args.extend_from_slice(flags);
        let err = fails(&args);
        assert!(err.contains(needle), "{flags:?}: expected '{needle}' in: {err}");
    }
    for (flags, needle) in [
        (&["--frames", "0"][..], "frames = 0 is out of range"),
        (&["--warmup", "100000"][..], "warmup = 100000 is out of range"),
        (&["--samples", "0"][..], "samples = 0"),
    ] {
        let mut args = vec!["bench", "--out", out];
        args.extend_from_slice(flags);
        let err = fails(&args);
        assert!(err.contains(needle), "bench {flags:?}: expected '{needle}' in: {err}");
    }
    // The ranges are in the help text, taken from params.rs.
    let help = String::from_utf8_lossy(&epivox(&["render", "--help"], &[]).stdout).into_owned();
    for r in ["[range: 2..=65536", "[range: 1..=32768]", "[range: 64..=16384 texels]", "[range: 1..=16384 pixels]"] {
        assert!(help.contains(r), "render --help lacks {r}: {help}");
    }
}

// ---------------------------------------------------------------------------------------------
// Item 4: outputs
// ---------------------------------------------------------------------------------------------

#[test]
fn outputs_never_overwrite_an_input() {
    let d = tempfile::tempdir().unwrap();
    let scene = tiny_scene(d.path());
    let before = std::fs::read(&scene).unwrap();
    // The scene itself (its extension is not an image's either).
    let err = fails(&["render", s(&scene), "--out", s(&scene)]);
    assert!(err.contains("--out") && err.contains(".png"), "{err}");
    // A link with an image name onto an input: the scene file, the mesh it references, the preset.
    let preset = write(d.path(), "look.toml", "format = 1\n");
    #[cfg(unix)]
    for (link, target, flag) in [
        ("scene.png", &scene, "--out"),
        ("mesh.exr", &d.path().join("tri.obj"), "--hdr-exr"),
        ("preset.exr", &preset, "--scatter-exr"),
    ] {
        let l = d.path().join(link);
        std::os::unix::fs::symlink(target, &l).unwrap();
        let out = d.path().join("fine.png");
        let mut args = vec!["render", s(&scene), "--preset", s(&preset), "--method", "reference", "--size", "4x4"];
        if flag == "--out" {
            args.extend(["--out", s(&l)]);
        } else {
            args.extend(["--out", s(&out), flag, s(&l)]);
        }
        let err = fails(&args);
        assert!(err.contains(flag) && err.contains("input"), "{link}: {err}");
        assert!(!out.exists(), "{link}: an output was written");
    }
    assert_eq!(std::fs::read(&scene).unwrap(), before);
    assert_eq!(std::fs::read(d.path().join("tri.obj")).unwrap(), TRI.as_bytes());
}

#[test]
fn outputs_follow_their_extension_and_differ() {
    let d = tempfile::tempdir().unwrap();
    let scene = tiny_scene(d.path());
    let p = |n: &str| d.path().join(n);
    let err = fails(&["render", s(&scene), "--out", s(&p("x.jpg"))]);
    assert!(err.contains("--out") && err.contains(".png") && err.contains(".exr"), "{err}");
    let err = fails(&["render", s(&scene), "--out", s(&p("a.png")), "--hdr-exr", s(&p("b.png"))]);
    assert!(err.contains("--hdr-exr") && err.contains(".exr extension"), "{err}");
    let err = fails(&["render", s(&scene), "--out", s(&p("a.exr")), "--hdr-exr", s(&p("a.exr"))]);
    assert!(err.contains("the same file"), "{err}");
    let dotted = format!("{}/./a.EXR", d.path().display());
    let err = fails(&["render", s(&scene), "--out", &dotted, "--scatter-exr", s(&p("a.EXR"))]);
    assert!(err.contains("the same file"), "{err}");
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 2, "something was written");

    // --out x.exr writes an OpenEXR file (the linear image), x.png a PNG.
    let o = reference_render(&scene, &p("x.exr"), &["--hdr-exr", s(&p("hdr.exr"))]);
    assert!(o.status.success(), "{}", stderr(&o));
    let exr = Image::read_exr(p("x.exr")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(exr, Image::read_exr(p("hdr.exr")).unwrap());
    let o = reference_render(&scene, &p("x.png"), &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(&std::fs::read(p("x.png")).unwrap()[1..4], b"PNG");
}

#[test]
fn a_failing_output_leaves_every_output_as_it_was() {
    let d = tempfile::tempdir().unwrap();
    let scene = tiny_scene(d.path());
    let png = write(d.path(), "keep.png", "old picture");
    // Into a missing folder: refused before rendering, the earlier output untouched.
    let missing = d.path().join("no/such/folder/h.exr");
    let o = reference_render(&scene, &png, &["--hdr-exr", s(&missing)]);
    let err = stderr(&o);
    assert!(!o.status.success() && err.contains("--hdr-exr") && err.contains("no/such/folder"), "{err}");
    assert_eq!(std::fs::read(&png).unwrap(), b"old picture");
    // The output is a folder.
    let o = reference_render(&scene, &png, &["--scatter-exr", s(d.path())]);
    assert!(!o.status.success() && stderr(&o).contains("--scatter-exr"), "{}", stderr(&o));
    assert_eq!(std::fs::read(&png).unwrap(), b"old picture");
    // No temporary file is left behind.
    let names: Vec<String> =
        std::fs::read_dir(d.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(!names.iter().any(|n| n.ends_with(".tmp")), "{names:?}");
}

#[test]
fn bench_refuses_a_file_as_its_output_folder() {
    let d = tempfile::tempdir().unwrap();
    let scene = tiny_scene(d.path());
    let before = std::fs::read(&scene).unwrap();
    let err = fails(&["bench", s(&scene), "--out", s(&scene), "--quick"]);
    assert!(err.contains("--out") && err.contains("is a file"), "{err}");
    assert_eq!(std::fs::read(&scene).unwrap(), before);
}

// ---------------------------------------------------------------------------------------------
// Item 5: every value from every source passes the same checks
// ---------------------------------------------------------------------------------------------

#[test]
fn scene_file_values_are_checked_with_the_field_named() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "tri.obj", TRI);
    let mesh = "format = 1\n[[mesh]]\nfile = \"tri.obj\"\n";
    let cases: &[(&str, &str, &[&str])] = &[
        ("neg_intensity", "[light]\ntype = \"point\"\nintensity = -5\n", &["intensity = -5 is out of range"]),
        (
            "neg_irradiance",
            "[light]\ntype = \"directional\"\ndirection = [0, 1, 0]\nirradiance = [1, -2, 1]\n",
            &["irradiance = -2 is out of range"],
        ),
        ("zero_dir", "[light]\ntype = \"directional\"\ndirection = [0, 0, 0]\n", &["light direction", "non-zero"]),
        ("nan_dir", "[light]\ntype = \"directional\"\ndirection = [nan, 1, 0]\n", &["light direction"]),
        ("up", "[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\nup = [0, 0, 0]\n", &["camera up", "non-zero"]),
        ("eye4", "[camera]\neye = [0, 1, 5, 7]\n", &["array of 3 numbers"]),
        ("target2", "[camera]\ntarget = [0, 1]\n", &["array of 3 numbers"]),
        ("pos4", "[light]\ntype = \"point\"\nposition = [0, 1, 5, 1]\n", &["array of 3 numbers"]),
        ("phase_g", "[medium]\nphase = { type = \"isotropic\", g = 0.5 }\n", &["'isotropic' has no `g`"]),
        ("phase_nog", "[medium]\nphase = { type = \"schlick\" }\n", &["'schlick' needs `g`"]),
        ("phase_kind", "[medium]\nphase = { type = \"mie\", g = 0.5 }\n", &["unknown phase function type 'mie'"]),
        ("radius", "[light]\ntype = \"point\"\nradius = -1\n", &["radius = -1 is out of range"]),
    ];
    for (name, body, needles) in cases {
        let p = write(d.path(), &format!("{name}.scene.toml"), format!("{mesh}{body}"));
        load_err(&p, needles);
    }
    for (albedo, needle) in [("-0.5", "albedo = -0.5 is out of range"), ("5.0", "albedo = 5"), ("nan", "albedo")] {
        let p = write(d.path(), "albedo.scene.toml", format!("{mesh}albedo = {albedo}\n"));
        load_err(&p, &[needle, "mesh 'tri'"]);
    }
}

fn gltf_with(light: &str, base_color: &str) -> String {
    // One triangle (positions only, no indices) in a data URI.
    let mut bytes = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    const T: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let b64: String = bytes
        .chunks(3)
        .flat_map(|c| {
            let n = (c[0] as u32) << 16 | (c[1] as u32) << 8 | c[2] as u32;
            (0..4).map(move |i| T[(n >> (18 - 6 * i)) as usize & 63] as char)
        })
        .collect();
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"translation": [0, 3, 0], "rotation": [0.7071, 0, 0, 0.7071], "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": {base_color}}}}}],
  "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
  "buffers": [{{"byteLength": 36, "uri": "data:application/octet-stream;base64,{b64}"}}],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{light}]}}}}}}"#
    )
}

#[test]
fn gltf_values_are_checked() {
    let d = tempfile::tempdir().unwrap();
    let grey = "[0.5, 0.5, 0.5, 1]";
    let ok = write(d.path(), "ok.gltf", gltf_with(r#"{"type": "point", "intensity": 4}"#, grey));
    assert!(matches!(load_scene(&ok).unwrap_or_else(|e| panic!("{e}")).light, Light::Point { .. }));
    let p = write(d.path(), "neg.gltf", gltf_with(r#"{"type": "point", "intensity": -4}"#, grey));
    load_err(&p, &["intensity = -4 is out of range"]);
    // Two negatives do not make a positive.
    let p =
        write(d.path(), "negneg.gltf", gltf_with(r#"{"type": "point", "color": [-1, -1, -1], "intensity": -4}"#, grey));
    load_err(&p, &["light '0'", "color"]);
    let p = write(d.path(), "negsun.gltf", gltf_with(r#"{"type": "directional", "color": [1, -0.5, 1]}"#, grey));
    load_err(&p, &["color", "must be finite and >= 0"]);
    let p = write(d.path(), "albedo.gltf", gltf_with(r#"{"type": "point"}"#, "[5, 0.5, 0.5, 1]"));
    load_err(&p, &["albedo = 5 is out of range"]);
    let p = write(d.path(), "albedo_neg.gltf", gltf_with(r#"{"type": "point"}"#, "[0.5, -0.5, 0.5, 1]"));
    load_err(&p, &["albedo = -0.5 is out of range"]);
    // A node scaled to nothing: its light has no direction (refused, not replaced by +Y).
    let flat = gltf_with(r#"{"type": "directional"}"#, grey)
        .replace(r#""rotation": [0.7071, 0, 0, 0.7071]"#, r#""scale": [0, 0, 0]"#);
    let p = write(d.path(), "flat.gltf", flat);
    load_err(&p, &["light direction"]);
}

fn mitsuba(body: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"0.5\"/></transform></shape>\n{body}\n</scene>"
    )
}

#[test]
fn mitsuba_values_and_references_are_checked() {
    let d = tempfile::tempdir().unwrap();
    let cases: &[(&str, &str, &[&str])] = &[
        (
            "neg_point",
            r#"<emitter type="point"><point name="position" value="0, 3, 0"/><rgb name="intensity" value="-7"/></emitter>"#,
            &["intensity = -7 is out of range"],
        ),
        (
            "neg_sun",
            r#"<emitter type="directional"><vector name="direction" value="0, -1, 0"/><rgb name="irradiance" value="-2"/></emitter>"#,
            &["irradiance = -2 is out of range"],
        ),
        (
            "zero_sun",
            r#"<emitter type="sun"><vector name="sun_direction" x="0" y="0" z="0"/></emitter>"#,
            &["light direction", "non-zero"],
        ),
        (
            "neg_area",
            r#"<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="-3, 1, 1"/></emitter></shape>"#,
            &["line 3", "radiance = -3 is out of range"],
        ),
        ("sphere", r#"<shape type="sphere"><float name="radius" value="-1"/></shape>"#, &["line 3", "radius = -1 must be > 0"]),
        ("sphere0", r#"<shape type="sphere"><float name="radius" value="0"/></shape>"#, &["radius = 0 must be > 0"]),
        (
            "dangling",
            r#"<shape type="rectangle"><ref id="nothing"/></shape>"#,
            &["line 3", "<ref id=\"nothing\"> refers to nothing"],
        ),
        (
            "self",
            r#"<bsdf type="twosided" id="a"><ref id="a"/></bsdf><shape type="rectangle"><ref id="a"/></shape>"#,
            &["cycle", "a -> a"],
        ),
        (
            "cycle",
            "<bsdf type=\"twosided\" id=\"a\"><ref id=\"b\"/></bsdf>\n<bsdf type=\"twosided\" id=\"b\"><ref id=\"a\"/></bsdf>\n<shape type=\"rectangle\"><ref id=\"a\"/></shape>",
            &["cycle", "a -> b -> a"],
        ),
        (
            "albedo",
            r#"<shape type="rectangle"><bsdf type="diffuse"><rgb name="reflectance" value="1.5, 0.5, 0.5"/></bsdf></shape>"#,
            &["albedo = 1.5 is out of range"],
        ),
    ];
    for (name, body, needles) in cases {
        let p = write(d.path(), &format!("{name}.xml"), mitsuba(body));
        load_err(&p, needles);
    }
    // A reference chain that ends well still works.
    let good = mitsuba(
        r#"<bsdf type="diffuse" id="c"><rgb name="reflectance" value="0.25"/></bsdf><bsdf type="twosided" id="w"><ref id="c"/></bsdf><shape type="rectangle" id="r"><ref id="w"/></shape>"#,
    );
    let scene = load_scene(&write(d.path(), "good.xml", good)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.meshes.iter().find(|m| m.name == "r").unwrap().albedo, Vec3::splat(0.25));
}

#[test]
fn obj_albedo_out_of_range_is_refused() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "m.mtl", "newmtl hot\nKd 2 0.5 0.5\n");
    let p = write(d.path(), "hot.obj", format!("mtllib m.mtl\nusemtl hot\n{TRI}"));
    load_err(&p, &["albedo = 2 is out of range"]);
}

#[test]
fn ply_header_that_lies_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let header = |verts: usize, faces: usize| {
        format!(
            "ply\nformat ascii 1.0\nelement vertex {verts}\nproperty float x\nproperty float y\nproperty float z\n\
             element face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let data = "0 0 0\n1 0 0\n0 1 0\n1 1 0\n3 0 1 2\n3 1 3 2\n";
    let ok = write(d.path(), "ok.ply", format!("{}{data}", header(4, 2)));
    assert_eq!(load_scene(&ok).unwrap().triangle_count(), 2);
    // Fewer vertices than the file holds: a vertex line is read as a face.
    let p = write(d.path(), "fewer_vertices.ply", format!("{}{data}", header(3, 2)));
    load_err(&p, &["PLY"]);
    let p = write(d.path(), "fewer_faces.ply", format!("{}{data}", header(4, 1)));
    load_err(&p, &["more data than its header declares", "4 vertex, 1 face"]);
    // Binary: bytes after the last element.
    let mut b = header(3, 1).replace("ascii", "binary_little_endian").into_bytes();
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend_from_slice(&c.to_le_bytes());
    }
    b.push(3);
    for i in [0i32, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let ok = write(d.path(), "ok_binary.ply", &b);
    assert_eq!(load_scene(&ok).unwrap().triangle_count(), 1);
    b.extend_from_slice(&[0, 0, 0, 0]);
    let p = write(d.path(), "extra_binary.ply", &b);
    load_err(&p, &["4 bytes left over"]);
}

#[test]
fn preset_values_are_checked_strictly() {
    let parse = |t: &str| Preset::parse(t, Path::new("look.toml")).map(|_| ()).map_err(|e| e.to_string());
    assert!(parse("format = 1\n[medium]\nscattering = [0.1, 0.1, 0.1]\n").is_ok());
    for (text, needle) in [
        ("format = 1\n[medium]\nscattering = [0.1, 0.1, 0.1, 0.1]\n", "array of 3 numbers"),
        ("format = 1\n[medium]\nabsorption = [0.1, 0.1]\n", "array of 3 numbers"),
        ("format = 1\n[medium]\nphase = { type = \"henyey-greenstein\", g = 0.5, k = 1 }\n", "unknown field `k`"),
        ("format = 1\n[medium]\nphase = { type = \"rayleigh\", g = 0.5 }\n", "'rayleigh' has no `g`"),
        ("format = 1\n[medium]\nphase = { type = \"cornette-shanks\" }\n", "needs `g`"),
        ("format = 1\n[medium]\nphase = { type = \"schlick\", g = 0.95 }\n", "out of range [-0.93, 0.93]"),
        ("format = 1\nexposure = nan\n", "exposure"),
    ] {
        let e = parse(text).expect_err(text);
        assert!(e.contains("look.toml") && e.contains(needle), "{text}: expected '{needle}' in: {e}");
    }
}

// ---------------------------------------------------------------------------------------------
// Item 6: warnings reach stderr in every command
// ---------------------------------------------------------------------------------------------

#[test]
fn loader_warnings_reach_stderr() {
    let d = tempfile::tempdir().unwrap();
    let p = write(d.path(), "nomtl.obj", format!("mtllib missing.mtl\n{TRI}"));
    let out = d.path().join("o.png");
    let o = reference_render(&p, &out, &["--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("warning:") && err.contains("missing.mtl"), "{err}");
    // stdout stays one JSON object.
    serde_json::from_slice::<serde_json::Value>(&o.stdout).expect("stdout is JSON");
    // RUST_LOG still decides.
    let o = epivox(
        &["render", s(&p), "--method", "reference", "--size", "4x4", "--samples", "8", "--out", s(&out)],
        &[("RUST_LOG", "error")],
    );
    assert!(o.status.success() && !stderr(&o).contains("missing.mtl"), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------------------------
// Item 7: messages
// ---------------------------------------------------------------------------------------------

#[test]
fn each_error_is_printed_once_and_names_the_file() {
    let d = tempfile::tempdir().unwrap();
    write(d.path(), "tri.obj", TRI);
    let out = d.path().join("o.png");
    let p = write(
        d.path(),
        "eye.scene.toml",
        "format = 1\n[[mesh]]\nfile = \"tri.obj\"\n[camera]\neye = [1, 2, 3]\ntarget = [1, 2, 3]\n",
    );
    let err = fails(&["render", s(&p), "--out", s(&out)]);
    assert_eq!(err.matches("degenerate camera").count(), 1, "{err}");
    assert_eq!(err.matches("eye and target coincide").count(), 1, "{err}");
    assert!(err.contains("eye.scene.toml"), "{err}");
    // A referenced mesh's error: the chain is said once too.
    let p = write(d.path(), "gone.scene.toml", "format = 1\n[[mesh]]\nfile = \"gone.obj\"\n");
    let err = fails(&["render", s(&p), "--out", s(&out)]);
    assert_eq!(err.matches("no such file or directory").count(), 1, "{err}");
    // The eye on the light: the scene file is named, for the GPU methods and the reference alike.
    let p = write(
        d.path(),
        "lamp.scene.toml",
        "format = 1\n[[mesh]]\nfile = \"tri.obj\"\n[camera]\neye = [0, 1, 5]\ntarget = [0, 0, 0]\n\
         [light]\ntype = \"point\"\nposition = [0, 1, 5]\n",
    );
    for method in ["vsv", "reference"] {
        let err = fails(&["render", s(&p), "--method", method, "--out", s(&out)]);
        assert!(err.contains("lamp.scene.toml") && err.contains("the eye sits exactly on the point light"), "{err}");
    }
    assert!(!out.exists());
}

#[cfg(unix)]
#[test]
fn symlink_loops_are_reported_as_such() {
    let d = tempfile::tempdir().unwrap();
    let lp = d.path().join("loop.obj");
    std::os::unix::fs::symlink(&lp, &lp).unwrap();
    load_err(&lp, &["a loop of symbolic links"]);
    // In a folder of meshes: named, not "no .obj file".
    let folder = d.path().join("meshes");
    std::fs::create_dir(&folder).unwrap();
    write(&folder, "a.obj", TRI);
    let l = folder.join("b.obj");
    std::os::unix::fs::symlink(&l, &l).unwrap();
    let e = load_scene(&folder).unwrap_err().to_string();
    assert!(e.contains("b.obj") && e.contains("a loop of symbolic links"), "{e}");
    // A dangling link too.
    std::fs::remove_file(&l).unwrap();
    std::os::unix::fs::symlink(folder.join("nowhere.obj"), &l).unwrap();
    let e = load_scene(&folder).unwrap_err().to_string();
    assert!(e.contains("b.obj") && e.contains("symbolic link to nothing"), "{e}");
    // And through a scene file.
    let p = write(d.path(), "s.scene.toml", "format = 1\n[[mesh]]\nfile = \"loop.obj\"\n");
    load_err(&p, &["loop.obj", "a loop of symbolic links"]);
}

#[test]
fn control_characters_in_names_are_escaped() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o.png");
    let evil = d.path().join("evil\u{1b}[2J\u{7}\r.obj");
    let err = fails(&["render", s(&evil), "--out", s(&out)]);
    assert!(!err.chars().any(|c| c.is_control() && c != '\n'), "raw control characters: {err:?}");
    assert!(err.contains("\\u{1b}[2J\\u{7}\\r.obj"), "{err}");
    // In a flag's value that clap reports.
    let err = fails(&["render", "--out", s(&out), "--size", "4x\u{1b}]0;title\u{7}"]);
    assert!(!err.chars().any(|c| c.is_control() && c != '\n'), "raw control characters: {err:?}");
    // In a name from inside a file (a mesh name in an error).
    let obj = format!("mtllib m.mtl\no a\u{1b}[31mred\nusemtl hot\n{TRI}o b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n");
    write(d.path(), "m.mtl", "newmtl hot\nKd 2 0 0\n");
    let p = write(d.path(), "named.obj", obj);
    let err = fails(&["render", s(&p), "--out", s(&out)]);
    assert!(!err.contains('\u{1b}') && err.contains("albedo"), "{err:?}");
}

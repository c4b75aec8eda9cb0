//! `epivox bench`: a quick run writes every file with rows for every method; the reference cache is
//! keyed by the data (reused when nothing changed, re-rendered when the scene, light or medium did).
//! (The error metrics themselves are checked against hand-computed values in image_metrics.rs.)

mod common;

use common::*;
use epivox::bench::{self, cached_reference, reference_key, BenchOptions, CacheStatus};
use epivox::params::Light;
use epivox::reference::ReferenceOptions;
use epivox::scene::Scene;
use glam::Vec3;
use std::path::Path;
use std::process::Command;

/// The occluder scene lit from straight above and seen horizontally: the light is along the
/// camera's up axis, so the Cartesian method applies too.
fn axis_aligned_scene() -> Scene {
    let mut scene = occluder_scene(Light::Directional { direction: Vec3::Y, irradiance: Vec3::splat(2.0) });
    scene.camera.target = Vec3::new(0.0, 1.5, 0.0);
    scene
}

fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap_or_default().split(',').map(String::from).collect();
    // Settings may be quoted ("16 steps, map 256"): split outside quotes.
    let rows = lines
        .map(|l| {
            let mut fields = vec![String::new()];
            let mut quoted = false;
            for c in l.chars() {
                match c {
                    '"' => quoted = !quoted,
                    ',' if !quoted => fields.push(String::new()),
                    _ => fields.last_mut().map(|f| f.push(c)).unwrap_or(()),
                }
            }
            fields
        })
        .collect();
    (header, rows)
}

#[test]
fn quick_bench_writes_every_file_with_rows_for_every_method() {
    let Some(mut r) = renderer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut opts = BenchOptions::new(dir.path(), true);
    (opts.width, opts.height) = (32, 32);
    let scene = axis_aligned_scene();
    let res = bench::run(&mut r, &scene, &opts).unwrap_or_else(|e| panic!("{e}"));

    for f in bench::output_files(dir.path()) {
        let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
        assert!(len > 0, "{} is empty", f.display());
    }
    for png in ["error_vs_time.png", "time_vs_triangles.png", "time_vs_resolution.png"] {
        let img = image::open(dir.path().join(png)).unwrap_or_else(|e| panic!("{png}: {e}"));
        assert!(img.width() >= 600 && img.height() >= 400, "{png}");
    }

    let (header, rows) = csv_rows(&dir.path().join("results.csv"));
    assert_eq!(header[..6], ["method", "setting", "total_ms", "rel_rmse", "max_abs", "psnr"]);
    for pass in ["shadow_map_ms", "surface_ms", "voxelize_ms", "scan_ms", "integrate_ms", "raymarch_ms", "composite_ms"]
    {
        assert!(header.iter().any(|h| h == pass), "no column {pass} in {header:?}");
    }
    for method in ["vsv", "cartesian", "raymarch"] {
        let n = rows.iter().filter(|r| r[0] == method).count();
        assert!(n >= 2, "{n} rows for {method}");
    }
    for row in &rows {
        assert_eq!(row.len(), header.len(), "{row:?}");
        let total: f64 = row[2].parse().unwrap();
        let err: f64 = row[3].parse().unwrap();
        assert!(total.is_finite() && err.is_finite() && err >= 0.0, "{row:?}");
        if r.ctx.timestamps {
            assert!(total > 0.0, "{row:?}");
        }
    }
    assert_eq!(rows.len(), res.rows.len());
    assert!(!res.triangle_rows.is_empty() && !res.resolution_rows.is_empty());

    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(report.contains(&r.ctx.adapter_name()), "the report names the adapter");
    assert!(report.contains("logical CPUs"), "the report describes the machine");
    assert!(report.contains("error_vs_time.png"));
    assert!(report.contains("| cartesian |") && report.contains("| raymarch |") && report.contains("| vsv |"));
    // Target 3's figure: each scaling point's time at the most triangles over a tenth of them.
    for p in bench::scaling_points_of(&res.triangle_rows) {
        let g = bench::triangle_growth(&res.triangle_rows, &p).expect("two triangle counts");
        assert!(report.contains(&g.describe()), "the report lacks {}", g.describe());
    }
}

/// With `rounds = 3` every point of the error sweep is timed three times, interleaved: its time is
/// the median of three times as many frames, its image and error those of the first round, and
/// the report says how it was timed. The triangle sweep takes the same rounds, each room in turn.
#[test]
fn rounds_pool_every_points_frames() {
    let Some(mut r) = renderer() else { return };
    let dir = tempfile::tempdir().unwrap();
    let mut opts = BenchOptions::new(dir.path(), true);
    (opts.width, opts.height, opts.scaling, opts.frames) = (32, 32, false, 2);
    let scene = axis_aligned_scene();
    let once = bench::run(&mut r, &scene, &opts).unwrap_or_else(|e| panic!("{e}"));
    opts.rounds = 3;
    opts.scaling = true;
    let res = bench::run(&mut r, &scene, &opts).unwrap_or_else(|e| panic!("{e}"));
    assert!(!res.triangle_rows.is_empty());
    for row in &res.triangle_rows {
        // Three rounds of min(frames, 3) = 2 frames each.
        assert_eq!((row.timing.frames, row.timing.round_ms.len()), (6, 3), "{} triangles", row.triangles);
    }
    assert_eq!(res.rows.len(), once.rows.len());
    for (a, b) in once.rows.iter().zip(&res.rows) {
        assert_eq!(a.point, b.point);
        assert_eq!((a.timing.frames, b.timing.frames), (2, 6), "{:?}", b.point);
        assert_eq!(a.scatter.rel_rmse, b.scatter.rel_rmse, "the error comes from the same render");
        assert!(b.timing.total_ms.is_finite());
    }
    let report = std::fs::read_to_string(dir.path().join("report.md")).unwrap();
    assert!(report.contains("pooled over 3 interleaved rounds"), "{report}");
}

/// The reference is rendered once; it is found again when nothing changed (also when only the grid
/// changed, which the reference does not use) and rendered anew when the geometry, the camera, the
/// light or the medium changed.
#[test]
fn reference_cache_is_keyed_by_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let opts = ReferenceOptions { samples: 32, ..Default::default() };
    let (w, h) = (8, 8);
    let base = axis_aligned_scene();
    let get = |s: &Scene| cached_reference(s, w, h, &opts, dir.path()).unwrap_or_else(|e| panic!("{e}"));

    let first = get(&base);
    assert!(matches!(first.status, CacheStatus::Rendered { .. }));
    let again = get(&base);
    assert_eq!(again.status, CacheStatus::Hit);
    assert_eq!(again.key, first.key);
    assert_eq!(again.scatter, first.scatter, "the cached image is the rendered one, bit for bit");

    let mut grid_only = base.clone();
    grid_only.grid.bins = 64;
    assert_eq!(get(&grid_only).status, CacheStatus::Hit, "the grid does not change the reference");

    let mut medium = base.clone();
    medium.medium.density *= 2.0;
    let mut geometry = base.clone();
    geometry.meshes[1].positions[0].y += 0.01;
    let mut light = base.clone();
    light.light = Light::Directional { direction: Vec3::new(0.0, 1.0, 0.1).normalize(), irradiance: Vec3::splat(2.0) };
    let mut camera = base.clone();
    camera.camera.fov_y_deg += 1.0;
    let mut keys = vec![first.key.clone()];
    for (what, s) in [("medium", &medium), ("geometry", &geometry), ("light", &light), ("camera", &camera)] {
        let c = get(s);
        assert!(matches!(c.status, CacheStatus::Rendered { .. }), "a changed {what} reused the cache");
        assert!(!keys.contains(&c.key), "{what}: key collision");
        keys.push(c.key);
        assert_eq!(get(s).status, CacheStatus::Hit, "{what}: not cached after rendering");
    }
    // The image size is part of the key too.
    assert_ne!(reference_key(&base, 8, 8, &opts), reference_key(&base, 8, 9, &opts));
    // And the first entry is still there.
    assert_eq!(get(&base).status, CacheStatus::Hit);
}

/// The command end to end: `epivox bench --quick` on the built-in scene writes the files (with the
/// grids asked for with `--grid`), and a second run into the same folder takes the reference from
/// the cache.
#[test]
fn bench_command_quick_run_and_cache_reuse() {
    if epivox::gpu::GpuContext::headless().is_err() {
        eprintln!("SKIPPED: no GPU adapter at all");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let run = || {
        let o = Command::new(env!("CARGO_BIN_EXE_epivox"))
            .args(["bench", "--quick", "--size", "24x24", "--no-scaling", "--out", out])
            // A grid of one's own joins the sweep; one the adapter cannot hold is noted and skipped
            // (as bits: the first hits of every grid within Grid's limits fit llvmpipe's binding).
            .args(["--volume", "bits"])
            .args(["--grid", "96x96x64", "--grid", "8192x8192x2048"])
            .output()
            .expect("run epivox");
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(o.status.success(), "stdout: {stdout}\nstderr: {}", String::from_utf8_lossy(&o.stderr));
        stdout
    };
    let first = run();
    assert!(first.contains("reference rendered"), "{first}");
    assert!(first.contains("cartesian: skipped"), "the built-in point light has no Cartesian grid: {first}");
    let own = first.lines().find(|l| l.starts_with("vsv") && l.contains("96x96x64"));
    assert!(own.is_some_and(|l| l.contains('%')), "the --grid point has no row: {first}");
    assert!(
        first.lines().any(|l| l.contains("8192x8192x2048: skipped") && l.contains("allows at most")),
        "the grid too large for the adapter is not named: {first}"
    );
    for f in ["results.csv", "report.md", "error_vs_time.png"] {
        assert!(dir.path().join(f).is_file(), "{f} missing");
    }
    let second = run();
    assert!(second.contains("reference from the cache"), "{second}");
}

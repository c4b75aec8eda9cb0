//! The real editor window: `epivox edit` under an X server (Xvfb in `scripts/test.sh`), and the
//! message without one.
//!
//! With `EPIVOX_EDITOR_SCREENSHOT=path` the window's screenshot is also copied there (how
//! `docs/editor.png` is made).

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn epivox() -> Command {
    Command::new(env!("CARGO_BIN_EXE_epivox"))
}

/// Runs `cmd` with a time limit, returning (exit code, stdout, stderr).
fn run_limited(mut cmd: Command, limit: Duration) -> (Option<i32>, String, String) {
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("spawn epivox");
    let t0 = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait") {
            let out = child.wait_with_output().expect("output");
            let _ = status;
            return (
                out.status.code(),
                String::from_utf8_lossy(&out.stdout).to_string(),
                String::from_utf8_lossy(&out.stderr).to_string(),
            );
        }
        if t0.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "epivox edit did not quit within {limit:?}\nstdout:\n{}\nstderr:\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn without_a_display_it_says_so_and_points_to_render() {
    let mut cmd = epivox();
    cmd.env_remove("DISPLAY").env_remove("WAYLAND_DISPLAY");
    let (code, _, err) = run_limited(cmd, Duration::from_secs(60));
    assert_ne!(code, Some(0), "exited 0 without a display");
    assert!(code.is_some(), "killed by a signal (a panic?): {err}");
    assert!(err.contains("no display") && err.contains("epivox render"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn the_window_opens_on_the_built_in_scene_draws_and_quits() {
    let display = std::env::var_os("DISPLAY").filter(|d| !d.is_empty());
    if display.is_none() {
        eprintln!("SKIPPED: DISPLAY is not set (scripts/test.sh starts Xvfb for this test)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("editor.png");
    let mut cmd = epivox();
    cmd.args(["edit", "--quit-after-frames", "4", "--screenshot"]).arg(&shot);
    // Keep the user's recent files out of it, and use Xvfb's display only.
    cmd.env("EPIVOX_CONFIG_DIR", dir.path().join("config")).env_remove("WAYLAND_DISPLAY");
    // The software driver needs seconds per frame of the default 1024 x 1024 x 256 grid.
    let (code, out, err) = run_limited(cmd, Duration::from_secs(600));
    assert_eq!(code, Some(0), "epivox edit failed\nstdout:\n{out}\nstderr:\n{err}");
    let summary: serde_json::Value = serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"));
    eprintln!("editor window run: {summary}");
    assert_eq!(summary["scene"], "built-in", "{summary}");
    assert!(summary["errors"].as_array().is_some_and(|e| e.is_empty()), "{summary}");
    let img = image::open(&shot).unwrap_or_else(|e| panic!("{}: {e}", shot.display())).to_rgba8();
    // The viewport's part of the screenshot is a picture, not one flat colour.
    let v: Vec<u32> = summary["viewport_px"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap() as u32).collect();
    let (x0, y0, w, h) = (v[0], v[1], v[2], v[3]);
    assert!(
        w > 64 && h > 64 && x0 + w <= img.width() && y0 + h <= img.height(),
        "viewport {v:?} in {}x{}",
        img.width(),
        img.height()
    );
    let mut colours: Vec<[u8; 4]> = Vec::new();
    for y in (y0 + 2..y0 + h - 2).step_by(3) {
        for x in (x0 + 2..x0 + w - 2).step_by(3) {
            colours.push(img.get_pixel(x, y).0);
        }
    }
    colours.sort();
    colours.dedup();
    assert!(colours.len() > 100, "the viewport is (nearly) one colour: {} colours", colours.len());
    if let Some(p) = std::env::var_os("EPIVOX_EDITOR_SCREENSHOT") {
        std::fs::copy(&shot, Path::new(&p)).expect("copy the screenshot");
    }
}

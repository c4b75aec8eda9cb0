//! The editor, headless: egui_kittest drives the real `Editor` and renders it with wgpu (the
//! software Vulkan driver in CI), viewport included, so the tests see what a user would see.
//!
//! The scenes use a small grid (128 x 128 x 64) and a small window: on the software driver a frame
//! of the default 1024 x 1024 x 256 grid takes seconds.
//!
//! The editor renders on a worker thread and never waits for it, so a test that wants to see a
//! state's picture steps the UI until the editor has caught up ([`settle`]).

use eframe::egui;
use eframe::egui_wgpu;
use egui_kittest::kittest::{NodeT, Queryable};
use egui_kittest::Harness;
use epivox::editor::{Command, Editor, EditorOptions, ExposureMode, InspectorMode, Quality, RenderPriority, ViewMode};
use epivox::gpu::{GpuContext, GpuError, EMBEDDED};
use epivox::params::Grid;
use epivox::scene::{builtin_scene, Scene};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Creates the editor on the harness's context.
type MakeEditor = Box<dyn FnOnce(&egui::Context) -> Editor>;

/// The app under test: the editor is created inside the first frame, on the harness's context.
struct App {
    make: Option<MakeEditor>,
    editor: Option<Editor>,
}

impl App {
    fn ed(&self) -> &Editor {
        self.editor.as_ref().expect("the editor exists after the first frame")
    }
    fn ed_mut(&mut self) -> &mut Editor {
        self.editor.as_mut().expect("the editor exists after the first frame")
    }
}

fn small_scene() -> Scene {
    let mut s = builtin_scene();
    s.grid = Grid { planes: 128, rays: 128, bins: 64, ..Grid::default() };
    s
}

/// A harness around a fresh editor, or `None` (test skipped) without any GPU adapter.
fn harness(opts: EditorOptions) -> Option<Harness<'static, App>> {
    match GpuContext::headless() {
        Err(GpuError::NoAdapter) => {
            eprintln!("SKIPPED: no GPU adapter (install mesa-vulkan-drivers for the software one)");
            return None;
        }
        Err(e) => panic!("{e}"),
        Ok(_) => {}
    }
    let rs =
        egui_kittest::wgpu::create_render_state(epivox::editor::wgpu_setup(), egui_wgpu::RendererOptions::default());
    let rs2 = rs.clone();
    let make = Box::new(move |ctx: &egui::Context| {
        Editor::new(ctx, rs2, small_scene(), 0.0, None, &opts).unwrap_or_else(|e| panic!("{e}"))
    });
    let app = App { make: Some(make), editor: None };
    let mut h = Harness::builder()
        .with_size(egui::vec2(1200.0, 820.0))
        // A finished frame asks for a repaint from the worker thread: `run` may take a few more
        // steps than an editor that renders inline.
        .with_max_steps(64)
        .renderer(egui_kittest::wgpu::WgpuTestRenderer::from_render_state(rs))
        .build_ui_state(
            |ui, app: &mut App| {
                if let Some(make) = app.make.take() {
                    app.editor = Some(make(ui.ctx()));
                }
                if let Some(e) = app.editor.as_mut() {
                    e.ui(ui);
                }
            },
            app,
        );
    h.run();
    Some(h)
}

/// Options with private folders, so that tests do not touch the user's config or presets.
fn options(dir: &Path) -> EditorOptions {
    let presets = dir.join("presets");
    std::fs::create_dir_all(&presets).unwrap();
    EditorOptions {
        presets_dir: Some(presets),
        config_dir: Some(dir.join("config")),
        watch_shaders: false,
        shader_dir: None,
        // The harness polls for the render on the UI thread while other tests load the same
        // cores: a SCHED_IDLE worker could wait behind them for as long as they run.
        render_priority: RenderPriority::Lowered,
        ..EditorOptions::default()
    }
}

/// Steps the UI until the editor shows the newest state at full quality with nothing left to
/// render (the worker renders in the background; the UI never waits for it).
fn settle(h: &mut Harness<'static, App>) {
    h.step();
    let t0 = Instant::now();
    while !h.state().ed().settled() {
        assert!(t0.elapsed() < Duration::from_secs(180), "the editor did not catch up within 180 s");
        std::thread::sleep(Duration::from_millis(10));
        h.step();
    }
    h.step();
}

/// The viewport's pixels (RGBA8, row-major) and its size, once the editor has caught up.
fn viewport_pixels(h: &mut Harness<'static, App>) -> (Vec<[u8; 4]>, u32, u32) {
    settle(h);
    let img = h.render().unwrap_or_else(|e| panic!("{e}"));
    let r = h.state().ed().viewport_rect().expect("a viewport was laid out");
    let ppp = h.ctx.pixels_per_point();
    // Stay clear of the border (egui's frame, anti-aliasing).
    let (x0, y0) = (((r.left() + 2.0) * ppp) as u32, ((r.top() + 2.0) * ppp) as u32);
    let (x1, y1) = (((r.right() - 2.0) * ppp) as u32, ((r.bottom() - 2.0) * ppp) as u32);
    let (x1, y1) = (x1.min(img.width()), y1.min(img.height()));
    let mut px = Vec::new();
    for y in y0..y1 {
        for x in x0..x1 {
            px.push(img.get_pixel(x, y).0);
        }
    }
    (px, x1 - x0, y1 - y0)
}

fn distinct_colours(px: &[[u8; 4]]) -> usize {
    let mut v: Vec<[u8; 4]> = px.to_vec();
    v.sort();
    v.dedup();
    v.len()
}

/// Mean absolute difference per channel (0..255).
fn mean_diff(a: &[[u8; 4]], b: &[[u8; 4]]) -> f64 {
    assert_eq!(a.len(), b.len());
    let s: u64 =
        a.iter().zip(b).map(|(p, q)| (0..3).map(|c| (p[c] as i64 - q[c] as i64).unsigned_abs()).sum::<u64>()).sum();
    s as f64 / (a.len() * 3) as f64
}

fn has_label_containing(h: &Harness<'static, App>, text: &str) -> bool {
    h.query_all_by_label_contains(text).next().is_some()
}

/// The slider labelled `label` (its text label is a node of its own).
fn slider<'a>(h: &'a Harness<'static, App>, label: &'a str) -> egui_kittest::Node<'a> {
    h.get_by_role_and_label(egui::accesskit::Role::Slider, label)
}

#[test]
fn panels_exist_and_the_viewport_shows_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    for label in ["Presets", "Medium", "Phase function", "Light", "Grid", "Stats", "Accuracy", "Epipolar grid"] {
        assert!(has_label_containing(&h, label), "no '{label}' in the editor");
    }
    for slider in ["density", "g (asymmetry)", "intensity", "planes", "rays", "bins", "exposure"] {
        assert!(h.query_by_role_and_label(egui::accesskit::Role::Slider, slider).is_some(), "no '{slider}' slider");
    }
    // The shipped presets are listed.
    let (px, w, hgt) = viewport_pixels(&mut h);
    assert!(w > 100 && hgt > 100, "viewport {w}x{hgt}");
    let n = distinct_colours(&px);
    assert!(n > 200, "the viewport is (nearly) one colour: {n} colours");
    assert_eq!(h.state().ed().full_frames_rendered(), 1);
    let frames = h.state().ed().frames_rendered();
    // Nothing changed: drawing again does not render again.
    let _ = viewport_pixels(&mut h);
    let _ = viewport_pixels(&mut h);
    assert_eq!(h.state().ed().frames_rendered(), frames, "re-rendered without a change");
    // Which picture is on screen is said in Stats.
    assert!(has_label_containing(&h, "on screen: full quality"), "Stats do not say which picture is shown");
    // The stats show GPU time per pass when the adapter has timestamps, and the grid memory.
    assert!(has_label_containing(&h, "grid memory"));
    assert!(has_label_containing(&h, "triangles voxelized"), "no account of the work kept");
    assert!(has_label_containing(&h, "shaders specialised to: point light"), "no shader variant in the stats");
    assert!(h.state().ed().frame_error().is_none());
    assert!(h.state().ed().shown().is_some_and(|p| p.quality == Quality::Full));
}

#[test]
fn a_slider_changes_the_rendered_viewport_and_undo_restores_it() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let (before, ..) = viewport_pixels(&mut h);
    let d0 = h.state().ed().look().medium.density;
    slider(&h, "density").set_value_accesskit(4.0);
    h.run();
    assert_eq!(h.state().ed().look().medium.density, 4.0);
    let (after, ..) = viewport_pixels(&mut h);
    let diff = mean_diff(&before, &after);
    assert!(diff > 2.0, "the viewport barely changed (mean difference {diff:.2} of 255)");
    // Undo: back to the first look and the first picture.
    assert!(h.state().ed().history().can_undo());
    h.state_mut().ed_mut().apply(Command::Undo);
    assert_eq!(h.state().ed().look().medium.density, d0);
    let (undone, ..) = viewport_pixels(&mut h);
    assert!(mean_diff(&before, &undone) < 0.5, "undo did not restore the picture");
    h.state_mut().ed_mut().apply(Command::Redo);
    assert_eq!(h.state().ed().look().medium.density, 4.0);
    // The view modes change the picture too.
    settle(&mut h);
    let renders = h.state().ed().frames_rendered();
    h.state_mut().ed_mut().apply(Command::SetView(ViewMode::Scattered));
    let (scatter, ..) = viewport_pixels(&mut h);
    assert!(mean_diff(&after, &scatter) > 1.0);
    // Both images of a frame are on screen already: switching to the scattered light renders nothing.
    assert_eq!(
        h.state().ed().frames_rendered(),
        renders,
        "switching the view mode rendered again: {:?}",
        h.state().ed().render_log()
    );
}

/// Mean luminance of RGBA8 pixels (0..255).
fn brightness(px: &[[u8; 4]]) -> f64 {
    px.iter().map(|p| 0.2126 * p[0] as f64 + 0.7152 * p[1] as f64 + 0.0722 * p[2] as f64).sum::<f64>() / px.len() as f64
}

#[test]
fn the_scattered_light_alone_is_exposed_automatically_or_by_hand() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    // A thin medium: its scattered light alone is far darker than the final image.
    slider(&h, "density").set_value_accesskit(0.05);
    h.run();
    h.state_mut().ed_mut().apply(Command::SetView(ViewMode::Scattered));
    h.state_mut().ed_mut().apply(Command::SetExposureMode(ExposureMode::Manual));
    h.state_mut().ed_mut().apply(Command::SetScatterExposure(0.0));
    let (manual, ..) = viewport_pixels(&mut h);
    // Automatic (the default): the mean maps to middle grey, whatever the medium.
    h.state_mut().ed_mut().apply(Command::SetExposureMode(ExposureMode::AutoMean));
    let (auto, ..) = viewport_pixels(&mut h);
    let (dark, bright) = (brightness(&manual), brightness(&auto));
    eprintln!("scattered light alone: mean brightness {dark:.1} at 0 EV, {bright:.1} auto-exposed");
    assert!(bright > 40.0, "the auto-exposed scattered light is still dark: {bright:.1} of 255");
    assert!(bright > dark + 10.0, "auto exposure did not brighten the view: {dark:.1} -> {bright:.1}");
    let mean_ev = h.state().ed().shown_exposure();
    h.state_mut().ed_mut().apply(Command::SetExposureMode(ExposureMode::AutoPercentile));
    h.step();
    let p99_ev = h.state().ed().shown_exposure();
    assert!(mean_ev != p99_ev && p99_ev.is_finite(), "percentile {p99_ev} vs mean {mean_ev}");
    // The toolbar keeps an exposure slider in this view (enabled in manual mode).
    assert!(h.query_by_role_and_label(egui::accesskit::Role::Slider, "exposure").is_some());
    // The final image keeps the look's own exposure.
    h.state_mut().ed_mut().apply(Command::SetView(ViewMode::Final));
    h.step();
    assert_eq!(h.state().ed().shown_exposure(), h.state().ed().look().exposure);
}

#[test]
fn a_bad_preset_is_refused_with_its_field_named_and_the_look_kept() {
    let dir = tempfile::tempdir().unwrap();
    let opts = options(dir.path());
    let presets = opts.presets_dir.clone().unwrap();
    std::fs::write(presets.join("broken.toml"), "format = 1\n[medium]\ndensity = -3.0\n").unwrap();
    let Some(mut h) = harness(opts) else { return };
    let look = *h.state().ed().look();
    h.get_by_label("broken").click();
    h.run();
    assert_eq!(*h.state().ed().look(), look, "a refused preset changed the look");
    assert!(has_label_containing(&h, "preset refused"), "no error shown");
    assert!(has_label_containing(&h, "density"), "the error does not name the field");
    // Unknown fields and other versions are refused as well, naming what is wrong.
    let unknown = presets.join("unknown.toml");
    std::fs::write(&unknown, "format = 1\n[medium]\ndensty = 2.0\n").unwrap();
    h.state_mut().ed_mut().apply(Command::LoadPreset(unknown));
    h.run();
    assert!(has_label_containing(&h, "densty"));
    let newer = presets.join("newer.toml");
    std::fs::write(&newer, "format = 9\n").unwrap();
    h.state_mut().ed_mut().apply(Command::LoadPreset(newer));
    h.run();
    assert!(has_label_containing(&h, "format = 9"));
    assert_eq!(*h.state().ed().look(), look);
    assert!(!h.state().ed().history().can_undo(), "a refused preset left an undo step");
}

#[test]
fn saving_and_loading_a_preset_round_trips_and_never_overwrites_silently() {
    let dir = tempfile::tempdir().unwrap();
    let opts = options(dir.path());
    let presets = opts.presets_dir.clone().unwrap();
    let Some(mut h) = harness(opts) else { return };
    slider(&h, "density").set_value_accesskit(2.5);
    slider(&h, "g (asymmetry)").set_value_accesskit(-0.25);
    h.run();
    let saved = *h.state().ed().look();
    // Type a name and save into the preset folder.
    let field = h.get_by_role(egui::accesskit::Role::TextInput);
    field.focus();
    h.run();
    h.get_by_role(egui::accesskit::Role::TextInput).type_text("My Look");
    h.run();
    h.get_by_label("Save to folder").click();
    h.run();
    let file = presets.join("my-look.toml");
    assert!(file.is_file(), "{} not written", file.display());
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("format = 1") && text.contains("density = 2.5"), "{text}");
    // Change the look, then load the preset back from the list.
    slider(&h, "density").set_value_accesskit(0.5);
    h.run();
    assert_ne!(h.state().ed().look().medium, saved.medium);
    h.get_by_label("my-look").click();
    h.run();
    assert_eq!(h.state().ed().look().medium, saved.medium, "the preset did not round-trip");
    // Saving again under the same name asks first, and Cancel keeps the file.
    slider(&h, "density").set_value_accesskit(7.0);
    h.run();
    h.get_by_label("Save to folder").click();
    h.run();
    assert!(h.state().ed().confirming_overwrite().is_some(), "no question before overwriting");
    assert!(has_label_containing(&h, "already exists"));
    h.get_by_label("Cancel").click();
    h.run();
    assert!(h.state().ed().confirming_overwrite().is_none());
    assert_eq!(std::fs::read_to_string(&file).unwrap(), text, "the file changed without consent");
    // Replace, when asked for, writes it.
    h.get_by_label("Save to folder").click();
    h.run();
    h.get_by_label("Replace").click();
    h.run();
    assert!(std::fs::read_to_string(&file).unwrap().contains("density = 7.0"));
    // No temporary files are left in the folder.
    let names: Vec<String> =
        std::fs::read_dir(&presets).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().to_string()).collect();
    assert_eq!(names, vec!["my-look.toml".to_string()]);
}

/// Steps the harness until `done` holds or `timeout` passes (the watcher works on its own thread).
fn wait_for(h: &mut Harness<'static, App>, timeout: Duration, done: impl Fn(&Editor) -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < timeout {
        h.step();
        if done(h.state().ed()) {
            h.run();
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

fn copy_shaders(dir: &Path) -> PathBuf {
    let d = dir.join("shaders");
    std::fs::create_dir_all(&d).unwrap();
    for (name, text) in EMBEDDED {
        std::fs::write(d.join(name), text).unwrap();
    }
    d
}

/// Runs the UI the way a window's event loop does: a frame only when one was asked for (no input
/// arrives) — by a repaint request from another thread (the watcher's, the worker's: `woken`), or
/// by the last frame's own repaint delay — until `done` holds or `timeout` passes. Returns how
/// long it took.
fn idle_until(
    h: &mut Harness<'static, App>,
    woken: &AtomicBool,
    timeout: Duration,
    done: impl Fn(&Editor) -> bool,
) -> Option<Duration> {
    let t0 = Instant::now();
    let delay = |h: &Harness<'static, App>| {
        h.output().viewport_output.get(&egui::ViewportId::ROOT).map_or(Duration::MAX, |v| v.repaint_delay)
    };
    let mut next = Instant::now().checked_add(delay(h));
    while t0.elapsed() < timeout {
        if woken.swap(false, Ordering::SeqCst) || next.is_some_and(|n| Instant::now() >= n) {
            h.step();
            next = Instant::now().checked_add(delay(h));
            if done(h.state().ed()) {
                return Some(t0.elapsed());
            }
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    None
}

/// Sets `woken` on every repaint request made between frames (from the watcher's and the
/// worker's threads), as eframe's event loop is woken.
fn watch_repaints(h: &Harness<'static, App>) -> Arc<AtomicBool> {
    let woken = Arc::new(AtomicBool::new(false));
    let w = woken.clone();
    h.ctx.set_request_repaint_callback(move |info| {
        if info.delay == Duration::ZERO {
            w.store(true, Ordering::SeqCst);
        }
    });
    woken
}

/// `text` with its last `textureStore(target, coords, value)` writing `value` times `tint`.
fn tinted(text: &str, tint: &str) -> String {
    let at = text.rfind("textureStore(").expect("a textureStore call to tint");
    let open = at + "textureStore(".len();
    let end = text[open..].find(");").expect("the call's end") + open;
    // The third top-level argument.
    let (mut depth, mut commas, mut third) = (0, 0, None);
    for (i, c) in text[open..end].char_indices() {
        match c {
            '(' => depth += 1,
            ')' => depth -= 1,
            ',' if depth == 0 => {
                commas += 1;
                if commas == 2 {
                    third = Some(open + i + 1);
                }
            }
            _ => {}
        }
    }
    let third = third.expect("textureStore has three arguments");
    format!("{}({}) * {tint}{}", &text[..third], text[third..end].trim(), &text[end..])
}

#[test]
fn shader_saves_reach_the_screen_without_input_and_a_broken_one_keeps_the_picture() {
    let dir = tempfile::tempdir().unwrap();
    let shaders = copy_shaders(dir.path());
    let mut opts = options(dir.path());
    opts.shader_dir = Some(shaders.clone());
    opts.watch_shaders = true;
    let Some(mut h) = harness(opts) else { return };
    let (before, w, _) = viewport_pixels(&mut h);
    let woken = watch_repaints(&h);
    let (gen0, epoch0) = (h.state().ed().generation(), h.state().ed().shader_epoch());
    let seen = |e: &Editor, gen: u64| e.shown().is_some_and(|p| p.generation > gen);

    // 1. A tinted composite.wgsl saved in place: the new picture comes with no input at all.
    let composite = std::fs::read_to_string(shaders.join("composite.wgsl")).unwrap();
    std::fs::write(shaders.join("composite.wgsl"), tinted(&composite, "vec4f(1.0, 0.25, 0.25, 1.0)")).unwrap();
    let first = idle_until(&mut h, &woken, Duration::from_secs(60), |e| e.shader_epoch() > epoch0 && seen(e, gen0))
        .expect("the saved shader never reached the screen without input");
    let full = idle_until(&mut h, &woken, Duration::from_secs(60), |e| e.settled())
        .expect("the full-quality frame never came without input");
    eprintln!(
        "shader save -> first new picture {:.2} s, full quality {:.2} s later",
        first.as_secs_f64(),
        full.as_secs_f64()
    );
    let (tint, ..) = viewport_pixels(&mut h);
    assert!(mean_diff(&before, &tint) > 2.0, "the tinted shader did not change the picture");
    let red = |px: &[[u8; 4]]| px.iter().map(|p| p[0] as f64 - p[1] as f64).sum::<f64>() / px.len() as f64;
    assert!(red(&tint) > red(&before) + 2.0, "the picture is not tinted red");

    // 2. A broken save: the error (file:line:col) shows over the picture, which stays.
    let good = std::fs::read_to_string(shaders.join("integrate.wgsl")).unwrap();
    let broken = good.replacen("fn ", "fn broken_fn() -> f32 { return undefined_name; }\nfn ", 1);
    let line = broken.lines().position(|l| l.contains("undefined_name")).unwrap() + 1;
    std::fs::write(shaders.join("integrate.wgsl"), &broken).unwrap();
    idle_until(&mut h, &woken, Duration::from_secs(60), |e| e.shader_error().is_some() && !e.compiling())
        .expect("the broken shader was not reported without input");
    let err = h.state().ed().shader_error().unwrap().to_string();
    assert!(err.contains(&format!("integrate.wgsl:{line}:")), "the error does not name file:line:col: {err}");
    assert!(has_label_containing(&h, "integrate.wgsl:"), "the error is not shown over the viewport");
    // Compare the lower half: the error text covers the top.
    let (kept, ..) = viewport_pixels(&mut h);
    let half = before.len() / 2 / w as usize * w as usize;
    assert!(mean_diff(&tint[half..], &kept[half..]) < 0.5, "the picture changed after a broken edit");
    // Other edits still render with the last good pipelines.
    slider(&h, "density").set_value_accesskit(3.0);
    h.run();
    let (edited, ..) = viewport_pixels(&mut h);
    assert!(mean_diff(&kept[half..], &edited[half..]) > 1.0, "edits stopped rendering after a broken shader");

    // 3. The fix, saved the way many editors do (a temporary file renamed over the original).
    let gen1 = h.state().ed().generation();
    let tmp = shaders.join(".integrate.wgsl.swp-save");
    std::fs::write(&tmp, &good).unwrap();
    std::fs::rename(&tmp, shaders.join("integrate.wgsl")).unwrap();
    let fixed = idle_until(&mut h, &woken, Duration::from_secs(60), |e| e.shader_error().is_none() && seen(e, gen1))
        .expect("fixing the shader did not reach the screen without input");
    eprintln!("fix saved -> error gone and new picture {:.2} s", fixed.as_secs_f64());
    assert!(!has_label_containing(&h, "integrate.wgsl:"));

    // 4. The shared module: a broken one is reported by its own name, and its fix clears it.
    let common = std::fs::read_to_string(shaders.join("common.wgsl")).unwrap();
    std::fs::write(shaders.join("common.wgsl"), format!("{common}\nfn oops( {{\n")).unwrap();
    idle_until(&mut h, &woken, Duration::from_secs(60), |e| {
        e.shader_error().is_some_and(|m| m.contains("common.wgsl:"))
    })
    .expect("a broken common.wgsl was not reported");
    std::fs::write(shaders.join("common.wgsl"), &common).unwrap();
    idle_until(&mut h, &woken, Duration::from_secs(60), |e| e.shader_error().is_none()).expect("common.wgsl fix");
}

#[test]
fn the_inspector_reads_the_grid_and_links_hover_both_ways() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let _ = viewport_pixels(&mut h);
    assert!(has_label_containing(&h, "128 planes × 128 rays × 64 bins"), "no grid picture");
    // The grid shown is the full frame's on screen (a preview's coarser grid is never shown).
    let (g_gen, g) = h.state().ed().inspector_grid().expect("no grid read back");
    assert_eq!((g_gen, g.planes, g.rays), (h.state().ed().generation(), 128, 128));
    // A medium edit reuses the shadow volume (Renderer::reuse_unchanged): the grid is not read back
    // again, and the inspector does not call the one it holds older than the picture.
    slider(&h, "density").set_value_accesskit(2.0);
    let _ = viewport_pixels(&mut h);
    assert!(h.state().ed().generation() > g_gen, "the edit rendered nothing");
    assert_eq!(h.state().ed().inspector_grid().map(|g| g.0), Some(g_gen), "the same grid was read back again");
    assert!(!has_label_containing(&h, "the grid of the last full-quality frame"), "the reused grid is called older");
    // Viewport -> inspector: the pixel under the pointer has a plane and a ray, and the slice
    // follows its plane.
    let r = h.state().ed().viewport_rect().unwrap();
    h.hover_at(r.center() + egui::vec2(-r.width() * 0.2, r.height() * 0.1));
    h.run();
    let (x, y) = h.state().ed().viewport_cell().expect("no grid cell under the pointer");
    assert!((0.0..128.0).contains(&x) && (0.0..128.0).contains(&y), "{x},{y}");
    assert_eq!(h.state().ed().slice_plane(), x as u32, "the slice did not follow the pointer");
    // Inspector -> viewport: hovering the grid picture names the cell under the pointer.
    let (ix, iy) = hover_inspector_picture(&mut h, egui::vec2(0.25, 0.75));
    assert!((ix - 32.0).abs() < 2.0 && (iy - 96.0).abs() < 2.0, "{ix},{iy}");
    assert!(h.state().ed().viewport_cell().is_none());
    // Export the picture.
    let png = dir.path().join("grid.png");
    h.state_mut().ed_mut().apply(Command::ExportInspector(png.clone()));
    let img = image::open(&png).unwrap_or_else(|e| panic!("{}: {e}", png.display())).to_rgba8();
    assert!(img.width() >= 128 + 64 && img.height() == 128, "{}x{}", img.width(), img.height());
    // The layer view: one bin of both grids as a planes x rays picture, with a bin slider, in the
    // grid picture's place (so hover links the same way).
    h.state_mut().ed_mut().apply(Command::SetInspectorMode(InspectorMode::Layer(40)));
    h.run();
    assert!(h.query_by_role_and_label(egui::accesskit::Role::Slider, "bin").is_some(), "no bin slider");
    let layer_png = |h: &mut Harness<'static, App>, k: u32, name: &str| {
        h.state_mut().ed_mut().apply(Command::SetInspectorMode(InspectorMode::Layer(k)));
        h.run();
        let path = dir.path().join(name);
        h.state_mut().ed_mut().apply(Command::ExportInspector(path.clone()));
        image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
    };
    let (near, far) = (layer_png(&mut h, 2, "near.png"), layer_png(&mut h, 40, "far.png"));
    let grid_part = |i: &image::RgbaImage| -> Vec<[u8; 4]> {
        (0..128).flat_map(|y| (0..128).map(move |x| (x, y))).map(|(x, y)| i.get_pixel(x, y).0).collect()
    };
    assert!(mean_diff(&grid_part(&near), &grid_part(&far)) > 1.0, "two layers look the same");
    assert!(mean_diff(&grid_part(&img), &grid_part(&far)) > 1.0, "the layer looks like the count picture");
    let (lx, ly) = hover_inspector_picture(&mut h, egui::vec2(0.75, 0.25));
    assert!((lx - 96.0).abs() < 2.0 && (ly - 32.0).abs() < 2.0, "{lx},{ly}");
    // A screenshot of the viewport.
    let shot = dir.path().join("shot.png");
    h.state_mut().ed_mut().apply(Command::Screenshot(shot.clone()));
    assert!(image::open(&shot).is_ok());
    assert!(h.state().ed().messages().iter().all(|m| !m.error), "{:?}", h.state().ed().messages());
}

/// Hovers the inspector's grid (or layer) picture at `frac` of its size, once the editor has
/// caught up, and returns the cell the editor names. The picture is looked up again after the
/// hover's frames and the pointer put back on the same point of it when it moved: a line that
/// appears above it between two frames moves it down (seen once in a CI run on 2 loaded cores,
/// where the layer picture's hover read row 26.6 for 32).
fn hover_inspector_picture(h: &mut Harness<'static, App>, frac: egui::Vec2) -> (f64, f64) {
    settle(h);
    for _ in 0..3 {
        let g = h.state().ed().inspector_grid_rect().expect("no grid picture drawn");
        h.hover_at(g.left_top() + g.size() * frac);
        h.run();
        if h.state().ed().inspector_grid_rect() == Some(g) {
            break;
        }
    }
    h.state().ed().inspector_cell().expect("no cell under the pointer in the inspector")
}

/// Presses at `from`, moves to `to` in steps, releases.
fn drag(h: &mut Harness<'static, App>, from: egui::Pos2, to: egui::Pos2) {
    h.hover_at(from);
    h.run();
    h.drag_at(from);
    h.run();
    for i in 1..=4 {
        h.hover_at(from + (to - from) * (i as f32 / 4.0));
        h.run();
    }
    h.drop_at(to);
    h.run();
}

#[test]
fn dragging_orbits_the_camera_or_moves_the_light_and_each_drag_is_one_undo_step() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let _ = viewport_pixels(&mut h);
    let r = h.state().ed().viewport_rect().unwrap();
    let cam0 = h.state().ed().look().camera;
    drag(&mut h, r.center(), r.center() + egui::vec2(80.0, 30.0));
    let cam1 = h.state().ed().look().camera;
    assert_ne!(cam0.eye, cam1.eye, "dragging did not orbit");
    assert_eq!(cam0.target, cam1.target, "orbiting moved the target");
    assert!(((cam1.eye - cam1.target).length() - (cam0.eye - cam0.target).length()).abs() < 1e-3);
    h.state_mut().ed_mut().apply(Command::Undo);
    assert_eq!(h.state().ed().look().camera, cam0, "one undo did not undo the whole drag");
    // Put a point light in view, then drag its handle: the light moves, the camera does not.
    let target = cam0.target;
    let light = epivox::params::Light::Point {
        position: target + glam::Vec3::Y * 0.3,
        intensity: glam::Vec3::splat(5.0),
        radius: 0.0,
    };
    h.state_mut().ed_mut().apply(Command::SetLight(light, None));
    h.run();
    let handle = h.state().ed().light_handle_pos().expect("the light is in view");
    assert!(r.contains(handle));
    drag(&mut h, handle, handle + egui::vec2(40.0, -20.0));
    let moved = h.state().ed().look().light;
    assert_eq!(h.state().ed().look().camera, cam0, "dragging the light moved the camera");
    let epivox::params::Light::Point { position, .. } = moved else { panic!("{moved:?}") };
    assert!(position.distance(target + glam::Vec3::Y * 0.3) > 1e-3, "the light did not move");
    let after = h.state().ed().light_handle_pos().unwrap();
    assert!(
        (after - (handle + egui::vec2(40.0, -20.0))).length() < 3.0,
        "the light does not follow the pointer: {after:?}"
    );
    h.state_mut().ed_mut().apply(Command::Undo);
    assert_eq!(h.state().ed().look().light, light.normalized());
}

#[test]
fn a_slider_drag_never_waits_for_a_render_and_only_the_newest_value_is_rendered() {
    let dir = tempfile::tempdir().unwrap();
    let mut opts = options(dir.path());
    // Every frame takes at least this long, as on a slow GPU, whatever the machine.
    opts.frame_delay = Some(Duration::from_millis(400));
    let Some(mut h) = harness(opts) else { return };
    settle(&mut h);
    let log_start = h.state().ed().render_log().len();
    let rail = slider(&h, "density").rect();
    let y = rail.center().y;
    let (x0, x1) = (rail.left() + rail.width() * 0.2, rail.left() + rail.width() * 0.8);
    h.hover_at(egui::pos2(x0, y));
    h.step();
    h.drag_at(egui::pos2(x0, y));
    h.step();
    let drag_start = Instant::now();
    // (the render in flight and its count before, after) for every UI frame of the drag.
    let mut frames = Vec::new();
    let mut values = Vec::new();
    let n = 12;
    for i in 1..=n {
        h.hover_at(egui::pos2(x0 + (x1 - x0) * i as f32 / n as f32, y));
        let before = (h.state().ed().render_in_flight(), h.state().ed().frames_rendered());
        h.step();
        let after = (h.state().ed().render_in_flight(), h.state().ed().frames_rendered());
        frames.push((before, after));
        let d = h.state().ed().look().medium.density;
        if values.last() != Some(&d) {
            values.push(d);
        }
    }
    h.drop_at(egui::pos2(x1, y));
    h.step();
    let drag_time = drag_start.elapsed();
    let last = h.state().ed().look().medium.density;
    assert!(values.len() >= 6, "the drag produced too few values: {values:?}");
    assert_eq!(Some(&last), values.last());
    // The UI went on while a render was in flight: frames that began and ended with the same
    // render still running (it takes 400 ms; a UI that waited for it would see it finish).
    let during = frames.iter().filter(|((a, fa), (b, fb))| *a && *b && fa == fb).count();
    assert!(during >= 6, "only {during} of {n} UI frames were produced while a render was in flight: {frames:?}");
    settle(&mut h);
    let rendered: Vec<(u64, bool, f32)> = h.state().ed().render_log()[log_start..].to_vec();
    eprintln!("values while dragging: {values:?}\nrendered: {rendered:?}");
    // Coalescing: the worker took one value while the drag went on (each render takes 400 ms, the
    // drag's frames were faster), then only the newest; no queue of stale values was worked off.
    let stale: Vec<f32> = rendered.iter().map(|r| r.2).filter(|d| *d != last).collect();
    let allowed = 1 + (drag_time.as_secs_f64() / 0.4) as usize;
    assert!(
        stale.len() <= allowed && stale.len() < values.len() / 2,
        "{} stale values were rendered during a {drag_time:?} drag: {rendered:?} of {values:?}",
        stale.len()
    );
    assert!(rendered.iter().filter(|(_, full, _)| *full).all(|(_, _, d)| *d == last), "{rendered:?}");
    assert_eq!(rendered.last().map(|r| (r.1, r.2)), Some((true, last)), "the newest value was not rendered last");
}

#[test]
fn the_accuracy_check_runs_in_the_background_and_can_be_cancelled() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let _ = viewport_pixels(&mut h);
    h.state_mut().ed_mut().apply(Command::StartAccuracy { width: 32 });
    assert!(h.state().ed().accuracy_running());
    // Editing goes on meanwhile.
    slider(&h, "density").set_value_accesskit(1.5);
    // A fixed number of frames: while the job runs the editor keeps repainting (its progress), so
    // `run` (step until settled) would depend on how fast the reference finishes.
    h.run_steps(3);
    assert_eq!(h.state().ed().look().medium.density, 1.5);
    assert!(wait_for(&mut h, Duration::from_secs(300), |e| !e.accuracy_running()), "the reference did not finish");
    let (scatter, hdr) = h.state().ed().accuracy_rel_rmse().expect("no accuracy result");
    let (w, ht) = h.state().ed().accuracy_size().unwrap();
    eprintln!("accuracy check at {w}x{ht}: scattered light rel. RMSE {scatter:.4}, final {hdr:.4}");
    assert!(scatter.is_finite() && hdr.is_finite());
    // The same measurement made independently (headless GPU renderer, reference, metrics) agrees:
    // the check measured the look and view it was started on, at its size.
    let scene = small_scene();
    let mut r =
        epivox::render::Renderer::new(GpuContext::headless().unwrap(), &epivox::gpu::ShaderLibrary::default()).unwrap();
    let gpu = r.render(&scene, w, ht, epivox::render::Method::Vsv).unwrap();
    let reference = epivox::reference::render(&scene, w, ht, &epivox::editor::check_options());
    let expect = epivox::metrics::compare(&gpu.scatter, &reference.scatter).unwrap().rel_rmse;
    assert!((expect - scatter).abs() < 1e-3 + 0.02 * expect, "editor {scatter} vs independent {expect}");
    assert!(has_label_containing(&h, "rel. RMSE"));
    assert!(has_label_containing(&h, "measured for an earlier look"), "the result is not marked stale after an edit");
    // Cancel: the job stops, nothing replaces the last result.
    h.state_mut().ed_mut().apply(Command::StartAccuracy { width: 256 });
    h.state_mut().ed_mut().apply(Command::CancelAccuracy);
    assert!(wait_for(&mut h, Duration::from_secs(60), |e| !e.accuracy_running()), "cancel did not stop the job");
    assert!(h.state().ed().messages().iter().any(|m| m.text.contains("cancelled")));
}

#[test]
fn broken_shaders_at_start_fall_back_to_the_embedded_ones() {
    let dir = tempfile::tempdir().unwrap();
    let shaders = copy_shaders(dir.path());
    std::fs::write(shaders.join("scan.wgsl"), "#import common\nfn nope( {\n").unwrap();
    let mut opts = options(dir.path());
    opts.shader_dir = Some(shaders.clone());
    opts.watch_shaders = true;
    let Some(mut h) = harness(opts) else { return };
    assert!(
        wait_for(&mut h, Duration::from_secs(60), |e| e.shader_error().is_some()),
        "the broken shader is not reported"
    );
    let err = h.state().ed().shader_error().unwrap().to_string();
    assert!(err.contains("scan.wgsl:2:"), "{err}");
    let (px, ..) = viewport_pixels(&mut h);
    assert!(distinct_colours(&px) > 200, "no picture from the embedded shaders");
    // Fixing the file on disk clears the error (the folder is still watched).
    std::fs::write(shaders.join("scan.wgsl"), EMBEDDED.iter().find(|(n, _)| *n == "scan.wgsl").unwrap().1).unwrap();
    assert!(wait_for(&mut h, Duration::from_secs(60), |e| e.shader_error().is_none()));
}

/// The toolbar's "shadows: grid" (VSV's surface shadows from the shadow volume): a pick
/// renders again without a shadow map, and the picture stays the same but for the shadows' edges.
#[test]
fn surface_shadows_from_the_grid_are_one_pick_and_draw_no_shadow_map() {
    use epivox::render::Pass;
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let (before, ..) = viewport_pixels(&mut h);
    let shown = |h: &Harness<'static, App>| h.state().ed().shown().expect("a picture is shown").info.passes.clone();
    assert!(shown(&h).contains(&Pass::ShadowMap), "the default frame drew no shadow map");
    pick_surface_shadows(&mut h, "grid");
    assert!(h.state().ed().grid_shadows(), "the click did not reach the view");
    // The map's size no longer applies: its picker is disabled.
    let picker = |h: &Harness<'static, App>| h.get_by_label("shadow map").accesskit_node().is_disabled();
    assert!(picker(&h), "the shadow-map size is still offered with the shadows from the grid");
    let (after, ..) = viewport_pixels(&mut h);
    let passes = shown(&h);
    assert!(!passes.contains(&Pass::ShadowMap), "the grid-shadowed frame drew a map: {passes:?}");
    // Measured: 6.1 of 255. This editor's grid has 64 bins, so the grating's shadows on the floor
    // step over several pixels at their edges (`epivox render --grid 128x128x64 --surface-shadows
    // grid` shows it); the lit floor itself, a quarter of the view, would move the mean by far more.
    let diff = mean_diff(&before, &after);
    assert!(diff > 0.0 && diff < 10.0, "the picture changed by {diff:.2} of 255");
    // The baseline always draws its map: the picker is back.
    h.state_mut().ed_mut().apply(Command::SetMethod(epivox::render::Method::Raymarch { steps: 64, jitter: true }));
    h.run();
    assert!(!picker(&h), "the shadow-map size is disabled for the baseline");
}

/// The toolbar's "shadows" under a sun: exact by default (`Renderer::surface_shadows`: exact, the
/// surfaces' shadows tested against the triangles); a pick of "map" renders again from the shadow
/// map and one of "exact" goes back; picking the grid's instead turns exact off.
#[test]
fn exact_sun_shadows_are_the_default_and_one_pick() {
    use epivox::render::Pass;
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let sun = epivox::params::Light::Directional {
        direction: glam::Vec3::new(0.4, 1.0, 0.3).normalize(),
        irradiance: glam::Vec3::splat(3.0),
    };
    h.state_mut().ed_mut().apply(Command::SetLight(sun, None));
    let (exact, ..) = viewport_pixels(&mut h);
    let shown = |h: &Harness<'static, App>| h.state().ed().shown().expect("a picture is shown").info.passes.clone();
    assert!(h.state().ed().exact_shadows(), "exact shadows are not the default");
    assert!(shown(&h).contains(&Pass::ExactShadows), "the default frame under a sun: {:?}", shown(&h));
    pick_surface_shadows(&mut h, "map");
    assert!(!h.state().ed().exact_shadows(), "the click did not reach the view");
    let (map, ..) = viewport_pixels(&mut h);
    let passes = shown(&h);
    assert!(passes.contains(&Pass::ShadowMap) && !passes.contains(&Pass::ExactShadows), "{passes:?}");
    // The shadows' edges move by a texel or so; the lit surfaces and the shafts stay.
    let diff = mean_diff(&exact, &map);
    assert!(diff < 10.0, "the picture changed by {diff:.2} of 255");
    pick_surface_shadows(&mut h, "exact");
    assert!(h.state().ed().exact_shadows(), "the click did not reach the view");
    viewport_pixels(&mut h);
    assert!(shown(&h).contains(&Pass::ExactShadows), "the frame after the click: {:?}", shown(&h));
    // One choice of three: the grid's shadows replace the exact ones.
    pick_surface_shadows(&mut h, "grid");
    assert!(h.state().ed().grid_shadows() && !h.state().ed().exact_shadows());
}

/// Opens the toolbar's "shadows" (the surfaces') and picks `item`.
fn pick_surface_shadows(h: &mut Harness<'static, App>, item: &str) {
    h.get_by_label("shadows").click();
    h.run();
    h.get_by_label(item).click();
    h.run();
}

/// The Grid panel's "volume" (`Renderer::shadow_volume`): first hits by default, so the frame's
/// passes take the hits' bounds; the panel offers both, and picking the bits renders again with
/// the scan (the pick as the panel emits it: the panel sits below the fold of the test window).
#[test]
fn the_grid_panel_offers_the_shadow_volume_and_the_frame_follows_it() {
    use epivox::render::{Pass, ShadowVolume};
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let _ = viewport_pixels(&mut h);
    let shown = |h: &Harness<'static, App>| h.state().ed().shown().expect("a picture is shown").info.passes.clone();
    let passes = shown(&h);
    assert!(passes.contains(&Pass::HitBounds) && !passes.contains(&Pass::Scan), "{passes:?}");
    for label in ["first-hits", "bits"] {
        assert!(has_label_containing(&h, label), "the Grid panel offers no '{label}'");
    }
    h.state_mut().ed_mut().apply(Command::SetShadowVolume(ShadowVolume::Bits));
    h.run();
    assert_eq!(h.state().ed().shadow_volume(), ShadowVolume::Bits);
    let _ = viewport_pixels(&mut h);
    let passes = shown(&h);
    assert!(passes.contains(&Pass::Scan) && !passes.contains(&Pass::HitBounds), "{passes:?}");
    h.state_mut().ed_mut().apply(Command::SetShadowVolume(ShadowVolume::FirstHits));
    h.run();
    let _ = viewport_pixels(&mut h);
    assert!(shown(&h).contains(&Pass::HitBounds));
}

/// The toolbar's "adaptive pixels" (`Renderer::adaptive_pixels`, on by default): a click renders
/// again with every pixel integrated, and the frame says which it did; the picture stays the same
/// to the eye (the pixels from their neighbours are within 1% of their own integrals).
#[test]
fn adaptive_pixels_are_one_click_and_the_frame_says_which_pixels_it_integrated() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    let (before, ..) = viewport_pixels(&mut h);
    let adaptive = |h: &Harness<'static, App>| h.state().ed().shown().expect("a picture is shown").info.adaptive_pixels;
    assert!(h.state().ed().adaptive_pixels(), "adaptive pixels are not the editor's default");
    assert!(adaptive(&h), "the default frame integrated every pixel");
    h.get_by_label("adaptive pixels").click();
    h.run();
    assert!(!h.state().ed().adaptive_pixels(), "the click did not reach the view");
    let (after, ..) = viewport_pixels(&mut h);
    assert!(!adaptive(&h), "the frame after the click still took pixels from their neighbours");
    // 8-bit sRGB of the final image: a difference of 1% in the scattered light moves a pixel by
    // at most a level or two.
    let diff = mean_diff(&before, &after);
    assert!(diff < 1.0, "the picture changed by {diff:.2} of 255");
    // The baseline has no Integrate: the switch is not offered.
    h.state_mut().ed_mut().apply(Command::SetMethod(epivox::render::Method::Raymarch { steps: 64, jitter: true }));
    h.run();
    assert!(h.query_by_label("adaptive pixels").is_none(), "the baseline offers adaptive pixels");
}

/// The toolbar's two rows fit the tests' 1200-point window (the app opens at 1280) whatever the
/// method shows on them, and a narrower window scrolls them sideways instead of wrapping or
/// cutting them: every control stays on the rows, and the viewport below keeps its place (a
/// toolbar that grew a row would move it, and a new viewport size renders again).
#[test]
fn the_toolbar_fits_its_window_and_scrolls_in_a_narrower_one() {
    let dir = tempfile::tempdir().unwrap();
    let Some(mut h) = harness(options(dir.path())) else { return };
    settle(&mut h);
    let width = 1200.0;
    let right = |h: &Harness<'static, App>, label: &str| h.get_by_label(label).rect().max.x;
    for label in ["adaptive pixels", "Screenshot…"] {
        assert!(right(&h, label) <= width, "\"{label}\" ends at {} of {width} points", right(&h, label));
    }
    // The baseline's row: its steps slider and map size instead of VSV's switches.
    h.state_mut().ed_mut().apply(Command::SetMethod(epivox::render::Method::Raymarch { steps: 64, jitter: true }));
    h.run();
    let steps = slider(&h, "steps").rect().max.x;
    assert!(steps <= width, "the baseline's steps slider ends at {steps} of {width} points");
    h.state_mut().ed_mut().apply(Command::SetMethod(epivox::render::Method::Vsv));
    settle(&mut h);
    let top = h.state().ed().viewport_rect().expect("a viewport was laid out").top();
    h.set_size(egui::vec2(820.0, 820.0));
    h.run();
    let narrow = h.state().ed().viewport_rect().expect("a viewport was laid out").top();
    assert_eq!(top, narrow, "the viewport moved when the window narrowed (the toolbar wrapped)");
    for label in ["adaptive pixels", "Screenshot…", "Final"] {
        assert!(h.query_by_label(label).is_some(), "\"{label}\" left the toolbar in a narrow window");
    }
}

//! A sun's shadow map fitted to the view (`ShadowFit`, `Renderer::fit_shadow_map`): the map's
//! texels go where the frame looks it up, so thin casters' shadows that a map spread over the whole
//! scene loses come out as the exact reference draws them, for the surfaces (every method) and for
//! the march's volume; nothing the frame looks up falls outside the narrowed map.

mod common;

use common::{dump, quad, renderer};
use epivox::params::{Grid, Light};
use epivox::reference::{self, ReferenceOptions};
use epivox::render::{Method, Pass, Renderer, SurfaceShadows};
use epivox::scene::build::haze;
use epivox::scene::{Camera, Scene};
use epivox::{metrics, Image};
use glam::Vec3;

const W: u32 = 96;
const H: u32 = 72;

/// A 40 m walkway under a pergola: beams 5 cm wide every 40 cm along all of it, 1.2 m up. The
/// camera, above the medium's box, looks down at 4 m of it and past its far edge at the sky; the
/// sun slants across the beams. Spread over the casters' 40 m, a 512 map's texels are 8 cm wide,
/// more than a beam; fitted to the view, under 2 cm.
fn walkway() -> Scene {
    let mut meshes = vec![quad("floor", Vec3::ZERO, Vec3::X * 20.0, Vec3::Z * 1.5)];
    for i in 0..100 {
        let x = -19.8 + 0.4 * i as f32;
        meshes.push(quad(&format!("beam{i}"), Vec3::new(x, 1.2, 0.0), Vec3::X * 0.025, Vec3::Z * 1.5));
    }
    Scene {
        name: "walkway".into(),
        source: None,
        meshes,
        camera: Camera {
            eye: Vec3::new(0.3, 2.6, 2.8),
            target: Vec3::new(0.0, 0.0, -0.6),
            up: Vec3::Y,
            fov_y_deg: 50.0,
            near: 0.01,
            far: 100.0,
        },
        light: Light::Directional { direction: Vec3::new(0.45, 1.0, 0.25).normalize(), irradiance: Vec3::splat(2.0) },
        medium: haze(),
        grid: Grid { planes: 512, rays: 512, bins: 128, ..Grid::default() },
    }
}

fn rel_rmse(a: &Image, b: &Image) -> f64 {
    metrics::compare(a, b).unwrap_or_else(|e| panic!("{e}")).rel_rmse
}

#[test]
fn a_sun_map_fitted_to_the_view_shadows_as_the_reference_does() {
    let Some(mut r) = renderer() else { return };
    // The map's own behaviour: VSV's surfaces lit from it too.
    r.surface_shadows = SurfaceShadows::Map;
    r.set_shadow_map_size(512).unwrap_or_else(|e| panic!("{e}"));
    let scene = walkway();
    let exact = reference::render(&scene, W, H, &ReferenceOptions { progress: false, ..Default::default() });
    dump("walkway_reference", &exact.hdr);
    let march = Method::Raymarch { steps: 256, jitter: false };
    let run = |r: &mut Renderer, fit: bool, method: Method| {
        r.fit_shadow_map = fit;
        let out = r.render(&scene, W, H, method).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out.passes.contains(&Pass::ShadowFit), fit, "fit {fit}: ran {:?}", out.passes);
        dump(&format!("walkway_{method:?}_fit_{fit}"), &out.hdr);
        out
    };
    let vsv = [false, true].map(|fit| rel_rmse(&run(&mut r, fit, Method::Vsv).hdr, &exact.hdr));
    let marched = [false, true].map(|fit| run(&mut r, fit, march));
    let march_hdr = marched.each_ref().map(|o| rel_rmse(&o.hdr, &exact.hdr));
    let march_scatter = marched.each_ref().map(|o| rel_rmse(&o.scatter, &exact.scatter));
    eprintln!(
        "walkway, whole image against the reference: VSV {:.2}% -> {:.2}% fitted, march {:.2}% -> {:.2}% \
         (its scattered light {:.2}% -> {:.2}%)",
        100.0 * vsv[0],
        100.0 * vsv[1],
        100.0 * march_hdr[0],
        100.0 * march_hdr[1],
        100.0 * march_scatter[0],
        100.0 * march_scatter[1]
    );
    // The surfaces' light is the same code for both methods: it improves alike. The bounds sit
    // between the measured errors with and without the fit (see the message above), so a fit that
    // did nothing, or left part of the view outside the map (lit, where beams shadow it), fails.
    for (what, e) in [("VSV", vsv), ("march", march_hdr)] {
        assert!(e[1] < 0.5 * e[0], "{what}: fitted {:.2}% against {:.2}%", 100.0 * e[1], 100.0 * e[0]);
    }
    // The march samples the same map along its view rays.
    assert!(
        march_scatter[1] < 0.75 * march_scatter[0],
        "march's scattered light: fitted {:.2}% against {:.2}%",
        100.0 * march_scatter[1],
        100.0 * march_scatter[0]
    );
}

/// VSV's sun map is drawn with texels about square over the rectangle it is fitted to, from a
/// view's first `render` on (which renders the frame again when its first fit asks for another
/// shape), and holds about the budget's texels; its whole image is nearer the reference than with
/// the budget's square, whose texels are as long as the rectangle is wide. The march keeps the
/// square (its volume reads the map too: `ShadowMap::wanted_dims`).
#[test]
fn vsv_shapes_the_sun_map_to_its_rectangle_and_the_march_keeps_the_square() {
    let Some(mut r) = renderer() else { return };
    // The map's own behaviour: VSV's surfaces lit from it too.
    r.surface_shadows = SurfaceShadows::Map;
    r.set_shadow_map_size(512).unwrap_or_else(|e| panic!("{e}"));
    let scene = walkway_lengthwise();
    let out = r.render(&scene, W, H, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    let fit = r.read_shadow_fit().unwrap_or_else(|e| panic!("{e}")).unwrap_or_else(|| panic!("not fitted"));
    let (w, h) = r.shadow_map_dims();
    // The fitted map's extent along each axis: 2 / |row i of its orthographic view-projection|.
    let m = fit.view_proj;
    let extent = |i: usize| 2.0 / Vec3::new(m.x_axis[i], m.y_axis[i], m.z_axis[i]).length();
    let (tx, ty) = (extent(0) / w as f32, extent(1) / h as f32);
    assert!(fit.aspect.log2().abs() > 0.5, "the walkway's rectangle is near square ({}): nothing to shape", fit.aspect);
    assert!((tx / ty).log2().abs() < 0.2, "{w} x {h} over {} x {} m: texels {tx} x {ty} m", extent(0), extent(1));
    let budget = (w * h) as f64 / (512.0 * 512.0);
    assert!((budget - 1.0).abs() < 0.05, "{w} x {h} against 512 x 512");
    // The same frame with the square map (its texels as long as the rectangle is wide).
    r.shape_shadow_map = false;
    let square = r.render(&scene, W, H, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.shadow_map_dims(), (512, 512));
    let exact = reference::render(&scene, W, H, &ReferenceOptions { progress: false, ..Default::default() });
    let (shaped_err, square_err) = (rel_rmse(&out.hdr, &exact.hdr), rel_rmse(&square.hdr, &exact.hdr));
    eprintln!(
        "walkway, VSV's whole image: {:.2}% shaped ({w} x {h}), {:.2}% square",
        100.0 * shaped_err,
        100.0 * square_err
    );
    assert!(shaped_err < square_err, "shaped {:.3}% against square {:.3}%", 100.0 * shaped_err, 100.0 * square_err);
    r.shape_shadow_map = true;
    r.render(&scene, W, H, Method::Raymarch { steps: 64, jitter: false }).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.shadow_map_dims(), (512, 512), "the march's map");
}

/// The walkway seen along its length from low over it: the view segments' rectangle is long, and
/// its aspect lies steps away from the casters' 40 m rectangle's.
fn walkway_lengthwise() -> Scene {
    let mut scene = walkway();
    scene.camera.eye = Vec3::new(-3.0, 1.6, 0.75);
    scene.camera.target = Vec3::new(4.0, 0.0, 0.75);
    scene
}

/// After a camera move whose view segments' rectangle has another shape, the frame after the
/// move's first (with nothing changed) remakes the map in the shape the move's fit asked for,
/// which `would_reuse` foresees (the editor then renders a preview first, not a frame it expects
/// to be quick); the frame after that takes everything before the volume over.
#[test]
fn the_frame_after_a_move_reshapes_the_map_and_would_reuse_foresees_it() {
    let Some(mut r) = renderer() else { return };
    // The map's own behaviour: VSV's surfaces lit from it too.
    r.surface_shadows = SurfaceShadows::Map;
    r.set_shadow_map_size(512).unwrap_or_else(|e| panic!("{e}"));
    let frame =
        |r: &mut Renderer, scene: &Scene| r.render_frame(scene, W, H, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    // A still view settles by its fourth frame: the first draws the casters' shape, the second
    // the fit's, the third reads a pyramid of that map, the fourth takes it all over.
    let above = walkway();
    let settled_at = (1..=4).find(|_| frame(&mut r, &above).reused_all_before_volume());
    assert_eq!(settled_at, Some(4), "a still view's frames");
    let settled = r.shadow_map_dims();
    let along = walkway_lengthwise();
    frame(&mut r, &along);
    assert_eq!(r.shadow_map_dims(), settled, "the move's first frame has the last fit's shape");
    assert!(!r.would_reuse(&along, W, H, Method::Vsv), "a map to reshape foreseen as reused");
    let reshaped = frame(&mut r, &along);
    assert_ne!(r.shadow_map_dims(), settled, "the map kept the view above's shape");
    assert!(reshaped.passes.contains(&Pass::ShadowMap), "ran {:?}", reshaped.passes);
    // The reshaped map's pyramid (made at that frame's end) serves the next frame, which reads it
    // (not yet foreseen as reused: its hidden-triangle test changes), and the one after reuses.
    assert!(!frame(&mut r, &along).reused_all_before_volume(), "the pyramid's first reader reused");
    assert!(r.would_reuse(&along, W, H, Method::Vsv), "the same frame again not foreseen as reused");
    assert!(frame(&mut r, &along).reused_all_before_volume(), "the view did not settle after the reshape");
}

/// A point light's cube map does not depend on the view: no fit runs, and a camera move keeps it.
#[test]
fn a_point_light_map_is_not_fitted() {
    let Some(mut r) = renderer() else { return };
    let mut scene = walkway();
    scene.light = Light::Point { position: Vec3::new(0.5, 3.0, 0.5), intensity: Vec3::splat(8.0), radius: 0.0 };
    let out = r.render(&scene, W, H, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    assert!(!out.passes.contains(&Pass::ShadowFit), "ran {:?}", out.passes);
    scene.camera.eye += Vec3::new(0.1, 0.0, 0.0);
    let out = r.render(&scene, W, H, Method::Vsv).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.reused, vec![Pass::ShadowMap], "ran {:?}", out.passes);
}

/// Every point a frame looks the map up at lies inside the fitted map, or outside the casters'
/// rectangle, where no caster is and the lookup finds none either way: the surface points
/// (Composite) and the ends of the view segments inside the medium's box (the march; the box is
/// the scene's bounds grown by 1%, so it reaches past the casters), for an eye above the box
/// looking down and one inside it looking along the walkway into the sky; and the map is much
/// narrower than the casters' rectangle.
#[test]
fn every_point_the_frame_looks_up_lies_in_the_fitted_map() {
    let Some(mut r) = renderer() else { return };
    let above = walkway();
    let mut inside = walkway();
    inside.camera.eye = Vec3::new(-3.0, 0.6, 0.5);
    inside.camera.target = Vec3::new(5.0, 0.9, -0.2);
    for (name, scene, narrow) in [("eye above the box", above, 0.05), ("eye inside the box", inside, 0.6)] {
        let out =
            r.render(&scene, W, H, Method::Raymarch { steps: 64, jitter: false }).unwrap_or_else(|e| panic!("{e}"));
        let fit = r.read_shadow_fit().unwrap_or_else(|e| panic!("{e}")).unwrap_or_else(|| panic!("{name}: not fitted"));
        let distance = r.read_view_distances().unwrap_or_else(|e| panic!("{e}"));
        let (lo, hi) = (scene.medium_bounds().min.as_dvec3(), scene.medium_bounds().max.as_dvec3());
        let eye = scene.camera.eye.as_dvec3();
        let m = fit.view_proj.as_dmat4();
        let (a, b) =
            (fit.rect.truncate().truncate().as_dvec2(), glam::DVec2::new(fit.rect.z as f64, fit.rect.w as f64));
        let (mut sky, mut worst, mut beyond) = (0, 0.0f64, 0);
        for (i, &t) in distance.iter().enumerate() {
            let v = scene.camera.pixel_dir_f64((i as u32 % W) as f64, (i as u32 / W) as f64, W, H);
            // The view ray's span inside the box.
            let inv = 1.0 / v;
            let (t1, t2) = ((lo - eye) * inv, (hi - eye) * inv);
            let (enter, exit) = (t1.min(t2).max_element().max(0.0), t1.max(t2).min_element());
            let mut ends = Vec::new();
            if t.is_finite() {
                ends.push(t as f64);
            } else {
                sky += 1;
                if enter <= exit {
                    ends.push(exit);
                }
            }
            if enter <= exit {
                ends.push(enter);
            }
            for s in ends {
                let c = m.project_point3(eye + v * s).truncate();
                // The same point in the casters' map coordinates.
                let core = a + (c + 1.0) * 0.5 * (b - a);
                if core.abs().max_element() > 1.0 + 1e-4 {
                    beyond += 1;
                } else {
                    worst = worst.max(c.abs().max_element());
                }
            }
        }
        let area = (fit.rect.z - fit.rect.x) * (fit.rect.w - fit.rect.y) / 4.0;
        eprintln!(
            "{name}: {sky} sky pixels, {beyond} lookups beyond the casters, the farthest other at \
             {worst:.4} of the fitted map's half-width, the map {:.1}% of the casters' rectangle, \
             texel {:.2} cm",
            100.0 * area,
            100.0 * fit.texel
        );
        assert!(sky > 0 || name.contains("above"), "{name}: the view shows no sky");
        // Half a texel of the map (1 / size of its half-width) beyond the farthest lookup, less
        // f32's rounding of the GPU's points.
        assert!(worst <= 1.0 + 1e-4, "{name}: a lookup at {worst} of the map's half-width");
        assert!(area < narrow, "{name}: the fitted map covers {:.1}% of the casters' rectangle", 100.0 * area);
        assert!(!out.hdr.pixels.is_empty());
    }
}

//! Solids (closed meshes, `epivox::scene::solid`) seen from outside are drawn, shadow-mapped and
//! voxelized by their faces toward the eye or the light only: the images are those of drawing
//! both sides, up to the silhouette pixels where rounding let a face turned away win the depth
//! test. Seen from inside (the eye or the light within a solid's box), both sides are drawn.

mod common;

use common::{point_light, renderer};
use epivox::params::{Grid, Light};
use epivox::render::{Method, Renderer};
use epivox::scene::Scene;
use glam::Vec3;

const W: u32 = 128;
const H: u32 = 112;

struct Difference {
    /// Pixels of the final image that differ at all.
    hdr_pixels: usize,
    /// Pixels of the scattered light that differ at all, and the largest difference over the
    /// image's brightest channel.
    scatter_pixels: usize,
    scatter_worst: f32,
    /// Triangles the Cull pass dropped as faces turned away from the light.
    culled_back: u32,
}

/// Renders `scene` with one-sided solids and with every face drawn, and compares.
fn difference(r: &mut Renderer, scene: &Scene, method: Method) -> Difference {
    let mut outs = Vec::new();
    let mut culled_back = 0;
    for one_sided in [true, false] {
        r.back_face_culling = one_sided;
        outs.push(r.render(scene, W, H, method).unwrap_or_else(|e| panic!("{e}")));
        if one_sided && method == Method::Vsv {
            culled_back = r.cull_counts().unwrap_or_else(|e| panic!("{e}")).culled_back;
        }
    }
    let (a, b) = (&outs[0], &outs[1]);
    let hdr_pixels = a.hdr.pixels.iter().zip(&b.hdr.pixels).filter(|(x, y)| x != y).count();
    let peak = b.scatter.pixels.iter().flatten().fold(0.0f32, |m, &v| m.max(v)).max(1e-20);
    let mut scatter_pixels = 0;
    let mut scatter_worst = 0.0f32;
    for (x, y) in a.scatter.pixels.iter().zip(&b.scatter.pixels) {
        if x != y {
            scatter_pixels += 1;
        }
        let d = (0..3).map(|c| (x[c] - y[c]).abs()).fold(0.0f32, f32::max);
        scatter_worst = scatter_worst.max(d / peak);
    }
    Difference { hdr_pixels, scatter_pixels, scatter_worst, culled_back }
}

fn small_grid(s: &mut Scene) {
    s.grid = Grid { planes: 128, rays: 128, bins: 64, ..Grid::default() };
}

/// Silhouette pixels only: at most 1% of the image may change, the scattered light by at most
/// 1% of its peak (a changed pixel's view ray ends on the other face of the same solid, a few
/// texels away at most).
fn assert_same_up_to_silhouettes(d: &Difference, what: &str) {
    let limit = (W * H) as usize / 100;
    assert!(d.hdr_pixels <= limit, "{what}: {} pixels of the image differ (limit {limit})", d.hdr_pixels);
    assert!(d.scatter_pixels <= limit, "{what}: {} pixels of the scatter differ", d.scatter_pixels);
    assert!(d.scatter_worst <= 0.01, "{what}: the scatter differs by {} of its peak", d.scatter_worst);
}

#[test]
fn spheres_under_a_point_light_look_the_same_one_sided() {
    let Some(mut r) = renderer() else { return };
    // 64 closed spheres (outward) in a room of open quads, the light outside every sphere.
    let mut room = epivox::bench::procedural_scene(20_000);
    small_grid(&mut room);
    for method in [Method::Vsv, Method::Raymarch { steps: 32, jitter: false }] {
        let d = difference(&mut r, &room, method);
        assert_same_up_to_silhouettes(&d, &format!("{method:?}"));
        if method == Method::Vsv {
            // Roughly the half of each sphere that faces away from the light.
            let spheres: usize =
                room.meshes.iter().filter(|m| m.name.starts_with("sphere")).map(|m| m.triangles.len()).sum();
            assert!(
                d.culled_back as usize > spheres / 4,
                "only {} of {spheres} sphere triangles were culled as faces away from the light",
                d.culled_back
            );
        }
    }
}

#[test]
fn spheres_under_the_sun_look_the_same_one_sided() {
    let Some(mut r) = renderer() else { return };
    // No ceiling: the sun comes in from above and the spheres shadow the floor.
    let mut room = epivox::bench::procedural_scene(20_000);
    room.meshes.retain(|m| m.name != "ceiling");
    room.light = Light::Directional { direction: Vec3::new(0.4, 1.0, 0.3).normalize(), irradiance: Vec3::splat(3.0) };
    small_grid(&mut room);
    let d = difference(&mut r, &room, Method::Vsv);
    assert_same_up_to_silhouettes(&d, "sun");
    assert!(d.culled_back > 0, "no triangle was culled as a face away from the sun");
}

#[test]
fn an_eye_or_a_light_inside_a_solid_sees_both_sides() {
    let Some(mut r) = renderer() else { return };
    let mut room = epivox::bench::procedural_scene(5_000);
    small_grid(&mut room);
    let Some(sphere) = room.meshes.iter().find(|m| m.name.starts_with("sphere")) else {
        panic!("the procedural room has no sphere")
    };
    let centre = sphere.bounds().center();
    // The eye inside a sphere sees its inner faces everywhere, one-sided or not.
    let mut eye_inside = room.clone();
    eye_inside.camera.eye = centre;
    eye_inside.camera.target = centre + Vec3::new(1.0, -0.3, 0.5);
    let d = difference(&mut r, &eye_inside, Method::Vsv);
    assert_eq!(d.hdr_pixels, 0, "eye inside a sphere: {} pixels differ", d.hdr_pixels);
    // The light inside a sphere lights only its inside: every face is kept for it.
    let mut light_inside = room.clone();
    light_inside.light = point_light(centre);
    let d = difference(&mut r, &light_inside, Method::Vsv);
    assert_eq!(d.hdr_pixels + d.scatter_pixels, 0, "light inside a sphere: the images differ");
}

//! Scenes: triangle meshes in world space, a camera, one light, a medium and grid settings.
//!
//! Every loader produces the same [`Scene`]; the GPU pipeline and the reference renderer both read it
//! and nothing else. Meshes are flattened to world space at load time (node transforms applied), so
//! the renderers never see a hierarchy.

use crate::params::{Grid, Light, Medium, ParamError, Surface, View};
use glam::{Mat4, Vec3};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

pub mod build;
mod builtin;
mod load;
pub mod solid;

pub use builtin::builtin_scene;
pub use load::{load_scene, load_scene_with_summary, LoadSummary, SceneError};

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { min: Vec3::splat(f32::INFINITY), max: Vec3::splat(f32::NEG_INFINITY) };

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb { min: self.min.min(o.min), max: self.max.max(o.max) }
    }
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
    /// Radius of the bounding sphere around [`Aabb::center`].
    pub fn radius(&self) -> f32 {
        self.extent().length() * 0.5
    }
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }
    /// The eight corners (bit 1 of the index picks max x, bit 2 max y, bit 4 max z).
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            let pick = |bit: usize, a: f32, b: f32| if i & bit == 0 { a } else { b };
            Vec3::new(pick(1, self.min.x, self.max.x), pick(2, self.min.y, self.max.y), pick(4, self.min.z, self.max.z))
        })
    }
}

/// A triangle mesh in world space with one diffuse colour.
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Diffuse reflectance (linear RGB, 0..1).
    pub albedo: Vec3,
}

impl Mesh {
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for &p in &self.positions {
            b.grow(p);
        }
        b
    }

    /// Removes the triangles whose area is zero to `f32` precision (two corners equal, or all three
    /// on one line: the height over the longest edge below 2^-24 of that edge) and returns how many
    /// went. They cover nothing, yet every pass would pay for them. Triangles indexing past the
    /// vertices are kept for [`Scene::validate`] to report.
    pub fn drop_degenerate(&mut self) -> usize {
        let before = self.triangles.len();
        let positions = &self.positions;
        self.triangles.retain(|t| {
            let corner = |i: u32| positions.get(i as usize).map(|p| p.as_dvec3());
            let (Some(a), Some(b), Some(c)) = (corner(t[0]), corner(t[1]), corner(t[2])) else {
                return true;
            };
            let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
            let twice_area = (b - a).cross(c - a).length();
            // NaN corners compare as not degenerate: validation reports them.
            let degenerate = twice_area <= f64::from(f32::EPSILON) * 0.5 * longest;
            !degenerate
        });
        before - self.triangles.len()
    }

    /// Applies an affine transform to every vertex.
    pub fn transform(&mut self, m: Mat4) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
    }
}

/// A pinhole camera. `fov_y_deg` is the vertical field of view.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Vertical field of view in degrees ([`View::FOV_Y`]).
    pub fov_y_deg: f32,
    /// Near clipping distance (> 0).
    #[serde(default = "default_near")]
    pub near: f32,
    /// Far clipping distance (> near).
    #[serde(default = "default_far")]
    pub far: f32,
}

fn default_up() -> Vec3 {
    Vec3::Y
}
fn default_near() -> f32 {
    Camera::default().near
}
fn default_far() -> f32 {
    Camera::default().far
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            eye: Vec3::new(0.0, 1.0, 5.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y_deg: 45.0,
            near: 0.01,
            far: 1000.0,
        }
    }
}

impl Camera {
    /// Rejects cameras that cannot form an image.
    pub fn validate(&self) -> Result<(), ParamError> {
        let bad = |why: &str| Err(ParamError::Invalid(format!("degenerate camera: {why}")));
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return bad("eye, target and up must be finite");
        }
        let fwd = self.target - self.eye;
        if fwd.length() < 1e-12 * (1.0 + self.eye.length()) {
            return bad("eye and target coincide");
        }
        if self.up.length() < 1e-12 {
            return bad(&format!("up = {} is not a direction", self.up));
        }
        if fwd.normalize().cross(self.up.normalize_or_zero()).length() < 1e-6 {
            return bad("the up vector is parallel to the view direction");
        }
        let fov = View::FOV_Y;
        if fov.check(self.fov_y_deg as f64).is_err() {
            return bad(&format!(
                "the vertical field of view (fov_y_deg = {}) must lie in [{}, {}] degrees",
                self.fov_y_deg, fov.min, fov.max
            ));
        }
        if !(self.near > 0.0 && self.far > self.near && self.far.is_finite()) {
            return bad("near must be > 0 and far > near");
        }
        Ok(())
    }

    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }

    /// Right-handed perspective with depth in [0, 1] (wgpu convention).
    pub fn proj(&self, aspect: f32) -> Mat4 {
        // wgpu's NDC is D3D's: y up, depth in [0, 1].
        glam::camera::rh::proj::directx::perspective(self.fov_y_deg.to_radians(), aspect, self.near, self.far)
    }

    pub fn view_proj(&self, aspect: f32) -> Mat4 {
        self.proj(aspect) * self.view()
    }

    /// Orthonormal camera basis (right, up, forward) in world space, in f64.
    pub fn basis_f64(&self) -> [[f64; 3]; 3] {
        let e = self.eye.as_dvec3();
        let f = (self.target.as_dvec3() - e).normalize();
        let r = f.cross(self.up.as_dvec3()).normalize();
        let u = r.cross(f);
        [r.to_array(), u.to_array(), f.to_array()]
    }

    /// World-space unit direction of the ray through the centre of pixel `(px, py)` of a
    /// `width x height` image (row 0 at the top). This is *the* pixel convention: the shaders and
    /// the reference renderer use the same formula.
    pub fn pixel_dir_f64(&self, px: f64, py: f64, width: u32, height: u32) -> glam::DVec3 {
        let [r, u, f] = self.basis_f64();
        let (r, u, f) = (glam::DVec3::from(r), glam::DVec3::from(u), glam::DVec3::from(f));
        let tan_half = (self.fov_y_deg as f64).to_radians() * 0.5;
        let tan_half = tan_half.tan();
        let aspect = width as f64 / height as f64;
        let ndc_x = (2.0 * (px + 0.5) / width as f64 - 1.0) * tan_half * aspect;
        let ndc_y = (1.0 - 2.0 * (py + 0.5) / height as f64) * tan_half;
        (f + r * ndc_x + u * ndc_y).normalize()
    }

    /// The continuous pixel position whose ray ([`Camera::pixel_dir_f64`]) runs along `dir`: its
    /// inverse. `None` when `dir` points away from the camera (or along its image plane).
    pub fn pixel_of_dir_f64(&self, dir: glam::DVec3, width: u32, height: u32) -> Option<(f64, f64)> {
        let [r, u, f] = self.basis_f64().map(glam::DVec3::from);
        let z = dir.dot(f);
        if z <= 1e-9 {
            return None;
        }
        let th = ((self.fov_y_deg as f64).to_radians() * 0.5).tan();
        let tw = th * width as f64 / height as f64;
        let nx = dir.dot(r) / z / tw;
        let ny = dir.dot(u) / z / th;
        Some(((nx + 1.0) * 0.5 * width as f64 - 0.5, (1.0 - ny) * 0.5 * height as f64 - 0.5))
    }

    /// A camera that frames `bounds` from a pleasant three-quarter view.
    pub fn framing(bounds: &Aabb) -> Camera {
        let c = bounds.center();
        let r = bounds.radius().max(1e-3);
        let fov = 45.0f32;
        let dist = r / (fov.to_radians() * 0.5).sin() * 1.05;
        let dir = Vec3::new(0.35, 0.3, 1.0).normalize();
        Camera { eye: c + dir * dist, target: c, up: Vec3::Y, fov_y_deg: fov, near: dist * 1e-3, far: dist + 4.0 * r }
    }
}

/// Everything one frame needs besides the image size.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Human-readable name (file stem or "built-in").
    pub name: String,
    /// Where it came from, for messages; `None` for the built-in scene.
    pub source: Option<PathBuf>,
    pub meshes: Vec<Mesh>,
    pub camera: Camera,
    pub light: Light,
    pub medium: Medium,
    pub grid: Grid,
}

impl Scene {
    pub fn bounds(&self) -> Aabb {
        self.meshes.iter().fold(Aabb::EMPTY, |b, m| b.union(&m.bounds()))
    }

    /// False when the frame has no in-scattering to compute: a clear medium or a dark light.
    pub fn needs_scattering(&self) -> bool {
        !self.medium.is_clear() && self.light.power().max_element() > 0.0
    }

    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.triangles.len()).sum()
    }

    /// A 64-bit hash of the meshes' content (positions, triangles, albedo), so that a renderer can
    /// tell when it must upload the geometry again: two scenes with the same triangle count but
    /// different meshes differ here. About 0.7 ms for the classroom (104 000 triangles).
    pub fn geometry_fingerprint(&self) -> u64 {
        // A multiply-rotate hash over the raw words, two at a time: fast (the renderer checks it
        // every frame). The product's high half is folded back into the low one at every step: a
        // multiply carries a word's low bits up but never its high bits down, and without the
        // fold a flipped sign bit and a change in the next word's fifth bit cancelled (review).
        let mut h: u64 = 0x9e37_79b9_7f4a_7c15 ^ self.meshes.len() as u64;
        let mut eat = |w: u64| {
            h = (h.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95);
            h ^= h >> 32;
        };
        let mut words = |ws: &[u32]| {
            let pairs = ws.chunks_exact(2);
            let odd = pairs.remainder().first().map(|&w| w as u64 | 1 << 63);
            for p in pairs {
                eat(p[0] as u64 | (p[1] as u64) << 32);
            }
            eat(odd.unwrap_or(0));
        };
        for m in &self.meshes {
            words(&[m.positions.len() as u32, m.triangles.len() as u32]);
            words(&m.albedo.to_array().map(f32::to_bits));
            words(bytemuck::cast_slice(&m.positions));
            words(bytemuck::cast_slice(&m.triangles));
        }
        h
    }

    /// The bounds without "backdrops": meshes of at most 16 triangles whose extent is over 4 times
    /// that of everything else together (the classroom's 221 m ground quad). The directional
    /// shadow map covers these bounds, so a backdrop does not spread its texels over hundreds of
    /// metres; backdrops themselves are not needed as casters there (they lie under everything).
    pub fn core_bounds(&self) -> Aabb {
        bounds_without_backdrops(&self.meshes, |b| b.extent().max_element(), |_| {})
    }

    /// The box the medium fills for a directional light: the scene's bounds grown by 1% so that
    /// surfaces on the boundary are inside. (A point light's medium is unbounded; see DESIGN 1.)
    pub fn medium_bounds(&self) -> Aabb {
        let b = self.bounds();
        let pad = b.extent().max_element() * 0.01 + 1e-6;
        Aabb { min: b.min - Vec3::splat(pad), max: b.max + Vec3::splat(pad) }
    }

    /// All triangles as world-space vertex triples, with the index of their mesh.
    pub fn world_triangles(&self) -> impl Iterator<Item = ([Vec3; 3], usize)> + '_ {
        self.meshes.iter().enumerate().flat_map(|(mi, m)| {
            m.triangles.iter().map(move |t| {
                ([m.positions[t[0] as usize], m.positions[t[1] as usize], m.positions[t[2] as usize]], mi)
            })
        })
    }

    /// Checks everything a renderer relies on; loaders call it before returning.
    pub fn validate(&self) -> Result<(), ParamError> {
        if self.triangle_count() == 0 {
            return Err(ParamError::Invalid("the scene has no triangles".into()));
        }
        for m in &self.meshes {
            if let Some(i) = m.positions.iter().position(|p| !p.is_finite()) {
                return Err(ParamError::Invalid(format!(
                    "mesh '{}' has a non-finite vertex (index {i}: {})",
                    m.name, m.positions[i]
                )));
            }
            let n = m.positions.len() as u32;
            if let Some(t) = m.triangles.iter().find(|t| t.iter().any(|&i| i >= n)) {
                return Err(ParamError::Invalid(format!(
                    "mesh '{}' has a triangle {t:?} indexing past its {n} vertices",
                    m.name
                )));
            }
            Surface::ALBEDO.check_rgb(m.albedo).map_err(|e| ParamError::Invalid(format!("mesh '{}': {e}", m.name)))?;
        }
        self.camera.validate()?;
        self.light.validate()?;
        self.medium.validate()?;
        self.grid.validate()
    }
}

/// The union of the meshes' bounds but those of at most 16 triangles whose `size` is over 4 times
/// that of all the other meshes together (`on_backdrop` hears of each); all of them when that
/// leaves nothing. Linear in the meshes: each one's bounds once, and "all the others" from prefix
/// and suffix unions (the classroom's ~1 000 meshes took ~2 ms a frame with a union per mesh).
pub(crate) fn bounds_without_backdrops(
    meshes: &[Mesh],
    size: impl Fn(&Aabb) -> f32,
    mut on_backdrop: impl FnMut(&Mesh),
) -> Aabb {
    let b: Vec<Aabb> = meshes.iter().map(Mesh::bounds).collect();
    let mut suffix = vec![Aabb::EMPTY; b.len() + 1];
    for i in (0..b.len()).rev() {
        suffix[i] = suffix[i + 1].union(&b[i]);
    }
    let (mut before, mut core) = (Aabb::EMPTY, Aabb::EMPTY);
    for (i, m) in meshes.iter().enumerate() {
        let others = before.union(&suffix[i + 1]);
        before = before.union(&b[i]);
        if m.triangles.len() <= 16 && !others.is_empty() && size(&b[i]) > 4.0 * size(&others) {
            on_backdrop(m);
        } else {
            core = core.union(&b[i]);
        }
    }
    if core.is_empty() {
        before
    } else {
        core
    }
}

#[cfg(test)]
mod tests {
    use super::build::{quad, sphere};
    use super::*;

    /// A ground quad far larger than the rest is left out of the core bounds, whatever its place
    /// in the list; a small quad among the rest is not; with the ground alone nothing is left
    /// out. Against the direct form: a union over all the other meshes for every mesh.
    #[test]
    fn core_bounds_leave_out_only_backdrops() {
        let ball = sphere("ball", Vec3::new(0.0, 1.0, 0.0), 1.0, 8, 12);
        let card = quad("card", Vec3::new(0.5, 0.5, 2.0), Vec3::X * 0.3, Vec3::Y * 0.3);
        let ground = quad("ground", Vec3::ZERO, Vec3::X * 200.0, Vec3::Z * 200.0);
        let direct = |meshes: &[Mesh]| {
            let mut core = Aabb::EMPTY;
            for (i, m) in meshes.iter().enumerate() {
                let others = meshes
                    .iter()
                    .enumerate()
                    .filter(|(j, _)| *j != i)
                    .fold(Aabb::EMPTY, |a, (_, o)| a.union(&o.bounds()));
                let size = |b: &Aabb| b.extent().max_element();
                if m.triangles.len() <= 16 && !others.is_empty() && size(&m.bounds()) > 4.0 * size(&others) {
                    continue;
                }
                core = core.union(&m.bounds());
            }
            core
        };
        let mut scene = builtin::builtin_scene();
        for order in [vec![&ball, &card, &ground], vec![&ground, &ball, &card], vec![&card, &ground, &ball]] {
            scene.meshes = order.into_iter().cloned().collect();
            let core = scene.core_bounds();
            assert_eq!(core, ball.bounds().union(&card.bounds()));
            assert_eq!(core, direct(&scene.meshes));
        }
        scene.meshes = vec![ground.clone()];
        assert_eq!(scene.core_bounds(), ground.bounds());
    }

    /// Meshes that differ in a sign and, in the next coordinate, in a bit that the sign's bit
    /// lands on after one step of the hash: the pair that collided before the fold.
    #[test]
    fn the_fingerprint_tells_a_sign_and_the_next_words_low_bits_apart() {
        let mesh = |b: f32, c: f32| Mesh {
            name: "m".into(),
            positions: vec![Vec3::new(1.0, b, c), Vec3::new(4.0, 5.0, 6.0)],
            triangles: vec![[0, 1, 1]],
            albedo: Vec3::ONE,
        };
        let mut a = builtin::builtin_scene();
        let mut b = a.clone();
        a.meshes = vec![mesh(2.0, 3.0)];
        b.meshes = vec![mesh(-2.0, f32::from_bits(3.0f32.to_bits() + 16))];
        assert_ne!(a.geometry_fingerprint(), b.geometry_fingerprint());
        b.meshes = vec![mesh(2.0, 3.0)];
        assert_eq!(a.geometry_fingerprint(), b.geometry_fingerprint());
    }
}

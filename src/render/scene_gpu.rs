//! The scene's geometry on the GPU, uploaded once per scene, and which of its meshes bound solids
//! (`crate::scene::solid`): their faces turned away from a viewpoint outside them are skipped.

use super::cull::CullLists;
use crate::params::Light;
use crate::scene::solid::{self, Closure};
use crate::scene::{Aabb, Scene};
use rayon::prelude::*;
use std::ops::Range;
use wgpu::util::DeviceExt;

/// One mesh of the uploaded scene: its triangles' place in the index buffer and whether it bounds
/// a solid.
#[derive(Debug, Clone)]
pub struct MeshRange {
    pub closure: Closure,
    pub bounds: Aabb,
    /// Its indices in [`SceneGpu::indices`].
    pub indices: Range<u32>,
}

/// Which faces a raster pass skips for a run of meshes, by their winding normal
/// `(b - a) x (c - a)` against the direction toward the viewpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Facing {
    /// Both sides drawn: open meshes, and solids that hold the viewpoint.
    Both,
    /// Only the triangles whose winding normal faces the viewpoint (outward solids).
    Toward,
    /// Only those whose winding normal faces away (inward solids).
    Away,
}

impl Facing {
    fn of(closure: Closure, outside: bool) -> Facing {
        match (closure, outside) {
            (Closure::Outward, true) => Facing::Toward,
            (Closure::Inward, true) => Facing::Away,
            _ => Facing::Both,
        }
    }
}

/// Vertex/index buffers for rasterizing surfaces, and the triangle list the voxelizer pulls from.
pub struct SceneGpu {
    /// `[position, albedo]` per vertex (24 bytes).
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    /// Three `vec4<f32>` world vertices per triangle (the first one's `w` its mesh, as an f32),
    /// for Cull and Voxelize, and whole for the eye's and the shadow map's culling
    /// ([`SceneGpu::whole_triangles`]), in chunks that each fit the adapter's largest storage
    /// binding (one chunk unless the mesh is huge), with the number of triangles in each.
    pub chunks: Vec<(wgpu::Buffer, u32)>,
    pub triangle_count: u32,
    /// The Cull pass's lists, sized for the largest chunk.
    pub lists: CullLists,
    /// Per mesh, in upload order (the index buffer holds them one after the other).
    pub meshes: Vec<MeshRange>,
    /// The largest magnitude of any coordinate of the meshes' boxes (an empty mesh's infinite box
    /// left out): how coarsely f32 holds the scene's positions (ExactShadows' depth offset).
    pub largest_coordinate: f32,
    /// Per mesh, written by [`SceneGpu::update_light_facing`]: `+1` keep only triangles whose
    /// winding normal faces the light, `-1` only those facing away, `0` keep all (f32).
    pub light_sides: wgpu::Buffer,
    /// What [`SceneGpu::light_sides`] holds (`None` until first written).
    light_facing: Option<Vec<Facing>>,
    /// The same for the eye, written by [`SceneGpu::update_eye_sides`] (Surface's culling).
    pub eye_sides: wgpu::Buffer,
    eye_facing: Option<Vec<Facing>>,
}

impl SceneGpu {
    /// Bytes per triangle in a chunk.
    pub const TRIANGLE_BYTES: u64 = 48;

    /// Every triangle's vertices and mesh in one buffer, in the index buffer's order, for the
    /// culling passes that read them by triangle (surface_cull.wgsl, shadow_cull.wgsl): the one
    /// chunk, unless the mesh needs several or its mesh numbers are past an f32's integers.
    pub fn whole_triangles(&self) -> Option<&wgpu::Buffer> {
        match self.chunks.as_slice() {
            [(buffer, _)] if self.meshes.len() <= 1 << 24 => Some(buffer),
            _ => None,
        }
    }

    /// The chunks that hold triangles, numbered, with their buffer and triangle count (a scene
    /// without triangles has none).
    pub fn nonempty_chunks(&self) -> impl Iterator<Item = (usize, &wgpu::Buffer, u32)> {
        self.chunks.iter().filter(|(_, n)| *n > 0).enumerate().map(|(i, (b, n))| (i, b, *n))
    }

    /// Uploads `scene`; `max_binding` is the largest storage binding the adapter allows (bytes).
    pub fn new(device: &wgpu::Device, scene: &Scene, max_binding: u64) -> SceneGpu {
        let mut vertices: Vec<[f32; 6]> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut tris: Vec<[f32; 4]> = Vec::with_capacity(scene.triangle_count() * 3);
        let closures: Vec<Closure> = scene.meshes.par_iter().map(solid::closure).collect();
        let mut meshes = Vec::with_capacity(scene.meshes.len());
        for (mesh, (m, &closure)) in scene.meshes.iter().zip(&closures).enumerate() {
            let base = vertices.len() as u32;
            let first = indices.len() as u32;
            vertices.extend(m.positions.iter().map(|p| [p.x, p.y, p.z, m.albedo.x, m.albedo.y, m.albedo.z]));
            for t in &m.triangles {
                indices.extend(t.iter().map(|&i| base + i));
                for (k, &i) in t.iter().enumerate() {
                    let p = m.positions[i as usize];
                    // The first vertex's w: the mesh, for the side tests of Cull and of the eye's
                    // and the map's culling (a float holding an integer, exact below 2^24 meshes:
                    // past that light_facing keeps all faces and whole_triangles gives none; its
                    // bits as a u32 would be a subnormal, which a GPU may flush to zero).
                    let w = if k == 0 { mesh as f32 } else { 0.0 };
                    tris.push([p.x, p.y, p.z, w]);
                }
            }
            meshes.push(MeshRange { closure, bounds: m.bounds(), indices: first..indices.len() as u32 });
        }
        let triangle_count = (tris.len() / 3) as u32;
        if tris.is_empty() {
            // Keep every binding valid; a scene without triangles draws nothing.
            tris.extend([[0.0; 4]; 3]);
            vertices.push([0.0; 6]);
        }
        let vb = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("SceneGpu::vertices"),
            contents: bytemuck::cast_slice(&vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let index_count = indices.len() as u32;
        if indices.is_empty() {
            indices.extend([0, 0, 0]);
        }
        let ib = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("SceneGpu::indices"),
            contents: bytemuck::cast_slice(&indices),
            usage: wgpu::BufferUsages::INDEX | wgpu::BufferUsages::STORAGE,
        });
        let per_chunk = (max_binding / Self::TRIANGLE_BYTES).clamp(1, u32::MAX as u64) as usize;
        let chunks: Vec<(wgpu::Buffer, u32)> = tris
            .chunks(per_chunk * 3)
            .enumerate()
            .map(|(i, c)| {
                let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(&format!("SceneGpu::triangles[{i}]")),
                    contents: bytemuck::cast_slice(c),
                    usage: wgpu::BufferUsages::STORAGE,
                });
                (buffer, (c.len() / 3) as u32 * u32::from(triangle_count > 0))
            })
            .collect();
        let largest = chunks.iter().map(|(_, n)| *n).max().unwrap_or(1);
        let sides = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 4 * meshes.len().max(1) as u64,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let light_sides = sides("SceneGpu::light_sides");
        let eye_sides = sides("SceneGpu::eye_sides");
        SceneGpu {
            vertices: vb,
            indices: ib,
            index_count,
            chunks,
            triangle_count,
            lists: CullLists::new(device, largest),
            largest_coordinate: meshes
                .iter()
                .filter(|r| r.bounds.min.is_finite() && r.bounds.max.is_finite())
                .map(|r| r.bounds.min.abs().max(r.bounds.max.abs()).max_element())
                .fold(0.0, f32::max),
            meshes,
            light_sides,
            light_facing: None,
            eye_sides,
            eye_facing: None,
        }
    }

    /// Which side of each mesh the light can see first: the solids the light lies outside of
    /// (by more than its radius; a sun is outside every mesh) keep only their faces toward it.
    /// Also writes [`SceneGpu::light_sides`] for the compute passes, only when it changed since the
    /// last frame (the light or the switch moved): an unchanged frame uploads nothing.
    pub fn update_light_facing(&mut self, queue: &wgpu::Queue, light: &Light, enabled: bool) {
        // Cull reads a triangle's mesh from an f32 (`SceneGpu::new`).
        let enabled = enabled && self.meshes.len() <= 1 << 24;
        let outside = |b: &Aabb| match *light {
            Light::Point { position, radius, .. } => solid::outside(b, position, radius),
            Light::Directional { .. } => true,
        };
        let of = |m: &MeshRange| if enabled { Facing::of(m.closure, outside(&m.bounds)) } else { Facing::Both };
        let facing = self.meshes.iter().map(of);
        write_sides(queue, &self.light_sides, &mut self.light_facing, facing);
    }

    /// Writes [`SceneGpu::eye_sides`] from the eye's facing per mesh ([`SceneGpu::eye_facing`]),
    /// only when it changed since the last frame.
    pub fn update_eye_sides(&mut self, queue: &wgpu::Queue, facing: &[Facing]) {
        write_sides(queue, &self.eye_sides, &mut self.eye_facing, facing.iter().copied());
    }

    /// Per mesh, the faces the light can see first, as [`SceneGpu::update_light_facing`] last set
    /// them.
    pub fn light_facing(&self) -> &[Facing] {
        self.light_facing.as_deref().unwrap_or_default()
    }

    /// The index ranges a raster pass draws, each with the faces it keeps ([`draw_runs`]).
    pub fn draw_runs(&self, facing: &[Facing]) -> Vec<(Range<u32>, Facing)> {
        draw_runs(&self.meshes, facing)
    }

    /// Which faces the eye can see first: the solids it lies outside of, by more than the
    /// distance to the near plane's farthest corner (so that no near-plane cut opens one), keep
    /// only their faces toward it.
    pub fn eye_facing(&self, eye: glam::Vec3, near_corner: f32, enabled: bool) -> Vec<Facing> {
        self.meshes
            .iter()
            .map(|m| {
                if enabled {
                    Facing::of(m.closure, solid::outside(&m.bounds, eye, near_corner))
                } else {
                    Facing::Both
                }
            })
            .collect()
    }
}

/// Writes per-mesh sides (`+1` keep the faces whose winding normal faces the viewpoint, `-1` those
/// facing away, `0` all, as f32) into `buffer` unless `written` already holds `facing`: an
/// unchanged frame uploads nothing, and compares in place, allocating nothing either.
fn write_sides(
    queue: &wgpu::Queue,
    buffer: &wgpu::Buffer,
    written: &mut Option<Vec<Facing>>,
    facing: impl Iterator<Item = Facing> + Clone,
) {
    if written.as_ref().is_some_and(|old| old.iter().copied().eq(facing.clone())) {
        return;
    }
    let facing: Vec<Facing> = facing.collect();
    let sides: Vec<f32> = facing
        .iter()
        .map(|f| match f {
            Facing::Both => 0.0,
            Facing::Toward => 1.0,
            Facing::Away => -1.0,
        })
        .collect();
    if !sides.is_empty() {
        queue.write_buffer(buffer, 0, bytemuck::cast_slice(&sides));
    }
    *written = Some(facing);
}

/// The index ranges that draw `meshes`, each with the faces it keeps (`facing`, per mesh):
/// consecutive meshes that keep the same faces share one draw, and empty meshes draw nothing.
pub fn draw_runs(meshes: &[MeshRange], facing: &[Facing]) -> Vec<(Range<u32>, Facing)> {
    let mut runs: Vec<(Range<u32>, Facing)> = Vec::new();
    for (m, &f) in meshes.iter().zip(facing) {
        if m.indices.is_empty() {
            continue;
        }
        match runs.last_mut() {
            Some((r, g)) if *g == f && r.end == m.indices.start => r.end = m.indices.end,
            _ => runs.push((m.indices.clone(), f)),
        }
    }
    runs
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn mesh(closure: Closure, indices: Range<u32>) -> MeshRange {
        MeshRange { closure, bounds: Aabb { min: Vec3::ZERO, max: Vec3::ONE }, indices }
    }

    #[test]
    fn runs_merge_neighbours_that_keep_the_same_faces() {
        let meshes = [
            mesh(Closure::Open, 0..6),
            mesh(Closure::Outward, 6..12),
            mesh(Closure::Outward, 12..12),
            mesh(Closure::Outward, 12..30),
            mesh(Closure::Inward, 30..36),
        ];
        let facing: Vec<Facing> = meshes.iter().map(|m| Facing::of(m.closure, true)).collect();
        assert_eq!(
            draw_runs(&meshes, &facing),
            vec![(0..6, Facing::Both), (6..30, Facing::Toward), (30..36, Facing::Away)]
        );
        // Seen from inside, every mesh draws both sides: one draw.
        let inside: Vec<Facing> = meshes.iter().map(|m| Facing::of(m.closure, false)).collect();
        assert_eq!(draw_runs(&meshes, &inside), vec![(0..36, Facing::Both)]);
    }
}

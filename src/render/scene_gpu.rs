//! The scene's geometry on the GPU, uploaded once per scene.

use super::cull::CullLists;
use crate::scene::Scene;
use wgpu::util::DeviceExt;

/// Vertex/index buffers for rasterizing surfaces, and the triangle list the voxelizer pulls from.
pub struct SceneGpu {
    /// `[position, albedo]` per vertex (24 bytes).
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    /// Three `vec4<f32>` world vertices per triangle, for Cull and Voxelize, in chunks that each
    /// fit the adapter's largest storage binding (one chunk unless the mesh is huge), with the
    /// number of triangles in each.
    pub chunks: Vec<(wgpu::Buffer, u32)>,
    pub triangle_count: u32,
    /// The Cull pass's lists, sized for the largest chunk.
    pub lists: CullLists,
}

impl SceneGpu {
    /// Bytes per triangle in a chunk.
    pub const TRIANGLE_BYTES: u64 = 48;

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
        for m in &scene.meshes {
            let base = vertices.len() as u32;
            vertices.extend(m.positions.iter().map(|p| [p.x, p.y, p.z, m.albedo.x, m.albedo.y, m.albedo.z]));
            for t in &m.triangles {
                indices.extend(t.iter().map(|&i| base + i));
                for &i in t {
                    let p = m.positions[i as usize];
                    tris.push([p.x, p.y, p.z, 0.0]);
                }
            }
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
            // STORAGE: the shadow map's face culling reads the positions.
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
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
        SceneGpu {
            vertices: vb,
            indices: ib,
            index_count,
            chunks,
            triangle_count,
            lists: CullLists::new(device, largest),
        }
    }
}

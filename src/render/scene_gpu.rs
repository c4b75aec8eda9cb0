//! The scene's geometry on the GPU, uploaded once per scene.

use crate::scene::Scene;
use wgpu::util::DeviceExt;

/// Vertex/index buffers for rasterizing surfaces, and the triangle list the voxelizer pulls from.
pub struct SceneGpu {
    /// `[position, albedo]` per vertex (24 bytes).
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    /// Three `vec4<f32>` world vertices per triangle, for vertex pulling in the voxelizer.
    pub triangles: wgpu::Buffer,
    pub triangle_count: u32,
    /// The Cull pass's output: kept triangle indices and two rectangles each.
    pub kept: wgpu::Buffer,
    pub kept_rects: wgpu::Buffer,
}

impl SceneGpu {
    pub fn new(device: &wgpu::Device, scene: &Scene) -> SceneGpu {
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
        if tris.is_empty() {
            // Keep every binding valid; a scene without triangles draws nothing.
            tris.push([0.0; 4]);
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
            usage: wgpu::BufferUsages::INDEX,
        });
        let tb = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("SceneGpu::triangles"),
            contents: bytemuck::cast_slice(&tris),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let n = (index_count as u64 / 3).max(1);
        let storage = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        SceneGpu {
            vertices: vb,
            indices: ib,
            index_count,
            triangles: tb,
            triangle_count: index_count / 3,
            kept: storage("SceneGpu::kept", n * 4),
            kept_rects: storage("SceneGpu::kept_rects", n * 32),
        }
    }
}

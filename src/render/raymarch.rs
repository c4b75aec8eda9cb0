//! Raymarch: the baseline the shadow volumes are measured against (`shaders/raymarch.wgsl`).
//!
//! Per pixel, `steps` samples along the view ray with one shadow-map lookup each (the cube map for a
//! point light, the orthographic layer for a directional one), midpoint rule or one jittered offset
//! per pixel:
//!
//! ```text
//! point:        L = Σ σs p(cosθ) V I0 exp(-σt (d + t)) / (d² + r²) Δt
//! directional:  L = Σ σs p(w·v) V E0 exp(-σt (l + m)) Δt      (l, m: paths inside the medium box)
//! ```
//!
//! It writes the same scatter texture as [`super::Integrate`], so [`super::Composite`] runs unchanged.
//! A point light's medium is unbounded: on a sky pixel the steps cover the ray up to where it leaves
//! the scene's box and `max(steps / 4, 4)` more cover the rest of the ray out to infinity in the
//! reference's angle variable (see the shader's header), so the march converges to the reference.

use super::util::{storage_texture_entry, texture_entry, uniform_entry};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};
use bytemuck::{Pod, Zeroable};
use glam::UVec4;

/// `struct March` in raymarch.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct RaymarchUniforms {
    /// x: steps, y: 1 = jitter.
    pub params: UVec4,
}

pub struct Raymarch {
    pipelines: SpecialisedCompute<1>,
    pub layout: wgpu::BindGroupLayout,
    /// Steps and jitter of the next frame, written by [`Raymarch::record`].
    pub uniforms: wgpu::Buffer,
}

impl Raymarch {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
    /// Most steps per pixel: beyond this a frame takes seconds even on a fast GPU, and the error is
    /// long dominated by the shadow map's resolution.
    pub const MAX_STEPS: u32 = 65536;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Raymarch, GpuError> {
        let module = lib.module(device, "raymarch.wgsl")?;
        let c = wgpu::ShaderStages::COMPUTE;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("Raymarch::layout"),
            entries: &[
                uniform_entry(0, c),
                uniform_entry(1, c),
                texture_entry(2, c, wgpu::TextureViewDimension::D2Array),
                texture_entry(3, c, wgpu::TextureViewDimension::D2),
                storage_texture_entry(4, Self::OUTPUT),
                uniform_entry(5, c),
            ],
        });
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Raymarch::uniforms"),
            size: std::mem::size_of::<RaymarchUniforms>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(Raymarch {
            pipelines: SpecialisedCompute::new(
                device,
                "Raymarch",
                module,
                &layout,
                ["main"],
                Specialised::LightAndPhase,
            ),
            layout,
            uniforms,
        })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// Records the march of every pixel. `steps` is clamped to `1..=MAX_STEPS`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        bind_group: &wgpu::BindGroup,
        width: u32,
        height: u32,
        steps: u32,
        jitter: bool,
    ) {
        let u = RaymarchUniforms { params: UVec4::new(steps.clamp(1, Self::MAX_STEPS), jitter as u32, 0, 0) };
        // Queue writes land before the submission that carries this encoder.
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Raymarch::pass"), timestamp_writes: None });
        // Renderer::render_frame prepares every variant it records.
        let Some([pipeline]) = self.pipelines.get(variant) else {
            return;
        };
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

#[cfg(test)]
mod tests {
    //! raymarch.wgsl keeps its own copy of the shadow-lookup struct: it must match surface.wgsl's
    //! (whose layout `layout_tests` checks against the Rust one) member for member.
    use super::*;

    fn members(file: &str, name: &str) -> (Vec<(Option<String>, u32)>, u32) {
        let (module, _) = ShaderLibrary::embedded().validate(file).unwrap_or_else(|e| panic!("{e}"));
        for (_, ty) in module.types.iter() {
            if ty.name.as_deref() == Some(name) {
                if let naga::TypeInner::Struct { members, span } = &ty.inner {
                    return (members.iter().map(|m| (m.name.clone(), m.offset)).collect(), *span);
                }
            }
        }
        panic!("struct {name} not found in {file}");
    }

    #[test]
    fn shadow_faces_match_surface() {
        assert_eq!(members("raymarch.wgsl", "ShadowFaces"), members("surface.wgsl", "ShadowFaces"));
    }

    #[test]
    fn march_uniforms_match_wgsl() {
        let (m, span) = members("raymarch.wgsl", "March");
        assert_eq!(m, vec![(Some("params".to_string()), 0)]);
        assert_eq!(span as usize, std::mem::size_of::<RaymarchUniforms>());
    }
}

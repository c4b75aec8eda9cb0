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

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};
use crate::params::Baseline;
use bytemuck::{Pod, Zeroable};
use glam::UVec4;

bindings! {
    /// Raymarch's bind group (raymarch.wgsl; `march` is the pass's own uniform buffer).
    RaymarchBindings {
        frame_in: Kind::Storage,
        shadow_in: Kind::Storage,
        shadow_map: Kind::DepthArray,
        distance: Kind::Texture,
        scatter_out: Kind::StorageTexture(Raymarch::OUTPUT),
        march_in: Kind::Storage,
    }
}

/// `struct March` in raymarch.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct RaymarchUniforms {
    /// x: steps, y: 1 = jitter.
    pub params: UVec4,
}

pub struct Raymarch {
    pipelines: SpecialisedCompute<1>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// Steps and jitter of the next frame, written by [`Raymarch::record`].
    pub uniforms: wgpu::Buffer,
}

impl Raymarch {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
    /// Most steps per pixel ([`Baseline::STEPS`]).
    pub const MAX_STEPS: u32 = Baseline::STEPS.max as u32;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<Raymarch, GpuError> {
        let module = lib.module(device, "raymarch.wgsl")?;
        let layout = RaymarchBindings::layout(device, "Raymarch::layout", wgpu::ShaderStages::COMPUTE);
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("Raymarch::uniforms"),
            size: std::mem::size_of::<RaymarchUniforms>() as u64,
            // Storage, like the frame's (see Renderer::new): the step count steers the march.
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let pipelines =
            SpecialisedCompute::new(device, "Raymarch", module, &layout, ["main"], Specialised::LightPhaseAndMedium);
        Ok(Raymarch { pipelines, layout, bind_group: None, uniforms })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// (Re)binds the inputs; called when the targets or the shadow map change. `b.march` is
    /// ignored: the pass binds its own uniforms.
    pub fn bind(&mut self, device: &wgpu::Device, b: RaymarchBindings) {
        let b = RaymarchBindings { march_in: self.uniforms.as_entire_binding(), ..b };
        self.bind_group = Some(b.bind(device, "Raymarch::bind_group", &self.layout));
    }

    /// Records the march of every pixel. `steps` is clamped to `1..=MAX_STEPS`.
    pub fn record(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        (width, height): (u32, u32),
        steps: u32,
        jitter: bool,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([pipeline]), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        let u = RaymarchUniforms { params: UVec4::new(steps.clamp(1, Self::MAX_STEPS), jitter as u32, 0, 0) };
        // Queue writes land before the submission that carries this encoder.
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(&u));
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some("Raymarch::pass"), timestamp_writes: None });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind_group, &[]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn march_uniforms_match_wgsl() {
        let (module, _) = ShaderLibrary::embedded().validate("raymarch.wgsl").unwrap_or_else(|e| panic!("{e}"));
        let (members, span) = module
            .types
            .iter()
            .find_map(|(_, ty)| match &ty.inner {
                naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some("March") => {
                    Some((members.iter().map(|m| (m.name.clone(), m.offset)).collect::<Vec<_>>(), *span))
                }
                _ => None,
            })
            .unwrap_or_else(|| panic!("struct March not found"));
        assert_eq!(members, vec![(Some("params".to_string()), 0)]);
        assert_eq!(span as usize, std::mem::size_of::<RaymarchUniforms>());
    }
}

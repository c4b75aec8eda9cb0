//! ShadowFit: the directional shadow map's rectangle fitted to what the frame looks up
//! (`shaders/shadow_fit.wgsl`).
//!
//! [`super::ShadowMap::uniforms`] fits the sun's orthographic map to the casters' box across the
//! light, which does not depend on the camera; on the classroom that is 48 x 14 m, of which the
//! view sees 13 x 5 m. This pass takes the view segments' ends from the Surface pass's distances
//! (the surface points Composite lights, and the stretch inside the medium's box the march
//! samples), their rectangle in the casters' map coordinates `m = (M_core P).xy`, and narrows the
//! map to it: `M_fit = S M_core`, `S` mapping the rectangle `[a, b]` (widened to steps of 1/32 of
//! the casters' rectangle and half a texel) onto `[-1, 1]^2`. Casters outside it cannot shadow a
//! point inside it (they project outside it along the light too). The renderer copies `M_fit` and
//! the new texel size into the map's face uniforms, its draw list's parameters and the lookups'
//! `ShadowFaces` before the map is drawn: no CPU round trip, and every method (VSV's surfaces,
//! the march's volume) gets the finer map.
//!
//! The rectangle's shape (width over height in scene units) goes the other way, to the CPU, for
//! the next frames' map ([`AspectReadback`], read without waiting): the map is drawn at a width
//! and height that make its texels about square over it ([`super::ShadowMap::dims`]).

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};
use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

bindings! {
    /// ShadowFit's bind group (shadow_fit.wgsl; `fit` is the pass's own result buffer).
    ShadowFitBindings { frame_in: Kind::Storage, shadow: Kind::Storage, distance: Kind::Texture, fit: Kind::StorageRw }
}

/// The pass's result (`struct Fit` in shadow_fit.wgsl; a layout test checks it).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct FitResult {
    /// Order-preserving codes of the view segments' extremes (`reduce`'s scratch).
    pub extremes: [u32; 4],
    /// The fitted map's view-projection.
    pub view_proj: Mat4,
    /// Its texel size, the coarser side, in scene units.
    pub texel: f32,
    /// The rectangle's width over its height, in scene units.
    pub aspect: f32,
    pub _pad: [f32; 2],
    /// The fitted rectangle `(a.x, a.y, b.x, b.y)` in the casters' map coordinates (`[-1, 1]`).
    pub rect: Vec4,
}

pub struct ShadowFit {
    pipelines: SpecialisedCompute<2>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    /// A [`FitResult`].
    pub result: wgpu::Buffer,
}

impl ShadowFit {
    /// Pixels per thread of `reduce`, a column (shadow_fit.wgsl's `ROWS`).
    pub const ROWS: u32 = 16;
    const VIEW_PROJ: u64 = std::mem::offset_of!(FitResult, view_proj) as u64;
    const TEXEL: u64 = std::mem::offset_of!(FitResult, texel) as u64;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary) -> Result<ShadowFit, GpuError> {
        let module = lib.module(device, "shadow_fit.wgsl")?;
        let layout = ShadowFitBindings::layout(device, "ShadowFit::layout", wgpu::ShaderStages::COMPUTE);
        let result = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("ShadowFit::result"),
            size: std::mem::size_of::<FitResult>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(ShadowFit {
            pipelines: SpecialisedCompute::new(
                device,
                "ShadowFit",
                module,
                &layout,
                ["reduce", "finish"],
                Specialised::Light,
            ),
            layout,
            bind_group: None,
            result,
        })
    }

    /// (Re)binds the inputs; called when the targets change.
    pub fn bind(
        &mut self,
        device: &wgpu::Device,
        frame: &wgpu::Buffer,
        shadow: &wgpu::Buffer,
        distance: &wgpu::TextureView,
    ) {
        let b = ShadowFitBindings {
            frame_in: frame.as_entire_binding(),
            shadow: shadow.as_entire_binding(),
            distance: wgpu::BindingResource::TextureView(distance),
            fit: self.result.as_entire_binding(),
        };
        self.bind_group = Some(b.bind(device, "ShadowFit::bind_group", &self.layout));
    }

    /// Builds the pipelines specialised to `variant` unless they exist.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// Fits the map to the frame's view segments (after Surface), from the casters' fit that
    /// `shadow_uniforms` holds, then writes the fit into it ([`ShadowFit::copy_lookup`]).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        shadow_uniforms: &wgpu::Buffer,
        width: u32,
        height: u32,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some(pipelines), Some(bind_group)) = (self.pipelines.get(variant), &self.bind_group) else { return };
        encoder.clear_buffer(&self.result, 0, Some(16));
        let size = (width, height, Self::ROWS);
        super::util::record_reduction(encoder, "ShadowFit::pass", pipelines, bind_group, size);
        self.copy_lookup(encoder, shadow_uniforms);
    }

    /// Writes the last fit's matrix and texel size into the lookups' `ShadowFaces` (whose CPU
    /// copy holds the casters' fit): also in a frame that reuses the map drawn with it.
    pub fn copy_lookup(&self, encoder: &mut wgpu::CommandEncoder, shadow_uniforms: &wgpu::Buffer) {
        use super::ShadowUniforms as S;
        encoder.copy_buffer_to_buffer(&self.result, Self::VIEW_PROJ, shadow_uniforms, 0, 64);
        let texel = std::mem::offset_of!(S, params) as u64 + 4;
        encoder.copy_buffer_to_buffer(&self.result, Self::TEXEL, shadow_uniforms, texel, 4);
    }

    /// Writes the last fit's matrix into `buffer` at `offset` (the map's face uniforms, its draw
    /// list's parameters).
    pub fn copy_matrix(&self, encoder: &mut wgpu::CommandEncoder, buffer: &wgpu::Buffer, offset: u64) {
        encoder.copy_buffer_to_buffer(&self.result, Self::VIEW_PROJ, buffer, offset, 64);
    }
}

/// The fitted rectangle's aspect ([`FitResult::aspect`]) carried back to the CPU without a wait:
/// [`AspectReadback::record`] copies it out of a frame's fit, [`AspectReadback::submitted`] asks
/// for the copy to be mapped once that frame is on the queue, and [`AspectReadback::take`] returns
/// it when the mapping is done (a frame's timestamps are read with a wait, so by the next frame it
/// is; without them a later frame's `take` finds it). One copy in flight at a time: a frame that
/// finds the last one still mapping records none.
pub struct AspectReadback {
    /// [`FitResult::texel`] and [`FitResult::aspect`].
    staging: wgpu::Buffer,
    state: std::sync::Arc<std::sync::atomic::AtomicU8>,
}

impl AspectReadback {
    const IDLE: u8 = 0;
    const COPIED: u8 = 1;
    const MAPPING: u8 = 2;
    const MAPPED: u8 = 3;
    const FAILED: u8 = 4;
    const FROM: u64 = std::mem::offset_of!(FitResult, texel) as u64;

    pub fn new(device: &wgpu::Device) -> AspectReadback {
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("AspectReadback::staging"),
            size: 8,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        AspectReadback { staging, state: Default::default() }
    }

    fn state(&self) -> u8 {
        self.state.load(std::sync::atomic::Ordering::Acquire)
    }

    fn set(&self, s: u8) {
        self.state.store(s, std::sync::atomic::Ordering::Release);
    }

    /// Copies `fit`'s result out, after its pass in `encoder`, unless a copy is in flight.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, fit: &ShadowFit) {
        if self.state() == Self::IDLE {
            encoder.copy_buffer_to_buffer(&fit.result, Self::FROM, &self.staging, 0, 8);
            self.set(Self::COPIED);
        }
    }

    /// The frame that recorded the copy was submitted (or dropped: the staging then holds an
    /// older value or zeros, which [`AspectReadback::take`] passes over).
    pub fn submitted(&self) {
        if self.state() != Self::COPIED {
            return;
        }
        self.set(Self::MAPPING);
        let state = self.state.clone();
        self.staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            state.store(if r.is_ok() { Self::MAPPED } else { Self::FAILED }, std::sync::atomic::Ordering::Release);
        });
    }

    /// Whether a copy was asked to be mapped and has not been taken.
    pub fn in_flight(&self) -> bool {
        matches!(self.state(), Self::MAPPING | Self::MAPPED)
    }

    /// The aspect of the last fit copied, once its mapping is done (a positive finite value);
    /// `None` while it is in flight or when there is none.
    pub fn take(&self, device: &wgpu::Device) -> Option<f32> {
        match self.peek(device) {
            AspectPeek::Ready(aspect) => {
                self.staging.unmap();
                self.set(Self::IDLE);
                aspect
            }
            AspectPeek::Pending | AspectPeek::Nothing => {
                if self.state() == Self::FAILED {
                    self.set(Self::IDLE);
                }
                None
            }
        }
    }

    /// What [`AspectReadback::take`] would return, leaving it there (`Renderer::would_reuse`,
    /// which changes nothing).
    pub fn peek(&self, device: &wgpu::Device) -> AspectPeek {
        if self.state() == Self::MAPPING {
            // Runs the callbacks of finished mappings; does not wait.
            let _ = device.poll(wgpu::PollType::Poll);
        }
        match self.state() {
            Self::COPIED | Self::MAPPING => AspectPeek::Pending,
            Self::MAPPED => {
                let aspect = match self.staging.slice(..).get_mapped_range() {
                    Ok(data) => f32::from_le_bytes([data[4], data[5], data[6], data[7]]),
                    Err(_) => f32::NAN,
                };
                AspectPeek::Ready(Some(aspect).filter(|a| a.is_finite() && *a > 0.0))
            }
            _ => AspectPeek::Nothing,
        }
    }
}

/// A look at an [`AspectReadback`]: a copy still on its way, one mapped (its aspect, `None` when
/// not a positive finite number), or none.
pub enum AspectPeek {
    Pending,
    Ready(Option<f32>),
    Nothing,
}

/// What a fitted map depends on besides the casters' fit: the view segments, that is the camera,
/// the image's size and the medium's box (with the geometry and the culling switches, which the
/// keys hold anyway). All zero where the map is not fitted (a point light, or the fit off): there
/// the camera does not change the map.
pub type FitKey = [u8; std::mem::size_of::<FitView>()];

/// The uniforms a fitted map's rectangle depends on ([`FitKey`] holds their bytes).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct FitView {
    camera: [Vec4; 4],
    medium: [Vec4; 2],
    image: glam::UVec4,
}

/// The [`FitKey`] of a frame with uniforms `u` whose map is `fitted` or not.
pub fn fit_key(fitted: bool, u: &super::FrameUniforms) -> FitKey {
    if !fitted {
        return [0; std::mem::size_of::<FitView>()];
    }
    bytemuck::cast(FitView {
        camera: [u.cam_right, u.cam_up, u.cam_fwd, u.eye],
        medium: [u.medium_min, u.medium_max],
        image: u.image,
    })
}

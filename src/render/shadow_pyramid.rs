//! ShadowPyramid: the farthest first hit over square blocks of the directional shadow map
//! (`shaders/shadow_pyramid.wgsl`), which Cull reads to drop triangles the light cannot reach:
//!
//!   level L, texel (i, j) = max of the map's depth over its texels [2^L i, 2^L (i + 1)) x [2^L j, 2^L (j + 1))
//!
//! A triangle whose nearest depth lies beyond that maximum over a block that holds its footprint,
//! grown by one texel, is behind a nearer surface at every texel centre around it: every light ray
//! that meets it met something else first, at a smaller angle `gamma`, and the scan shadows all
//! behind that (cull.wgsl, `hidden_from_light`). On the classroom most of the triangles inside the
//! room are such, under its roof. Approximate only where an occluder has a gap narrower than a texel
//! between texel centres (docs/pruning.md).
//!
//! The pyramid is made at the end of a frame, for the frames after it, and holds the map's
//! view-projection before its levels: a later frame whose map has the same inputs but for the view
//! a sun's map is fitted to ([`MapInputs`]: the geometry, the light's matrices, the size) has the
//! same casters in the same light, so its Cull reads this one, projecting with the matrix it was
//! made with, and the frame never waits for its own map's rasterization (on llvmpipe, which draws
//! it on its raster threads beside Cull and Voxelize, that wait cost what the culling saved:
//! docs/results.md, session 17). The map's own draw list reads it only where the matrix is its
//! own (shadow_cull.wgsl compares): there leaving the hidden triangles out gives the same map bit
//! for bit. The frame after the light or the geometry changed runs without the test; a frame whose
//! map's inputs changed at all makes the pyramid anew (under exact surface shadows, whose frames
//! draw the map only for it, not while the light, the casters or, with a pyramid of this light at
//! hand, the view change from frame to frame: `Renderer::last_sun`).
//!
//! Directional lights only: the cube map of a point light is not reduced (its Cull keeps every
//! triangle the other tests keep).
//!
//! The same reduction of a depth image makes [`EyePyramid`], of the eye's depth after Surface: a
//! later frame of the same view ([`EyeInputs`]) leaves out of Surface's draw list the triangles
//! behind it at every pixel they cover (surface_cull.wgsl). A W x H image's pyramid is one of
//! max(W, H) texels per side, its blocks past the image repeating the image's edge; the eye's also
//! keeps the image itself after its levels (`whole`), for the small triangles' pixel-by-pixel test.

use super::util::{bindings, compute_pipeline, Kind};
use crate::gpu::{GpuError, ShaderLibrary};
use bytemuck::{Pod, Zeroable};

bindings! {
    /// One level's bind group (shadow_pyramid.wgsl).
    ShadowPyramidBindings {
        shadow_map: Kind::DepthArray,
        pyramid: Kind::StorageRw,
        level: Kind::Storage,
    }
}

/// One level's parameters (`struct Level` in shadow_pyramid.wgsl).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq, Eq)]
pub struct Level {
    /// Texels per side of the level read (the map for the first level) and of the level written.
    pub src_size: u32,
    pub dst_size: u32,
    /// Where the read and the written level start in the pyramid buffer, in floats.
    pub src_offset: u32,
    pub dst_offset: u32,
}

/// The pyramid of block maxima of a depth image, keyed by what the image was drawn from: the sun's
/// shadow map ([`ShadowPyramid`]) or the eye's depth ([`EyePyramid`]).
pub struct DepthPyramid<K> {
    /// The wgpu objects' label prefix ("ShadowPyramid", "EyePyramid"), and the pass's label.
    name: &'static str,
    pass_label: String,
    from_map: wgpu::ComputePipeline,
    from_level: wgpu::ComputePipeline,
    /// With the image itself after the levels ([`DepthPyramid::new`]'s `whole`).
    whole_image: Option<wgpu::ComputePipeline>,
    layout: wgpu::BindGroupLayout,
    /// The view-projection of the map it was made from ([`ShadowPyramid::MATRIX_FLOATS`] floats;
    /// left unwritten in the eye's, which no reader projects with), then levels
    /// [`ShadowPyramid::FIRST_LEVEL`] to [`ShadowPyramid::coarsest`], one after the other
    /// (hidden.wgsl computes the same offsets from the map's size), then the eye's image itself.
    pub pyramid: Option<wgpu::Buffer>,
    /// What the pyramid and its bind groups were made for.
    bound: Option<Bound>,
    /// What the map the pyramid holds was drawn from, once built: a later frame whose map has the
    /// same inputs draws the same map, and Cull reads the pyramid as it is.
    pub built_from: Option<K>,
}

/// The depth image a pyramid is bound to: its size (texels per side, or the larger side), its
/// view, and per level a bind group and the level's texels per side.
struct Bound {
    size: u32,
    view: wgpu::TextureView,
    groups: Vec<(wgpu::BindGroup, u32)>,
    /// The image's own copy: its bind group and its width and height.
    whole: Option<(wgpu::BindGroup, (u32, u32))>,
}

/// The sun's shadow map's pyramid, for Cull and the map's own draw list.
pub type ShadowPyramid = DepthPyramid<MapInputs>;

/// The eye's depth's pyramid, for Surface's draw list.
pub type EyePyramid = DepthPyramid<EyeInputs>;

/// What the eye's depth is drawn from, compared bit for bit: the view-projection, the eye, the
/// image's size (`Frame`'s `view_proj`, `eye` and `image`), the geometry (its fingerprint) and
/// whether solids draw one side. A frame with the same inputs draws the same depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EyeInputs {
    view_proj: [u32; 16],
    eye: [u32; 4],
    size: [u32; 2],
    geometry: u64,
    one_sided: bool,
}

impl EyeInputs {
    pub fn new(u: &super::FrameUniforms, geometry: u64, one_sided: bool) -> EyeInputs {
        EyeInputs {
            view_proj: bytemuck::cast(u.view_proj),
            eye: bytemuck::cast(u.eye),
            size: [u.image.x, u.image.y],
            geometry,
            one_sided,
        }
    }
}

/// The inputs of a directional shadow map, compared bit for bit: the scene's geometry (its
/// fingerprint), the map's matrices and parameters (the light's direction, the casters'
/// rectangle, the size), the view its rectangle is fitted to ([`super::ShadowFit`]) and whether
/// solids draw one side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MapInputs {
    geometry: u64,
    shadow: [u8; std::mem::size_of::<super::ShadowUniforms>()],
    /// The view a fitted map follows ([`super::fit_key`]; zero when not fitted).
    view: super::FitKey,
    one_sided: bool,
}

impl MapInputs {
    /// The same casters in the same light: equal but for the view a fitted map follows.
    pub fn same_but_view(&self, other: &MapInputs) -> bool {
        MapInputs { view: other.view, ..*self } == *other
    }

    pub fn new(geometry: u64, shadow: &super::ShadowUniforms, view: super::FitKey, one_sided: bool) -> MapInputs {
        MapInputs { geometry, shadow: bytemuck::cast(*shadow), view, one_sided }
    }
}

impl<K> DepthPyramid<K> {
    /// The finest level made, blocks of 4x4 texels (cull.wgsl's `PYRAMID_FIRST_LEVEL`). Level 1
    /// would drop 0.4% more of the classroom's work items (1.295 M against 1.289 M), not worth its
    /// million threads; level 3 1.2% fewer.
    pub const FIRST_LEVEL: u32 = 2;
    /// The coarsest level: blocks of 128 texels. A triangle wider than three of them is seldom
    /// hidden whole (11 levels drop none more on the classroom).
    pub const MAX_LEVEL: u32 = 7;
    /// Floats before the first level: the map's view-projection (hidden.wgsl's
    /// `PYRAMID_MATRIX_FLOATS`).
    pub const MATRIX_FLOATS: u32 = 16;

    /// `name` prefixes the wgpu objects' labels; `whole` keeps the image itself after the levels
    /// (the eye's, whose small triangles Surface's culling tests pixel by pixel).
    pub fn new(
        device: &wgpu::Device,
        lib: &ShaderLibrary,
        name: &'static str,
        whole: bool,
    ) -> Result<DepthPyramid<K>, GpuError> {
        let module = lib.module(device, "shadow_pyramid.wgsl")?;
        let layout = ShadowPyramidBindings::layout(device, &format!("{name}::layout"), wgpu::ShaderStages::COMPUTE);
        Ok(DepthPyramid {
            name,
            pass_label: format!("{name}::pass"),
            from_map: compute_pipeline(device, &format!("{name}::from_map"), &module, "from_map", &layout),
            from_level: compute_pipeline(device, &format!("{name}::from_level"), &module, "from_level", &layout),
            whole_image: whole
                .then(|| compute_pipeline(device, &format!("{name}::whole_image"), &module, "whole_image", &layout)),
            layout,
            pyramid: None,
            bound: None,
            built_from: None,
        })
    }

    /// The coarsest level a map of `size` texels per side gets (a level has at least one texel);
    /// 0 when the map is too small for the first.
    pub fn coarsest(size: u32) -> u32 {
        let l = Self::MAX_LEVEL.min(size.max(1).ilog2());
        if l < Self::FIRST_LEVEL {
            0
        } else {
            l
        }
    }

    /// Each level's parameters for a map of `size` texels per side: level L has ceil(size / 2^L)
    /// texels per side.
    pub fn level_params(size: u32) -> Vec<Level> {
        let mut out = Vec::new();
        let mut offset = Self::MATRIX_FLOATS;
        let mut src = (size, 0);
        let first = Self::FIRST_LEVEL.min(Self::coarsest(size) + 1);
        for l in first..=Self::coarsest(size) {
            let dst = size.div_ceil(1 << l);
            out.push(Level { src_size: src.0, dst_size: dst, src_offset: src.1, dst_offset: offset });
            src = (dst, offset);
            offset += dst * dst;
        }
        out
    }

    /// Binds the depth image (`dims`: its width and height; the levels are those of a square of
    /// the larger side); the bind groups are remade for another image, the pyramid for another
    /// size (what it holds stays valid for the inputs it was built from, whichever texture held
    /// them).
    pub fn bind(&mut self, device: &wgpu::Device, map_view: &wgpu::TextureView, dims: (u32, u32)) {
        let size = dims.0.max(dims.1);
        if self.bound.as_ref().is_some_and(|b| b.size == size && b.view == *map_view) {
            return;
        }
        let params = Self::level_params(size);
        let levels_end = params.last().map_or(Self::MATRIX_FLOATS, |l| l.dst_offset + l.dst_size * l.dst_size);
        // The image's own copy: its width and height in a Level's sizes (shadow_pyramid.wgsl).
        let whole = self.whole_image.is_some().then_some(Level {
            src_size: dims.0,
            dst_size: dims.1,
            src_offset: 0,
            dst_offset: levels_end,
        });
        let floats = levels_end + whole.map_or(0, |_| dims.0 * dims.1);
        if self.pyramid.as_ref().is_none_or(|b| b.size() != floats as u64 * 4) {
            self.built_from = None;
            self.pyramid = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("{}::pyramid", self.name)),
                size: floats as u64 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let Some(pyramid) = &self.pyramid else { return };
        // One storage buffer per level: its parameters never change while the map keeps its size.
        let group = |name: &str, p: &Level| {
            let level = wgpu::util::DeviceExt::create_buffer_init(
                device,
                &wgpu::util::BufferInitDescriptor {
                    label: Some(&format!("{}::{name}", self.name)),
                    contents: bytemuck::bytes_of(p),
                    usage: wgpu::BufferUsages::STORAGE,
                },
            );
            let b = ShadowPyramidBindings {
                shadow_map: wgpu::BindingResource::TextureView(map_view),
                pyramid: pyramid.as_entire_binding(),
                level: level.as_entire_binding(),
            };
            b.bind(device, &format!("{}::bind_group_{name}", self.name), &self.layout)
        };
        let groups =
            params.iter().enumerate().map(|(i, p)| (group(&format!("level{}", i + 1), p), p.dst_size)).collect();
        let whole = whole.map(|p| (group("whole_image", &p), dims));
        self.bound = Some(Bound { size, view: map_view.clone(), groups, whole });
    }

    /// Reduces the map, level by level, after the view-projection it was drawn with when a reader
    /// projects with it (`matrix`: a buffer and the offset of the matrix in it; for the sun's map
    /// the first matrix of the lookups' `ShadowFaces`, which holds the fitted one). The eye's
    /// culling reads no matrix (its pyramid serves only the very view it was made from): `None`.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder, matrix: Option<(&wgpu::Buffer, u64)>) {
        let (Some(Bound { groups, whole, .. }), Some(pyramid)) = (&self.bound, &self.pyramid) else { return };
        if let Some((buffer, offset)) = matrix {
            encoder.copy_buffer_to_buffer(buffer, offset, pyramid, 0, Self::MATRIX_FLOATS as u64 * 4);
        }
        let mut pass = encoder
            .begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(&self.pass_label), timestamp_writes: None });
        for (i, (bind_group, size)) in groups.iter().enumerate() {
            pass.set_pipeline(if i == 0 { &self.from_map } else { &self.from_level });
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(size.div_ceil(8), size.div_ceil(8), 1);
        }
        if let (Some(pipeline), Some((bind_group, (w, h)))) = (&self.whole_image, whole) {
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
    }

    /// The coarsest level bound, which Cull's test reads up to (0: none, before
    /// [`ShadowPyramid::bind`] or for a map too small).
    pub fn bound_coarsest(&self) -> u32 {
        self.bound.as_ref().map_or(0, |b| Self::coarsest(b.size))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_and_follow_one_another() {
        let p = ShadowPyramid::level_params(2048);
        assert_eq!(p.len(), 6);
        let m = ShadowPyramid::MATRIX_FLOATS;
        assert_eq!(p[0], Level { src_size: 2048, dst_size: 512, src_offset: 0, dst_offset: m });
        assert_eq!(p[1], Level { src_size: 512, dst_size: 256, src_offset: m, dst_offset: m + 512 * 512 });
        assert_eq!(p[5].dst_size, 16);
        assert_eq!(ShadowPyramid::coarsest(2048), 7);
        // Odd sizes round up: the last texel of a level covers the map's edge.
        let odd = ShadowPyramid::level_params(1000);
        let sizes: Vec<u32> = odd.iter().map(|l| l.dst_size).collect();
        assert_eq!(sizes, [250, 125, 63, 32, 16, 8]);
        assert_eq!(ShadowPyramid::level_params(4).len(), 1);
        assert!(ShadowPyramid::level_params(2).is_empty());
        assert_eq!(ShadowPyramid::coarsest(2), 0);
    }
}

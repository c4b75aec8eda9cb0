//! Integrate: per-pixel single scattering over the lit stretches of the shadow volume
//! (`shaders/integrate.wgsl`):
//!
//!   L_scatter = sum_j C(z_j) (q_{j-1} - q_j),   C(z) = U(clamp(z, z_start, z_end))
//!
//! with U the cumulative unshadowed in-scattering along the view ray (point light: the scatter
//! table, `sigma_s I0 / h G`; directional: closed-form pieces of `exp(-sigma_t (l + m))`) and `q_j`
//! bin j's lit fraction blended between the two planes around the pixel, on its own ray cell. Only
//! the bins where `q` changes are visited.
//!
//! In a VSV frame it also reads the surfaces' shadows from the same bits (the pipeline constant
//! `GRID_SHADOWS`, [`super::Renderer::surface_shadows`]: grid): the lit fraction of the bins around the
//! surface point, a slope-scaled bias toward the light before it, into the output's alpha for
//! Composite.
//!
//! Adaptive pixels ([`super::Renderer::adaptive_pixels`], on by default): the image is cut into
//! 8x8 blocks of strips of four pixels along the axis nearer the epipolar lines, each pixel's
//! neighbours a step along its line (one pixel along the axis, and one across where the line runs
//! nearer the diagonal). Pixel 0 of every strip is integrated (`lattice_pixels`); pixel 2 takes the
//! mean of its neighbours two steps away where they lie on its surface and agree within 1% or lie
//! on a straight stretch with the pixels beyond them (`classify_mid`), else it is integrated
//! (`refine_mid`); then pixels 1 and 3 the same from their neighbours a step away (`classify`,
//! `refine`). Shafts run along the epipolar lines, so none is interpolated across: on the
//! classroom 43% of the pixels are integrated, at a lower error against the reference than with
//! every pixel (integrate.wgsl, "pixels from their neighbours").

use super::util::{bindings, Kind};
use super::variant::{Specialised, SpecialisedCompute, Variant};
use crate::gpu::{GpuError, ShaderLibrary};

bindings! {
    /// Integrate's bind group (integrate.wgsl).
    IntegrateBindings {
        frame_in: Kind::Storage,
        grid: Kind::Storage,
        table: Kind::Storage,
        distance: Kind::Texture,
        scatter_out: Kind::StorageTexture(Integrate::OUTPUT),
        material: Kind::Texture,
        values: Kind::StorageRw,
        refine_list: Kind::StorageRw,
        refine_count: Kind::StorageRw,
    }
}

/// What Integrate reads and writes that the renderer owns.
pub struct IntegrateInputs<'a> {
    pub frame_in: wgpu::BindingResource<'a>,
    pub grid: wgpu::BindingResource<'a>,
    pub table: wgpu::BindingResource<'a>,
    pub distance: &'a wgpu::TextureView,
    pub scatter_out: &'a wgpu::TextureView,
    pub material: &'a wgpu::TextureView,
    /// The targets' size.
    pub width: u32,
    pub height: u32,
}

/// The adaptive path's buffers for one image size: the values of the pixels that others are taken
/// from, the two lists of pixels left to integrate and their lengths.
struct Adaptive {
    values: wgpu::Buffer,
    list: wgpu::Buffer,
    count: wgpu::Buffer,
    /// Whether they hold a whole image (else they are stand-ins and only the full path runs: the
    /// image's values would pass the adapter's largest binding).
    usable: bool,
}

pub struct Integrate {
    pipelines: SpecialisedCompute<6>,
    layout: wgpu::BindGroupLayout,
    bind_group: Option<wgpu::BindGroup>,
    adaptive: Option<Adaptive>,
    /// A CPU adapter: `refine` runs a few workgroups there whose threads loop over the list (on
    /// llvmpipe a thread with nothing to do still runs the shader's code: docs/results.md,
    /// session 29); on a GPU one thread per pixel the list can hold.
    cpu_adapter: bool,
}

impl Integrate {
    pub const OUTPUT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

    /// `refine`'s workgroups on a CPU adapter (a few per core: each loops over its share of the list).
    const CPU_REFINE_GROUPS: u32 = 16;

    pub fn new(device: &wgpu::Device, lib: &ShaderLibrary, cpu_adapter: bool) -> Result<Integrate, GpuError> {
        let module = lib.module(device, "integrate.wgsl")?;
        let layout = IntegrateBindings::layout(device, "Integrate::layout", wgpu::ShaderStages::COMPUTE);
        let pipelines = SpecialisedCompute::new(
            device,
            "Integrate",
            module,
            &layout,
            ["main", "lattice_pixels", "classify_mid", "refine_mid", "classify", "refine"],
            Specialised::All,
        );
        Ok(Integrate { pipelines, layout, bind_group: None, adaptive: None, cpu_adapter })
    }

    /// Builds the pipeline specialised to `variant` unless it exists.
    pub fn prepare(&mut self, device: &wgpu::Device, variant: Variant) {
        self.pipelines.prepare(device, variant);
    }

    /// (Re)binds the inputs, and makes the adaptive path's buffers for the targets' size; called
    /// when the targets or the grid change.
    pub fn bind(&mut self, device: &wgpu::Device, inputs: IntegrateInputs) {
        let (w, h) = (inputs.width.max(1) as u64, inputs.height.max(1) as u64);
        // A vec4<f32> a pixel (written for pixels 0 and 2 of each strip of four); at most one pixel
        // a strip in the first list and two in the second.
        let values_bytes = 16 * w * h;
        let list_bytes = 4 * 3 * Self::strips(w, h);
        let limit = crate::gpu::max_binding(&device.limits());
        let usable = values_bytes.max(list_bytes) <= limit;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: if usable { size } else { 16 },
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let adaptive = Adaptive {
            values: buffer("Integrate::values", values_bytes, wgpu::BufferUsages::empty()),
            list: buffer("Integrate::refine_list", list_bytes, wgpu::BufferUsages::empty()),
            count: buffer("Integrate::refine_count", 8, wgpu::BufferUsages::COPY_DST),
            usable,
        };
        let b = IntegrateBindings {
            frame_in: inputs.frame_in,
            grid: inputs.grid,
            table: inputs.table,
            distance: wgpu::BindingResource::TextureView(inputs.distance),
            scatter_out: wgpu::BindingResource::TextureView(inputs.scatter_out),
            material: wgpu::BindingResource::TextureView(inputs.material),
            values: adaptive.values.as_entire_binding(),
            refine_list: adaptive.list.as_entire_binding(),
            refine_count: adaptive.count.as_entire_binding(),
        };
        self.bind_group = Some(b.bind(device, "Integrate::bind_group", &self.layout));
        self.adaptive = Some(adaptive);
    }

    /// Whether frames of the bound size can take the adaptive path (its buffers fit the adapter).
    pub fn adaptive_available(&self) -> bool {
        self.adaptive.as_ref().is_some_and(|a| a.usable)
    }

    /// Strips of four pixels along the epipolar direction in a `w` x `h` image (sixteen an 8x8
    /// block, `strips()` in integrate.wgsl).
    fn strips(w: u64, h: u64) -> u64 {
        16 * w.div_ceil(8) * h.div_ceil(8)
    }

    /// Every pixel, or with `adaptive` (where [`Integrate::adaptive_available`]) one pixel a strip
    /// of four, then the others from their neighbours or integrated.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        width: u32,
        height: u32,
        adaptive: bool,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([main, lattice, classify_mid, refine_mid, classify, refine]), Some(bind_group)) =
            (self.pipelines.get(variant), &self.bind_group)
        else {
            return;
        };
        let buffers = self.adaptive.as_ref().filter(|a| adaptive && a.usable);
        if let Some(a) = buffers {
            encoder.clear_buffer(&a.count, 0, None);
        }
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("Integrate::pass"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, bind_group, &[]);
        if buffers.is_none() {
            pass.set_pipeline(main);
            pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
            return;
        }
        // One thread per strip in each dispatch but the refines: a workgroup takes 2x2 blocks of
        // 8x8 pixels (`strip_of` in integrate.wgsl).
        let (gx, gy) = (width.div_ceil(16), height.div_ceil(16));
        // The refines: enough threads for every pixel the list can hold on a GPU; a few looping
        // ones on a CPU adapter.
        let strips = Self::strips(width as u64, height as u64);
        let groups = |most: u64| {
            if self.cpu_adapter {
                Self::CPU_REFINE_GROUPS
            } else {
                most.div_ceil(64).clamp(1, 65_535) as u32
            }
        };
        pass.set_pipeline(lattice);
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(classify_mid);
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(refine_mid);
        pass.dispatch_workgroups(groups(strips), 1, 1);
        pass.set_pipeline(classify);
        pass.dispatch_workgroups(gx, gy, 1);
        pass.set_pipeline(refine);
        pass.dispatch_workgroups(groups(2 * strips), 1, 1);
    }
}

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
//! `GRID_SHADOWS`, [`super::Renderer::grid_shadows`]): the lit fraction of the bins around the
//! surface point, a slope-scaled bias toward the light before it, into the output's alpha for
//! Composite.
//!
//! Adaptive pixels ([`super::Renderer::adaptive_pixels`], on by default): in each 2x2 block the
//! column or row across the epipolar lines is integrated first (`lattice_pixels`); each other
//! pixel takes the mean of its two neighbours along the epipolar direction where they lie on its
//! surface and agree within 1% (`classify`), and only the rest are integrated (`refine`, over a
//! list `classify` appends to). Shafts run along the epipolar lines, so none is interpolated
//! across: on the classroom 59% of the pixels are integrated, at a lower error against the
//! reference (integrate.wgsl, "pixels from their neighbours").

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
        lattice: Kind::StorageRw,
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

/// The adaptive path's buffers for one image size: the blocks' first integrated pixels, the list
/// of pixels left to integrate and its length.
struct Adaptive {
    lattice: wgpu::Buffer,
    list: wgpu::Buffer,
    count: wgpu::Buffer,
    /// Whether they hold a whole image (else they are stand-ins and only the full path runs: the
    /// image's lattice would pass the adapter's largest binding).
    usable: bool,
}

pub struct Integrate {
    pipelines: SpecialisedCompute<4>,
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
            ["main", "lattice_pixels", "classify", "refine"],
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
        // Two integrated pixels a 2x2 block (vec4<f32>), and at most two listed a block.
        let lattice_bytes = 32 * w.div_ceil(2) * h.div_ceil(2);
        let list_bytes = 4 * w * h;
        let limits = device.limits();
        let limit = limits.max_storage_buffer_binding_size.min(limits.max_buffer_size);
        let usable = lattice_bytes.max(list_bytes) <= limit;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: if usable { size } else { 16 },
                usage: wgpu::BufferUsages::STORAGE | usage,
                mapped_at_creation: false,
            })
        };
        let adaptive = Adaptive {
            lattice: buffer("Integrate::lattice", lattice_bytes, wgpu::BufferUsages::empty()),
            list: buffer("Integrate::refine_list", list_bytes, wgpu::BufferUsages::empty()),
            count: buffer("Integrate::refine_count", 4, wgpu::BufferUsages::COPY_DST),
            usable,
        };
        let b = IntegrateBindings {
            frame_in: inputs.frame_in,
            grid: inputs.grid,
            table: inputs.table,
            distance: wgpu::BindingResource::TextureView(inputs.distance),
            scatter_out: wgpu::BindingResource::TextureView(inputs.scatter_out),
            material: wgpu::BindingResource::TextureView(inputs.material),
            lattice: adaptive.lattice.as_entire_binding(),
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

    /// Every pixel, or with `adaptive` (where [`Integrate::adaptive_available`]) two pixels a 2x2
    /// block, then the others from their neighbours or integrated.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        variant: Variant,
        width: u32,
        height: u32,
        adaptive: bool,
    ) {
        // Renderer::render_frame prepares every variant it records and binds before it records.
        let (Some([main, lattice, classify, refine]), Some(bind_group)) =
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
        // One thread per integrated pixel (two a 2x2 block), then one per block.
        let (bx, by) = (width.div_ceil(2).div_ceil(8), height.div_ceil(2).div_ceil(8));
        pass.set_pipeline(lattice);
        pass.dispatch_workgroups(bx, (2 * height.div_ceil(2)).div_ceil(8), 1);
        pass.set_pipeline(classify);
        pass.dispatch_workgroups(bx, by, 1);
        // Enough threads for every pixel `classify` can list on a GPU; a few looping ones on a CPU
        // adapter.
        let odd = (width as u64 * height as u64).div_ceil(2 * 64).min(65_535) as u32;
        pass.set_pipeline(refine);
        pass.dispatch_workgroups(if self.cpu_adapter { Self::CPU_REFINE_GROUPS } else { odd.max(1) }, 1, 1);
    }
}

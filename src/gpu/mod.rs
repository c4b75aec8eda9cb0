//! The GPU side's plumbing: device creation (headless, or handed over by the editor), the shader
//! library, and encoder timestamps.

mod shaders;
mod timing;

pub use shaders::{ShaderError, ShaderLibrary, ShaderSource, EMBEDDED, IMPORTED_ONLY};

/// The shaders compiled into the binary, as (file name, text).
pub fn shaders_embedded() -> &'static [(&'static str, &'static str)] {
    EMBEDDED
}
pub use timing::GpuTimer;

use std::sync::{Arc, Mutex};

/// Errors of the GPU path. Every message says what to do or what was wrong.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(
        "no GPU adapter found (wgpu saw none). On Debian install the software Vulkan driver with \
         `apt-get install mesa-vulkan-drivers libvulkan1`, or run on a machine with a GPU"
    )]
    NoAdapter,
    #[error("could not open the GPU device on '{adapter}': {message}")]
    Device { adapter: String, message: String },
    #[error("{what} needs {needed} but the adapter '{adapter}' allows at most {limit}{hint}")]
    TooLarge { what: String, needed: u64, limit: u64, adapter: String, hint: String },
    #[error(transparent)]
    Shader(#[from] ShaderError),
    #[error("GPU error while {during}: {message}")]
    Validation { during: String, message: String },
    #[error("reading back from the GPU failed: {0}")]
    Readback(String),
    #[error(
        "wgpu panicked while {during}: {message} (most likely a bug of the shader compiler, on a \
         shader its validator had accepted)"
    )]
    Panicked { during: String, message: String },
}

/// A validation message, with what to do where the cause is known: a shader folder copied from an
/// older build lacks the `override` constants this build sets on every pipeline
/// (`render/variant.rs`), and wgpu only says that one is "not found in the shader".
fn with_hint(message: String) -> String {
    if message.contains("pipeline-overridable constant") && message.contains("not found") {
        return format!(
            "{message}\n(the shader folder is older than this build: add the `override` lines of \
             this build's shaders/common.wgsl to the folder's common.wgsl)"
        );
    }
    message
}

/// The text of a caught panic.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "a panic without a message".into())
}

/// An adapter, device and queue, plus what we learned about them.
#[derive(Clone)]
pub struct GpuContext {
    pub adapter: Arc<wgpu::Adapter>,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Encoder-level timestamps are available (see [`GpuTimer`]).
    pub timestamps: bool,
    /// wgpu errors that no error scope caught, kept here instead of panicking (wgpu's default);
    /// [`GpuContext::take_uncaptured`] turns them into a [`GpuError`].
    uncaptured: Arc<Mutex<Vec<String>>>,
}

/// The largest buffer a storage binding can hold under `limits` (bytes): the smaller of the
/// binding's and the buffer's limits.
pub fn max_binding(limits: &wgpu::Limits) -> u64 {
    limits.max_storage_buffer_binding_size.min(limits.max_buffer_size)
}

impl GpuContext {
    /// Features we use when present.
    pub const OPTIONAL_FEATURES: wgpu::Features =
        wgpu::Features::TIMESTAMP_QUERY.union(wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS);

    /// Opens the best adapter without a window (Vulkan first; the software driver counts).
    pub fn headless() -> Result<GpuContext, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|_| GpuError::NoAdapter)?;
        Self::from_adapter(adapter)
    }

    /// Opens a device on `adapter` with the adapter's own limits (large grids need them).
    pub fn from_adapter(adapter: wgpu::Adapter) -> Result<GpuContext, GpuError> {
        let info = adapter.get_info();
        let features = adapter.features() & Self::OPTIONAL_FEATURES;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("epivox::device"),
            required_features: features,
            required_limits: adapter.limits(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device { adapter: info.name.clone(), message: e.to_string() })?;
        let timestamps = features.contains(Self::OPTIONAL_FEATURES);
        Ok(Self::wrap(adapter, device, queue, info, timestamps))
    }

    /// Wraps a device someone else opened (the editor's eframe window).
    pub fn from_parts(adapter: wgpu::Adapter, device: wgpu::Device, queue: wgpu::Queue) -> GpuContext {
        let info = adapter.get_info();
        let timestamps = device.features().contains(Self::OPTIONAL_FEATURES);
        Self::wrap(adapter, device, queue, info, timestamps)
    }

    fn wrap(
        adapter: wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        info: wgpu::AdapterInfo,
        timestamps: bool,
    ) -> GpuContext {
        // wgpu panics on an error no scope catches; keep it instead, so that a command or an edit
        // that provokes one gets an error that says so and the program goes on.
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        GpuContext { adapter: Arc::new(adapter), device, queue, info, timestamps, uncaptured }
    }

    /// The wgpu errors that no scope caught since the last call, as one error (`None` when there
    /// were none). `during` says what was going on, for the message.
    pub fn take_uncaptured(&self, during: &str) -> Result<(), GpuError> {
        let errors = match self.uncaptured.lock() {
            Ok(mut v) => std::mem::take(&mut *v),
            Err(_) => return Ok(()),
        };
        match errors.first() {
            None => Ok(()),
            Some(first) => Err(GpuError::Validation {
                during: during.to_string(),
                message: if errors.len() > 1 {
                    format!("{first} (and {} more)", errors.len() - 1)
                } else {
                    first.clone()
                },
            }),
        }
    }

    /// Adapter name and backend, for reports.
    pub fn adapter_name(&self) -> String {
        format!("{} ({:?}, {})", self.info.name, self.info.backend, self.info.driver_info)
    }

    /// The largest buffer a storage binding can hold on this device (bytes): [`max_binding`].
    pub fn max_binding(&self) -> u64 {
        max_binding(&self.device.limits())
    }

    /// Checks a buffer size against the device's limits; `remedy` completes the error's message
    /// ("use fewer planes, rays or bins").
    pub fn check_buffer(&self, what: &str, bytes: u64, remedy: &str) -> Result<(), GpuError> {
        let limit = self.max_binding();
        if bytes > limit {
            return Err(GpuError::TooLarge {
                what: what.to_string(),
                needed: bytes,
                limit,
                adapter: self.info.name.clone(),
                hint: format!(" bytes; {remedy}"),
            });
        }
        Ok(())
    }

    /// Checks a 2-D texture size against the device's limits.
    pub fn check_texture(&self, what: &str, width: u32, height: u32) -> Result<(), GpuError> {
        let limit = self.device.limits().max_texture_dimension_2d;
        let needed = width.max(height);
        if needed > limit {
            return Err(GpuError::TooLarge {
                what: what.to_string(),
                needed: needed as u64,
                limit: limit as u64,
                adapter: self.info.name.clone(),
                hint: " texels per side".into(),
            });
        }
        Ok(())
    }

    /// Waits for all submitted work.
    pub fn wait(&self) -> Result<(), GpuError> {
        self.device.poll(wgpu::PollType::wait_indefinitely()).map(|_| ()).map_err(|e| GpuError::Readback(e.to_string()))
    }

    /// Copies a buffer back to the CPU (blocking).
    pub fn read_buffer(&self, buffer: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("GpuContext::read_buffer::staging"),
            size: buffer.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GpuContext::read_buffer") });
        enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
        self.queue.submit([enc.finish()]);
        self.map_read(&staging)
    }

    /// Maps a MAP_READ buffer and returns its bytes.
    pub fn map_read(&self, staging: &wgpu::Buffer) -> Result<Vec<u8>, GpuError> {
        let (tx, rx) = std::sync::mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        rx.recv().map_err(|e| GpuError::Readback(e.to_string()))?.map_err(|e| GpuError::Readback(e.to_string()))?;
        let bytes = staging.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?.to_vec();
        staging.unmap();
        Ok(bytes)
    }

    /// Reads an RGBA32Float texture back as `width * height * 4` floats.
    pub fn read_texture_rgba32f(&self, texture: &wgpu::Texture) -> Result<Vec<f32>, GpuError> {
        self.read_texture_f32(texture, 4)
    }

    /// Reads a 32-bit float texture of `channels` channels (R32Float, Rg32Float, Rgba32Float) back
    /// as `width * height * channels` floats, rows top to bottom.
    pub fn read_texture_f32(&self, texture: &wgpu::Texture, channels: u32) -> Result<Vec<f32>, GpuError> {
        let (w, h) = (texture.width(), texture.height());
        let texel = 4 * channels;
        let row = (w * texel).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("GpuContext::read_texture::staging"),
            size: row as u64 * h as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("GpuContext::read_texture") });
        enc.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(row), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.queue.submit([enc.finish()]);
        let bytes = self.map_read(&staging)?;
        let mut out = Vec::with_capacity((w * h * channels) as usize);
        for y in 0..h as usize {
            let start = y * row as usize;
            out.extend_from_slice(bytemuck::cast_slice(&bytes[start..start + (w * texel) as usize]));
        }
        Ok(out)
    }

    /// Runs `f` inside a validation error scope and reports what it caught. A panic in `f` is
    /// caught too, after the scope is closed, and reported as [`GpuError::Panicked`]: naga's SPIR-V
    /// back end can panic on a shader its validator accepted (naga 30, session 27: a `let` of a
    /// constant vector whose components feed `select`), and a shader edit must fail like any
    /// other broken edit, with the last good pipelines still running, not end the renderer.
    pub fn scoped<T>(&self, during: &str, f: impl FnOnce() -> T) -> Result<T, GpuError> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let value = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
        let caught = pollster::block_on(scope.pop());
        let value = value.map_err(|payload| GpuError::Panicked {
            during: during.to_string(),
            message: panic_message(payload.as_ref()),
        })?;
        match caught {
            None => Ok(value),
            Some(e) => Err(GpuError::Validation { during: during.to_string(), message: with_hint(e.to_string()) }),
        }
    }
}

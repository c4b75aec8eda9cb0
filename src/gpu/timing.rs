//! GPU time per pass from timestamp queries written on the *encoder* between passes.
//!
//! Pass-level timestamp writes are wrong on Mesa 22 (llvmpipe); encoder-level ones are right there
//! and everywhere else, so that is the only kind we use.
//!
//! The first write is followed by a second one, to a spare query that is never read. lavapipe
//! (Mesa 22.3) flushes llvmpipe before it writes a timestamp, but llvmpipe takes the time itself
//! only when its rasterizer next runs, at the next flush, while compute dispatches run at once. A
//! pass's mark is stamped at the barrier before the next pass; the frame's first mark had no
//! barrier between it and the first compute pass (that pass's resource transitions run ahead of
//! the command buffer), so it was stamped after the pass's first dispatch, which then fell outside
//! every pass and the frame: the eye's cull, 17.5 ms of the million-triangle room's frame and
//! 2.7 ms of the classroom's (docs/results.md, session 38). The spare write's own flush stamps
//! the first mark where it stands; nothing is pending there, so the flush costs nothing. (A spare
//! write after every mark would pin every pass's boundary too, but each of those flushes costs:
//! the million-triangle room's frame ~25% longer in wall-clock time.)

/// Collects timestamps for one frame: `begin`, then `mark(label)` after each pass; `L` names the
/// passes (the renderer's `Pass`).
pub struct GpuTimer<L> {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    capacity: u32,
    /// The label of each timestamp after the first.
    labels: Vec<L>,
    period_ns: f32,
}

impl<L: Copy> GpuTimer<L> {
    pub const CAPACITY: u32 = 32;

    /// `None` when the device has no encoder timestamps.
    pub fn new(ctx: &super::GpuContext) -> Option<GpuTimer<L>> {
        if !ctx.timestamps {
            return None;
        }
        let set = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("GpuTimer::queries"),
            ty: wgpu::QueryType::Timestamp,
            count: Self::CAPACITY,
        });
        let resolve = ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("GpuTimer::resolve"),
            size: Self::CAPACITY as u64 * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(GpuTimer {
            set,
            resolve,
            capacity: Self::CAPACITY,
            labels: Vec::new(),
            period_ns: ctx.queue.get_timestamp_period(),
        })
    }

    /// Starts a frame.
    pub fn begin(&mut self, encoder: &mut wgpu::CommandEncoder) {
        self.labels.clear();
        encoder.write_timestamp(&self.set, 0);
        encoder.write_timestamp(&self.set, self.spare());
    }

    /// Marks the end of the pass `label` (and the start of the next).
    pub fn mark(&mut self, encoder: &mut wgpu::CommandEncoder, label: L) {
        let i = self.labels.len() as u32 + 1;
        if i < self.spare() {
            encoder.write_timestamp(&self.set, i);
            self.labels.push(label);
        }
    }

    /// The query written after the first and never read (the module's header says why).
    fn spare(&self) -> u32 {
        self.capacity - 1
    }

    /// Resolves the queries into the readback buffer; call before `finish`.
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        let n = self.labels.len() as u32 + 1;
        encoder.resolve_query_set(&self.set, 0..n, &self.resolve, 0);
    }

    /// Reads the times back (blocking) after the frame's submission: each label with the
    /// milliseconds since the previous mark.
    pub fn read(&self, ctx: &super::GpuContext) -> Result<Vec<(L, f64)>, super::GpuError> {
        let bytes = ctx.read_buffer(&self.resolve)?;
        let stamps: &[u64] = bytemuck::cast_slice(&bytes);
        let mut out = Vec::new();
        for (i, label) in self.labels.iter().enumerate() {
            let (a, b) = (stamps[i], stamps[i + 1]);
            // A counter that went backwards is a driver bug; report 0 rather than 584 years.
            let ms = if b >= a { (b - a) as f64 * self.period_ns as f64 * 1e-6 } else { 0.0 };
            out.push((*label, ms));
        }
        Ok(out)
    }
}

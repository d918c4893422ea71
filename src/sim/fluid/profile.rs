//! Per-kernel GPU times (timestamp queries around every dispatch) and each kernel's compulsory
//! memory traffic, for `bench`.

use super::*;

impl GpuBatch {
    /// Compulsory memory traffic of one dispatch of each kernel (bytes): every buffer the
    /// kernel's shader reads or writes (per naga), counted once per read and once per write at
    /// its full size. An upper bound for kernels that touch part of a buffer (members).
    pub fn bytes_per_dispatch(&self) -> Vec<(String, u64)> {
        crate::gpu::traffic::kernel_accesses()
            .into_iter()
            .map(|k| {
                let bytes = k
                    .reads
                    .iter()
                    .chain(&k.writes)
                    .filter_map(|b| FieldBinding::from_index(*b))
                    .map(|b| self.buffer_bytes(b))
                    .sum();
                (k.entry, bytes)
            })
            .collect()
    }
    /// Whether the device can time each dispatch ([`Self::profile_step`]); never on the native
    /// backend.
    pub fn can_profile(&self) -> bool {
        let need = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        self.ctx.device.features().contains(need)
    }
    /// One control step exactly as [`Self::step`] records it, with a GPU timestamp before and
    /// after every dispatch; returns each kernel's dispatch count and total time over the step
    /// (s), in the order of first use. `None` where the adapter has no timestamps inside passes.
    pub fn profile_step(&mut self) -> Result<Option<KernelTimes>, SimError> {
        if !self.can_profile() {
            return Ok(None);
        }
        let capacity = 2 * self.dispatches_per_control_step();
        let set = self.ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let bytes = capacity as u64 * 8;
        let resolve = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps staging"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.upload_inlet();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let labels = {
            let pass = enc.begin_compute_pass(&Default::default());
            let mut rec = Recorder::timed(pass, &set, capacity);
            self.record_control_step(&mut rec);
            rec.labels().to_vec()
        };
        let used = 2 * labels.len() as u32;
        enc.resolve_query_set(&set, 0..used, &resolve, 0);
        enc.copy_buffer_to_buffer(&resolve, 0, &staging, 0, used as u64 * 8);
        self.submit_and_read_health(enc)?;
        let raw: Vec<u8> = map_and_read(&self.ctx, &staging, used as u64 * 8)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&raw);
        let period_s = self.ctx.queue.get_timestamp_period() as f64 * 1e-9;
        let mut totals: Vec<(&'static str, u32, f64)> = Vec::new();
        for (k, label) in labels.iter().enumerate() {
            let dt = ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64 * period_s;
            match totals.iter_mut().find(|t| t.0 == *label) {
                Some(t) => {
                    t.1 += 1;
                    t.2 += dt;
                }
                None => totals.push((label, 1, dt)),
            }
        }
        Ok(Some(totals))
    }
}

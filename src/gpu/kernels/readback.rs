//! Copying buffers back to the CPU (blocking): a staging copy, then map and read.

use crate::gpu::{GpuContext, GpuError};

/// Copies `bytes` bytes at `offset` of a buffer to the CPU (blocking). `buffer` needs COPY_SRC.
pub fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    buffer: &wgpu::Buffer,
    offset: u64,
    bytes: u64,
) -> Result<Vec<T>, GpuError> {
    let staging = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("read-back"),
        size: bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(buffer, offset, &staging, 0, bytes);
    ctx.queue.submit([enc.finish()]);
    map_and_read(ctx, &staging, bytes)
}

/// Maps a MAP_READ buffer (after its copy was submitted) and returns its first `bytes` bytes.
pub fn map_and_read<T: bytemuck::Pod>(
    ctx: &GpuContext,
    staging: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<T>, GpuError> {
    let slice = staging.slice(0..bytes);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    ctx.wait()?;
    rx.recv()
        .map_err(|e| GpuError::Operation(e.to_string()))?
        .map_err(|e| GpuError::Operation(format!("buffer map failed: {e}")))?;
    let data = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Operation(e.to_string()))?;
        bytemuck::pod_collect_to_vec(&view)
    };
    staging.unmap();
    Ok(data)
}

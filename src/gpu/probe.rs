//! Driver self-check: Debian 12's Mesa 22.3 lavapipe silently caps a shader invocation at
//! 65,535 loop trips. `loop_probe.wgsl` counts the trips of a 100,000-trip loop.

use wgpu::util::DeviceExt;

use super::{GpuContext, GpuError, shaders};

/// Trips the probe asks for: well above the 65,535 cap, far below any time limit.
pub const PROBE_TRIPS: u32 = 100_000;

/// Runs the probe; returns the number of loop trips the driver executed.
pub fn loop_trips(ctx: &GpuContext) -> Result<u32, GpuError> {
    let device = &ctx.device;
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("loop_probe"),
        source: wgpu::ShaderSource::Wgsl(shaders::LOOP_PROBE.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("loop_probe"),
        layout: None,
        module: &module,
        entry_point: Some("loop_probe"),
        compilation_options: Default::default(),
        cache: None,
    });
    let data = [PROBE_TRIPS, 0, 0, 0];
    let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("loop_probe"),
        contents: bytemuck::cast_slice(&data),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("loop_probe"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: buffer.as_entire_binding(),
        }],
    });
    let mut enc = device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind, &[]);
        pass.dispatch_workgroups(1, 1, 1);
    }
    ctx.queue.submit([enc.finish()]);
    let out: Vec<u32> = crate::gpu::kernels::read_buffer(ctx, &buffer, 0, 16)?;
    Ok(out[1])
}

/// `Ok(None)` when the driver counts correctly, `Ok(Some(message))` when it truncates loops.
pub fn check_loop_cap(ctx: &GpuContext) -> Result<Option<String>, GpuError> {
    let trips = loop_trips(ctx)?;
    if trips == PROBE_TRIPS {
        Ok(None)
    } else {
        Ok(Some(format!(
            "the driver of {} ran only {trips} of {PROBE_TRIPS} loop trips: it silently truncates \
             long shader loops (Debian 12's Mesa 22.3 caps them at 65,535) and can give wrong \
             results. Install Mesa >= 23 (on Debian 12: `bash scripts/install-vulkan.sh`, which \
             takes Mesa 25 from bookworm-backports).",
            ctx.describe()
        )))
    }
}

//! The driver self-check: a driver that truncates long shader loops (Debian 12's Mesa 22.3
//! lavapipe) is detected and named. CI installs Mesa 25, where this passes.

mod common;

use fluxswarm_gpu::gpu::probe;

#[test]
fn driver_runs_long_loops_in_full() {
    let (_lock, ctx) = common::gpu();
    let trips = probe::loop_trips(&ctx).unwrap();
    if let Some(message) = probe::check_loop_cap(&ctx).unwrap() {
        panic!("{message}");
    }
    assert_eq!(trips, probe::PROBE_TRIPS);
}

/// wgpu's validation errors would leave results silently unwritten (a rejected command buffer
/// runs nothing): the next wait reports them, once.
#[test]
fn a_rejected_command_fails_the_next_wait() {
    let (_lock, ctx) = common::gpu();
    let buffer = |usage| {
        ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: 16,
            usage,
            mapped_at_creation: false,
        })
    };
    let (src, dst) = (
        buffer(wgpu::BufferUsages::COPY_SRC),
        buffer(wgpu::BufferUsages::COPY_DST),
    );
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(&src, 0, &dst, 0, 32); // past the end of both
    ctx.queue.submit([enc.finish()]);
    let e = ctx.wait().unwrap_err().to_string();
    assert!(e.contains("rejected") && e.contains("report"), "{e}");
    ctx.wait().unwrap();
}

//! `solver.backend = "auto"` never crashes on an adapter it cannot use: on a device whose
//! limits are below what a kernel needs (WebGPU's default of 8 storage buffers per stage; the
//! MacCormack correction binds 10) it runs the CPU backend and its warning names the limit.

mod common;

use fluxswarm_gpu::gpu::{GpuContext, context};
use fluxswarm_gpu::sim::open;

#[test]
fn auto_falls_back_with_the_limit_named_on_a_device_too_small_for_the_kernels() {
    let _lock = common::gpu().0;
    let adapter = context::enumerate_adapters()
        .into_iter()
        .find(|a| a.get_info().device_type == wgpu::DeviceType::Cpu)
        .or_else(|| context::enumerate_adapters().into_iter().next())
        .expect("an adapter");
    let mut limits = adapter.limits();
    limits.max_storage_buffers_per_shader_stage = 8;
    let small = GpuContext::from_adapter_with_limits(adapter, limits).unwrap();
    let r = common::swarm_config(61, 13, &[[2.0, 0.5], [3.4, 0.8]], &[]);
    let opened = open::open_auto_on(&small, &r, 2, false).unwrap();
    assert_eq!(opened.batch.backend_name(), "native", "{}", opened.header());
    let warning = opened.warnings.join(" ");
    assert!(
        warning.contains("max_storage_buffers_per_shader_stage") && warning.contains("CPU backend"),
        "{warning}"
    );
    // The same device with `adapter` is a clear error, not a crash.
    let err = fluxswarm_gpu::sim::GpuBatch::new(&small, &r, 2)
        .err()
        .expect("refused");
    assert!(
        err.to_string()
            .contains("max_storage_buffers_per_shader_stage"),
        "{err}"
    );
}

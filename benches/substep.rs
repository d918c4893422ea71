//! One control step (20 substeps) at the configured grid with the swarm, two ways:
//! - `gpu`: `FluidBatch::step` on the adapter `auto` picks (lavapipe on the development
//!   machines), one submission and one read-back;
//! - `native`: the yardstick, `sim::native::NativeBatch`: the same control step in plain Rust
//!   written for speed (bit-identical to the twins), one environment per rayon task;
//! - `twins`: the plain-Rust CPU twins of the kernels (`sim::cpu`), written for clarity (they
//!   recompute the diffused field at every sample), one environment per rayon task.
//!
//! Size from the environment: FLUXSWARM_BENCH_ENVS (default 16) and FLUXSWARM_BENCH_NX
//! (default 1000, the paper's grid; the channel length scales with it, so dx stays the paper's).
//! CI runs it tiny: `FLUXSWARM_BENCH_ENVS=2 FLUXSWARM_BENCH_NX=100 cargo bench --bench substep
//! -- --test`. Throughput is reported in environment control steps per second.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};
use fluxswarm_gpu::sim::FluidBatch;
use fluxswarm_gpu::sim::cpu::CpuBatch;
use fluxswarm_gpu::sim::native::NativeBatch;
use rayon::prelude::*;

fn env_usize(key: &str, default: usize) -> usize {
    std::env::var(key)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn substep(c: &mut Criterion) {
    let envs = env_usize("FLUXSWARM_BENCH_ENVS", 16);
    let nx = env_usize("FLUXSWARM_BENCH_NX", 1000);
    let length = nx as f64 * 1e-4;
    let sets = vec![
        format!("domain.nx={nx}"),
        format!("domain.length_m={length}"),
        format!("domain.success_x_m={}", 0.2 * length),
        format!("domain.failure_x_m={}", 0.8 * length),
        format!("swarm.grid_centre_x_m={}", 0.5 * length),
    ];
    let resolved = Config::load(None, &sets).expect("benchmark configuration");
    let ctx = GpuContext::new(AdapterChoice::Auto).expect("an adapter (scripts/install-vulkan.sh)");
    eprintln!("{}", ctx.banner());
    let mut batch = FluidBatch::new(&ctx, &resolved, envs).expect("batch");
    let n = batch.n_members();
    batch.set_all_actions(&vec![[-1.0, 0.0]; envs * n]);

    // The yardstick and the twins start from the same state, one environment per task.
    let mut template = FluidBatch::new(&ctx, &resolved, envs)
        .expect("batch")
        .to_cpu(&ctx)
        .expect("read-back");
    template.actions = vec![[-1.0, 0.0]; envs * n];
    let control_dt = resolved.config.time.control_dt_s;
    let mut natives = NativeBatch::new(&template, resolved.waveform.clone(), control_dt);
    let mut twins: Vec<CpuBatch> = (0..envs).map(|e| natives.env(e).clone()).collect();
    let substeps = resolved.config.time.substeps as usize;
    let inlet: Vec<f32> = resolved
        .waveform
        .substep_values(0.0, control_dt, substeps)
        .collect();

    let mut group = c.benchmark_group(format!("control_step_nx{nx}_e{envs}"));
    group.sample_size(10);
    group.throughput(Throughput::Elements(envs as u64));
    group.bench_function("gpu", |b| b.iter(|| batch.step(&ctx).expect("step")));
    group.bench_function("native", |b| b.iter(|| natives.step()));
    group.bench_function("twins", |b| {
        b.iter(|| {
            twins.par_iter_mut().for_each(|cpu| {
                cpu.step(&inlet);
            })
        })
    });
    group.finish();
}

// No plots: criterion's plotters backend needs system fonts, which headless machines lack
// (it panics with FontUnavailable); the numbers go to the terminal and target/criterion.
criterion_group! {
    name = benches;
    config = Criterion::default().without_plots();
    targets = substep
}
criterion_main!(benches);

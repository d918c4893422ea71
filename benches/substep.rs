//! One control step (20 substeps) at the configured grid with the swarm, on both backends:
//! - `gpu`: `GpuBatch::step`, the WGSL kernels on the adapter `auto` picks (lavapipe on the
//!   development machines), one submission and one read-back;
//! - `native`: `CpuBatch::step`, the CPU stages, one environment per rayon task.
//!
//! Size from the environment: FLUXSWARM_BENCH_ENVS (default 16) and FLUXSWARM_BENCH_NX
//! (default 1000, the paper's grid; the channel length scales with it, so dx stays the paper's).
//! CI runs it tiny: `FLUXSWARM_BENCH_ENVS=2 FLUXSWARM_BENCH_NX=100 cargo bench --bench substep
//! -- --test`. Throughput is reported in environment control steps per second. Without an
//! adapter only `native` runs.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};
use fluxswarm_gpu::sim::{CpuBatch, FlowBatch, GpuBatch};

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
    let mut native = CpuBatch::new(&resolved, envs).expect("batch");
    let n = native.n_members();
    native
        .set_all_actions(&vec![[-1.0, 0.0]; envs * n])
        .expect("actions");
    let mut gpu = match GpuContext::new(AdapterChoice::Auto) {
        Ok(ctx) => {
            eprintln!("{}", ctx.banner());
            let mut batch = GpuBatch::new(&ctx, &resolved, envs).expect("batch");
            batch
                .set_all_actions(&vec![[-1.0, 0.0]; envs * n])
                .expect("actions");
            Some(batch)
        }
        Err(e) => {
            eprintln!("no adapter ({e}): timing the CPU backend only");
            None
        }
    };

    let mut group = c.benchmark_group(format!("control_step_nx{nx}_e{envs}"));
    group.sample_size(10);
    group.throughput(Throughput::Elements(envs as u64));
    if let Some(batch) = gpu.as_mut() {
        group.bench_function("gpu", |b| b.iter(|| batch.step().expect("step")));
    }
    group.bench_function("native", |b| b.iter(|| native.step().expect("step")));
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

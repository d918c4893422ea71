//! One rollout and update of the learner (`Learner::iterate`) on the CPU point-mass
//! environment of the tests instead of the fluid, so that the learner's own cost shows: the
//! paper's networks and `[train]` table, 16 agents, FLUXSWARM_BENCH_ENVS environments (default
//! 4, the paper's; 16 rollout steps each, so 64 samples in 16 minibatches of 4 at E = 4).
//!
//! `UNTUNED=1` skips `tuning::keep_freed_blocks` (glibc's thresholds, which `main` raises), to
//! measure what it buys. CI runs it once: `cargo bench --bench learner -- --test`.

use criterion::{Criterion, Throughput};
use fluxswarm_gpu::learn::env::MultiAgentEnv;
use fluxswarm_gpu::learn::mappo::{Learner, TrainConfig};
use fluxswarm_gpu::testing::PointMasses;

const AGENTS: usize = 16;

fn learner(c: &mut Criterion) {
    let envs = std::env::var("FLUXSWARM_BENCH_ENVS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(4);
    let mut env = PointMasses::new(envs, AGENTS, 1);
    let mut learner = Learner::new(AGENTS, 8, TrainConfig::default(), 1).expect("learner");
    let mut obs = env.reset().expect("reset");
    let mut group = c.benchmark_group("learner");
    group.sample_size(10);
    group.throughput(Throughput::Elements(
        (envs * TrainConfig::default().rollout_steps as usize) as u64,
    ));
    group.bench_function(format!("iterate/E={envs}"), |b| {
        b.iter(|| learner.iterate(&mut env, &mut obs).expect("iterate"))
    });
    group.finish();
}

fn main() {
    if std::env::var_os("UNTUNED").is_none() {
        fluxswarm_gpu::tuning::keep_freed_blocks();
    }
    // No plots: criterion's plotter needs system fonts, which headless machines lack.
    let mut c = Criterion::default().without_plots().configure_from_args();
    learner(&mut c);
    c.final_summary();
}

//! Times each stage of the substep alone (by repetition) at the paper grid.
//! `cargo run --release --example stage_timing -- [E]`
use std::time::Instant;

use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::{GpuBatch, Stage};

fn main() -> anyhow::Result<()> {
    let e: usize = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(16);
    let sets: Vec<String> = std::env::args().skip(2).collect();
    let resolved = Config::load(None, &sets)?;
    let ctx = GpuContext::new(AdapterChoice::Auto)?;
    println!("{}", ctx.banner());
    let mut batch = GpuBatch::new(&ctx, &resolved, e)?;
    batch.step()?;
    for stage in [
        Stage::Advect,
        Stage::PressureRhs,
        Stage::PressureSolve,
        Stage::Project,
        Stage::Diagnostics,
    ] {
        batch.run_stages(&[stage], 0, 2)?;
        let reps = 10;
        let t = Instant::now();
        batch.run_stages(&[stage], 0, reps)?;
        println!(
            "{stage:?}: {:.3} ms per dispatch set",
            t.elapsed().as_secs_f64() * 1e3 / reps as f64
        );
    }
    Ok(())
}

//! Resolution check (issue 5): are the key figures converged at the paper's grid? Runs the
//! paper setup with the swarm at zero action at the paper's resolution (dx = 0.1 mm, 20 cells
//! across, dt_sub = 0.25 ms) and at dx/2, dy/2, dt/2 (same CFL), and prints
//! - the swarm's centre of mass x_COM at t = 0.025, 0.05, 0.075, 0.1 s (the passive swarm's
//!   displacement over the first systole),
//! - the pressure drop along the channel, mean p over the inlet column minus the outlet
//!   column, at the same times (Pa).
//!
//! `cargo run --release --example resolution_check` (a few minutes on lavapipe; the fine grid
//! is 8x the work per step). `experiments/resolution_check.sh` wraps it.

use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::env::SwarmEnv;
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};

const REPORT_STEPS: [u32; 4] = [5, 10, 15, 20]; // control steps of 5 ms

fn run(ctx: &GpuContext, refine: u32) -> anyhow::Result<Vec<(f64, f64, f64)>> {
    let sets = vec![
        format!("domain.nx={}", 1000 * refine),
        format!("domain.ny={}", 20 * refine),
        format!("time.substeps={}", 20 * refine),
        "inlet.random_phase=false".to_string(),
        "env.position_jitter_m=0.0".to_string(),
    ];
    let resolved = Config::load(None, &sets)?;
    let mut env = SwarmEnv::new(
        Box::new(fluxswarm_gpu::sim::GpuBatch::new(ctx, &resolved, 1)?),
        &resolved,
        0,
    )?;
    env.reset()?;
    let n = env.n_agents();
    let dt = resolved.config.time.control_dt_s;
    let mut out = Vec::new();
    for step in 1..=*REPORT_STEPS.last().unwrap_or(&0) {
        let s = env.step(&vec![[0.0f32; 2]; n])?;
        if s.episodes[0].is_some() {
            anyhow::bail!("the episode ended at step {step}, before the last report time");
        }
        if REPORT_STEPS.contains(&step) {
            let x_com = s.members.iter().map(|m| m.pos[0] as f64).sum::<f64>() / n as f64;
            let f = env.batch().fields(0)?;
            let (nx, ny) = (f.nx, f.ny);
            let col = |i: usize| (0..ny).map(|j| f.p[j * nx + i] as f64).sum::<f64>() / ny as f64;
            out.push((step as f64 * dt, x_com * 1e3, col(0) - col(nx - 1)));
        }
    }
    Ok(out)
}

fn main() -> anyhow::Result<()> {
    let ctx = GpuContext::new(AdapterChoice::Auto)?;
    println!("{}", ctx.banner());
    let base = run(&ctx, 1)?;
    let fine = run(&ctx, 2)?;
    println!(
        "| t (s) | x_COM (mm), paper grid | x_COM (mm), dx/2 dt/2 | difference (mm) | dp (Pa), paper grid | dp (Pa), dx/2 dt/2 | difference |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (b, f) in base.iter().zip(&fine) {
        println!(
            "| {:.3} | {:.3} | {:.3} | {:+.3} | {:.1} | {:.1} | {:+.2} % |",
            b.0,
            b.1,
            f.1,
            f.1 - b.1,
            b.2,
            f.2,
            100.0 * (f.2 - b.2) / b.2.abs().max(1e-12)
        );
    }
    Ok(())
}

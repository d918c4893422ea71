//! Semi-Lagrangian vs MacCormack around a fixed solid disc (Brinkman, r = 250 um at x = 50 mm,
//! y = 1 mm) at the paper grid, against a MacCormack reference at dt/4.
//! `cargo run --release --example advection_accuracy -- [seconds]`
//! Prints the relative L2 error of u_x over 45 mm <= x <= 60 mm and the wall time per run.
use std::time::Instant;

use fluxswarm_gpu::config::Config;
use fluxswarm_gpu::gpu::{AdapterChoice, GpuContext};
use fluxswarm_gpu::sim::FlowBatch;
use fluxswarm_gpu::sim::GpuBatch;

fn run(
    ctx: &GpuContext,
    scheme: &str,
    trace: &str,
    substeps: u32,
    seconds: f64,
) -> anyhow::Result<(Vec<f32>, f64, f32)> {
    let r = Config::load(
        None,
        &[
            format!("solver.advection={scheme}"),
            format!("solver.backtrace={trace}"),
            format!("time.substeps={substeps}"),
        ],
    )?;
    let mut b = GpuBatch::new(ctx, &r, 1)?;
    let g = *b.grid();
    let (cx, cy, rad) = (0.05, 0.001, 250e-6);
    let body: Vec<[f32; 4]> = (0..g.n_cells())
        .map(|c| {
            let x = ((c % g.nx) as f64 + 0.5) * g.dx();
            let y = ((c / g.nx) as f64 + 0.5) * g.dy();
            let inside = (x - cx).powi(2) + (y - cy).powi(2) <= rad * rad;
            [if inside { 1.0 } else { 0.0 }, 0.0, 0.0, 0.0]
        })
        .collect();
    b.set_body(0, &body)?;
    let steps = (seconds / 0.005).round() as usize;
    let t = Instant::now();
    let mut max_div = 0.0f32;
    for _ in 0..steps {
        let h = b.step()?;
        max_div = max_div.max(h[0].max_div);
    }
    let wall = t.elapsed().as_secs_f64();
    Ok((b.fields(0)?.ux_cells(), wall, max_div))
}

fn main() -> anyhow::Result<()> {
    let seconds: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(0.12);
    let ctx = GpuContext::new(AdapterChoice::Auto)?;
    println!("{}", ctx.banner());
    let (reference, _, _) = run(&ctx, "maccormack", "rk2", 80, seconds)?;
    let nx = 1000;
    let region = |f: &[f32]| -> Vec<f32> {
        (0..20)
            .flat_map(|j| (450..600).map(move |i| (i, j)))
            .map(|(i, j)| f[j * nx + i])
            .collect()
    };
    let rr = region(&reference);
    let norm: f32 = rr.iter().map(|x| x * x).sum::<f32>().sqrt();
    for (scheme, trace, substeps) in [
        ("semi_lagrangian", "euler", 20),
        ("semi_lagrangian", "rk2", 20),
        ("maccormack", "euler", 20),
        ("maccormack", "rk2", 20),
        ("semi_lagrangian", "rk2", 40),
        ("maccormack", "euler", 40),
        ("maccormack", "rk2", 40),
    ] {
        let (f, wall, max_div) = run(&ctx, scheme, trace, substeps, seconds)?;
        let ff = region(&f);
        let err: f32 = ff
            .iter()
            .zip(&rr)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f32>()
            .sqrt()
            / norm;
        println!(
            "{scheme:16} {trace:5} substeps {substeps:3}: rel L2 error of u_x near the disc {err:.3e}, wall {wall:.1} s, max |div u| {max_div:.3e} 1/s"
        );
    }
    Ok(())
}

//! `fluxswarm-gpu bench`: environment steps per second per batch size at the configured grid,
//! cell updates per second, dispatches and pressure iterations per substep, the relative
//! divergence residual reached, and the time split by elimination (the advection passes
//! alone, the pressure passes alone, the member kernels alone, the diagnostics with the
//! health read-back alone). Prints a table and writes `bench.csv` (SPEC section 7). Where the
//! adapter has timestamps inside passes, also the GPU time and the bytes of every kernel over
//! one control step (`kernels.csv`). On the CPU backend the split comes from timing its stages
//! instead, with the roofline of the CPU step against this machine's measured peaks
//! (`stages.csv`, `roofline.csv`; [`super::bench_cpu`]).

use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::sim::{
    CpuBatch, EnvHealth, FlowBatch, GpuBatch, Stage, fluid::PRESSURE_ITERATIONS_PER_SUBSTEP,
};

use super::bench_cpu::{self, CpuProfile};
use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct BenchArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// Batch sizes, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64")]
    pub envs: Vec<usize>,
    /// Wall-clock seconds of timed control steps per batch size (at least 3 steps each).
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// Output directory (default runs/bench-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Also time the CPU backend (`sim::cpu`: the control step in plain Rust, one environment
    /// per rayon task) at every batch size, after the main runs, and write `native.csv` with
    /// the ratio.
    #[arg(long)]
    pub native: bool,
    /// Seconds for each of the machine-peak measurements of the CPU backend's roofline (FMA
    /// loops, in-cache and out-of-cache triads); 0 skips them.
    #[arg(long, default_value_t = 0.2)]
    pub peak_seconds: f64,
    /// Size of each of the three out-of-cache triad arrays (MiB, over all threads).
    #[arg(long, default_value_t = 256)]
    pub triad_mib: usize,
}

struct Row {
    envs: usize,
    env_steps_per_s: f64,
    cell_updates_per_s: f64,
    dispatches: u32,
    fluid_s: f64,
    pressure_s: f64,
    swarm_s: f64,
    readback_s: f64,
    step_s: f64,
    /// Worst relative divergence residual (max |div u| after / before the projection) over the
    /// environments at the last timed step.
    residual: f64,
    /// (kernel, dispatches per control step, median GPU time per control step (s), bytes per
    /// control step), where the adapter has timestamps.
    kernels: Vec<(String, u32, f64, u64)>,
    /// The CPU backend's stage times and counted work.
    cpu: Option<CpuProfile>,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median wall time of `f` over `reps` runs.
fn time_median(reps: usize, mut f: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<f64> {
    let mut t = Vec::with_capacity(reps);
    for _ in 0..reps {
        let s = Instant::now();
        f()?;
        t.push(s.elapsed().as_secs_f64());
    }
    Ok(median(t))
}

/// Median time of control steps taken by `step`, at least 3 and for at least `seconds`, and
/// the health after the last one; a diverged environment is an error.
fn timed_steps(
    seconds: f64,
    mut step: impl FnMut() -> anyhow::Result<Vec<EnvHealth>>,
) -> anyhow::Result<(f64, Vec<EnvHealth>)> {
    let mut times = Vec::new();
    let start = Instant::now();
    loop {
        let s = Instant::now();
        let health = step()?;
        times.push(s.elapsed().as_secs_f64());
        if let Some(e) = health.iter().position(|h| h.diverged()) {
            bail!("environment {e} diverged during the benchmark");
        }
        if times.len() >= 3 && start.elapsed().as_secs_f64() >= seconds {
            return Ok((median(times), health));
        }
    }
}

fn bench_one(
    args: &BenchArgs,
    resolved: &fluxswarm_gpu::config::Resolved,
    envs: usize,
) -> anyhow::Result<(Row, String)> {
    let opened = args.common.open_batch(resolved, envs)?;
    let runs_on = opened.batch.describe();
    let mut batch = opened.batch;
    batch.step()?; // warm-up: pipeline compilation, first touches
    let (step_s, health) = timed_steps(args.seconds, || Ok(batch.step()?))?;
    let residual = health
        .iter()
        .map(|h| h.residual() as f64)
        .fold(0.0, f64::max);
    let substeps = batch.substeps();
    let g = *batch.grid();
    let mut row = Row {
        envs,
        env_steps_per_s: envs as f64 / step_s,
        cell_updates_per_s: (envs * g.n_cells() * substeps) as f64 / step_s,
        dispatches: 0,
        fluid_s: 0.0,
        pressure_s: 0.0,
        swarm_s: 0.0,
        readback_s: 0.0,
        step_s,
        residual,
        kernels: Vec::new(),
        cpu: None,
    };
    // The time split by elimination and the kernel timestamps are the WGSL path's; the CPU
    // backend has no dispatches to split, but stages it can time.
    if let Some(gpu) = batch.as_gpu_mut() {
        split_times(gpu, &mut row)?;
    } else if batch.backend_name() == "native" {
        let p = bench_cpu::profile(resolved, batch.as_ref(), step_s, args.seconds)?;
        (row.fluid_s, row.pressure_s, row.swarm_s, row.readback_s) = p.split();
        row.cpu = Some(p);
    }
    Ok((row, runs_on))
}

/// The time split by elimination (advection, pressure, members, read-back) and the kernels'
/// timestamps of the WGSL path.
fn split_times(batch: &mut GpuBatch, row: &mut Row) -> anyhow::Result<()> {
    let substeps = batch.substeps();
    let reps = 3;
    row.fluid_s = time_median(reps, || {
        Ok(batch.run_stages(&[Stage::Advect], 0, substeps)?)
    })?;
    row.pressure_s = time_median(reps, || {
        Ok(batch.run_stages(
            &[Stage::PressureRhs, Stage::PressureSolve, Stage::Project],
            0,
            substeps,
        )?)
    })?;
    row.swarm_s = if batch.n_members() > 0 {
        time_median(reps, || {
            Ok(batch.run_stages(&[Stage::PaintBodies, Stage::MoveMembers], 0, substeps)?)
        })?
    } else {
        0.0
    };
    row.readback_s = time_median(reps, || {
        batch.health()?;
        Ok(())
    })?;
    row.kernels = kernel_times(batch)?;
    row.dispatches = batch.dispatches_per_substep();
    Ok(())
}

/// Per-kernel GPU times of one control step (median of three timestamped steps) with each
/// kernel's dispatch count and bytes per control step; empty without timestamp support.
fn kernel_times(batch: &mut GpuBatch) -> anyhow::Result<Vec<(String, u32, f64, u64)>> {
    let mut runs = Vec::new();
    for _ in 0..3 {
        match batch.profile_step()? {
            Some(t) => runs.push(t),
            None => return Ok(Vec::new()),
        }
    }
    let bytes = batch.bytes_per_dispatch();
    Ok(runs[0]
        .iter()
        .enumerate()
        .map(|(k, (name, count, _))| {
            let t = median(runs.iter().map(|r| r[k].2).collect());
            let b = bytes
                .iter()
                .find(|(e, _)| e == name)
                .map_or(0, |(_, b)| *b * *count as u64);
            (name.to_string(), *count, t, b)
        })
        .collect())
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    let resolved = args.common.load()?;
    if args.envs.is_empty() || args.envs.contains(&0) {
        bail!("--envs needs positive batch sizes, e.g. --envs 1,4,16,64");
    }
    let out = run_dir::prepare(
        &args
            .out
            .clone()
            .unwrap_or_else(|| run_dir::default_dir("bench")),
        &[],
    )?;
    let c = &resolved.config;
    println!(
        "bench: {} x {} grid, {} substeps per control step, {:?} advection, solver.backend = {}",
        c.domain.nx, c.domain.ny, c.time.substeps, c.solver.advection, c.solver.backend
    );
    let native = c.solver.backend == fluxswarm_gpu::config::Backend::Native;
    let mut peaks = if native {
        bench_cpu::measure_peaks(args.peak_seconds, args.triad_mib)
    } else {
        None
    };
    println!(
        "{:>5} {:>14} {:>12} {:>10} {:>9} {:>10} {:>11} {:>11} {:>11} {:>11} {:>11}",
        "envs",
        "env_steps/s",
        "Mcell/s",
        "disp/sub",
        "p_iters",
        "residual",
        "step_s",
        "fluid_s",
        "pressure_s",
        "swarm_s",
        "readback_s"
    );
    let mut csv = std::fs::File::create(out.join("bench.csv")).context("creating bench.csv")?;
    writeln!(csv, "{}", fluxswarm_gpu::output::tables::BENCH_COLUMNS)?;
    let mut rows = Vec::new();
    let mut adapter = String::new();
    for &envs in &args.envs {
        let (r, runs_on) = bench_one(&args, &resolved, envs)?;
        adapter = runs_on;
        println!(
            "{:>5} {:>14.2} {:>12.1} {:>10} {:>9} {:>10.2e} {:>11.4} {:>11.4} {:>11.4} {:>11.4} {:>11.4}",
            r.envs,
            r.env_steps_per_s,
            r.cell_updates_per_s / 1e6,
            r.dispatches,
            PRESSURE_ITERATIONS_PER_SUBSTEP,
            r.residual,
            r.step_s,
            r.fluid_s,
            r.pressure_s,
            r.swarm_s,
            r.readback_s
        );
        writeln!(
            csv,
            "{},{:.4},{:.4e},{},{},{:.6},{:.6},{:.6},{:.6},\"{}\"",
            r.envs,
            r.env_steps_per_s,
            r.cell_updates_per_s,
            r.dispatches,
            PRESSURE_ITERATIONS_PER_SUBSTEP,
            r.fluid_s,
            r.pressure_s,
            r.swarm_s,
            r.readback_s,
            adapter.replace('"', "'")
        )?;
        csv.flush()?;
        rows.push(r);
    }
    if rows.iter().any(|r| r.dispatches > 0) {
        write_kernel_table(&out, &rows, &adapter)?;
    }
    let profiles: Vec<CpuProfile> = rows.iter_mut().filter_map(|r| r.cpu.take()).collect();
    if !profiles.is_empty() {
        if peaks.is_none() && !native {
            // `auto` fell back to the CPU backend: measure the peaks now.
            peaks = bench_cpu::measure_peaks(args.peak_seconds, args.triad_mib);
        }
        bench_cpu::write_tables(&out, &profiles, peaks.as_ref())?;
    }
    if args.native {
        write_native_table(&args, &resolved, &out, &rows, &adapter)?;
    }
    println!("{}", out.display());
    Ok(())
}

/// Median control-step time of the CPU backend with `envs` environments, from the same
/// state as the main runs (developed Poiseuille flow, members at rest).
fn native_step_s(
    args: &BenchArgs,
    resolved: &fluxswarm_gpu::config::Resolved,
    envs: usize,
) -> anyhow::Result<f64> {
    let mut batch = CpuBatch::new(resolved, envs)?;
    batch.step()?; // warm-up: first touches of the scratch
    Ok(timed_steps(args.seconds, || Ok(batch.step()?))?.0)
}

/// Times the native yardstick at every batch size, prints it beside the adapter's rate and
/// writes `native.csv`: envs,native_env_steps_per_s,adapter_env_steps_per_s,native_over_adapter,
/// threads,adapter.
fn write_native_table(
    args: &BenchArgs,
    resolved: &fluxswarm_gpu::config::Resolved,
    out: &std::path::Path,
    rows: &[Row],
    adapter: &str,
) -> anyhow::Result<()> {
    let threads = rayon::current_num_threads();
    println!(
        "\nCPU backend (sim::cpu, {threads} threads, one environment per task) beside the runs above"
    );
    println!(
        "{:>5} {:>20} {:>21} {:>14}",
        "envs", "native env_steps/s", "adapter env_steps/s", "native/adapter"
    );
    let mut csv = std::fs::File::create(out.join("native.csv")).context("creating native.csv")?;
    writeln!(
        csv,
        "envs,native_env_steps_per_s,adapter_env_steps_per_s,native_over_adapter,threads,adapter"
    )?;
    for r in rows {
        let native = r.envs as f64 / native_step_s(args, resolved, r.envs)?;
        let ratio = native / r.env_steps_per_s;
        println!(
            "{:>5} {:>20.2} {:>21.2} {:>14.2}",
            r.envs, native, r.env_steps_per_s, ratio
        );
        writeln!(
            csv,
            "{},{:.4},{:.4},{:.4},{threads},\"{}\"",
            r.envs,
            native,
            r.env_steps_per_s,
            ratio,
            adapter.replace('"', "'")
        )?;
        csv.flush()?;
    }
    Ok(())
}

/// Prints the per-kernel table and writes `kernels.csv`
/// (`envs,kernel,dispatches_per_step,gpu_s_per_step,share,bytes_per_step,gb_per_s,adapter`).
fn write_kernel_table(out: &std::path::Path, rows: &[Row], adapter: &str) -> anyhow::Result<()> {
    if rows.iter().all(|r| r.kernels.is_empty()) {
        println!(
            "per-kernel times: this adapter has no timestamps inside passes (see the time split above)"
        );
        return Ok(());
    }
    let mut csv = std::fs::File::create(out.join("kernels.csv")).context("creating kernels.csv")?;
    writeln!(
        csv,
        "envs,kernel,dispatches_per_step,gpu_s_per_step,share,bytes_per_step,gb_per_s,adapter"
    )?;
    for r in rows {
        let total: f64 = r.kernels.iter().map(|k| k.2).sum();
        println!(
            "\nkernels at E = {} (GPU timestamps, one control step; sum {:.4} s of a {:.4} s step)",
            r.envs, total, r.step_s
        );
        println!(
            "{:>20} {:>8} {:>10} {:>7} {:>12} {:>8}",
            "kernel", "per_step", "s/step", "share", "MB/step", "GB/s"
        );
        for (name, n, t, bytes) in &r.kernels {
            let gbs = *bytes as f64 / t.max(1e-12) / 1e9;
            println!(
                "{:>20} {:>8} {:>10.4} {:>6.1}% {:>12.1} {:>8.2}",
                name,
                n,
                t,
                100.0 * t / total.max(1e-12),
                *bytes as f64 / 1e6,
                gbs
            );
            writeln!(
                csv,
                "{},{},{},{:.6},{:.4},{},{:.3},\"{}\"",
                r.envs,
                name,
                n,
                t,
                t / total.max(1e-12),
                bytes,
                gbs,
                adapter.replace('"', "'")
            )?;
        }
        let bytes: u64 = r.kernels.iter().map(|k| k.3).sum();
        println!(
            "{:>20} {:>8} {:>10.4} {:>7} {:>12.1} {:>8.2}",
            "all",
            r.kernels.iter().map(|k| k.1).sum::<u32>(),
            total,
            "",
            bytes as f64 / 1e6,
            bytes as f64 / total.max(1e-12) / 1e9
        );
    }
    Ok(())
}

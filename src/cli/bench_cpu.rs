//! `bench` on the CPU backend: the control step's time per stage (each environment's stages
//! timed and summed over the environments: CPU time, `CpuBatch::profile_step`) and the
//! roofline: flops and bytes per cell per substep counted from the stages' code
//! (`sim::cpu::counts`), the rates achieved over the untimed step's wall time, and their
//! fractions of this machine's peaks (`roofline::Peaks`, measured here). Prints both and
//! writes `stages.csv` and `roofline.csv` (docs/cli.md).

use std::io::Write;
use std::path::Path;
use std::time::Instant;

use anyhow::Context;
use fluxswarm_gpu::config::Resolved;
use fluxswarm_gpu::roofline::{PeakSizes, Peaks};
use fluxswarm_gpu::sim::cpu::{BodyLoad, CpuStage, StageWork};
use fluxswarm_gpu::sim::{CpuBatch, FlowBatch};

/// The CPU step at one batch size: stage times and counted work per control step.
pub struct CpuProfile {
    pub envs: usize,
    pub threads: usize,
    /// Median wall time of an untimed control step (the bench row's).
    pub step_s: f64,
    /// Profiled control steps and their mean wall time.
    pub profiled_steps: usize,
    pub profiled_wall_s: f64,
    /// CPU seconds per control step in each stage, summed over the environments.
    pub cpu_s: [f64; CpuStage::COUNT],
    /// Work per control step, summed over the environments.
    pub work: StageWork,
    /// Cells x substeps x environments of one control step.
    pub cell_substeps: u64,
    pub members: usize,
    pub substeps: usize,
}

/// Profiles the CPU step of `batch` (a native batch) from its present state and clock, on a
/// copy: at least three control steps and about `seconds` / 3; `step_s` is the untimed median.
pub fn profile(
    resolved: &Resolved,
    batch: &dyn FlowBatch,
    step_s: f64,
    seconds: f64,
) -> anyhow::Result<CpuProfile> {
    let envs = batch.n_env();
    let mut cpu = CpuBatch::new(resolved, envs)?;
    cpu.set_state(&batch.state()?, batch.member_forces())?;
    *cpu.core_mut() = batch.core().clone();
    cpu.profile_step()?; // warm-up: this copy's scratch
    let mut cpu_s = [0.0; CpuStage::COUNT];
    let (start, mut steps) = (Instant::now(), 0usize);
    while steps < 3 || start.elapsed().as_secs_f64() < seconds / 3.0 {
        let (_, t) = cpu.profile_step()?;
        for s in CpuStage::ALL {
            cpu_s[s.index()] += t.seconds(s);
        }
        steps += 1;
    }
    let profiled_wall_s = start.elapsed().as_secs_f64() / steps as f64;
    cpu_s.iter_mut().for_each(|t| *t /= steps as f64);
    let state = cpu.state_ref();
    let mut work = StageWork::default();
    for e in 0..envs {
        let load = BodyLoad::of(state, e);
        work += StageWork::control_step(&state.params, state.scheme, &load);
    }
    let p = &state.params;
    Ok(CpuProfile {
        envs,
        threads: rayon::current_num_threads(),
        step_s,
        profiled_steps: steps,
        profiled_wall_s,
        cpu_s,
        work,
        cell_substeps: (p.nx * p.ny * p.substeps) as u64 * envs as u64,
        members: p.n_members as usize,
        substeps: p.substeps as usize,
    })
}

impl CpuProfile {
    fn total_cpu_s(&self) -> f64 {
        self.cpu_s.iter().sum::<f64>().max(1e-12)
    }

    /// Each stage's share of the CPU time.
    pub fn share(&self, s: CpuStage) -> f64 {
        self.cpu_s[s.index()] / self.total_cpu_s()
    }

    /// The untimed step's wall time split by the stages' shares, in bench.csv's groups:
    /// (fluid = advect, pressure = rhs + solve + back + project, swarm = paint + move,
    /// read-back = diagnostics).
    pub fn split(&self) -> (f64, f64, f64, f64) {
        use CpuStage::*;
        let wall = |stages: &[CpuStage]| stages.iter().map(|&s| self.share(s)).sum::<f64>();
        (
            self.step_s * wall(&[Advect]),
            self.step_s * wall(&[PressureRhs, PressureSolve, PressureBack, Project]),
            self.step_s * wall(&[Paint, Move]),
            self.step_s * wall(&[Diagnostics]),
        )
    }

    fn per_cell(&self, x: u64) -> f64 {
        x as f64 / self.cell_substeps.max(1) as f64
    }
}

/// This machine's peaks, unless `seconds` is 0; says what it measures.
pub fn measure_peaks(seconds: f64, triad_mib: usize) -> Option<Peaks> {
    if seconds <= 0.0 {
        return None;
    }
    let sizes = PeakSizes {
        out_of_cache_array: triad_mib << 20,
        seconds,
        ..PeakSizes::default()
    };
    let peaks = Peaks::measure(sizes);
    let fma: Vec<String> = peaks
        .fma
        .iter()
        .map(|(k, g)| format!("{} {g:.1}", k.name()))
        .collect();
    println!(
        "machine peaks on {} threads (measured now, {seconds} s each): FMA GFlop/s: {}; triad ({}) GB/s: {:.1} in cache (3 x {} KiB a thread), {:.1} out of cache (3 x {} MiB in all)",
        peaks.threads,
        fma.join(", "),
        peaks.triad_kernel,
        peaks.triad_in_cache,
        sizes.in_cache_array >> 10,
        peaks.triad_out_of_cache,
        sizes.out_of_cache_array >> 20,
    );
    Some(peaks)
}

/// Prints the stage table and roofline line of every profile and writes `stages.csv`
/// (`envs,stage,cpu_s_per_control_step,share,wall_s_per_control_step,flops_per_cell_substep,
/// bytes_per_cell_substep,gflop_per_cpu_s,gb_per_cpu_s`) and `roofline.csv`.
pub fn write_tables(
    out: &Path,
    profiles: &[CpuProfile],
    peaks: Option<&Peaks>,
) -> anyhow::Result<()> {
    let mut stages =
        std::fs::File::create(out.join("stages.csv")).context("creating stages.csv")?;
    writeln!(
        stages,
        "envs,stage,cpu_s_per_control_step,share,wall_s_per_control_step,flops_per_cell_substep,bytes_per_cell_substep,gflop_per_cpu_s,gb_per_cpu_s"
    )?;
    let mut roof =
        std::fs::File::create(out.join("roofline.csv")).context("creating roofline.csv")?;
    writeln!(
        roof,
        "envs,threads,flops_per_cell_substep,bytes_per_cell_substep,gflop_per_s,gb_per_s,peak_gflop_per_s,peak_kernel,portable_peak_gflop_per_s,triad_in_cache_gb_per_s,triad_out_of_cache_gb_per_s,frac_peak_flops,frac_portable_flops,frac_in_cache_bw,frac_out_of_cache_bw"
    )?;
    for p in profiles {
        stage_table(&mut stages, p)?;
        roofline_line(&mut roof, p, peaks)?;
    }
    Ok(())
}

fn stage_table(csv: &mut impl Write, p: &CpuProfile) -> anyhow::Result<()> {
    println!(
        "\nCPU stages at E = {} ({} threads; CPU seconds summed over the environments, mean of {} timed steps of {:.4} s wall; untimed step {:.4} s)",
        p.envs, p.threads, p.profiled_steps, p.profiled_wall_s, p.step_s
    );
    println!(
        "{:>15} {:>11} {:>7} {:>11} {:>10} {:>10} {:>11} {:>9}",
        "stage",
        "cpu_s/step",
        "share",
        "wall_s/step",
        "flop/cell",
        "B/cell",
        "GFlop/cpu-s",
        "GB/cpu-s"
    );
    let mut row = |name: &str,
                   cpu_s: f64,
                   share: f64,
                   flops: u64,
                   bytes: u64|
     -> anyhow::Result<()> {
        let (gf, gb) = (
            flops as f64 / cpu_s.max(1e-12) / 1e9,
            bytes as f64 / cpu_s.max(1e-12) / 1e9,
        );
        let (fc, bc) = (p.per_cell(flops), p.per_cell(bytes));
        println!(
            "{name:>15} {cpu_s:>11.5} {:>6.1}% {:>11.5} {fc:>10.2} {bc:>10.2} {gf:>11.2} {gb:>9.2}",
            100.0 * share,
            share * p.step_s
        );
        writeln!(
            csv,
            "{},{name},{cpu_s:.6},{share:.4},{:.6},{fc:.3},{bc:.3},{gf:.3},{gb:.3}",
            p.envs,
            share * p.step_s
        )?;
        Ok(())
    };
    for s in CpuStage::ALL {
        let w = p.work[s];
        row(s.name(), p.cpu_s[s.index()], p.share(s), w.flops, w.bytes())?;
    }
    let w = p.work.total();
    row("all", p.total_cpu_s(), 1.0, w.flops, w.bytes())?;
    if p.members > 0 {
        let per = (p.envs * p.members * p.substeps) as f64;
        let (paint, mv) = (p.work[CpuStage::Paint], p.work[CpuStage::Move]);
        println!(
            "{:>15} paint {:.0} flop, move {:.0} flop and {:.0} B per member per substep",
            "members:",
            paint.flops as f64 / per,
            mv.flops as f64 / per,
            mv.bytes() as f64 / per
        );
    }
    Ok(())
}

fn roofline_line(
    csv: &mut impl Write,
    p: &CpuProfile,
    peaks: Option<&Peaks>,
) -> anyhow::Result<()> {
    let w = p.work.total();
    let (fc, bc) = (p.per_cell(w.flops), p.per_cell(w.bytes()));
    let gflops = w.flops as f64 / p.step_s / 1e9;
    let gbs = w.bytes() as f64 / p.step_s / 1e9;
    let mut line = format!(
        "roofline at E = {}: {fc:.1} flop and {bc:.1} B per cell per substep ({:.2} flop/B); achieved {gflops:.2} GFlop/s, {gbs:.2} GB/s",
        p.envs,
        fc / bc.max(1e-12)
    );
    let fields = match peaks {
        Some(pk) => {
            let (kernel, peak) = pk.best_fma();
            let portable = pk.portable_fma();
            let f = |x: f64, of: f64| x / of.max(1e-12);
            line += &format!(
                " = {:.1} % of the {peak:.1} GFlop/s {} peak ({:.1} % of the portable loop's {portable:.1}), {:.1} % of the in-cache triad's {:.1} GB/s, {:.1} % of the out-of-cache triad's {:.1} GB/s",
                100.0 * f(gflops, peak),
                kernel.name(),
                100.0 * f(gflops, portable),
                100.0 * f(gbs, pk.triad_in_cache),
                pk.triad_in_cache,
                100.0 * f(gbs, pk.triad_out_of_cache),
                pk.triad_out_of_cache
            );
            format!(
                "{peak:.3},\"{}\",{portable:.3},{:.3},{:.3},{:.5},{:.5},{:.5},{:.5}",
                kernel.name(),
                pk.triad_in_cache,
                pk.triad_out_of_cache,
                f(gflops, peak),
                f(gflops, portable),
                f(gbs, pk.triad_in_cache),
                f(gbs, pk.triad_out_of_cache)
            )
        }
        None => {
            line += " (peaks not measured: --peak-seconds 0)";
            ",,,,,,,,".to_string()
        }
    };
    println!("{line}");
    writeln!(
        csv,
        "{},{},{fc:.3},{bc:.3},{gflops:.4},{gbs:.4},{fields}",
        p.envs, p.threads
    )?;
    Ok(())
}

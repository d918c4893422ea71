//! `fluxswarm-gpu simulate`: runs the flow of E environments and writes (SPEC section 7)
//! `frames/env0_s<step>.png`, `fields/{ux,uy,p}_<step>.npy`, `summary.csv` and `config.toml`.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::config::Resolved;
use fluxswarm_gpu::output::frame::MemberMark;
use fluxswarm_gpu::output::{frame, npy, run_dir};
use fluxswarm_gpu::sim::{EnvHealth, FlowBatch, fluid::PRESSURE_ITERATIONS_PER_SUBSTEP};

use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// Number of environments simulated together.
    #[arg(long, default_value_t = 1)]
    pub envs: usize,
    /// Simulated time (s).
    #[arg(long, default_value_t = 1.0)]
    pub seconds: f64,
    /// Output directory (default runs/simulate-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a frame every K control steps (0: none).
    #[arg(long, default_value_t = 20, value_name = "K")]
    pub frames_every: u64,
    /// Write u_x, u_y, p fields every K control steps (default: none).
    #[arg(long, value_name = "K")]
    pub fields_every: Option<u64>,
    /// Environment whose fields are written.
    #[arg(long, default_value_t = 0)]
    pub env: usize,
    /// Run the flow without the swarm (same as `--set swarm.count=0`).
    #[arg(long)]
    pub no_swarm: bool,
    /// Also write `animation.gif` of the frames (640 px wide, for a README).
    #[arg(long)]
    pub gif: bool,
}

pub fn run(mut args: SimulateArgs) -> anyhow::Result<()> {
    if args.no_swarm {
        args.common.sets.push("swarm.count=0".into());
    }
    let resolved = args.common.load()?;
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        bail!(
            "--seconds {} must be a positive number of simulated seconds",
            args.seconds
        );
    }
    if args.env >= args.envs {
        bail!(
            "--env {} is outside the batch of --envs {}",
            args.env,
            args.envs
        );
    }
    if args.gif && args.frames_every == 0 {
        bail!("--gif animates the frames: give --frames-every K with K > 0");
    }
    if args.fields_every == Some(0) {
        bail!(
            "--fields-every 0: give a positive number of control steps, or leave it out for no fields"
        );
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| run_dir::default_dir("simulate"));
    let mut subdirs = vec![];
    if args.frames_every > 0 {
        subdirs.push("frames");
    }
    if args.fields_every.is_some() {
        subdirs.push("fields");
    }
    let out = run_dir::prepare(&out, &subdirs)?;
    std::fs::write(out.join("config.toml"), resolved.config.to_toml())
        .context("writing config.toml")?;

    let mut batch = args.common.open_batch(&resolved, args.envs)?.batch;
    let steps = (args.seconds / resolved.config.time.control_dt_s)
        .round()
        .max(1.0) as u64;
    log::info!(
        "simulating {} s ({steps} control steps x {} substeps) of {} environment(s) at {} x {}, {:?} advection",
        args.seconds,
        resolved.config.time.substeps,
        args.envs,
        resolved.config.domain.nx,
        resolved.config.domain.ny,
        resolved.config.solver.advection,
    );
    let mut writer = Writer::new(&out, &args, &resolved)?;
    let health = batch.health()?;
    writer.record(batch.as_ref(), 0, &health[args.env])?;

    let stop = super::signals::Stop::install("stopping after this step, keeping what was written");
    let mut bar = super::progress::Progress::new("simulate", "steps", steps, 0);
    let start = Instant::now();
    let mut done = 0;
    for step in (1..=steps).take_while(|_| !stop.requested()) {
        let health = batch.step()?;
        writer.record(batch.as_ref(), step, &health[args.env])?;
        for (e, h) in health.iter().enumerate() {
            if h.diverged() {
                bar.abandon();
                bail!(
                    "environment {e} diverged at step {step} (t = {:.3} s): {} non-finite values, \
                     max |u| = {} m/s. Outputs so far are in {}",
                    batch.time_s(e),
                    h.nonfinite,
                    h.max_speed,
                    out.display()
                );
            }
        }
        let sim_s = step as f64 * resolved.config.time.control_dt_s;
        let rate = sim_s / start.elapsed().as_secs_f64();
        bar.set(step, format!("{rate:.4} sim-s/s"));
        done = step;
    }
    bar.finish();
    writer.finish()?;
    let wall = start.elapsed().as_secs_f64();
    log::info!(
        "{done} control steps in {wall:.1} s: {:.2} environment steps/s",
        (done as f64 * args.envs as f64) / wall
    );
    if let Some(signal) = stop.signal().filter(|_| done < steps) {
        let what = format!("{done} of {steps} control steps written");
        return Err(super::signals::Stopped::new(signal, &what, &out).into());
    }
    if args.gif {
        super::common::write_gif(&out, &format!("env{}_s", args.env), Default::default())?;
    }
    println!("{}", out.display());
    Ok(())
}

struct Writer<'a> {
    out: &'a Path,
    args: &'a SimulateArgs,
    resolved: &'a Resolved,
    summary: std::io::BufWriter<std::fs::File>,
    v_range: (f64, f64),
}

impl<'a> Writer<'a> {
    fn new(out: &'a Path, args: &'a SimulateArgs, resolved: &'a Resolved) -> anyhow::Result<Self> {
        let file =
            std::fs::File::create(out.join("summary.csv")).context("creating summary.csv")?;
        let mut summary = std::io::BufWriter::new(file);
        writeln!(
            summary,
            "{}",
            fluxswarm_gpu::output::tables::SUMMARY_COLUMNS
        )?;
        // Fixed colour range for comparable frames: the waveform's extremes with headroom.
        let v_range = frame::velocity_range(resolved.waveform.points());
        Ok(Self {
            out,
            args,
            resolved,
            summary,
            v_range,
        })
    }

    fn record(&mut self, batch: &dyn FlowBatch, step: u64, h: &EnvHealth) -> anyhow::Result<()> {
        let e = self.args.env;
        writeln!(
            self.summary,
            "{step},{:.6},{:.6e},{:.6e},{:.6e},{:.6e},{},{:.3e}",
            batch.time_s(e),
            batch.inlet_u(e),
            h.max_div,
            h.flux_min,
            h.flux_max,
            if step == 0 {
                0
            } else {
                PRESSURE_ITERATIONS_PER_SUBSTEP
            },
            h.residual()
        )?;
        let frame_due = self.args.frames_every > 0 && step.is_multiple_of(self.args.frames_every);
        let fields_due = self
            .args
            .fields_every
            .is_some_and(|k| step.is_multiple_of(k));
        if !frame_due && !fields_due {
            return Ok(());
        }
        let fields = batch.fields(e)?;
        let ux = fields.ux_cells();
        let (nx, ny) = (fields.nx, fields.ny);
        if frame_due {
            let n = batch.n_members();
            let f_max = self.resolved.config.swarm.max_thrust_n;
            let marks: Vec<MemberMark> = batch
                .members()
                .iter()
                .zip(batch.member_forces())
                .skip(e * n)
                .take(n)
                .map(|(m, d)| MemberMark::new(m.pos, d.prop, f_max))
                .collect();
            let d = &self.resolved.config.domain;
            let path = self
                .out
                .join("frames")
                .join(format!("env{e}_s{step:06}.png"));
            frame::write(
                &path,
                &frame::FrameSpec {
                    ux: &ux,
                    nx,
                    ny,
                    length_m: d.length_m,
                    height_m: d.height_m,
                    x_min_m: d.success_x_m,
                    x_max_m: d.failure_x_m,
                    v_min: self.v_range.0,
                    v_max: self.v_range.1,
                    time_s: batch.time_s(e),
                    inlet_u_m_s: batch.inlet_u(e),
                    env: e,
                    members: &marks,
                    radius_m: self.resolved.config.swarm.radius_m,
                },
            )
            .with_context(|| format!("writing {}", path.display()))?;
        }
        if fields_due {
            let dir = self.out.join("fields");
            for (name, data) in [("ux", &ux), ("uy", &fields.uy_cells()), ("p", &fields.p)] {
                let path = dir.join(format!("{name}_{step:06}.npy"));
                npy::write_field(&path, ny, nx, data)
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
        Ok(())
    }

    fn finish(mut self) -> anyhow::Result<()> {
        self.summary.flush()?;
        Ok(())
    }
}

//! The [`Recorder`] behind `rollout` and `eval`: `episodes.csv`, `starts.csv`, `swarm.csv` and
//! `trajectories.csv` (SPEC section 7; the schemas are in [`crate::output::episodes`] and
//! [`crate::output::traces`]), optionally `gap.csv` (the flow past the swarm,
//! [`crate::sim::gap`]) and frames of environment 0
//! (`frames/env0_ep<episode:04>_s<step:06>.png`). Both read the flow fields, which are the next
//! episode's at an episode's last step (the environment has reset): they skip that step.

use std::path::{Path, PathBuf};

use super::{Recorder, RolloutError, StepView};
use crate::env::{SwarmEnv, reward};
use crate::gpu::params::{GpuMember, GpuMemberDiag};
use crate::learn::transition::EpisodeSummary;
use crate::output::episodes::EpisodesCsv;
use crate::output::frame::{self, MemberMark};
use crate::output::traces::{self, GapCsv, RowKey, StartsCsv, SwarmCsv, TrajectoriesCsv};
use crate::sim::gap;

/// What [`RolloutFiles`] writes besides `episodes.csv` and `starts.csv`.
#[derive(Debug, Clone, Copy)]
pub struct FileOptions {
    /// Also `swarm.csv` and `trajectories.csv`.
    pub traces: bool,
    /// Also `gap.csv`: a read-back of each environment's u_x field every step.
    pub gap: bool,
    /// A frame of environment 0 every K control steps (0: none; needs `frames/` in the
    /// output directory).
    pub frames_every: u64,
}

/// Writes a rollout into a directory.
pub struct RolloutFiles {
    out: PathBuf,
    options: FileOptions,
    episodes: EpisodesCsv,
    starts: StartsCsv,
    traces: Option<(SwarmCsv, TrajectoriesCsv)>,
    gap: Option<GapCsv>,
}

fn write_err(what: &str) -> impl FnOnce(std::io::Error) -> RolloutError + '_ {
    move |source| RolloutError::Write {
        what: what.to_string(),
        source,
    }
}

impl RolloutFiles {
    /// Creates the tables in `out` (an existing directory).
    pub fn create(out: &Path, options: FileOptions) -> Result<Self, RolloutError> {
        let traces = if options.traces {
            Some((
                SwarmCsv::create(out).map_err(write_err("swarm.csv"))?,
                TrajectoriesCsv::create(out).map_err(write_err("trajectories.csv"))?,
            ))
        } else {
            None
        };
        Ok(Self {
            out: out.to_path_buf(),
            options,
            episodes: EpisodesCsv::create(out, false).map_err(write_err("episodes.csv"))?,
            starts: StartsCsv::create(out).map_err(write_err("starts.csv"))?,
            traces,
            gap: if options.gap {
                Some(GapCsv::create(out).map_err(write_err("gap.csv"))?)
            } else {
                None
            },
        })
    }

    /// Writes what is buffered (`episodes.csv` is written row by row already).
    pub fn flush(&mut self) -> Result<(), RolloutError> {
        self.starts.flush().map_err(write_err("starts.csv"))?;
        if let Some((swarm, traj)) = &mut self.traces {
            swarm.flush().map_err(write_err("swarm.csv"))?;
            traj.flush().map_err(write_err("trajectories.csv"))?;
        }
        if let Some(gap) = &mut self.gap {
            gap.flush().map_err(write_err("gap.csv"))?;
        }
        Ok(())
    }

    fn gap(&mut self, env: &SwarmEnv, view: &StepView) -> Result<(), RolloutError> {
        let Some(csv) = &mut self.gap else {
            return Ok(());
        };
        if view.last {
            return Ok(());
        }
        let batch = env.batch();
        let ux = batch.fields(view.env)?.ux_cells();
        let centres: Vec<[f64; 2]> = view
            .members
            .iter()
            .map(|m| [m.pos[0] as f64, m.pos[1] as f64])
            .collect();
        let c = &env.resolved().config;
        let metrics = gap::gap_metrics(batch.grid(), &ux, &centres, c.swarm.radius_m);
        let at = RowKey {
            env: view.env,
            episode: view.episode,
            step: view.step,
        };
        let t_s = view.step as f64 * c.time.control_dt_s;
        csv.write(at, t_s, view.inlet_u_m_s, &metrics)
            .map_err(write_err("gap.csv"))
    }

    fn trace(&mut self, env: &SwarmEnv, view: &StepView) -> Result<(), RolloutError> {
        let Some((swarm, traj)) = &mut self.traces else {
            return Ok(());
        };
        let at = RowKey {
            env: view.env,
            episode: view.episode,
            step: view.step,
        };
        let pos: Vec<[f64; 2]> = view.members.iter().map(traces::position_mm).collect();
        let t_s = view.step as f64 * env.resolved().config.time.control_dt_s;
        swarm
            .write(at, t_s, view.inlet_u_m_s, reward::swarm_metrics(&pos))
            .map_err(write_err("swarm.csv"))?;
        traj.write(at, view.members, view.forces, view.actions)
            .map_err(write_err("trajectories.csv"))
    }

    fn frame(&self, env: &SwarmEnv, view: &StepView) -> Result<(), RolloutError> {
        let path = self
            .out
            .join("frames")
            .join(format!("env0_ep{:04}_s{:06}.png", view.episode, view.step));
        write_frame(env, &path, view.step, view.members, view.forces)
    }
}

impl Recorder for RolloutFiles {
    fn start(&mut self, env: &SwarmEnv, e: usize, episode: u64) -> Result<(), RolloutError> {
        let n = env.n_agents();
        let batch = env.batch();
        let inlet = batch.inlet_u(e);
        let members = batch.members()[e * n..(e + 1) * n].to_vec();
        let x_com = members.iter().map(|m| m.pos[0] as f64).sum::<f64>() / n as f64 * 1e3;
        self.starts
            .write(e, episode, batch.phase_s(e), inlet, x_com)
            .map_err(write_err("starts.csv"))?;
        let view = StepView {
            env: e,
            episode,
            step: 0,
            inlet_u_m_s: inlet,
            members: &members,
            forces: &vec![GpuMemberDiag::default(); n],
            actions: &vec![[0.0f32; 2]; n],
            last: false,
        };
        self.trace(env, &view)?;
        self.gap(env, &view)?;
        if e == 0 && self.options.frames_every > 0 {
            self.frame(env, &view)?;
        }
        Ok(())
    }

    fn step(&mut self, env: &SwarmEnv, view: &StepView) -> Result<(), RolloutError> {
        self.trace(env, view)?;
        self.gap(env, view)?;
        let every = self.options.frames_every;
        let due = every > 0 && (view.step as u64).is_multiple_of(every);
        if view.env == 0 && due && !view.last {
            self.frame(env, view)?;
        }
        Ok(())
    }

    fn finish(&mut self, summary: &EpisodeSummary) -> Result<(), RolloutError> {
        self.episodes
            .write(0, summary)
            .map_err(write_err("episodes.csv"))
    }
}

/// A frame of environment 0 of `env` at control step `step` of its episode, written to `path`.
fn write_frame(
    env: &SwarmEnv,
    path: &Path,
    step: u32,
    members: &[GpuMember],
    forces: &[GpuMemberDiag],
) -> Result<(), RolloutError> {
    render_frame(env, 0, step, members, forces)?
        .save(path)
        .map_err(|source| RolloutError::Frame {
            path: path.to_path_buf(),
            source,
        })
}

/// The frame of environment `e` of `env` at control step `step` of its episode: the u_x
/// field, the members (`members`, `forces`: `[N]`) and their thrust, as an RGB image.
pub fn render_frame(
    env: &SwarmEnv,
    e: usize,
    step: u32,
    members: &[GpuMember],
    forces: &[GpuMemberDiag],
) -> Result<image::RgbImage, RolloutError> {
    let resolved = env.resolved();
    let c = &resolved.config;
    let d = &c.domain;
    let fields = env.batch().fields(e)?;
    let marks: Vec<MemberMark> = members
        .iter()
        .zip(forces)
        .map(|(m, f)| MemberMark::new(m.pos, f.prop, c.swarm.max_thrust_n))
        .collect();
    let (v_min, v_max) = frame::velocity_range(resolved.waveform.points());
    let time_s = step as f64 * c.time.control_dt_s;
    Ok(frame::render(&frame::FrameSpec {
        ux: &fields.ux_cells(),
        nx: fields.nx,
        ny: fields.ny,
        length_m: d.length_m,
        height_m: d.height_m,
        x_min_m: d.success_x_m,
        x_max_m: d.failure_x_m,
        v_min,
        v_max,
        time_s,
        // The inlet now: the waveform at the environment's phase (random with
        // `inlet.random_phase`), not at the time since the episode's start.
        inlet_u_m_s: env.batch().inlet_u(e),
        env: e,
        members: &marks,
        radius_m: c.swarm.radius_m,
    }))
}

//! The rollout runner that `rollout`, `eval`, experiments and the Python package share: a
//! [`Policy`] (a non-learned controller or a trained actor) acts in a [`SwarmEnv`] of E
//! environments until K episodes have finished, and a [`Recorder`] sees every episode start,
//! every step and every finished episode ([`files::RolloutFiles`] writes them as SPEC section
//! 7's files).
//!
//! K episodes over E environments are collected as a quota per environment (the first
//! ceil(K/E) or floor(K/E) episodes each environment finishes, [`quota`]), so that long
//! episodes are not under-counted: taking the first K to finish over all environments would
//! favour short ones.

pub mod files;
mod policy;

pub use policy::{CustomPolicy, Policy};

use crate::checkpoint::CheckpointError;
use crate::config::ConfigError;
use crate::env::SwarmEnv;
use crate::gpu::params::{GpuMember, GpuMemberDiag};
use crate::learn::LearnError;
use crate::learn::transition::EpisodeSummary;
use crate::sim::SimError;

/// An error of a rollout: its policy, its environment or its files.
#[derive(Debug, thiserror::Error)]
pub enum RolloutError {
    /// The policy is neither a controller's name nor a file.
    #[error("{0}, or the path of a trained checkpoint or policy file")]
    UnknownPolicy(String),
    /// The flow batch failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The trained policy failed to load or act.
    #[error(transparent)]
    Learn(#[from] LearnError),
    /// The checkpoint or policy file could not be read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The configuration saved with a trained policy is not valid.
    #[error("the configuration saved in {file}: {source}")]
    SavedConfig {
        /// The checkpoint or policy file.
        file: std::path::PathBuf,
        /// What is wrong with it.
        source: ConfigError,
    },
    /// An output file could not be written.
    #[error("writing {what}: {source}")]
    Write {
        /// The file.
        what: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// A frame could not be drawn or written.
    #[error("writing {path}: {source}")]
    Frame {
        /// The image file.
        path: std::path::PathBuf,
        /// The image error.
        source: image::ImageError,
    },
}

/// One environment's state after a step (or at an episode's start, step 0): what a
/// [`Recorder`] gets.
pub struct StepView<'a> {
    /// Environment index.
    pub env: usize,
    /// Episode index within the environment.
    pub episode: u64,
    /// Control step within the episode (0: its start).
    pub step: u32,
    /// Inlet centreline velocity (m/s) at the end of the step.
    pub inlet_u_m_s: f64,
    /// The environment's members `[N]` and the forces on them (zero at a start).
    pub members: &'a [GpuMember],
    /// Forces on the members `[N]`.
    pub forces: &'a [GpuMemberDiag],
    /// The actions `[N]` that led here (zero at a start).
    pub actions: &'a [[f32; 2]],
    /// The episode ended with this step. The environment has been reset since, so its flow
    /// fields are already the next episode's: a recorder that reads them skips this step.
    pub last: bool,
}

/// What a rollout reports as it goes.
pub trait Recorder {
    /// Episode `episode` of environment `e` starts (after the reset that placed its members).
    fn start(&mut self, env: &SwarmEnv, e: usize, episode: u64) -> Result<(), RolloutError>;
    /// One environment after a step of an episode that counts.
    fn step(&mut self, env: &SwarmEnv, view: &StepView) -> Result<(), RolloutError>;
    /// An episode that counts has finished.
    fn finish(&mut self, summary: &EpisodeSummary) -> Result<(), RolloutError>;
}

/// A recorder that records nothing (summaries come back from [`run`] anyway).
pub struct Discard;

impl Recorder for Discard {
    fn start(&mut self, _: &SwarmEnv, _: usize, _: u64) -> Result<(), RolloutError> {
        Ok(())
    }
    fn step(&mut self, _: &SwarmEnv, _: &StepView) -> Result<(), RolloutError> {
        Ok(())
    }
    fn finish(&mut self, _: &EpisodeSummary) -> Result<(), RolloutError> {
        Ok(())
    }
}

/// Each environment's share of `episodes`: floor(K/E), plus one for the first K mod E.
pub fn quota(episodes: u64, envs: usize) -> Vec<u64> {
    let e_n = envs as u64;
    (0..e_n)
        .map(|e| episodes / e_n + u64::from(e < episodes % e_n))
        .collect()
}

/// Where a rollout stands, for a progress display.
#[derive(Debug, Clone, Copy)]
pub struct Progress<'a> {
    /// Episodes finished (counted) so far.
    pub finished: u64,
    /// Environment steps so far (every environment, counted or not).
    pub env_steps: u64,
    /// The episode that finished last, if any.
    pub last: Option<&'a EpisodeSummary>,
}

/// What a rollout did.
#[derive(Debug, Clone, Default)]
pub struct RolloutStats {
    /// The finished episodes in the order they finished (each environment's quota).
    pub episodes: Vec<EpisodeSummary>,
    /// Environment steps taken (every environment, counted or not).
    pub env_steps: u64,
}

/// Runs `policy` in `env` (reset first) until `episodes` have finished over its environments
/// (each environment's [`quota`]), or until `stop()` says so between steps. The recorder sees
/// the starts, the steps and the ends of the episodes that count; `progress` is called after
/// every step.
pub fn run(
    env: &mut SwarmEnv,
    policy: &mut Policy,
    episodes: u64,
    recorder: &mut dyn Recorder,
    stop: &dyn Fn() -> bool,
    progress: &mut dyn FnMut(Progress),
) -> Result<RolloutStats, RolloutError> {
    let (n_env, n) = (env.n_env(), env.n_agents());
    let dt = env.resolved().config.time.control_dt_s;
    let quota = quota(episodes, n_env);
    let mut counted = vec![0u64; n_env];
    let mut stats = RolloutStats::default();
    let mut obs = env.reset()?;
    for (e, &q) in quota.iter().enumerate() {
        if q > 0 {
            recorder.start(env, e, 0)?;
        }
    }
    while (stats.episodes.len() as u64) < episodes && !stop() {
        let actions = policy.act_all(&obs, env)?;
        // Inlet velocity at the end of this step, taken before any environment resets.
        let inlet_after: Vec<f64> = (0..n_env)
            .map(|e| env.batch().inlet_u_after(e, dt))
            .collect();
        let step = env.step(&actions)?;
        stats.env_steps += n_env as u64;
        for e in 0..n_env {
            if counted[e] == quota[e] {
                continue;
            }
            let view = StepView {
                env: e,
                episode: step.episode[e],
                step: step.episode_step[e],
                inlet_u_m_s: inlet_after[e],
                members: &step.members[e * n..(e + 1) * n],
                forces: &step.forces[e * n..(e + 1) * n],
                actions: &actions[e * n..(e + 1) * n],
                last: step.episodes[e].is_some(),
            };
            recorder.step(env, &view)?;
            if let Some(s) = &step.episodes[e] {
                counted[e] += 1;
                recorder.finish(s)?;
                stats.episodes.push(s.clone());
                if counted[e] < quota[e] {
                    recorder.start(env, e, step.episode[e] + 1)?;
                }
            }
        }
        obs = step.transition.obs;
        progress(Progress {
            finished: stats.episodes.len() as u64,
            env_steps: stats.env_steps,
            last: stats.episodes.last(),
        });
    }
    Ok(stats)
}

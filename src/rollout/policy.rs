//! What chooses a rollout's actions: a non-learned controller ([`Controller`], with its own
//! RNG for `random`) or a trained actor loaded from a checkpoint or `policy.safetensors`
//! (sampled, or its mean action), or any function of the observations and the environments
//! ([`Policy::custom`]: a controller tried out before it gets a name, docs/extending.md).

use std::path::Path;

use super::RolloutError;
use crate::checkpoint::{self, Archive};
use crate::config::{Config, Resolved};
use crate::env::policy::{Controller, Scripted};
use crate::env::{GLOBAL_DIM, OBS_DIM, SwarmEnv};
use crate::learn::env::MultiAgentEnv;
use crate::learn::mappo::Learner;
use crate::rng::Rng;

/// A custom policy: actions `[E][N]` from observations `[E][N][8]` and the environments (which
/// give the inlet phase, as `scripted` reads it).
pub type CustomPolicy = Box<dyn FnMut(&[f32], &SwarmEnv) -> Vec<[f32; 2]> + Send>;

/// What chooses the actions.
pub enum Policy {
    /// A non-learned controller and the RNG its `random` draws from.
    Controller(Controller, Rng),
    /// A trained actor.
    Trained {
        /// The learner holding the actor (and its observation normaliser).
        learner: Box<Learner>,
        /// Act with the mean action instead of sampling.
        deterministic: bool,
    },
    /// A function of the observations and the environments.
    Custom(CustomPolicy),
}

impl Policy {
    /// A controller whose random draws follow `seed`.
    pub fn controller(controller: Controller, seed: u64) -> Self {
        Policy::Controller(controller, Rng::new(seed.wrapping_add(0x9E37)))
    }

    /// A policy given as a function of the observations `[E][N][8]` and the environments.
    pub fn custom(act: impl FnMut(&[f32], &SwarmEnv) -> Vec<[f32; 2]> + Send + 'static) -> Self {
        Policy::Custom(Box::new(act))
    }

    /// The trained policy of a checkpoint or a `policy.safetensors` (a file, or a run
    /// directory: its newest checkpoint) and the configuration it was trained in; `seed`
    /// drives the sampled actions.
    pub fn load_trained(
        path: &Path,
        seed: u64,
        deterministic: bool,
    ) -> Result<(Self, Resolved), RolloutError> {
        let file = checkpoint::locate(path)?;
        let archive = Archive::load(&file)?;
        let resolved = Config::from_saved(archive.meta("config")?).map_err(|source| {
            RolloutError::SavedConfig {
                file: file.clone(),
                source,
            }
        })?;
        let agents = resolved.config.swarm.count as usize;
        let train = resolved.config.train.clone();
        // An actor that reads the inlet phase (train.actor_phase) is made with its width.
        let global = if train.actor_phase { GLOBAL_DIM } else { 0 };
        let mut learner = Learner::with_global_state(agents, OBS_DIM, global, train, seed)?;
        learner.load_policy(&archive)?;
        log::info!("policy: {}", file.display());
        let policy = Policy::Trained {
            learner: Box::new(learner),
            deterministic,
        };
        Ok((policy, resolved))
    }

    /// Actions `[E][N]` for observations `[E][N][8]` of `env`.
    pub fn act_all(&mut self, obs: &[f32], env: &SwarmEnv) -> Result<Vec<[f32; 2]>, RolloutError> {
        Ok(match self {
            Policy::Controller(c, rng) => {
                let batch = env.batch();
                let t: Vec<f64> = (0..env.n_env()).map(|e| batch.waveform_time_s(e)).collect();
                c.act_all(obs, &t, batch.waveform().period_s(), rng)
            }
            Policy::Trained {
                learner,
                deterministic,
            } => {
                let global = match learner.actor_reads_global() {
                    true => MultiAgentEnv::global_state(env),
                    false => Vec::new(),
                };
                let raw = learner
                    .act(&learner.normalize(obs), &global, *deterministic)?
                    .0;
                learner.applied(&raw)
            }
            Policy::Custom(act) => act(obs, env),
        })
    }

    /// What a run's header says of a privileged controller (empty for the others).
    pub fn privileged_note(&self) -> String {
        match self {
            Policy::Controller(Controller::Scripted(p), _) => scripted_note(p, "the nearer wall"),
            Policy::Controller(Controller::ScriptedHeading(p), _) => {
                scripted_note(p, "the upper wall for every member")
            }
            _ => String::new(),
        }
    }
}

/// The header note of a phase-switched controller: its two angles, its window and where the
/// angles point.
fn scripted_note(p: &Scripted, towards: &str) -> String {
    format!(
        " (privileged, reads the inlet phase: {} deg outside and {} deg inside [{} s, {} s) of the period, towards {towards})",
        p.calm_deg, p.storm_deg, p.storm_start_s, p.storm_end_s
    )
}

//! What one batched multi-agent, multi-objective step returns to the learner ([`Transition`]),
//! how an episode ended ([`Outcome`]) and its metrics ([`EpisodeSummary`], SPEC section 3, the
//! columns of `episodes.csv`). Environments (the swarm's in `crate::env`) produce them.

use std::fmt;

/// How an episode ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Goal reached (swarm mean x below the success line); terminated.
    Success,
    /// Failure (a member past the failure line); terminated.
    Failure,
    /// Step limit reached; truncated, so bootstrapped.
    Timeout,
    /// CFD divergence (non-finite or runaway state); never bootstrapped.
    Diverged,
}

impl fmt::Display for Outcome {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Outcome::Success => "success",
            Outcome::Failure => "failure",
            Outcome::Timeout => "timeout",
            Outcome::Diverged => "diverged",
        })
    }
}

/// Metrics of a finished episode (SPEC section 3, the columns of `episodes.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeSummary {
    /// Index of the environment in the batch.
    pub env: usize,
    /// Episode index within the environment.
    pub episode: u64,
    /// Control steps in the episode.
    pub steps: u32,
    /// How the episode ended.
    pub outcome: Outcome,
    /// Sum over steps of the agent-mean progress reward.
    pub progress: f64,
    /// Mean over steps of the agent-mean energy and smoothness rewards.
    pub energy: f64,
    /// Mean over steps of the agent-mean smoothness reward.
    pub smoothness: f64,
    /// Mean over steps of the agent-mean progress reward.
    pub progress_mean: f64,
    /// Sum over steps of the agent-mean energy reward.
    pub energy_sum: f64,
    /// Sum over steps of the agent-mean smoothness reward.
    pub smoothness_sum: f64,
    /// Sum over steps of the scalar reward (agent mean of the three columns).
    pub scalar_return: f64,
    /// Swarm mean x at the episode's end (mm).
    pub final_x_com_mm: f64,
}

/// One batched multi-agent, three-objective step: what every environment the learner drives
/// returns (see [`super::env::MultiAgentEnv`]).
#[derive(Debug, Clone)]
pub struct Transition {
    /// `[E][N][8]`; for an environment that just ended, the first observation of its new episode.
    pub obs: Vec<f32>,
    /// `[E][N][3]`; zero for a diverged environment (its state is garbage).
    pub rewards: Vec<f32>,
    /// `[E]`; episode ended by success or failure (not bootstrapped).
    pub terminated: Vec<bool>,
    /// `[E]`; episode reached the step limit (bootstrapped from `final_obs`).
    pub truncated: Vec<bool>,
    /// Outcome `diverged` (never bootstrapped); neither terminated nor truncated is set.
    pub diverged: Vec<bool>,
    /// `[N][8]` final observation of each environment whose episode ended this step.
    pub final_obs: Vec<Option<Vec<f32>>>,
    /// `[G]` global state that goes with each `final_obs` (empty where the environment offers
    /// none; [`super::env::MultiAgentEnv::global_state_dim`]).
    pub final_global_state: Vec<Option<Vec<f32>>>,
    /// Metrics of each episode that ended this step.
    pub episodes: Vec<Option<EpisodeSummary>>,
}

impl Transition {
    /// The step of `envs` environments of `agents` agents where nothing happened yet: zero
    /// rewards `[E][N][3]`, no episode ended, and no observations (the caller adds them).
    pub fn empty(envs: usize, agents: usize) -> Self {
        Self {
            obs: Vec::new(),
            rewards: vec![0.0; envs * agents * 3],
            terminated: vec![false; envs],
            truncated: vec![false; envs],
            diverged: vec![false; envs],
            final_obs: vec![None; envs],
            final_global_state: vec![None; envs],
            episodes: vec![None; envs],
        }
    }
}

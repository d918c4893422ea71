//! The environment interface the learner drives: it knows no GPU and no swarm, only batched
//! observations `[E][N][obs_dim]`, 2D actions `[E][N]` and the [`Transition`] it gets back.
//! A toy environment with a known optimum for tests is `crate::testing::PointMasses`.

pub use super::error::EnvError;
pub use super::transition::{EpisodeSummary, Outcome, Transition};
use crate::checkpoint::Archive;

/// A batched multi-agent, multi-objective environment with 2D actions.
pub trait MultiAgentEnv {
    /// Number of environments E.
    fn n_env(&self) -> usize;
    /// Number of agents N per environment.
    fn n_agents(&self) -> usize;
    /// Length of one agent's observation.
    fn obs_dim(&self) -> usize;
    /// Resets every environment; returns the observations `[E][N][obs_dim]`.
    fn reset(&mut self) -> Result<Vec<f32>, EnvError>;
    /// Advances every environment by one step with actions `[E][N][2]`.
    fn step(&mut self, actions: &[[f32; 2]]) -> Result<Transition, EnvError>;
    /// Adds the whole state of every environment (after `reset`) to a checkpoint under `env.`.
    fn save_state(&self, archive: &mut Archive) -> Result<(), EnvError>;
    /// Restores what `save_state` wrote into environments of the same shape.
    fn load_state(&mut self, archive: &Archive) -> Result<(), EnvError>;
    /// Length G of the global state an environment offers a centralised critic beyond the
    /// agents' joint observations (0: none, the default).
    fn global_state_dim(&self) -> usize {
        0
    }
    /// The global state `[E][G]` of every environment now (after `reset` or `step`: the state
    /// that goes with the observations just returned).
    fn global_state(&self) -> Vec<f32> {
        Vec::new()
    }
}

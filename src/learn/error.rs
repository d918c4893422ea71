//! The learner's errors: each says what went wrong and what to do about it.

use crate::checkpoint::CheckpointError;

/// What an environment's [`crate::learn::env::MultiAgentEnv`] methods fail with: any error of
/// the environment's own, boxed, so that the learner needs to know no environment's types.
pub type EnvError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// An error of the learner: its set-up, its networks, its saved state or the environment it
/// drives.
#[derive(Debug, thiserror::Error)]
pub enum LearnError {
    /// `FLUXSWARM_LEARNER_THREADS` is not a positive integer.
    #[error(
        "FLUXSWARM_LEARNER_THREADS={value}: give a positive number of threads, or unset it for 1"
    )]
    Threads {
        /// The variable's value as set.
        value: String,
    },
    /// The learner's thread pool could not start.
    #[error("starting the learner's thread pool: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    /// A network's hand-written layout differs from candle's variables (a programming error).
    #[error("the {net}'s layout {want:?} is not its variables' {have:?}")]
    Layout {
        /// `actor` or `critic`.
        net: &'static str,
        /// Names and shapes the layout expects.
        want: Vec<(String, Vec<usize>)>,
        /// Names and shapes of the variables.
        have: Vec<(String, Vec<usize>)>,
    },
    /// A tensor operation failed.
    #[error("a tensor operation of the learner failed: {0}")]
    Tensor(#[from] candle_core::Error),
    /// A checkpoint or policy file does not hold what the learner needs.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The environment offers a global state of another length than the critic reads.
    #[error(
        "the critic reads {want} global-state inputs but the environment offers {have}: make the \
         learner with the environment's `global_state_dim()` (or 0 to leave it out)"
    )]
    GlobalState {
        /// Inputs the critic was made for.
        want: usize,
        /// What the environment gave per environment.
        have: usize,
    },
    /// `train.actor_phase` on a learner made without a global state.
    #[error(
        "train.actor_phase gives the actor the environment's global state, but the learner was \
         made without one: make it with the environment's `global_state_dim()` \
         (train.critic_phase = true)"
    )]
    ActorPhase,
    /// The environment the learner drives failed.
    #[error(transparent)]
    Env(EnvError),
}

//! The learner's core (MOMAPPO with PCGrad, SPEC section 5), environment-agnostic: GAE per
//! objective and agent with episode-end masking ([`gae`]), Gaussian policy log-probabilities
//! and entropy (as candle tensors in [`nets`]; their closed forms, for the tests, in
//! `gaussian`; the tanh-squashed option's corrections in [`squash`]), PCGrad gradient surgery ([`pcgrad`], applied to candle gradients by [`surgery`]), the clipped surrogate ([`ppo`]) and
//! the actor and critic ([`nets`]), Adam with saveable moments ([`adam`]) and the running
//! observation normaliser ([`normalizer`]). [`mappo`] runs rollouts and updates on any
//! [`env::MultiAgentEnv`] and saves its whole state into a checkpoint. The learner knows no GPU
//! and no swarm: it names nothing outside `learn/` but the checkpoint archive and the RNG, and
//! the environments implement its trait with its [`transition`] types.

pub mod adam;
pub mod dense;
pub mod env;
pub mod error;
pub mod gae;
#[cfg(test)]
mod gaussian;
mod lanes;
pub mod mappo;
pub mod mlp;
pub mod nets;
pub mod normalizer;
pub mod pcgrad;
pub mod ppo;
pub mod squash;
pub mod surgery;
pub mod transition;

pub use error::{EnvError, LearnError};

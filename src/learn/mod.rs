//! The learner's core (MOMAPPO with PCGrad, SPEC section 5), environment-agnostic: GAE per
//! objective and agent with episode-end masking ([`gae`]), Gaussian policy log-probabilities
//! and entropy ([`gaussian`], and as candle tensors in [`nets`]), PCGrad gradient surgery
//! ([`pcgrad`], applied to candle gradients by [`surgery`]), the clipped surrogate ([`ppo`]) and
//! the actor and critic ([`nets`]). The rollout buffer, the update loop, checkpoints and `train`
//! build on these (issue 4, in progress).

pub mod env;
pub mod gae;
pub mod gaussian;
pub mod mappo;
pub mod nets;
pub mod pcgrad;
pub mod ppo;
pub mod surgery;

//! The learner's core (MOMAPPO with PCGrad, SPEC section 5), environment-agnostic: GAE per
//! objective and agent with episode-end masking ([`gae`]), Gaussian policy log-probabilities
//! and entropy ([`gaussian`]), and PCGrad gradient surgery ([`pcgrad`]). The networks, the
//! optimiser and `train` build on these (issue 4, in progress).

pub mod gae;
pub mod gaussian;
pub mod pcgrad;

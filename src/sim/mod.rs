//! The batched channel-flow simulation behind one trait ([`FlowBatch`]) with two backends:
//! the WGSL kernels ([`GpuBatch`], `fluid`) and the CPU stages ([`CpuBatch`], [`cpu`]), which
//! are also the reference the kernels are tested against. [`open`](mod@open) picks the backend per
//! `solver.backend`. Beside them: grid geometry ([`grid`]), the fast Poisson solver's tables
//! ([`poisson`]), the per-environment health ([`health`]) and the flow past the swarm ([`gap`]).

pub mod batch;
pub mod cpu;
pub mod fluid;
pub mod gap;
pub mod grid;
pub mod health;
pub mod open;
pub mod poisson;

pub use batch::{BatchCore, Fields, FlowBatch};
pub use cpu::{BatchState, CpuBatch};
pub use fluid::{GpuBatch, SimError, Stage, batch_params};
pub use grid::Grid;
pub use health::EnvHealth;
pub use open::{Opened, open};

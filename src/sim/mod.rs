//! The batched channel-flow simulation: grid geometry ([`grid`]), the fast Poisson solver's
//! tables ([`poisson`]), the GPU batch ([`fluid`]), its health read-back ([`health`]) and the
//! plain-Rust twin of every kernel ([`cpu`]) that tests compare against.

pub mod cpu;
pub mod fluid;
pub mod grid;
pub mod health;
pub mod native;
pub mod poisson;

pub use fluid::{Fields, FluidBatch, SimError, Stage};
pub use grid::Grid;
pub use health::EnvHealth;

#![warn(missing_docs)]
//! fluxswarm-gpu: a batched 2D incompressible Navier-Stokes channel solver in WGSL compute
//! shaders (wgpu) with a CPU backend beside it, for training micro-robot swarms to swim
//! upstream in pulsatile blood flow.
//!
//! Layers, each depending only on those below it (`tests/layering.rs` checks it):
//! the CLI (the binary) -> `rollout` (the rollout runner behind `rollout` and `eval`, for any
//! front end), `learn` (MOMAPPO + PCGrad, any `learn::env::MultiAgentEnv`), `env` (the swarm
//! environments), `report`, `output` -> `sim` (the batched flow: trait `FlowBatch`,
//! `CpuBatch`, `GpuBatch`) -> `gpu` (adapter, kernels), with `config`,
//! `waveform`, `checkpoint`, `rng`, `tuning` and `roofline` (this machine's measured peaks)
//! beside them; `sweep` (many runs of a command, locally or on Slurm) knows only `config`;
//! `testing` is test-only. The library's errors are typed, one `thiserror` enum per module;
//! `anyhow` is the binary's. Recipes for extending it: `docs/extending.md`.

pub mod checkpoint;
pub mod config;
pub mod env;
pub mod gpu;
pub mod learn;
pub mod output;
pub mod report;
pub mod rng;
pub mod rollout;
pub mod roofline;
pub mod sim;
pub mod sweep;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tuning;
pub mod waveform;

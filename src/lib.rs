//! fluxswarm-gpu: a batched 2D incompressible Navier-Stokes channel solver in WGSL compute
//! shaders (wgpu), for training micro-robot swarms to swim upstream in pulsatile blood flow.
//!
//! Layers, each depending only on those below it:
//! `output` (frames, .npy, CSV) -> `sim` (the batched flow) -> `gpu` (kernels, context),
//! with `config` and `waveform` beside them.

pub mod checkpoint;
pub mod config;
pub mod env;
pub mod gpu;
pub mod learn;
pub mod output;
pub mod report;
pub mod rng;
pub mod sim;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tuning;
pub mod waveform;

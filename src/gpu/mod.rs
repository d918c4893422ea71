//! GPU plumbing: adapter choice and device ([`context`]), the structs shared with WGSL
//! ([`params`]), the WGSL sources ([`shaders`]), one struct per kernel ([`kernels`]) and the
//! driver self-check ([`probe`]). Nothing here knows about environments or learning.

pub mod context;
pub mod kernels;
pub mod params;
pub mod probe;
pub mod shaders;
pub mod traffic;

pub use context::{AdapterChoice, GpuContext, GpuError};

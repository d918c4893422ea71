//! Structs shared with WGSL (`shaders/common.wgsl`), `#[repr(C)]` Pod with size asserts.

use bytemuck::{Pod, Zeroable};

/// Batch-wide constants of the fluid kernels (WGSL `Params`, a uniform).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct GpuParams {
    pub nx: u32,
    pub ny: u32,
    pub n_env: u32,
    pub substeps: u32,
    pub dx: f32,
    pub dy: f32,
    /// Substep length dt_sub (s).
    pub dt: f32,
    /// Kinematic viscosity (m^2/s).
    pub nu: f32,
    /// Density (kg/m^3).
    pub rho: f32,
    /// Channel height H (m).
    pub height: f32,
    /// 1: midpoint (RK2) backtrace, 0: Euler backtrace.
    pub rk2: u32,
    pub pad1: f32,
    /// 1 / dx, 1 / dy (1/m), so samplers multiply instead of divide.
    pub inv_dx: f32,
    pub inv_dy: f32,
    pub pad2: f32,
    pub pad3: f32,
}
const _: () = assert!(std::mem::size_of::<GpuParams>() == 64);

/// Index of the substep being run (WGSL `Substep`), one per dynamic-offset slot.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct SubstepUniform {
    pub index: u32,
    pub pad: [u32; 3],
}
const _: () = assert!(std::mem::size_of::<SubstepUniform>() == 16);

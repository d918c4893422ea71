//! Structs shared with WGSL (`shaders/common.wgsl`), `#[repr(C)]` Pod with size asserts.

use bytemuck::{Pod, Zeroable};

/// Batch-wide constants of the fluid kernels (WGSL `Params`, a uniform).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct GpuParams {
    /// Cells along x.
    pub nx: u32,
    /// Cells across the height.
    pub ny: u32,
    /// Environments in the batch (E).
    pub n_env: u32,
    /// Fluid substeps per control step.
    pub substeps: u32,
    /// Cell width along x (m).
    pub dx: f32,
    /// Cell height along y (m).
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
    /// Padding.
    pub pad1: f32,
    /// 1 / dx, 1 / dy (1/m), so samplers multiply instead of divide.
    pub inv_dx: f32,
    /// 1 / dy (1/m).
    pub inv_dy: f32,
    /// Channel length L (m) and dynamic viscosity mu (Pa s).
    pub length: f32,
    /// Dynamic viscosity mu (Pa s).
    pub mu: f32,
    /// Members per environment and 1 if the empirical drag is on.
    pub n_members: u32,
    /// 1 if the empirical (Schiller-Naumann) drag is on, else 0.
    pub drag: u32,
    /// Member radius r, pressure-sampling radius R_s = r + 2 dx, effective depth
    /// 4 r^2 / (3 R_s) (m) and mass 4/3 pi r^3 rho_s (kg).
    pub radius: f32,
    /// Pressure-sampling radius R_s = r + 2 dx (m).
    pub sample_radius: f32,
    /// Effective depth 4 r^2 / (3 R_s) (m).
    pub depth: f32,
    /// Member mass 4/3 pi r^3 rho_s (kg).
    pub mass: f32,
    /// Thrust bound F_max (N): F_prop = F_max a / max(1, |a|) for a raw action a.
    pub max_thrust: f32,
    /// Padding.
    pub pad4: f32,
    /// Padding.
    pub pad5: f32,
    /// Padding.
    pub pad6: f32,
    /// Padding.
    pub pad7: f32,
    /// Padding.
    pub pad8: f32,
}
const _: () = assert!(std::mem::size_of::<GpuParams>() == 112);

/// One swarm member as the GPU stores it (WGSL `Member`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq, Default)]
pub struct GpuMember {
    /// Centre (m).
    pub pos: [f32; 2],
    /// Velocity (m/s).
    pub vel: [f32; 2],
    /// 1: held fixed.
    pub pinned: f32,
    /// Padding to 32 bytes.
    pub pad: [f32; 3],
}
const _: () = assert!(std::mem::size_of::<GpuMember>() == 32);

/// Forces on a member during the last substep (N) and its pressure samples (Pa)
/// (WGSL `MemberDiag`). Samples k = 0..3 at angles 0, 90, 180, 270 degrees.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq, Default)]
pub struct GpuMemberDiag {
    /// Resolved pressure force from the four samples (N).
    pub hydro: [f32; 2],
    /// Empirical drag force (N).
    pub drag: [f32; 2],
    /// Contact force from touching members (N).
    pub contact: [f32; 2],
    /// Propulsion force F_prop (N).
    pub prop: [f32; 2],
    /// Pressure at the four sample points, k = 0..3 (Pa).
    pub p: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuMemberDiag>() == 48);

/// Index of the substep being run (WGSL `Substep`), one per dynamic-offset slot.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable, PartialEq)]
pub struct SubstepUniform {
    /// Substep index within the control step.
    pub index: u32,
    /// Padding to 16 bytes.
    pub pad: [u32; 3],
}
const _: () = assert!(std::mem::size_of::<SubstepUniform>() == 16);

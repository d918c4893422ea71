//! The WGSL path: a batch of E channel flows on the GPU ([`GpuBatch`], one of the two
//! [`FlowBatch`] backends), advanced one control step (S substeps) per submission with no
//! read-back in between; after the step one small read-back of the health of every
//! environment, its members and their forces.
//!
//! Per substep (6 dispatches with semi-Lagrangian advection, 7 with MacCormack):
//!   diffuse             w = u^n + dt nu lap u^n
//!   advect [+ correct]  u* = A(w) along the velocity u^n, boundary values, Brinkman blend
//!   pressure_rhs        phat = Q^T (rho/dt div u*)          (y-cosine modes per column)
//!   pressure_solve      (Lx + lambda_k) p_k = phat_k         (Thomas along x per mode: exact)
//!    or pressure_scan   the same systems as two parallel scans (`solver.pressure_sweep`)
//!   pressure_back       p = Q p_k                            (per column)
//!   project             u = u* - dt/rho grad p
//! Buffers (`[E]` outermost): u`[2]` `[E][ny][nx+1]` and v`[2]` `[E][ny+1][nx]` (ping-pong), u_hat/v_hat
//! (MacCormack predictor and clamp extrema, vec4), w_u/w_v (diffused), p and modes `[E][ny][nx]`, body `[E][ny][nx]` vec4 (chi, u_body, v_body, 0),
//! inlet `[E][S]`, poisson tables, divstar `[E][nx]`, colstats `[E][nx+1]` vec4, health `[E][2]` vec4.
//! By job: `buffers` (the buffers and bind groups), `io` (reads and writes), `step`
//! (recording and submitting a control step), `profile` (per-kernel times and bytes),
//! `sizes` (sizes, the largest batch, the batch constants), `flow` (the trait).

use thiserror::Error;
use wgpu::util::DeviceExt;

use super::batch::{BatchCore, Fields, FlowBatch, swarm_box};
use super::cpu::BatchState;
use super::{EnvHealth, Grid, poisson::PoissonTables};
use crate::config::{Backtrace, Resolved};
use crate::gpu::kernels::{
    Advect, BindGroups, Dims, FieldBinding, Kernels, Recorder, map_and_read, read_buffer,
};
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams, SubstepUniform};
use crate::gpu::{GpuContext, GpuError};

/// Why a batch could not be created, stepped, read or written.
#[derive(Debug, Error)]
pub enum SimError {
    /// A GPU error.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The batch's largest buffer exceeds the adapter's storage-binding limit.
    #[error(
        "a batch of {n_env} environments at {nx} x {ny} needs a {need} MiB buffer, above this \
         adapter's {limit} MiB storage-binding limit: use at most {max_env} environments \
         (`fluxswarm-gpu info` lists the limits)"
    )]
    TooLarge {
        /// Environments asked for.
        n_env: usize,
        /// Cells along x.
        nx: usize,
        /// Cells across the height.
        ny: usize,
        /// Size of the largest buffer (MiB).
        need: u64,
        /// The adapter's `max_storage_buffer_binding_size` (MiB).
        limit: u64,
        /// Most environments that fit.
        max_env: usize,
    },
    /// An environment index outside the batch.
    #[error("environment index {0} is outside the batch")]
    NoSuchEnv(usize),
    /// A batch of zero environments was asked for.
    #[error("the batch needs at least one environment")]
    Empty,
    /// A checkpoint error.
    #[error(transparent)]
    Checkpoint(#[from] crate::checkpoint::CheckpointError),
    /// The start-up self-check of the WGSL path failed (loop cap or disagreement with the CPU
    /// step); the message says how.
    #[error("GPU self-check failed: {0}")]
    SelfCheck(String),
    /// An array handed to the batch has the wrong length.
    #[error("{what}: {got} values given where the batch holds {want}")]
    WrongLength {
        /// Which array.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length the batch needs.
        want: usize,
    },
}

/// Per kernel: entry point, dispatches in the control step, total GPU time (s).
pub type KernelTimes = Vec<(&'static str, u32, f64)>;

/// One stage of the substep, for tests and timing by elimination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Diffusion and advection (with the MacCormack correction if chosen): u*.
    Advect,
    /// div u* in y-cosine modes (`pressure_rhs`).
    PressureRhs,
    /// The per-mode tridiagonal solve (`pressure_solve` or `pressure_scan`).
    PressureSolve,
    /// Pressure back-transform and velocity correction (`pressure_back`, `project`).
    Project,
    /// The health of every environment (`diag_columns`, `diag_reduce`).
    Diagnostics,
    /// Members painted into the body field.
    PaintBodies,
    /// Members sampled, forced and moved (reads the projected velocity, `UOut`/`VOut`).
    MoveMembers,
}

/// Pressure iterations per substep: the fast solver is exact for the channel's matrix.
pub const PRESSURE_ITERATIONS_PER_SUBSTEP: u32 = 1;

/// Every pipeline, each with its own bind group layout (`gpu::kernels`).
type Pipelines = Kernels;

/// E channel flows advanced together on a wgpu adapter.
pub struct GpuBatch {
    ctx: GpuContext,
    core: BatchCore,
    /// `pressure_scan` instead of `pressure_solve` (`solver.pressure_sweep`, resolved).
    scan_sweep: bool,
    substep_stride: u32,
    pipelines: Pipelines,
    buffers: Buffers,
    /// Every pipeline's bind groups; side g reads u[g], v[g] and writes u[1-g], v[1-g].
    bind: BindGroups,
    /// Which of u[0], u[1] holds the current field.
    cur: usize,
    /// Members and their forces as read back with the health after the last step.
    last_members: Vec<GpuMember>,
    last_diag: Vec<GpuMemberDiag>,
}

mod buffers;
mod flow;
mod io;
mod profile;
mod sizes;
mod step;

use buffers::Buffers;
pub use sizes::{batch_params, bytes_per_env, largest_buffer_per_env, max_batch};

impl GpuBatch {
    /// A batch of `n_env` environments on `ctx`'s adapter, each reset to the developed flow
    /// at phase 0.
    pub fn new(ctx: &GpuContext, resolved: &Resolved, n_env: usize) -> Result<Self, SimError> {
        let core = BatchCore::new(resolved, n_env)?;
        let grid = core.grid;
        let max_env = max_batch(&ctx.limits, &grid);
        if n_env > max_env {
            return Err(SimError::TooLarge {
                n_env,
                nx: grid.nx,
                ny: grid.ny,
                need: (largest_buffer_per_env(&grid) * n_env as u64) >> 20,
                limit: ctx.limits.max_storage_buffer_binding_size >> 20,
                max_env,
            });
        }
        let config = &resolved.config;
        let substeps = core.substeps;
        let n_members = core.n_members;
        let params = core.params;
        let device = &ctx.device;
        // The column kernels are generated for this ny (`gpu::kernels::Columns`). Fails with
        // GpuError::Limit where a kernel needs more than the adapter allows.
        let pipelines = Pipelines::new(ctx, grid.ny as u32)?;
        let stride = ctx.limits.min_uniform_buffer_offset_alignment.max(16);
        let buffers = Self::create_buffers(ctx, &grid, &params, n_env, substeps, n_members, stride);
        let bind = Self::bind_groups(device, &pipelines, &buffers);
        let mut batch = Self {
            ctx: ctx.clone(),
            scan_sweep: config.solver.pressure_sweep.uses_scan(ctx.is_software()),
            substep_stride: stride,
            pipelines,
            buffers,
            bind,
            cur: 0,
            last_members: (0..n_env)
                .flat_map(|_| core.initial_members.iter().copied())
                .collect(),
            last_diag: vec![GpuMemberDiag::default(); n_env * n_members],
            core,
        };
        for e in 0..n_env {
            batch.reset_env(e)?;
        }
        ctx.wait()?;
        Ok(batch)
    }
    /// The adapter the batch runs on.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }
    /// The kernel of the tridiagonal solve: "scan" or "sequential" (`solver.pressure_sweep`).
    pub fn pressure_sweep(&self) -> &'static str {
        if self.scan_sweep {
            "scan"
        } else {
            "sequential"
        }
    }
    /// Dispatches per substep (advection scheme dependent) and per control step.
    pub fn dispatches_per_substep(&self) -> u32 {
        // With members: `move_members`; the paint runs inside `diffuse`.
        Advect::dispatches(self.core.scheme) + 4 + if self.core.n_members > 0 { 1 } else { 0 }
    }
    /// Dispatches per control step: every substep's and the two of the diagnostics.
    pub fn dispatches_per_control_step(&self) -> u32 {
        self.dispatches_per_substep() * self.core.substeps as u32 + 2
    }
}

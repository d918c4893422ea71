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
//! Buffers ([E] outermost): u[2] [E][ny][nx+1] and v[2] [E][ny+1][nx] (ping-pong), u_hat/v_hat
//! (MacCormack predictor and clamp extrema, vec4), w_u/w_v (diffused), p and modes [E][ny][nx], body [E][ny][nx] vec4 (chi, u_body, v_body, 0),
//! inlet [E][S], poisson tables, divstar [E][nx], colstats [E][nx+1] vec4, health [E][2] vec4.

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

#[derive(Debug, Error)]
pub enum SimError {
    #[error(transparent)]
    Gpu(#[from] GpuError),
    #[error(
        "a batch of {n_env} environments at {nx} x {ny} needs a {need} MiB buffer, above this \
         adapter's {limit} MiB storage-binding limit: use at most {max_env} environments \
         (`fluxswarm-gpu info` lists the limits)"
    )]
    TooLarge {
        n_env: usize,
        nx: usize,
        ny: usize,
        need: u64,
        limit: u64,
        max_env: usize,
    },
    #[error("environment index {0} is outside the batch")]
    NoSuchEnv(usize),
    #[error("the batch needs at least one environment")]
    Empty,
    #[error(transparent)]
    Checkpoint(#[from] crate::checkpoint::CheckpointError),
    #[error("GPU self-check failed: {0}")]
    SelfCheck(String),
    #[error("{what}: {got} values given where the batch holds {want}")]
    WrongLength {
        what: &'static str,
        got: usize,
        want: usize,
    },
}

/// Per kernel: entry point, dispatches in the control step, total GPU time (s).
pub type KernelTimes = Vec<(&'static str, u32, f64)>;

/// One stage of the substep, for tests and timing by elimination.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    Advect,
    PressureRhs,
    PressureSolve,
    Project,
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

struct Buffers {
    params: wgpu::Buffer,
    substep: wgpu::Buffer,
    u: [wgpu::Buffer; 2],
    v: [wgpu::Buffer; 2],
    u_hat: wgpu::Buffer,
    v_hat: wgpu::Buffer,
    p: wgpu::Buffer,
    modes: wgpu::Buffer,
    body: wgpu::Buffer,
    inlet: wgpu::Buffer,
    poisson: wgpu::Buffer,
    divstar: wgpu::Buffer,
    colstats: wgpu::Buffer,
    health: wgpu::Buffer,
    health_staging: wgpu::Buffer,
    w_u: wgpu::Buffer,
    w_v: wgpu::Buffer,
    members: wgpu::Buffer,
    member_diag: wgpu::Buffer,
    thrust: wgpu::Buffer,
    swarm_box: wgpu::Buffer,
}

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

/// Bytes of the largest single buffer of one environment (the body buffer, 16 B per cell).
pub fn largest_buffer_per_env(grid: &Grid) -> u64 {
    (grid.n_cells() * 16)
        .max(grid.n_u() * 4)
        .max(grid.n_v() * 4) as u64
}

/// Bytes of all buffers of one environment.
pub fn bytes_per_env(grid: &Grid, substeps: usize) -> u64 {
    let f = 4u64;
    let vel = (grid.n_u() + grid.n_v()) as u64 * f;
    8 * vel // u, v ping-pong, w_u/w_v, u_hat/v_hat (vec4)
        + 2 * grid.n_cells() as u64 * f // p, modes
        + grid.n_cells() as u64 * 16 // body
        + substeps as u64 * f
        + grid.nx as u64 * f
        + (grid.nx as u64 + 1) * 16
        + 32
}

/// Largest batch the adapter's binding and dispatch limits allow at this grid.
pub fn max_batch(limits: &wgpu::Limits, grid: &Grid) -> usize {
    let binding = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    let by_binding = (binding / largest_buffer_per_env(grid)) as usize;
    by_binding.min(limits.max_compute_workgroups_per_dimension as usize)
}

/// The kernels' batch constants for `n_env` environments of this configuration (no GPU needed:
/// the CPU stages take the same struct).
pub fn batch_params(resolved: &Resolved, n_env: usize) -> GpuParams {
    let config = &resolved.config;
    let grid = Grid::from_config(config);
    let swarm = &config.swarm;
    let substeps = config.time.substeps as usize;
    let n_members = swarm.count as usize;
    // Pressure samples just outside the painted solid: R_s = r + 2 dx (SPEC section 2).
    let sample_radius = swarm.radius_m + 2.0 * grid.dx();
    GpuParams {
        nx: grid.nx as u32,
        ny: grid.ny as u32,
        n_env: n_env as u32,
        substeps: substeps as u32,
        dx: grid.dx() as f32,
        dy: grid.dy() as f32,
        dt: config.dt_sub() as f32,
        nu: config.kinematic_viscosity() as f32,
        rho: config.fluid.density_kg_m3 as f32,
        height: grid.height_m as f32,
        rk2: (config.solver.backtrace == Backtrace::Rk2) as u32,
        pad1: 0.0,
        inv_dx: (1.0 / grid.dx()) as f32,
        inv_dy: (1.0 / grid.dy()) as f32,
        length: grid.length_m as f32,
        mu: config.fluid.viscosity_pa_s as f32,
        n_members: n_members as u32,
        drag: config.swarm.drag as u32,
        radius: swarm.radius_m as f32,
        sample_radius: sample_radius as f32,
        depth: (4.0 * swarm.radius_m * swarm.radius_m / (3.0 * sample_radius)) as f32,
        mass: swarm.mass_kg() as f32,
        max_thrust: swarm.max_thrust_n as f32,
        pad4: 0.0,
        pad5: 0.0,
        pad6: 0.0,
        pad7: 0.0,
        pad8: 0.0,
    }
}

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

    /// A [`BatchState`] of `n_env` environments from `read`, which returns a buffer's words for
    /// those environments.
    fn cpu_batch_from(
        &self,
        n_env: usize,
        poisson: Vec<f32>,
        read: impl Fn(FieldBinding) -> Result<Vec<f32>, SimError>,
    ) -> Result<BatchState, SimError> {
        let quads = |v: Vec<f32>| -> Vec<[f32; 4]> {
            v.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
        };
        let n = n_env * self.core.n_members;
        let (members, actions, boxes) = if self.core.n_members > 0 {
            let m: Vec<GpuMember> = bytemuck::pod_collect_to_vec(&read(FieldBinding::Members)?);
            let t = read(FieldBinding::Thrust)?;
            let b = read(FieldBinding::SwarmBox)?;
            (
                m[..n].to_vec(),
                t.chunks(2).take(n).map(|c| [c[0], c[1]]).collect(),
                b.chunks(8).map(|c| [c[0], c[1], c[2], c[3]]).collect(),
            )
        } else {
            (Vec::new(), Vec::new(), vec![[0.0; 4]; n_env])
        };
        Ok(BatchState {
            params: GpuParams {
                n_env: n_env as u32,
                ..self.core.params
            },
            scheme: self.core.scheme,
            poisson,
            u: read(FieldBinding::UIn)?,
            v: read(FieldBinding::VIn)?,
            p: read(FieldBinding::Pressure)?,
            body: quads(read(FieldBinding::Body)?),
            divstar: read(FieldBinding::DivStar)?,
            members,
            actions,
            boxes,
        })
    }

    fn create_buffers(
        ctx: &GpuContext,
        grid: &Grid,
        params: &GpuParams,
        n_env: usize,
        substeps: usize,
        n_members: usize,
        stride: u32,
    ) -> Buffers {
        let device = &ctx.device;
        let storage = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC;
        let zeros = |label: &str, bytes: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (bytes.max(16) as u64).next_multiple_of(16),
                usage: storage,
                mapped_at_creation: false,
            })
        };
        let f = 4;
        let mut slots = vec![0u8; stride as usize * substeps];
        for s in 0..substeps {
            let u = SubstepUniform {
                index: s as u32,
                pad: [0; 3],
            };
            let at = s * stride as usize;
            slots[at..at + 16].copy_from_slice(bytemuck::bytes_of(&u));
        }
        Buffers {
            params: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("params"),
                contents: bytemuck::bytes_of(params),
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            substep: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("substep slots"),
                contents: &slots,
                usage: wgpu::BufferUsages::UNIFORM,
            }),
            u: [
                zeros("u0", n_env * grid.n_u() * f),
                zeros("u1", n_env * grid.n_u() * f),
            ],
            v: [
                zeros("v0", n_env * grid.n_v() * f),
                zeros("v1", n_env * grid.n_v() * f),
            ],
            u_hat: zeros("u_hat", n_env * grid.n_u() * 16),
            v_hat: zeros("v_hat", n_env * grid.n_v() * 16),
            p: zeros("p", n_env * grid.n_cells() * f),
            modes: zeros("modes", n_env * grid.n_cells() * f),
            body: zeros("body", n_env * grid.n_cells() * 16),
            inlet: zeros("inlet", n_env * substeps * f),
            poisson: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("poisson"),
                contents: bytemuck::cast_slice(&PoissonTables::new(grid).to_gpu()),
                usage: storage,
            }),
            divstar: zeros("divstar", n_env * grid.nx * f),
            colstats: zeros("colstats", n_env * (grid.nx + 1) * 16),
            health: zeros("health", n_env * 32),
            w_u: zeros("w_u", n_env * grid.n_u() * f),
            w_v: zeros("w_v", n_env * grid.n_v() * f),
            // At least one element each: `diffuse` (which paints) binds them in every batch.
            members: zeros("members", n_env * n_members.max(1) * 32),
            member_diag: zeros("member diag", n_env * n_members.max(1) * 48),
            thrust: zeros("thrust", n_env * n_members.max(1) * 8),
            swarm_box: zeros("swarm box", n_env * 32),
            health_staging: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("health + members staging"),
                size: (n_env * (32 + n_members * (32 + 48))) as u64,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }

    /// Every pipeline's bind groups, both sides (built once per batch).
    fn bind_groups(device: &wgpu::Device, pipelines: &Pipelines, b: &Buffers) -> BindGroups {
        pipelines.bind_groups(device, &b.params, &b.substep, |which, g| match which {
            FieldBinding::UIn => &b.u[g],
            FieldBinding::VIn => &b.v[g],
            FieldBinding::UOut => &b.u[1 - g],
            FieldBinding::VOut => &b.v[1 - g],
            FieldBinding::UHat => &b.u_hat,
            FieldBinding::VHat => &b.v_hat,
            FieldBinding::Pressure => &b.p,
            FieldBinding::Modes => &b.modes,
            FieldBinding::Body => &b.body,
            FieldBinding::Inlet => &b.inlet,
            FieldBinding::Poisson => &b.poisson,
            FieldBinding::DivStar => &b.divstar,
            FieldBinding::ColStats => &b.colstats,
            FieldBinding::Health => &b.health,
            FieldBinding::WU => &b.w_u,
            FieldBinding::WV => &b.w_v,
            FieldBinding::Members => &b.members,
            FieldBinding::MemberDiag => &b.member_diag,
            FieldBinding::Thrust => &b.thrust,
            FieldBinding::SwarmBox => &b.swarm_box,
        })
    }

    /// Dispatches per substep (advection scheme dependent) and per control step.
    pub fn dispatches_per_substep(&self) -> u32 {
        // With members: `move_members`; the paint runs inside `diffuse`.
        Advect::dispatches(self.core.scheme) + 4 + if self.core.n_members > 0 { 1 } else { 0 }
    }

    pub fn dispatches_per_control_step(&self) -> u32 {
        self.dispatches_per_substep() * self.core.substeps as u32 + 2
    }

    fn buffer(&self, which: FieldBinding) -> &wgpu::Buffer {
        let b = &self.buffers;
        match which {
            FieldBinding::UIn => &b.u[self.cur],
            FieldBinding::VIn => &b.v[self.cur],
            FieldBinding::UOut => &b.u[1 - self.cur],
            FieldBinding::VOut => &b.v[1 - self.cur],
            FieldBinding::UHat => &b.u_hat,
            FieldBinding::VHat => &b.v_hat,
            FieldBinding::Pressure => &b.p,
            FieldBinding::Modes => &b.modes,
            FieldBinding::Body => &b.body,
            FieldBinding::Inlet => &b.inlet,
            FieldBinding::Poisson => &b.poisson,
            FieldBinding::DivStar => &b.divstar,
            FieldBinding::ColStats => &b.colstats,
            FieldBinding::Health => &b.health,
            FieldBinding::WU => &b.w_u,
            FieldBinding::WV => &b.w_v,
            FieldBinding::Members => &b.members,
            FieldBinding::MemberDiag => &b.member_diag,
            FieldBinding::Thrust => &b.thrust,
            FieldBinding::SwarmBox => &b.swarm_box,
        }
    }

    /// Elements (of 4 bytes) one environment holds in a buffer.
    fn words_per_env(&self, which: FieldBinding) -> usize {
        let g = &self.core.grid;
        match which {
            FieldBinding::UIn | FieldBinding::UOut | FieldBinding::WU => g.n_u(),
            FieldBinding::VIn | FieldBinding::VOut | FieldBinding::WV => g.n_v(),
            FieldBinding::UHat => 4 * g.n_u(),
            FieldBinding::VHat => 4 * g.n_v(),
            FieldBinding::Pressure | FieldBinding::Modes => g.n_cells(),
            FieldBinding::Body => 4 * g.n_cells(),
            FieldBinding::Inlet => self.core.substeps,
            FieldBinding::Poisson => 0,
            FieldBinding::DivStar => g.nx,
            FieldBinding::ColStats => 4 * (g.nx + 1),
            FieldBinding::Health => 8,
            FieldBinding::Members => 8 * self.core.n_members,
            FieldBinding::MemberDiag => 12 * self.core.n_members,
            FieldBinding::Thrust => 2 * self.core.n_members,
            FieldBinding::SwarmBox => 8,
        }
    }

    fn write_env_pod<T: bytemuck::Pod>(
        &self,
        which: FieldBinding,
        e: usize,
        data: &[T],
    ) -> Result<(), SimError> {
        self.core.check_env(e)?;
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let per_env = self.words_per_env(which) * 4;
        BatchCore::check_len(
            "values of one environment's buffer",
            bytes.len() / 4,
            per_env / 4,
        )?;
        self.ctx
            .queue
            .write_buffer(self.buffer(which), (e * per_env) as u64, bytes);
        Ok(())
    }

    /// Overwrites environment e's part of a buffer (`UIn`/`VIn` are the current field).
    pub fn write_env(&self, which: FieldBinding, e: usize, data: &[f32]) -> Result<(), SimError> {
        self.write_env_pod(which, e, data)
    }

    /// Overwrites a whole buffer (all environments).
    pub fn write_all(&self, which: FieldBinding, data: &[f32]) {
        self.ctx
            .queue
            .write_buffer(self.buffer(which), 0, bytemuck::cast_slice(data));
    }

    /// Reads a whole buffer (all environments).
    pub fn read_all(&self, which: FieldBinding) -> Result<Vec<f32>, SimError> {
        let words = if which == FieldBinding::Poisson {
            self.core.grid.ny * self.core.grid.ny + 2 * self.core.grid.n_cells()
        } else {
            self.words_per_env(which) * self.core.n_env
        };
        Ok(read_buffer(
            &self.ctx,
            self.buffer(which),
            0,
            (words * 4) as u64,
        )?)
    }

    /// The whole batch's current state as a [`BatchState`] (fields, body, members, raw actions,
    /// swarm boxes, Poisson tables), as the CPU backend holds and steps it. A full read-back;
    /// not for the stepping loop.
    pub fn to_cpu(&self) -> Result<BatchState, SimError> {
        self.cpu_batch_from(self.core.n_env, self.core.poisson.clone(), |w| {
            self.read_all(w)
        })
    }

    /// Reads environment e's part of a buffer.
    pub fn read_env(&self, which: FieldBinding, e: usize) -> Result<Vec<f32>, SimError> {
        self.core.check_env(e)?;
        let bytes = (self.words_per_env(which) * 4) as u64;
        Ok(read_buffer(
            &self.ctx,
            self.buffer(which),
            e as u64 * bytes,
            bytes,
        )?)
    }

    /// Writes the inlet centreline velocity of every environment at the end of every substep
    /// of the coming control step.
    fn upload_inlet(&self) {
        self.write_all(FieldBinding::Inlet, &self.core.inlet_values());
    }

    fn offset(&self, s: usize) -> u32 {
        s as u32 * self.substep_stride
    }

    fn dims(&self) -> Dims {
        Dims {
            nx: self.core.grid.nx as u32,
            ny: self.core.grid.ny as u32,
            n_env: self.core.n_env as u32,
        }
    }

    fn record_stage(&self, pass: &mut Recorder<'_>, stage: Stage, bind: usize, s: usize) {
        let (b, o, d) = (self.bind.side(bind), self.offset(s), self.dims());
        let p = &self.pipelines;
        match stage {
            Stage::Advect => p.advect.record(pass, b, o, d, self.core.scheme),
            Stage::PressureRhs => p.rhs.record(pass, b, o, d),
            Stage::PressureSolve if self.scan_sweep => p.scan.record(pass, b, o, d),
            Stage::PressureSolve => p.solve.record(pass, b, o, d),
            Stage::Project => p.project.record(pass, b, o, d),
            Stage::Diagnostics => p.diagnostics.record(pass, b, o, d),
            Stage::PaintBodies => p.members.record_paint(pass, b, o, d),
            Stage::MoveMembers => p.members.record_move(pass, b, o, d),
        }
    }

    /// Advances every environment by one control step (S substeps, one submission) and reads
    /// back the health of each.
    fn step_kernels(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        self.upload_inlet();
        let mut enc = self
            .ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("control step"),
            });
        {
            let pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("substeps"),
                timestamp_writes: None,
            });
            self.record_control_step(&mut Recorder::new(pass));
        }
        self.submit_and_read_health(enc)
    }

    /// Bytes of a whole buffer (all environments).
    fn buffer_bytes(&self, which: FieldBinding) -> u64 {
        let words = if which == FieldBinding::Poisson {
            self.core.grid.ny * self.core.grid.ny + 2 * self.core.grid.n_cells()
        } else {
            self.words_per_env(which) * self.core.n_env
        };
        4 * words as u64
    }

    /// Compulsory memory traffic of one dispatch of each kernel (bytes): every buffer the
    /// kernel's shader reads or writes (per naga), counted once per read and once per write at
    /// its full size. An upper bound for kernels that touch part of a buffer (members).
    pub fn bytes_per_dispatch(&self) -> Vec<(String, u64)> {
        crate::gpu::traffic::kernel_accesses()
            .into_iter()
            .map(|k| {
                let bytes = k
                    .reads
                    .iter()
                    .chain(&k.writes)
                    .filter_map(|b| FieldBinding::from_index(*b))
                    .map(|b| self.buffer_bytes(b))
                    .sum();
                (k.entry, bytes)
            })
            .collect()
    }

    /// Whether the device can time each dispatch ([`Self::profile_step`]); never on the native
    /// backend.
    pub fn can_profile(&self) -> bool {
        let need = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        self.ctx.device.features().contains(need)
    }

    /// One control step exactly as [`Self::step`] records it, with a GPU timestamp before and
    /// after every dispatch; returns each kernel's dispatch count and total time over the step
    /// (s), in the order of first use. `None` where the adapter has no timestamps inside passes.
    pub fn profile_step(&mut self) -> Result<Option<KernelTimes>, SimError> {
        if !self.can_profile() {
            return Ok(None);
        }
        let capacity = 2 * self.dispatches_per_control_step();
        let set = self.ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let bytes = capacity as u64 * 8;
        let resolve = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps staging"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.upload_inlet();
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        let labels = {
            let pass = enc.begin_compute_pass(&Default::default());
            let mut rec = Recorder::timed(pass, &set, capacity);
            self.record_control_step(&mut rec);
            rec.labels().to_vec()
        };
        let used = 2 * labels.len() as u32;
        enc.resolve_query_set(&set, 0..used, &resolve, 0);
        enc.copy_buffer_to_buffer(&resolve, 0, &staging, 0, used as u64 * 8);
        self.submit_and_read_health(enc)?;
        let raw: Vec<u8> = map_and_read(&self.ctx, &staging, used as u64 * 8)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&raw);
        let period_s = self.ctx.queue.get_timestamp_period() as f64 * 1e-9;
        let mut totals: Vec<(&'static str, u32, f64)> = Vec::new();
        for (k, label) in labels.iter().enumerate() {
            let dt = ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64 * period_s;
            match totals.iter_mut().find(|t| t.0 == *label) {
                Some(t) => {
                    t.1 += 1;
                    t.2 += dt;
                }
                None => totals.push((label, 1, dt)),
            }
        }
        Ok(Some(totals))
    }

    /// Records the S substeps and the diagnostics of one control step and advances the clocks.
    fn record_control_step(&mut self, rec: &mut Recorder<'_>) {
        let mut cur = self.cur;
        for s in 0..self.core.substeps {
            for stage in [
                Stage::Advect,
                Stage::PressureRhs,
                Stage::PressureSolve,
                Stage::Project,
            ] {
                self.record_stage(rec, stage, cur, s);
            }
            if self.core.n_members > 0 {
                self.record_stage(rec, Stage::MoveMembers, cur, s);
            }
            cur = 1 - cur;
        }
        // The diagnostics read the "out" side: the bind group whose output is `cur`.
        self.record_stage(rec, Stage::Diagnostics, 1 - cur, 0);
        self.cur = cur;
        self.core.advance();
    }

    /// Health of the current state without stepping (e.g. of the initial state).
    fn health_kernels(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut rec = Recorder::new(enc.begin_compute_pass(&Default::default()));
            self.record_stage(&mut rec, Stage::Diagnostics, 1 - self.cur, 0);
        }
        self.submit_and_read_health(enc)
    }

    /// Appends the copy of the health buffer to `enc`, submits it and reads the health back:
    /// the one read-back of a control step (32 bytes per environment).
    /// With members, the copy also carries the members and their forces (32 + 48 bytes each).
    fn submit_and_read_health(
        &mut self,
        mut enc: wgpu::CommandEncoder,
    ) -> Result<Vec<EnvHealth>, SimError> {
        let health_bytes = (self.core.n_env * 32) as u64;
        let member_bytes = (self.core.n_env * self.core.n_members * 32) as u64;
        let diag_bytes = (self.core.n_env * self.core.n_members * 48) as u64;
        let b = &self.buffers;
        enc.copy_buffer_to_buffer(&b.health, 0, &b.health_staging, 0, health_bytes);
        if self.core.n_members > 0 {
            enc.copy_buffer_to_buffer(&b.members, 0, &b.health_staging, health_bytes, member_bytes);
            let at = health_bytes + member_bytes;
            enc.copy_buffer_to_buffer(&b.member_diag, 0, &b.health_staging, at, diag_bytes);
        }
        self.ctx.queue.submit([enc.finish()]);
        let total = health_bytes + member_bytes + diag_bytes;
        let raw: Vec<u8> = map_and_read(&self.ctx, &b.health_staging, total)?;
        let (h, rest) = raw.split_at(health_bytes as usize);
        let (m, d) = rest.split_at(member_bytes as usize);
        self.last_members = bytemuck::pod_collect_to_vec(m);
        self.last_diag = bytemuck::pod_collect_to_vec(d);
        let health: Vec<[[f32; 4]; 2]> = bytemuck::pod_collect_to_vec(h);
        Ok(health.iter().map(EnvHealth::from_raw).collect())
    }

    /// Runs the given stages of substep `s` once on the current bind group, without swapping
    /// the velocity buffers (for kernel tests and timing by elimination).
    pub fn run_stages(&self, stages: &[Stage], s: usize, repeats: usize) -> Result<(), SimError> {
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        {
            let mut rec = Recorder::new(enc.begin_compute_pass(&Default::default()));
            for _ in 0..repeats {
                for &stage in stages {
                    let bind = if stage == Stage::Diagnostics {
                        1 - self.cur
                    } else {
                        self.cur
                    };
                    self.record_stage(&mut rec, stage, bind, s);
                }
            }
        }
        self.ctx.queue.submit([enc.finish()]);
        self.ctx.wait()?;
        Ok(())
    }

    /// Writes the inlet values of the coming control step (exposed for kernel tests).
    pub fn prepare_inlet(&self) {
        self.upload_inlet();
    }
}

impl FlowBatch for GpuBatch {
    fn core(&self) -> &BatchCore {
        &self.core
    }

    fn core_mut(&mut self) -> &mut BatchCore {
        &mut self.core
    }

    fn backend_name(&self) -> &'static str {
        "adapter"
    }

    fn as_gpu_mut(&mut self) -> Option<&mut GpuBatch> {
        Some(self)
    }

    fn describe(&self) -> String {
        format!("WGSL kernels on {}", self.ctx.describe())
    }

    fn step(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        self.step_kernels()
    }

    fn health(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        self.health_kernels()
    }

    fn members(&self) -> &[GpuMember] {
        &self.last_members
    }

    fn member_forces(&self) -> &[GpuMemberDiag] {
        &self.last_diag
    }

    fn set_members(&mut self, e: usize, members: &[GpuMember]) -> Result<(), SimError> {
        let n = self.core.n_members;
        BatchCore::check_len("members", members.len(), n)?;
        self.write_env_pod(FieldBinding::Members, e, members)?;
        let b = swarm_box(members);
        // The last painted box is unknown after a jump: the next paint clears everywhere.
        let all = f32::MAX;
        self.write_env(
            FieldBinding::SwarmBox,
            e,
            &[b[0], b[1], b[2], b[3], -all, all, -all, all],
        )?;
        self.last_members[e * n..(e + 1) * n].copy_from_slice(members);
        Ok(())
    }

    fn set_actions(&mut self, e: usize, actions: &[[f32; 2]]) -> Result<(), SimError> {
        BatchCore::check_len("actions", actions.len(), self.core.n_members)?;
        self.write_env_pod(FieldBinding::Thrust, e, actions)
    }

    fn set_all_actions(&mut self, actions: &[[f32; 2]]) -> Result<(), SimError> {
        let want = self.core.n_env * self.core.n_members;
        BatchCore::check_len("actions of the batch", actions.len(), want)?;
        if want > 0 {
            self.ctx.queue.write_buffer(
                self.buffer(FieldBinding::Thrust),
                0,
                bytemuck::cast_slice(actions),
            );
        }
        Ok(())
    }

    fn set_body(&mut self, e: usize, cells: &[[f32; 4]]) -> Result<(), SimError> {
        BatchCore::check_len("body cells", cells.len(), self.core.grid.n_cells())?;
        self.write_env_pod(FieldBinding::Body, e, cells)
    }

    fn set_flow(&mut self, e: usize, u: &[f32], v: &[f32], p: &[f32]) -> Result<(), SimError> {
        self.write_env(FieldBinding::UIn, e, u)?;
        self.write_env(FieldBinding::VIn, e, v)?;
        self.write_env(FieldBinding::Pressure, e, p)
    }

    fn fields(&self, e: usize) -> Result<Fields, SimError> {
        let body: Vec<[f32; 4]> =
            bytemuck::pod_collect_to_vec(&self.read_env(FieldBinding::Body, e)?);
        Ok(Fields::with_bodies(
            &self.core.grid,
            self.read_env(FieldBinding::UIn, e)?,
            self.read_env(FieldBinding::VIn, e)?,
            self.read_env(FieldBinding::Pressure, e)?,
            &body,
        ))
    }

    fn state(&self) -> Result<BatchState, SimError> {
        self.to_cpu()
    }

    fn set_state(&mut self, state: &BatchState, forces: &[GpuMemberDiag]) -> Result<(), SimError> {
        self.core.check_state(state, forces)?;
        let (ne, n, g) = (self.core.n_env, self.core.n_members, self.core.grid);
        self.write_all(FieldBinding::UIn, &state.u);
        self.write_all(FieldBinding::VIn, &state.v);
        self.write_all(FieldBinding::Pressure, &state.p);
        self.write_all(FieldBinding::Body, bytemuck::cast_slice(&state.body));
        if state.divstar.len() == ne * g.nx {
            self.write_all(FieldBinding::DivStar, &state.divstar);
        }
        if n > 0 {
            self.write_all(FieldBinding::MemberDiag, bytemuck::cast_slice(forces));
            self.set_all_actions(&state.actions)?;
            for e in 0..ne {
                self.set_members(e, &state.members[e * n..(e + 1) * n])?;
            }
        }
        self.last_diag = forces.to_vec();
        Ok(())
    }
}

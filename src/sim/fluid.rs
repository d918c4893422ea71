//! A batch of E channel flows on the GPU, advanced one control step (S substeps) per
//! submission with no read-back in between; after the step one small read-back of the health
//! of every environment.
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

mod checkpoint;

use thiserror::Error;
use wgpu::util::DeviceExt;

use std::cell::RefCell;

use super::cpu::CpuBatch;
use super::native::NativeBatch;
use super::{EnvHealth, Grid, poisson::PoissonTables};
use crate::config::{Advection, Backend, Backtrace, Resolved};
use crate::gpu::kernels::{
    Advect, BindGroups, Dims, FieldBinding, Kernels, Recorder, map_and_read, read_buffer,
};
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams, SubstepUniform};
use crate::gpu::{GpuContext, GpuError};
use crate::waveform::Waveform;

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

/// Cell-centred fields of one environment, [ny][nx], row 0 at the bottom wall.
#[derive(Debug, Clone)]
pub struct Fields {
    pub nx: usize,
    pub ny: usize,
    /// Face velocities as stored: u [ny][nx+1], v [ny+1][nx] (m/s).
    pub u_faces: Vec<f32>,
    pub v_faces: Vec<f32>,
    /// Pressure at cell centres (Pa).
    pub p: Vec<f32>,
}

impl Fields {
    /// u_x at cell centres (mean of the two faces), [ny][nx].
    pub fn ux_cells(&self) -> Vec<f32> {
        let (nx, ny) = (self.nx, self.ny);
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .map(|(j, i)| {
                0.5 * (self.u_faces[j * (nx + 1) + i] + self.u_faces[j * (nx + 1) + i + 1])
            })
            .collect()
    }

    /// u_y at cell centres, [ny][nx].
    pub fn uy_cells(&self) -> Vec<f32> {
        let (nx, ny) = (self.nx, self.ny);
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .map(|(j, i)| 0.5 * (self.v_faces[j * nx + i] + self.v_faces[(j + 1) * nx + i]))
            .collect()
    }
}

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

/// E channel flows advanced together.
pub struct FluidBatch {
    ctx_device: wgpu::Device,
    ctx_queue: wgpu::Queue,
    grid: Grid,
    params: GpuParams,
    scheme: Advection,
    /// `pressure_scan` instead of `pressure_solve` (`solver.pressure_sweep`, resolved).
    scan_sweep: bool,
    waveform: Waveform,
    n_env: usize,
    substeps: usize,
    control_dt: f64,
    density: f64,
    viscosity: f64,
    substep_stride: u32,
    pipelines: Pipelines,
    buffers: Buffers,
    /// Every pipeline's bind groups; side g reads u[g], v[g] and writes u[1-g], v[1-g].
    bind: BindGroups,
    /// Which of u[0], u[1] holds the current field.
    cur: usize,
    /// Time of each environment (s), measured from its reset.
    time_s: Vec<f64>,
    /// Waveform phase offset of each environment (s).
    phase_s: Vec<f64>,
    /// Members per environment, their initial centres (m) and pinned flags.
    n_members: usize,
    initial_members: Vec<GpuMember>,
    /// Members and their forces as read back with the health after the last step.
    last_members: Vec<GpuMember>,
    last_diag: Vec<GpuMemberDiag>,
    steps: u64,
    /// With `solver.backend = "native"`: the native step's state (see [`NativeMode`]).
    native: Option<NativeMode>,
}

/// The native backend inside a batch: the control step runs on the CPU (`sim::native`), and the
/// device buffers stay the batch's state of record. Every write to them marks the environment
/// stale, and the next step first takes its state back from the buffers; every step writes its
/// results back, so reads (fields, checkpoints, frames) see the same state as on the adapter.
struct NativeMode {
    batch: NativeBatch,
    /// Environments written on the device since the native state was taken from it.
    stale: RefCell<Vec<bool>>,
    /// Raw actions [E][N], kept on the CPU as well (written every step).
    actions: RefCell<Vec<[f32; 2]>>,
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
/// the CPU twins and the native yardstick take the same struct).
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

impl FluidBatch {
    pub fn new(ctx: &GpuContext, resolved: &Resolved, n_env: usize) -> Result<Self, SimError> {
        let config = &resolved.config;
        let grid = Grid::from_config(config);
        if n_env == 0 {
            return Err(SimError::Empty);
        }
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
        let substeps = config.time.substeps as usize;
        let swarm = &config.swarm;
        let n_members = swarm.count as usize;
        let initial_members: Vec<GpuMember> = swarm
            .initial_positions(grid.height_m)
            .iter()
            .enumerate()
            .map(|(k, p)| GpuMember {
                pos: [p[0] as f32, p[1] as f32],
                vel: [0.0; 2],
                pinned: swarm.pinned.contains(&(k as u32)) as u32 as f32,
                pad: [0.0; 3],
            })
            .collect();
        let params = batch_params(resolved, n_env);
        let device = &ctx.device;
        // Fails with GpuError::Limit where a kernel needs more than the adapter allows.
        let pipelines = Pipelines::new(ctx)?;
        let stride = ctx.limits.min_uniform_buffer_offset_alignment.max(16);
        let buffers = Self::create_buffers(ctx, &grid, &params, n_env, substeps, n_members, stride);
        let bind = Self::bind_groups(device, &pipelines, &buffers);
        let mut batch = Self {
            ctx_device: device.clone(),
            ctx_queue: ctx.queue.clone(),
            grid,
            params,
            scheme: config.solver.advection,
            scan_sweep: config.solver.pressure_sweep.uses_scan(ctx.is_software()),
            waveform: resolved.waveform.clone(),
            n_env,
            substeps,
            control_dt: config.time.control_dt_s,
            density: config.fluid.density_kg_m3,
            viscosity: config.fluid.viscosity_pa_s,
            substep_stride: stride,
            pipelines,
            buffers,
            bind,
            cur: 0,
            time_s: vec![0.0; n_env],
            phase_s: vec![0.0; n_env],
            n_members,
            last_members: (0..n_env)
                .flat_map(|_| initial_members.iter().copied())
                .collect(),
            last_diag: vec![GpuMemberDiag::default(); n_env * n_members],
            initial_members,
            steps: 0,
            native: None,
        };
        for e in 0..n_env {
            batch.reset_env(e)?;
        }
        if config.solver.backend == Backend::Native {
            log::info!(
                "control step: native backend (plain Rust on {} threads, solver.backend = \"native\"); the adapter only keeps the buffers",
                rayon::current_num_threads()
            );
            let start = batch.to_cpu(ctx)?;
            batch.native = Some(NativeMode {
                batch: NativeBatch::new(&start, batch.waveform.clone(), batch.control_dt),
                stale: RefCell::new(vec![false; n_env]),
                actions: RefCell::new(start.actions.clone()),
            });
        }
        Ok(batch)
    }

    /// The kernel of the tridiagonal solve: "scan" or "sequential" (`solver.pressure_sweep`).
    pub fn pressure_sweep(&self) -> &'static str {
        if self.scan_sweep {
            "scan"
        } else {
            "sequential"
        }
    }

    /// Whether the control step runs natively on the CPU (`solver.backend = "native"`).
    pub fn is_native(&self) -> bool {
        self.native.is_some()
    }

    /// Marks environment e (all, with `None`) as written on the device; writes of the raw
    /// actions also go to the native copy.
    fn device_written(&self, which: FieldBinding, e: Option<usize>, bytes: &[u8]) {
        let Some(native) = &self.native else {
            return;
        };
        if which == FieldBinding::Thrust {
            let values: Vec<[f32; 2]> = bytemuck::pod_collect_to_vec(bytes);
            let mut actions = native.actions.borrow_mut();
            let n = self.n_members;
            match e {
                Some(e) => actions[e * n..(e + 1) * n].copy_from_slice(&values),
                None => {
                    let len = actions.len();
                    actions.copy_from_slice(&values[..len]);
                }
            }
            return;
        }
        let mut stale = native.stale.borrow_mut();
        match e {
            Some(e) => stale[e] = true,
            None => stale.fill(true),
        }
    }

    /// Environment e's state from the device buffers, as a single-environment [`CpuBatch`].
    fn env_to_cpu(
        &self,
        ctx: &GpuContext,
        e: usize,
        poisson: &[f32],
    ) -> Result<CpuBatch, SimError> {
        self.cpu_batch_from(1, poisson.to_vec(), |w| self.read_env(ctx, w, e))
    }

    /// A [`CpuBatch`] of `n_env` environments from `read`, which returns a buffer's words for
    /// those environments.
    fn cpu_batch_from(
        &self,
        n_env: usize,
        poisson: Vec<f32>,
        read: impl Fn(FieldBinding) -> Result<Vec<f32>, SimError>,
    ) -> Result<CpuBatch, SimError> {
        let quads = |v: Vec<f32>| -> Vec<[f32; 4]> {
            v.chunks(4).map(|c| [c[0], c[1], c[2], c[3]]).collect()
        };
        let n = n_env * self.n_members;
        let (members, actions, boxes) = if self.n_members > 0 {
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
        Ok(CpuBatch {
            params: GpuParams {
                n_env: n_env as u32,
                ..self.params
            },
            scheme: self.scheme,
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

    /// One control step on the CPU: take back stale environments, step, write the results
    /// to the device buffers (velocity, pressure, body, divergence, members, their forces,
    /// swarm boxes) and advance the clocks.
    fn step_native(&mut self, ctx: &GpuContext) -> Result<Vec<EnvHealth>, SimError> {
        let inlet = self.inlet_values();
        // Read the stale environments before taking the native state out of `self`, so that a
        // failed read leaves the batch in native mode with those environments still stale.
        let mut fresh = Vec::new();
        if let Some(native) = &self.native {
            let stale: Vec<usize> = (0..self.n_env)
                .filter(|&e| native.stale.borrow()[e])
                .collect();
            for e in stale {
                let poisson = &native.batch.env(e).poisson;
                fresh.push((e, self.env_to_cpu(ctx, e, poisson)?));
            }
        }
        let mut native = self.native.take().expect("native mode");
        for (e, env) in fresh {
            native.batch.replace_env(e, env);
        }
        native.stale.borrow_mut().fill(false);
        let n = self.n_members;
        if n > 0 {
            let actions = native.actions.borrow().clone();
            for e in 0..self.n_env {
                native.batch.set_actions(e, &actions[e * n..(e + 1) * n]);
            }
        }
        let health = native.batch.step_with_inlet(&inlet);
        let mut members = Vec::with_capacity(self.n_env * n);
        let mut diags = Vec::with_capacity(self.n_env * n);
        for e in 0..self.n_env {
            let env = native.batch.env(e);
            let put = |which: FieldBinding, bytes: &[u8]| {
                let at = (e * self.words_per_env(which) * 4) as u64;
                self.ctx_queue.write_buffer(self.buffer(which), at, bytes);
            };
            put(FieldBinding::UIn, bytemuck::cast_slice(&env.u));
            put(FieldBinding::VIn, bytemuck::cast_slice(&env.v));
            put(FieldBinding::Pressure, bytemuck::cast_slice(&env.p));
            put(FieldBinding::Body, bytemuck::cast_slice(&env.body));
            put(FieldBinding::DivStar, bytemuck::cast_slice(&env.divstar));
            if n > 0 {
                let b = env.boxes[0];
                put(FieldBinding::Members, bytemuck::cast_slice(&env.members));
                put(
                    FieldBinding::MemberDiag,
                    bytemuck::cast_slice(native.batch.diags(e)),
                );
                put(FieldBinding::SwarmBox, bytemuck::cast_slice(&[b, b]));
                members.extend_from_slice(&env.members);
                diags.extend_from_slice(native.batch.diags(e));
            }
        }
        self.native = Some(native);
        self.last_members = members;
        self.last_diag = diags;
        for t in &mut self.time_s {
            *t += self.control_dt;
        }
        self.steps += 1;
        Ok(health)
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

    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    pub fn n_env(&self) -> usize {
        self.n_env
    }

    pub fn substeps(&self) -> usize {
        self.substeps
    }

    pub fn params(&self) -> &GpuParams {
        &self.params
    }

    pub fn scheme(&self) -> Advection {
        self.scheme
    }

    pub fn waveform(&self) -> &Waveform {
        &self.waveform
    }

    pub fn control_dt(&self) -> f64 {
        self.control_dt
    }

    /// Control steps taken since the batch was created.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Time of environment e since its reset (s).
    pub fn time_s(&self, e: usize) -> f64 {
        self.time_s[e]
    }

    /// Inlet centreline velocity of environment e `dt` seconds from now (m/s).
    pub fn inlet_u_after(&self, e: usize, dt: f64) -> f64 {
        self.waveform.at(self.time_s[e] + self.phase_s[e] + dt)
    }

    /// Inlet centreline velocity of environment e now (m/s).
    pub fn inlet_u(&self, e: usize) -> f64 {
        self.waveform.at(self.time_s[e] + self.phase_s[e])
    }

    /// Dispatches per substep (advection scheme dependent) and per control step.
    pub fn dispatches_per_substep(&self) -> u32 {
        // With members: `move_members`; the paint runs inside `diffuse`.
        Advect::dispatches(self.scheme) + 4 + if self.n_members > 0 { 1 } else { 0 }
    }

    pub fn dispatches_per_control_step(&self) -> u32 {
        self.dispatches_per_substep() * self.substeps as u32 + 2
    }

    fn check_env(&self, e: usize) -> Result<(), SimError> {
        if e < self.n_env {
            Ok(())
        } else {
            Err(SimError::NoSuchEnv(e))
        }
    }

    /// Resets environment e to the developed Poiseuille flow of U(phase) with its linear
    /// pressure, time 0, waveform phase 0, no solid.
    pub fn reset_env(&mut self, e: usize) -> Result<(), SimError> {
        self.reset_env_with_phase(e, 0.0)
    }

    /// As [`Self::reset_env`], starting the waveform at `phase_s`.
    pub fn reset_env_with_phase(&mut self, e: usize, phase_s: f64) -> Result<(), SimError> {
        self.check_env(e)?;
        self.time_s[e] = 0.0;
        self.phase_s[e] = phase_s;
        let g = self.grid;
        let u0 = self.waveform.at(phase_s);
        let mut u = vec![0.0f32; g.n_u()];
        for j in 0..g.ny {
            let w = g.inlet_profile(u0, j) as f32;
            u[j * (g.nx + 1)..(j + 1) * (g.nx + 1)].fill(w);
        }
        let v = vec![0.0f32; g.n_v()];
        // Poiseuille: dp/dx = -8 mu U / H^2, p = 0 at the outlet face.
        let grad = 8.0 * self.viscosity * u0 / (g.height_m * g.height_m);
        let p: Vec<f32> = (0..g.n_cells())
            .map(|c| {
                let x = ((c % g.nx) as f64 + 0.5) * g.dx();
                (grad * (g.length_m - x)) as f32
            })
            .collect();
        self.write_env(FieldBinding::UIn, e, &u)?;
        self.write_env(FieldBinding::VIn, e, &v)?;
        self.write_env(FieldBinding::Pressure, e, &p)?;
        self.set_body(e, &vec![[0.0; 4]; g.n_cells()])?;
        if self.n_members > 0 {
            let members = self.initial_members.clone();
            self.set_members(e, &members)?;
            self.set_actions(e, &vec![[0.0; 2]; self.n_members])?;
        }
        Ok(())
    }

    /// Members per environment.
    pub fn n_members(&self) -> usize {
        self.n_members
    }

    /// Places the members of environment e (positions, velocities, pinned flags).
    pub fn set_members(&mut self, e: usize, members: &[GpuMember]) -> Result<(), SimError> {
        assert_eq!(members.len(), self.n_members, "one entry per member");
        self.write_env_pod(FieldBinding::Members, e, members)?;
        let (xs, ys): (Vec<f32>, Vec<f32>) = members.iter().map(|m| (m.pos[0], m.pos[1])).unzip();
        let lo = |v: &[f32]| v.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = |v: &[f32]| v.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        // The last painted box is unknown after a jump: the next paint clears everywhere.
        let all = f32::MAX;
        self.write_env(
            FieldBinding::SwarmBox,
            e,
            &[lo(&xs), hi(&xs), lo(&ys), hi(&ys), -all, all, -all, all],
        )?;
        let k = e * self.n_members;
        if self.last_members.len() >= k + self.n_members {
            self.last_members[k..k + self.n_members].copy_from_slice(members);
        }
        Ok(())
    }

    /// Sets the raw actions a (one [ax, ay] per member) of environment e for the coming
    /// steps; the kernels apply F_prop = F_max a / max(1, |a|).
    pub fn set_actions(&self, e: usize, actions: &[[f32; 2]]) -> Result<(), SimError> {
        assert_eq!(actions.len(), self.n_members, "one action per member");
        self.write_env_pod(FieldBinding::Thrust, e, actions)
    }

    /// Raw actions of every environment at once, [E][N].
    pub fn set_all_actions(&self, actions: &[[f32; 2]]) {
        assert_eq!(
            actions.len(),
            self.n_env * self.n_members,
            "one action per member"
        );
        self.ctx_queue.write_buffer(
            self.buffer(FieldBinding::Thrust),
            0,
            bytemuck::cast_slice(actions),
        );
        self.device_written(FieldBinding::Thrust, None, bytemuck::cast_slice(actions));
    }

    /// Members of every environment, [E][N], as read back with the last step's health.
    pub fn members(&self) -> &[GpuMember] {
        &self.last_members
    }

    /// Forces and pressure samples of every member during the last substep, [E][N].
    pub fn member_forces(&self) -> &[GpuMemberDiag] {
        &self.last_diag
    }

    /// Sets the solid fraction and body velocity of every cell of environment e:
    /// `[chi, u_body, v_body, 0]`, [ny][nx] (chi in [0, 1]). A batch with members repaints
    /// the body field from them every substep, so this is for member-free batches.
    pub fn set_body(&mut self, e: usize, cells: &[[f32; 4]]) -> Result<(), SimError> {
        self.check_env(e)?;
        assert_eq!(
            cells.len(),
            self.grid.n_cells(),
            "body needs one entry per cell"
        );
        self.write_env_pod(FieldBinding::Body, e, cells)
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
        let g = &self.grid;
        match which {
            FieldBinding::UIn | FieldBinding::UOut | FieldBinding::WU => g.n_u(),
            FieldBinding::VIn | FieldBinding::VOut | FieldBinding::WV => g.n_v(),
            FieldBinding::UHat => 4 * g.n_u(),
            FieldBinding::VHat => 4 * g.n_v(),
            FieldBinding::Pressure | FieldBinding::Modes => g.n_cells(),
            FieldBinding::Body => 4 * g.n_cells(),
            FieldBinding::Inlet => self.substeps,
            FieldBinding::Poisson => 0,
            FieldBinding::DivStar => g.nx,
            FieldBinding::ColStats => 4 * (g.nx + 1),
            FieldBinding::Health => 8,
            FieldBinding::Members => 8 * self.n_members,
            FieldBinding::MemberDiag => 12 * self.n_members,
            FieldBinding::Thrust => 2 * self.n_members,
            FieldBinding::SwarmBox => 8,
        }
    }

    fn write_env_pod<T: bytemuck::Pod>(
        &self,
        which: FieldBinding,
        e: usize,
        data: &[T],
    ) -> Result<(), SimError> {
        self.check_env(e)?;
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let per_env = self.words_per_env(which) * 4;
        assert_eq!(
            bytes.len(),
            per_env,
            "{which:?}: wrong length for one environment"
        );
        self.ctx_queue
            .write_buffer(self.buffer(which), (e * per_env) as u64, bytes);
        self.device_written(which, Some(e), bytes);
        Ok(())
    }

    /// Overwrites environment e's part of a buffer (`UIn`/`VIn` are the current field).
    pub fn write_env(&self, which: FieldBinding, e: usize, data: &[f32]) -> Result<(), SimError> {
        self.write_env_pod(which, e, data)
    }

    /// Overwrites a whole buffer (all environments).
    pub fn write_all(&self, which: FieldBinding, data: &[f32]) {
        self.ctx_queue
            .write_buffer(self.buffer(which), 0, bytemuck::cast_slice(data));
        self.device_written(which, None, bytemuck::cast_slice(data));
    }

    /// Reads a whole buffer (all environments).
    pub fn read_all(&self, ctx: &GpuContext, which: FieldBinding) -> Result<Vec<f32>, SimError> {
        let words = if which == FieldBinding::Poisson {
            self.grid.ny * self.grid.ny + 2 * self.grid.n_cells()
        } else {
            self.words_per_env(which) * self.n_env
        };
        Ok(read_buffer(ctx, self.buffer(which), 0, (words * 4) as u64)?)
    }

    /// The whole batch's current state as a [`CpuBatch`] (fields, body, members, raw actions,
    /// swarm boxes, Poisson tables): the starting point of the CPU twins and the native
    /// yardstick. A full read-back; not for the stepping loop.
    pub fn to_cpu(&self, ctx: &GpuContext) -> Result<CpuBatch, SimError> {
        let poisson = self.read_all(ctx, FieldBinding::Poisson)?;
        self.cpu_batch_from(self.n_env, poisson, |w| self.read_all(ctx, w))
    }

    /// Reads environment e's part of a buffer.
    pub fn read_env(
        &self,
        ctx: &GpuContext,
        which: FieldBinding,
        e: usize,
    ) -> Result<Vec<f32>, SimError> {
        self.check_env(e)?;
        let bytes = (self.words_per_env(which) * 4) as u64;
        Ok(read_buffer(
            ctx,
            self.buffer(which),
            e as u64 * bytes,
            bytes,
        )?)
    }

    /// The current velocity and pressure of environment e (a full-field read-back).
    pub fn fields(&self, ctx: &GpuContext, e: usize) -> Result<Fields, SimError> {
        let g = self.grid;
        let mut u_faces = self.read_env(ctx, FieldBinding::UIn, e)?;
        let mut v_faces = self.read_env(ctx, FieldBinding::VIn, e)?;
        // Solid cells hold the body velocity (SPEC section 7): set the faces of solid cells.
        let body = self.read_env(ctx, FieldBinding::Body, e)?;
        for j in 0..g.ny {
            for i in 0..g.nx {
                let c = 4 * g.c_idx(i, j);
                let [chi, ub, vb] = [body[c], body[c + 1], body[c + 2]];
                if chi >= 0.5 {
                    u_faces[g.u_idx(i, j)] = ub;
                    u_faces[g.u_idx(i + 1, j)] = ub;
                    v_faces[g.v_idx(i, j)] = vb;
                    v_faces[g.v_idx(i, j + 1)] = vb;
                }
            }
        }
        Ok(Fields {
            nx: g.nx,
            ny: g.ny,
            u_faces,
            v_faces,
            p: self.read_env(ctx, FieldBinding::Pressure, e)?,
        })
    }

    /// Writes the inlet centreline velocity of every environment at the end of every substep
    /// of the coming control step.
    fn upload_inlet(&self) {
        self.write_all(FieldBinding::Inlet, &self.inlet_values());
    }

    /// The inlet centreline velocity of every environment at the end of every substep of the
    /// coming control step, [E][S] (m/s).
    fn inlet_values(&self) -> Vec<f32> {
        (0..self.n_env)
            .flat_map(|e| {
                let t0 = self.time_s[e] + self.phase_s[e];
                self.waveform
                    .substep_values(t0, self.control_dt, self.substeps)
            })
            .collect()
    }

    fn offset(&self, s: usize) -> u32 {
        s as u32 * self.substep_stride
    }

    fn dims(&self) -> Dims {
        Dims {
            nx: self.grid.nx as u32,
            ny: self.grid.ny as u32,
            n_env: self.n_env as u32,
        }
    }

    fn record_stage(&self, pass: &mut Recorder<'_>, stage: Stage, bind: usize, s: usize) {
        let (b, o, d) = (self.bind.side(bind), self.offset(s), self.dims());
        let p = &self.pipelines;
        match stage {
            Stage::Advect => p.advect.record(pass, b, o, d, self.scheme),
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
    pub fn step(&mut self, ctx: &GpuContext) -> Result<Vec<EnvHealth>, SimError> {
        if self.native.is_some() {
            return self.step_native(ctx);
        }
        self.upload_inlet();
        let mut enc = self
            .ctx_device
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
        self.submit_and_read_health(ctx, enc)
    }

    /// Bytes of a whole buffer (all environments).
    fn buffer_bytes(&self, which: FieldBinding) -> u64 {
        let words = if which == FieldBinding::Poisson {
            self.grid.ny * self.grid.ny + 2 * self.grid.n_cells()
        } else {
            self.words_per_env(which) * self.n_env
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
        if self.native.is_some() {
            return false; // the native step has no dispatches to time
        }
        let need = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        self.ctx_device.features().contains(need)
    }

    /// One control step exactly as [`Self::step`] records it, with a GPU timestamp before and
    /// after every dispatch; returns each kernel's dispatch count and total time over the step
    /// (s), in the order of first use. `None` where the adapter has no timestamps inside passes.
    pub fn profile_step(&mut self, ctx: &GpuContext) -> Result<Option<KernelTimes>, SimError> {
        if !self.can_profile() {
            return Ok(None);
        }
        let capacity = 2 * self.dispatches_per_control_step();
        let set = self.ctx_device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: capacity,
        });
        let bytes = capacity as u64 * 8;
        let resolve = self.ctx_device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = self.ctx_device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps staging"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.upload_inlet();
        let mut enc = self.ctx_device.create_command_encoder(&Default::default());
        let labels = {
            let pass = enc.begin_compute_pass(&Default::default());
            let mut rec = Recorder::timed(pass, &set, capacity);
            self.record_control_step(&mut rec);
            rec.labels().to_vec()
        };
        let used = 2 * labels.len() as u32;
        enc.resolve_query_set(&set, 0..used, &resolve, 0);
        enc.copy_buffer_to_buffer(&resolve, 0, &staging, 0, used as u64 * 8);
        self.submit_and_read_health(ctx, enc)?;
        let raw: Vec<u8> = map_and_read(ctx, &staging, used as u64 * 8)?;
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&raw);
        let period_s = self.ctx_queue.get_timestamp_period() as f64 * 1e-9;
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
        for s in 0..self.substeps {
            for stage in [
                Stage::Advect,
                Stage::PressureRhs,
                Stage::PressureSolve,
                Stage::Project,
            ] {
                self.record_stage(rec, stage, cur, s);
            }
            if self.n_members > 0 {
                self.record_stage(rec, Stage::MoveMembers, cur, s);
            }
            cur = 1 - cur;
        }
        // The diagnostics read the "out" side: the bind group whose output is `cur`.
        self.record_stage(rec, Stage::Diagnostics, 1 - cur, 0);
        self.cur = cur;
        for t in &mut self.time_s {
            *t += self.control_dt;
        }
        self.steps += 1;
    }

    /// Health of the current state without stepping (e.g. of the initial state).
    pub fn health(&mut self, ctx: &GpuContext) -> Result<Vec<EnvHealth>, SimError> {
        let mut enc = self.ctx_device.create_command_encoder(&Default::default());
        {
            let mut rec = Recorder::new(enc.begin_compute_pass(&Default::default()));
            self.record_stage(&mut rec, Stage::Diagnostics, 1 - self.cur, 0);
        }
        self.submit_and_read_health(ctx, enc)
    }

    /// Appends the copy of the health buffer to `enc`, submits it and reads the health back:
    /// the one read-back of a control step (32 bytes per environment).
    /// With members, the copy also carries the members and their forces (32 + 48 bytes each).
    fn submit_and_read_health(
        &mut self,
        ctx: &GpuContext,
        mut enc: wgpu::CommandEncoder,
    ) -> Result<Vec<EnvHealth>, SimError> {
        let health_bytes = (self.n_env * 32) as u64;
        let member_bytes = (self.n_env * self.n_members * 32) as u64;
        let diag_bytes = (self.n_env * self.n_members * 48) as u64;
        let b = &self.buffers;
        enc.copy_buffer_to_buffer(&b.health, 0, &b.health_staging, 0, health_bytes);
        if self.n_members > 0 {
            enc.copy_buffer_to_buffer(&b.members, 0, &b.health_staging, health_bytes, member_bytes);
            let at = health_bytes + member_bytes;
            enc.copy_buffer_to_buffer(&b.member_diag, 0, &b.health_staging, at, diag_bytes);
        }
        self.ctx_queue.submit([enc.finish()]);
        let total = health_bytes + member_bytes + diag_bytes;
        let raw: Vec<u8> = map_and_read(ctx, &b.health_staging, total)?;
        let (h, rest) = raw.split_at(health_bytes as usize);
        let (m, d) = rest.split_at(member_bytes as usize);
        self.last_members = bytemuck::pod_collect_to_vec(m);
        self.last_diag = bytemuck::pod_collect_to_vec(d);
        let health: Vec<[[f32; 4]; 2]> = bytemuck::pod_collect_to_vec(h);
        Ok(health.iter().map(EnvHealth::from_raw).collect())
    }

    /// Runs the given stages of substep `s` once on the current bind group, without swapping
    /// the velocity buffers (for kernel tests and timing by elimination).
    pub fn run_stages(
        &self,
        ctx: &GpuContext,
        stages: &[Stage],
        s: usize,
        repeats: usize,
    ) -> Result<(), SimError> {
        let mut enc = self.ctx_device.create_command_encoder(&Default::default());
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
        self.ctx_queue.submit([enc.finish()]);
        // The kernels wrote the device buffers: a native batch takes them back at its next step.
        if let Some(native) = &self.native {
            native.stale.borrow_mut().fill(true);
        }
        ctx.wait()?;
        Ok(())
    }

    /// Writes the inlet values of the coming control step (exposed for kernel tests).
    pub fn prepare_inlet(&self) {
        self.upload_inlet();
    }

    /// Density (kg/m^3) and dynamic viscosity (Pa s) of the fluid.
    pub fn fluid_properties(&self) -> (f64, f64) {
        (self.density, self.viscosity)
    }
}

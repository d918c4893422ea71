//! The one interface of a batch of E channel flows, whichever backend runs it: the WGSL kernels
//! ([`crate::sim::GpuBatch`]) or the CPU stages ([`crate::sim::CpuBatch`]). Both hold the same
//! state, per environment (environment index outermost):
//! u `[ny][nx+1]`, v `[ny+1][nx]`, p `[ny][nx]`, body `[ny][nx]` (chi, u_body, v_body, 0), members,
//! their raw actions and last forces `[N]`, the swarm box, and a clock (time since reset and
//! waveform phase). [`FlowBatch::state`] / [`FlowBatch::set_state`] move that state between
//! backends as a [`BatchState`]; checkpoints store it in one format for both.

use crate::checkpoint::Archive;
use crate::config::{Advection, Resolved};
use crate::gpu::params::{GpuMember, GpuMemberDiag, GpuParams};
use crate::waveform::Waveform;

use super::cpu::BatchState;
use super::{EnvHealth, Grid, SimError, poisson::PoissonTables};

/// Cell-centred fields of one environment, `[ny][nx]`, row 0 at the bottom wall.
#[derive(Debug, Clone)]
pub struct Fields {
    /// Cells along x.
    pub nx: usize,
    /// Cells across the height.
    pub ny: usize,
    /// Face velocities as stored: u `[ny][nx+1]`, v `[ny+1][nx]` (m/s).
    pub u_faces: Vec<f32>,
    /// v face velocities `[ny+1][nx]` (m/s).
    pub v_faces: Vec<f32>,
    /// Pressure at cell centres (Pa).
    pub p: Vec<f32>,
}

impl Fields {
    /// The fields of one environment from its faces, pressure and body; solid cells hold the
    /// body velocity (SPEC section 7), so the faces of every cell with chi >= 1/2 are set to it.
    pub fn with_bodies(
        g: &Grid,
        mut u_faces: Vec<f32>,
        mut v_faces: Vec<f32>,
        p: Vec<f32>,
        body: &[[f32; 4]],
    ) -> Self {
        for j in 0..g.ny {
            for i in 0..g.nx {
                let [chi, ub, vb, _] = body[g.c_idx(i, j)];
                if chi >= 0.5 {
                    u_faces[g.u_idx(i, j)] = ub;
                    u_faces[g.u_idx(i + 1, j)] = ub;
                    v_faces[g.v_idx(i, j)] = vb;
                    v_faces[g.v_idx(i, j + 1)] = vb;
                }
            }
        }
        Self {
            nx: g.nx,
            ny: g.ny,
            u_faces,
            v_faces,
            p,
        }
    }

    /// u_x at cell centres (mean of the two faces), `[ny][nx]`.
    pub fn ux_cells(&self) -> Vec<f32> {
        let (nx, ny) = (self.nx, self.ny);
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .map(|(j, i)| {
                0.5 * (self.u_faces[j * (nx + 1) + i] + self.u_faces[j * (nx + 1) + i + 1])
            })
            .collect()
    }

    /// u_y at cell centres, `[ny][nx]`.
    pub fn uy_cells(&self) -> Vec<f32> {
        let (nx, ny) = (self.nx, self.ny);
        (0..ny)
            .flat_map(|j| (0..nx).map(move |i| (j, i)))
            .map(|(j, i)| 0.5 * (self.v_faces[j * nx + i] + self.v_faces[(j + 1) * nx + i]))
            .collect()
    }
}

/// What every backend's batch shares: the configuration's constants, the Poisson tables and
/// the clock of each environment.
#[derive(Debug, Clone)]
pub struct BatchCore {
    /// The channel's grid.
    pub grid: Grid,
    /// Batch-wide kernel constants.
    pub params: GpuParams,
    /// Advection scheme.
    pub scheme: Advection,
    /// Inlet centreline-velocity waveform.
    pub waveform: Waveform,
    /// Environments in the batch (E).
    pub n_env: usize,
    /// Members per environment (N).
    pub n_members: usize,
    /// Fluid substeps per control step (S).
    pub substeps: usize,
    /// Control step length (s).
    pub control_dt: f64,
    /// Density (kg/m^3) and dynamic viscosity (Pa s).
    pub density: f64,
    /// Dynamic viscosity (Pa s).
    pub viscosity: f64,
    /// The fast solver's tables as the kernels read them ([`PoissonTables::to_gpu`]).
    pub poisson: Vec<f32>,
    /// Members at reset: configured centres, at rest, pinned flags.
    pub initial_members: Vec<GpuMember>,
    /// Time of each environment since its reset and its waveform phase offset (s).
    pub time_s: Vec<f64>,
    /// Waveform phase offset of each environment (s), `[E]`.
    pub phase_s: Vec<f64>,
    /// Control steps taken since the batch was created.
    pub steps: u64,
}

impl BatchCore {
    /// The shared state of an `n_env`-environment batch, every clock at zero.
    pub fn new(resolved: &Resolved, n_env: usize) -> Result<Self, SimError> {
        if n_env == 0 {
            return Err(SimError::Empty);
        }
        let config = &resolved.config;
        let grid = Grid::from_config(config);
        let swarm = &config.swarm;
        let initial_members = swarm
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
        Ok(Self {
            grid,
            params: super::batch_params(resolved, n_env),
            scheme: config.solver.advection,
            waveform: resolved.waveform.clone(),
            n_env,
            n_members: swarm.count as usize,
            substeps: config.time.substeps as usize,
            control_dt: config.time.control_dt_s,
            density: config.fluid.density_kg_m3,
            viscosity: config.fluid.viscosity_pa_s,
            poisson: PoissonTables::new(&grid).to_gpu(),
            initial_members,
            time_s: vec![0.0; n_env],
            phase_s: vec![0.0; n_env],
            steps: 0,
        })
    }

    /// An error unless environment `e` exists.
    pub fn check_env(&self, e: usize) -> Result<(), SimError> {
        if e < self.n_env {
            Ok(())
        } else {
            Err(SimError::NoSuchEnv(e))
        }
    }

    /// An error unless `got` equals `want` (the length of an array handed to the batch).
    pub fn check_len(what: &'static str, got: usize, want: usize) -> Result<(), SimError> {
        if got == want {
            Ok(())
        } else {
            Err(SimError::WrongLength { what, got, want })
        }
    }

    /// An error unless `state` and `forces` have this batch's shape (every array's length).
    pub fn check_state(
        &self,
        state: &BatchState,
        forces: &[GpuMemberDiag],
    ) -> Result<(), SimError> {
        let (ne, n, g) = (self.n_env, self.n_members, self.grid);
        Self::check_len("u faces of the batch", state.u.len(), ne * g.n_u())?;
        Self::check_len("v faces of the batch", state.v.len(), ne * g.n_v())?;
        Self::check_len(
            "pressure cells of the batch",
            state.p.len(),
            ne * g.n_cells(),
        )?;
        Self::check_len(
            "body cells of the batch",
            state.body.len(),
            ne * g.n_cells(),
        )?;
        Self::check_len("members of the batch", state.members.len(), ne * n)?;
        Self::check_len("actions of the batch", state.actions.len(), ne * n)?;
        Self::check_len("member forces of the batch", forces.len(), ne * n)
    }

    /// The inlet centreline velocity of every environment at the end of every substep of the
    /// coming control step, `[E][S]` (m/s).
    pub fn inlet_values(&self) -> Vec<f32> {
        (0..self.n_env)
            .flat_map(|e| {
                let t0 = self.time_s[e] + self.phase_s[e];
                self.waveform
                    .substep_values(t0, self.control_dt, self.substeps)
            })
            .collect()
    }

    /// Advances every clock by one control step.
    pub fn advance(&mut self) {
        for t in &mut self.time_s {
            *t += self.control_dt;
        }
        self.steps += 1;
    }

    /// The developed Poiseuille flow of U(phase) with its linear pressure (dp/dx = -8 mu U /
    /// H^2, p = 0 on the outlet face): u `[ny][nx+1]`, v `[ny+1][nx]`, p `[ny][nx]`.
    pub fn initial_flow(&self, phase_s: f64) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let g = self.grid;
        let u0 = self.waveform.at(phase_s);
        let mut u = vec![0.0f32; g.n_u()];
        for j in 0..g.ny {
            let w = g.inlet_profile(u0, j) as f32;
            u[j * (g.nx + 1)..(j + 1) * (g.nx + 1)].fill(w);
        }
        let v = vec![0.0f32; g.n_v()];
        let grad = 8.0 * self.viscosity * u0 / (g.height_m * g.height_m);
        let p = (0..g.n_cells())
            .map(|c| {
                let x = ((c % g.nx) as f64 + 0.5) * g.dx();
                (grad * (g.length_m - x)) as f32
            })
            .collect();
        (u, v, p)
    }
}

/// (x_min, x_max, y_min, y_max) of the members' centres.
pub fn swarm_box(members: &[GpuMember]) -> [f32; 4] {
    members.iter().fold(
        [
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ],
        |b, m| {
            [
                b[0].min(m.pos[0]),
                b[1].max(m.pos[0]),
                b[2].min(m.pos[1]),
                b[3].max(m.pos[1]),
            ]
        },
    )
}

/// E channel flows with their swarms, advanced one control step (S substeps) per [`step`]
/// with no read-back in between; only the health, members and their forces come back.
///
/// [`step`]: FlowBatch::step
pub trait FlowBatch: Send {
    /// The shared state.
    fn core(&self) -> &BatchCore;
    /// The shared state, mutable.
    fn core_mut(&mut self) -> &mut BatchCore;

    /// Which backend runs the step, for run headers: "native" or "adapter".
    fn backend_name(&self) -> &'static str;
    /// What runs the step, in words (the adapter, or the CPU backend and its threads).
    fn describe(&self) -> String;

    /// Advances every environment by one control step and returns the health of each.
    fn step(&mut self) -> Result<Vec<EnvHealth>, SimError>;
    /// Health of the current state without stepping (e.g. of the initial state).
    fn health(&mut self) -> Result<Vec<EnvHealth>, SimError>;

    /// Members of every environment, `[E][N]`, after the last step or write.
    fn members(&self) -> &[GpuMember];
    /// Forces and pressure samples of every member during the last substep, `[E][N]`.
    fn member_forces(&self) -> &[GpuMemberDiag];
    /// Places the members of environment e (positions, velocities, pinned flags).
    fn set_members(&mut self, e: usize, members: &[GpuMember]) -> Result<(), SimError>;
    /// Sets the raw actions a (one [ax, ay] per member) of environment e for the coming steps;
    /// the step applies F_prop = F_max a / max(1, |a|).
    fn set_actions(&mut self, e: usize, actions: &[[f32; 2]]) -> Result<(), SimError>;
    /// Raw actions of every environment at once, `[E][N]`.
    fn set_all_actions(&mut self, actions: &[[f32; 2]]) -> Result<(), SimError>;
    /// Sets the solid fraction and body velocity of every cell of environment e,
    /// `[chi, u_body, v_body, 0]`, `[ny][nx]`. A batch with members repaints the body field
    /// from them every substep, so this is for member-free batches.
    fn set_body(&mut self, e: usize, cells: &[[f32; 4]]) -> Result<(), SimError>;
    /// Overwrites the velocity and pressure of environment e.
    fn set_flow(&mut self, e: usize, u: &[f32], v: &[f32], p: &[f32]) -> Result<(), SimError>;
    /// The current velocity and pressure of environment e.
    fn fields(&self, e: usize) -> Result<Fields, SimError>;
    /// The whole batch's state (a full read-back on the GPU; not for the stepping loop).
    fn state(&self) -> Result<BatchState, SimError>;
    /// Overwrites the whole batch's state and the members' last forces.
    fn set_state(&mut self, state: &BatchState, forces: &[GpuMemberDiag]) -> Result<(), SimError>;

    /// The WGSL batch behind this one, for what only it has (per-stage timing, profiling).
    fn as_gpu_mut(&mut self) -> Option<&mut super::GpuBatch> {
        None
    }

    /// The channel's grid.
    fn grid(&self) -> &Grid {
        &self.core().grid
    }
    /// Environments in the batch (E).
    fn n_env(&self) -> usize {
        self.core().n_env
    }
    /// Members per environment (N).
    fn n_members(&self) -> usize {
        self.core().n_members
    }
    /// Fluid substeps per control step (S).
    fn substeps(&self) -> usize {
        self.core().substeps
    }
    /// Batch-wide kernel constants.
    fn params(&self) -> &GpuParams {
        &self.core().params
    }
    /// Advection scheme.
    fn scheme(&self) -> Advection {
        self.core().scheme
    }
    /// Inlet centreline-velocity waveform.
    fn waveform(&self) -> &Waveform {
        &self.core().waveform
    }
    /// Control step length (s).
    fn control_dt(&self) -> f64 {
        self.core().control_dt
    }
    /// Control steps taken since the batch was created.
    fn steps(&self) -> u64 {
        self.core().steps
    }
    /// Time of environment e since its reset (s).
    fn time_s(&self, e: usize) -> f64 {
        self.core().time_s[e]
    }
    /// Waveform time of environment e now: its time since reset plus its start phase (s).
    fn waveform_time_s(&self, e: usize) -> f64 {
        let c = self.core();
        c.time_s[e] + c.phase_s[e]
    }
    /// Start phase of environment e's episode (s into the waveform period).
    fn phase_s(&self, e: usize) -> f64 {
        self.core().phase_s[e]
    }
    /// Inlet centreline velocity of environment e now (m/s).
    fn inlet_u(&self, e: usize) -> f64 {
        self.core().waveform.at(self.waveform_time_s(e))
    }
    /// Inlet centreline velocity of environment e `dt` seconds from now (m/s).
    fn inlet_u_after(&self, e: usize, dt: f64) -> f64 {
        let c = self.core();
        c.waveform.at(c.time_s[e] + c.phase_s[e] + dt)
    }
    /// Density (kg/m^3) and dynamic viscosity (Pa s) of the fluid.
    fn fluid_properties(&self) -> (f64, f64) {
        (self.core().density, self.core().viscosity)
    }

    /// Resets environment e to the developed Poiseuille flow of U(0) with its linear
    /// pressure, time 0, waveform phase 0, no solid, members at their initial centres.
    fn reset_env(&mut self, e: usize) -> Result<(), SimError> {
        self.reset_env_with_phase(e, 0.0)
    }

    /// As [`Self::reset_env`], starting the waveform at `phase_s`.
    fn reset_env_with_phase(&mut self, e: usize, phase_s: f64) -> Result<(), SimError> {
        self.core().check_env(e)?;
        let (u, v, p) = self.core().initial_flow(phase_s);
        let core = self.core_mut();
        core.time_s[e] = 0.0;
        core.phase_s[e] = phase_s;
        let (cells, members) = (core.grid.n_cells(), core.initial_members.clone());
        self.set_flow(e, &u, &v, &p)?;
        self.set_body(e, &vec![[0.0; 4]; cells])?;
        if !members.is_empty() {
            self.set_actions(e, &vec![[0.0; 2]; members.len()])?;
            self.set_members(e, &members)?;
        }
        Ok(())
    }

    /// Adds the batch's state under `prefix`: the arrays of [`BatchState`] (velocity,
    /// pressure, body, members, their last forces, actions, swarm boxes) and every clock.
    /// Both backends write and read the same arrays, so a run resumes on either.
    fn save_state(&self, archive: &mut Archive, prefix: &str) -> Result<(), SimError> {
        let s = self.state()?;
        let c = self.core();
        let (ne, n) = (c.n_env, c.n_members);
        let put = |archive: &mut Archive, name: &str, per_env: usize, data: &[f32]| {
            archive.put_f32(&format!("{prefix}.{name}"), &[ne, per_env], data);
        };
        put(archive, "u", c.grid.n_u(), &s.u);
        put(archive, "v", c.grid.n_v(), &s.v);
        put(archive, "p", c.grid.n_cells(), &s.p);
        put(
            archive,
            "body",
            4 * c.grid.n_cells(),
            bytemuck::cast_slice(&s.body),
        );
        put(archive, "members", 8 * n, bytemuck::cast_slice(&s.members));
        put(
            archive,
            "member_diag",
            12 * n,
            bytemuck::cast_slice(self.member_forces()),
        );
        put(archive, "thrust", 2 * n, bytemuck::cast_slice(&s.actions));
        // The current box, then the box of the last paint (unknown here: "clear everywhere").
        let all = f32::MAX;
        let boxes: Vec<f32> = (0..ne)
            .flat_map(|e| {
                let b = s.boxes.get(e).copied().unwrap_or([0.0; 4]);
                [b[0], b[1], b[2], b[3], -all, all, -all, all]
            })
            .collect();
        put(archive, "swarm_box", 8, &boxes);
        archive.put_f64(&format!("{prefix}.time_s"), &[ne], &c.time_s);
        archive.put_f64(&format!("{prefix}.phase_s"), &[ne], &c.phase_s);
        archive.put_u64(&format!("{prefix}.steps"), &[c.steps]);
        Ok(())
    }

    /// Restores what [`Self::save_state`] wrote (by either backend); the batch must have the
    /// same number of environments, grid and members (a mismatch is an error naming the array).
    fn load_state(&mut self, archive: &Archive, prefix: &str) -> Result<(), SimError> {
        let c = self.core();
        let (ne, n, g) = (c.n_env, c.n_members, c.grid);
        let get = |name: &str, per_env: usize| {
            archive.f32(&format!("{prefix}.{name}"), Some(ne * per_env))
        };
        let quads = |v: Vec<f32>| -> Vec<[f32; 4]> { bytemuck::pod_collect_to_vec(&v) };
        let state = BatchState {
            params: c.params,
            scheme: c.scheme,
            poisson: c.poisson.clone(),
            u: get("u", g.n_u())?,
            v: get("v", g.n_v())?,
            p: get("p", g.n_cells())?,
            body: quads(get("body", 4 * g.n_cells())?),
            divstar: vec![0.0; ne * g.nx],
            members: bytemuck::pod_collect_to_vec(&get("members", 8 * n)?),
            actions: bytemuck::pod_collect_to_vec(&get("thrust", 2 * n)?),
            boxes: get("swarm_box", 8)?
                .chunks(8)
                .map(|b| [b[0], b[1], b[2], b[3]])
                .collect(),
        };
        let forces: Vec<GpuMemberDiag> = bytemuck::pod_collect_to_vec(&get("member_diag", 12 * n)?);
        let time_s = archive.f64(&format!("{prefix}.time_s"), Some(ne))?;
        let phase_s = archive.f64(&format!("{prefix}.phase_s"), Some(ne))?;
        let steps = archive.u64(&format!("{prefix}.steps"), Some(1))?[0];
        self.set_state(&state, &forces)?;
        let core = self.core_mut();
        core.time_s = time_s;
        core.phase_s = phase_s;
        core.steps = steps;
        Ok(())
    }
}

//! The CPU backend (`solver.backend = "native"`): a [`BatchState`] stepped in place by the CPU
//! stages, one environment per rayon task, with the clock of [`BatchCore`]. Needs no adapter.

use super::{BatchState, Scratch, StageTimes};
use crate::config::Resolved;
use crate::gpu::params::{GpuMember, GpuMemberDiag};
use crate::sim::batch::{BatchCore, Fields, FlowBatch, swarm_box};
use crate::sim::{EnvHealth, SimError};

/// E channel flows stepped on the CPU cores.
pub struct CpuBatch {
    core: BatchCore,
    state: BatchState,
    scratch: Vec<Scratch>,
    /// Forces and pressure samples of every member in the last substep, [E][N].
    diags: Vec<GpuMemberDiag>,
}

impl CpuBatch {
    /// A batch of `n_env` environments, each reset to the developed flow at phase 0.
    pub fn new(resolved: &Resolved, n_env: usize) -> Result<Self, SimError> {
        let core = BatchCore::new(resolved, n_env)?;
        let g = core.grid;
        let n = core.n_members;
        let state = BatchState {
            params: core.params,
            scheme: core.scheme,
            poisson: core.poisson.clone(),
            u: vec![0.0; n_env * g.n_u()],
            v: vec![0.0; n_env * g.n_v()],
            p: vec![0.0; n_env * g.n_cells()],
            body: vec![[0.0; 4]; n_env * g.n_cells()],
            divstar: vec![0.0; n_env * g.nx],
            members: vec![GpuMember::default(); n_env * n],
            actions: vec![[0.0; 2]; n_env * n],
            boxes: vec![[0.0; 4]; n_env],
        };
        let mut batch = Self {
            core,
            state,
            scratch: vec![Scratch::default(); n_env],
            diags: vec![GpuMemberDiag::default(); n_env * n],
        };
        for e in 0..n_env {
            batch.reset_env(e)?;
        }
        Ok(batch)
    }

    /// The batch's state, borrowed (no copy).
    pub fn state_ref(&self) -> &BatchState {
        &self.state
    }

    /// One control step exactly as [`FlowBatch::step`] (the same state, bit for bit, and the
    /// clock advanced), with each stage's time summed over the environments (CPU time: with
    /// several threads the sum exceeds the step's wall time).
    pub fn profile_step(&mut self) -> Result<(Vec<EnvHealth>, StageTimes), SimError> {
        let inlet = self.core.inlet_values();
        let mut times = vec![StageTimes::default(); self.core.n_env];
        let health = self
            .state
            .step_timed(&inlet, &mut self.scratch, &mut self.diags, &mut times);
        self.core.advance();
        Ok((health, times.into_iter().sum()))
    }

    fn span(&self, e: usize, per_env: usize) -> std::ops::Range<usize> {
        e * per_env..(e + 1) * per_env
    }
}

impl FlowBatch for CpuBatch {
    fn core(&self) -> &BatchCore {
        &self.core
    }

    fn core_mut(&mut self) -> &mut BatchCore {
        &mut self.core
    }

    fn backend_name(&self) -> &'static str {
        "native"
    }

    fn describe(&self) -> String {
        format!("CPU backend, {} threads", rayon::current_num_threads())
    }

    fn step(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        let inlet = self.core.inlet_values();
        let health = self
            .state
            .step_with(&inlet, &mut self.scratch, &mut self.diags);
        self.core.advance();
        Ok(health)
    }

    fn health(&mut self) -> Result<Vec<EnvHealth>, SimError> {
        let s = &self.state;
        Ok(super::diagnostics(&s.params, &s.u, &s.v, &s.p, &s.divstar))
    }

    fn members(&self) -> &[GpuMember] {
        &self.state.members
    }

    fn member_forces(&self) -> &[GpuMemberDiag] {
        &self.diags
    }

    fn set_members(&mut self, e: usize, members: &[GpuMember]) -> Result<(), SimError> {
        self.core.check_env(e)?;
        let n = self.core.n_members;
        BatchCore::check_len("members", members.len(), n)?;
        let span = self.span(e, n);
        self.state.members[span].copy_from_slice(members);
        self.state.boxes[e] = swarm_box(members);
        Ok(())
    }

    fn set_actions(&mut self, e: usize, actions: &[[f32; 2]]) -> Result<(), SimError> {
        self.core.check_env(e)?;
        let n = self.core.n_members;
        BatchCore::check_len("actions", actions.len(), n)?;
        let span = self.span(e, n);
        self.state.actions[span].copy_from_slice(actions);
        Ok(())
    }

    fn set_all_actions(&mut self, actions: &[[f32; 2]]) -> Result<(), SimError> {
        let want = self.core.n_env * self.core.n_members;
        BatchCore::check_len("actions of the batch", actions.len(), want)?;
        self.state.actions.copy_from_slice(actions);
        Ok(())
    }

    fn set_body(&mut self, e: usize, cells: &[[f32; 4]]) -> Result<(), SimError> {
        self.core.check_env(e)?;
        let nc = self.core.grid.n_cells();
        BatchCore::check_len("body cells", cells.len(), nc)?;
        let span = self.span(e, nc);
        self.state.body[span].copy_from_slice(cells);
        Ok(())
    }

    fn set_flow(&mut self, e: usize, u: &[f32], v: &[f32], p: &[f32]) -> Result<(), SimError> {
        self.core.check_env(e)?;
        let g = self.core.grid;
        BatchCore::check_len("u faces", u.len(), g.n_u())?;
        BatchCore::check_len("v faces", v.len(), g.n_v())?;
        BatchCore::check_len("pressure cells", p.len(), g.n_cells())?;
        let (su, sv, sp) = (
            self.span(e, g.n_u()),
            self.span(e, g.n_v()),
            self.span(e, g.n_cells()),
        );
        self.state.u[su].copy_from_slice(u);
        self.state.v[sv].copy_from_slice(v);
        self.state.p[sp].copy_from_slice(p);
        Ok(())
    }

    fn fields(&self, e: usize) -> Result<Fields, SimError> {
        self.core.check_env(e)?;
        let g = self.core.grid;
        let s = &self.state;
        Ok(Fields::with_bodies(
            &g,
            s.u[self.span(e, g.n_u())].to_vec(),
            s.v[self.span(e, g.n_v())].to_vec(),
            s.p[self.span(e, g.n_cells())].to_vec(),
            &s.body[self.span(e, g.n_cells())],
        ))
    }

    fn state(&self) -> Result<BatchState, SimError> {
        Ok(self.state.clone())
    }

    fn set_state(&mut self, state: &BatchState, forces: &[GpuMemberDiag]) -> Result<(), SimError> {
        self.core.check_state(state, forces)?;
        let (ne, n) = (self.core.n_env, self.core.n_members);
        let s = &mut self.state;
        s.u.copy_from_slice(&state.u);
        s.v.copy_from_slice(&state.v);
        s.p.copy_from_slice(&state.p);
        s.body.copy_from_slice(&state.body);
        s.members.copy_from_slice(&state.members);
        s.actions.copy_from_slice(&state.actions);
        if state.divstar.len() == s.divstar.len() {
            s.divstar.copy_from_slice(&state.divstar);
        }
        for e in 0..ne {
            s.boxes[e] = if n > 0 {
                swarm_box(&s.members[e * n..(e + 1) * n])
            } else {
                [0.0; 4]
            };
        }
        self.diags.copy_from_slice(forces);
        Ok(())
    }
}

//! [`GpuBatch`] as a [`FlowBatch`].

use super::*;

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

//! Recording and running a control step: S substeps of the kernels in one submission, the
//! diagnostics, and the one read-back of health, members and forces; single stages for tests and
//! timing by elimination.

use super::*;

impl GpuBatch {
    /// Writes the inlet centreline velocity of every environment at the end of every substep
    /// of the coming control step.
    pub(super) fn upload_inlet(&self) {
        self.write_all(FieldBinding::Inlet, &self.core.inlet_values());
    }
    pub(super) fn offset(&self, s: usize) -> u32 {
        s as u32 * self.substep_stride
    }
    pub(super) fn dims(&self) -> Dims {
        Dims {
            nx: self.core.grid.nx as u32,
            ny: self.core.grid.ny as u32,
            n_env: self.core.n_env as u32,
        }
    }
    pub(super) fn record_stage(
        &self,
        pass: &mut Recorder<'_>,
        stage: Stage,
        bind: usize,
        s: usize,
    ) {
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
    pub(super) fn step_kernels(&mut self) -> Result<Vec<EnvHealth>, SimError> {
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
    /// Records the S substeps and the diagnostics of one control step and advances the clocks.
    pub(super) fn record_control_step(&mut self, rec: &mut Recorder<'_>) {
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
    pub(super) fn health_kernels(&mut self) -> Result<Vec<EnvHealth>, SimError> {
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
    pub(super) fn submit_and_read_health(
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

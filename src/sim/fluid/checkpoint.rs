//! Saving and restoring a batch's state in a checkpoint: the current velocity [E][ny][nx+1] and
//! [E][ny+1][nx], pressure and body field [E][ny][nx] (x1, x4), members, their last forces,
//! actions and bounding boxes, plus each environment's clock and waveform phase. Scratch
//! buffers (diffused and predicted fields, column statistics) are rewritten before they are
//! read in every substep, so they are not saved.

use super::{FluidBatch, SimError};
use crate::checkpoint::Archive;
use crate::gpu::GpuContext;
use crate::gpu::kernels::FieldBinding;

/// The device buffers that carry state from one control step to the next.
const SAVED: [(FieldBinding, &str); 8] = [
    (FieldBinding::UIn, "u"),
    (FieldBinding::VIn, "v"),
    (FieldBinding::Pressure, "p"),
    (FieldBinding::Body, "body"),
    (FieldBinding::Members, "members"),
    (FieldBinding::MemberDiag, "member_diag"),
    (FieldBinding::Thrust, "thrust"),
    (FieldBinding::SwarmBox, "swarm_box"),
];

impl FluidBatch {
    /// Adds the batch's state under `prefix` (one read-back of each saved buffer).
    pub fn save_state(
        &self,
        ctx: &GpuContext,
        archive: &mut Archive,
        prefix: &str,
    ) -> Result<(), SimError> {
        for (which, name) in SAVED {
            let per_env = self.words_per_env(which);
            let data = if per_env == 0 {
                Vec::new()
            } else {
                self.read_all(ctx, which)?
            };
            archive.put_f32(&format!("{prefix}.{name}"), &[self.n_env, per_env], &data);
        }
        archive.put_f64(&format!("{prefix}.time_s"), &[self.n_env], &self.time_s);
        archive.put_f64(&format!("{prefix}.phase_s"), &[self.n_env], &self.phase_s);
        archive.put_u64(&format!("{prefix}.steps"), &[self.steps]);
        Ok(())
    }

    /// Restores what [`Self::save_state`] wrote; the batch must have the same number of
    /// environments, grid and members (a mismatch is an error naming the array).
    pub fn load_state(&mut self, archive: &Archive, prefix: &str) -> Result<(), SimError> {
        let mut data = Vec::with_capacity(SAVED.len());
        for (which, name) in SAVED {
            let len = self.words_per_env(which) * self.n_env;
            data.push(archive.f32(&format!("{prefix}.{name}"), Some(len))?);
        }
        let time_s = archive.f64(&format!("{prefix}.time_s"), Some(self.n_env))?;
        let phase_s = archive.f64(&format!("{prefix}.phase_s"), Some(self.n_env))?;
        let steps = archive.u64(&format!("{prefix}.steps"), Some(1))?[0];
        for ((which, _), words) in SAVED.iter().zip(&data) {
            if !words.is_empty() {
                self.write_all(*which, words);
            }
        }
        self.last_members = bytemuck::pod_collect_to_vec(&data[4]);
        self.last_diag = bytemuck::pod_collect_to_vec(&data[5]);
        self.time_s = time_s;
        self.phase_s = phase_s;
        self.steps = steps;
        Ok(())
    }
}

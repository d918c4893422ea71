//! Reads and writes of the device buffers: one environment's part or a whole buffer, and the
//! whole batch as a [`BatchState`].

use super::*;

impl GpuBatch {
    /// A [`BatchState`] of `n_env` environments from `read`, which returns a buffer's words for
    /// those environments.
    pub(super) fn cpu_batch_from(
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
    pub(super) fn write_env_pod<T: bytemuck::Pod>(
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
}

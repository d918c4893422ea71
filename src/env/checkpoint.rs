//! Saving and restoring the swarm environments in a checkpoint: the fluid batch (see
//! `sim::FlowBatch::save_state`, the same arrays for both backends), the environment RNG, and each environment's episode clock:
//! index and step [E], member positions at the previous control step and previous actions
//! [E][N][2] (NaN where no action was taken yet) and the running reward sums [E][3].

use super::{Episode, SwarmEnv};
use crate::checkpoint::Archive;
use crate::sim::SimError;

impl SwarmEnv {
    /// Adds every environment's state under `prefix` (after a `reset`).
    pub fn save_state(&self, archive: &mut Archive, prefix: &str) -> Result<(), SimError> {
        assert_eq!(self.episodes.len(), self.n_env, "reset before saving");
        self.batch.save_state(archive, &format!("{prefix}.fluid"))?;
        let (ne, n) = (self.n_env, self.n);
        archive.put_u64(&format!("{prefix}.rng"), &[self.rng.0]);
        let eps = &self.episodes;
        archive.put_u64(
            &format!("{prefix}.episode"),
            &eps.iter().map(|e| e.index).collect::<Vec<_>>(),
        );
        archive.put_u64(
            &format!("{prefix}.episode_step"),
            &eps.iter().map(|e| e.steps as u64).collect::<Vec<_>>(),
        );
        let positions: Vec<f64> = eps.iter().flat_map(|e| e.positions.concat()).collect();
        archive.put_f64(&format!("{prefix}.positions_m"), &[ne, n, 2], &positions);
        let previous: Vec<f64> = eps
            .iter()
            .flat_map(|e| e.previous_action.iter())
            .flat_map(|a| a.unwrap_or([f64::NAN; 2]))
            .collect();
        archive.put_f64(&format!("{prefix}.previous_action"), &[ne, n, 2], &previous);
        let sums: Vec<f64> = eps
            .iter()
            .flat_map(|e| [e.progress_sum, e.energy_sum, e.smoothness_sum])
            .collect();
        archive.put_f64(&format!("{prefix}.reward_sums"), &[ne, 3], &sums);
        Ok(())
    }

    /// Restores what [`Self::save_state`] wrote into environments of the same shape.
    pub fn load_state(&mut self, archive: &Archive, prefix: &str) -> Result<(), SimError> {
        let (ne, n) = (self.n_env, self.n);
        let index = archive.u64(&format!("{prefix}.episode"), Some(ne))?;
        let steps = archive.u64(&format!("{prefix}.episode_step"), Some(ne))?;
        let positions = archive.f64(&format!("{prefix}.positions_m"), Some(ne * n * 2))?;
        let previous = archive.f64(&format!("{prefix}.previous_action"), Some(ne * n * 2))?;
        let sums = archive.f64(&format!("{prefix}.reward_sums"), Some(ne * 3))?;
        let rng = archive.u64(&format!("{prefix}.rng"), Some(1))?[0];
        self.batch.load_state(archive, &format!("{prefix}.fluid"))?;
        self.rng.0 = rng;
        self.episodes = (0..ne)
            .map(|e| {
                let pair = |v: &[f64], i: usize| [v[(e * n + i) * 2], v[(e * n + i) * 2 + 1]];
                Episode {
                    index: index[e],
                    steps: steps[e] as u32,
                    positions: (0..n).map(|i| pair(&positions, i)).collect(),
                    previous_action: (0..n)
                        .map(|i| Some(pair(&previous, i)).filter(|a| !a[0].is_nan()))
                        .collect(),
                    progress_sum: sums[e * 3],
                    energy_sum: sums[e * 3 + 1],
                    smoothness_sum: sums[e * 3 + 2],
                }
            })
            .collect();
        Ok(())
    }
}

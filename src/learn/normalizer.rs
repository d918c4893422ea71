//! Running observation normalisation: per observation dimension (shared by all agents, as the
//! actor is), mean and variance over every observation seen in training, merged batch by batch
//! (Chan et al.'s parallel update, in f64), and x' = clamp((x - mean) / sqrt(var + 1e-8), -10, 10).
//! Saved with the checkpoint so a trained policy sees the same inputs in `eval`.

/// Running per-dimension observation statistics (see the module header).
#[derive(Debug, Clone, PartialEq)]
pub struct ObsNormalizer {
    /// Number of observation rows merged so far.
    pub count: f64,
    /// Running mean per observation dimension.
    pub mean: Vec<f64>,
    /// Running (population) variance per observation dimension.
    pub var: Vec<f64>,
}

/// Normalised values are clamped to +-CLIP.
pub const CLIP: f64 = 10.0;
const EPS: f64 = 1e-8;

impl ObsNormalizer {
    /// A normaliser for `dim` dimensions: no rows seen, mean 0, variance 1.
    pub fn new(dim: usize) -> Self {
        Self {
            count: 0.0,
            mean: vec![0.0; dim],
            var: vec![1.0; dim],
        }
    }

    /// Observation dimension.
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Merges a batch of observations `[rows][dim]` into the running statistics.
    pub fn update(&mut self, obs: &[f32]) {
        let d = self.dim();
        let rows = obs.len() / d;
        if rows == 0 {
            return;
        }
        let n = rows as f64;
        for k in 0..d {
            let xs = obs.iter().skip(k).step_by(d).map(|x| *x as f64);
            let m = xs.clone().sum::<f64>() / n;
            let v = xs.map(|x| (x - m).powi(2)).sum::<f64>() / n;
            let total = self.count + n;
            let delta = m - self.mean[k];
            let m2 = self.var[k] * self.count + v * n + delta * delta * self.count * n / total;
            self.mean[k] += delta * n / total;
            self.var[k] = m2 / total;
        }
        self.count += n;
    }

    /// The normalised copy of observations `[rows][dim]`.
    pub fn apply(&self, obs: &[f32]) -> Vec<f32> {
        let d = self.dim();
        obs.iter()
            .enumerate()
            .map(|(i, x)| {
                let k = i % d;
                ((*x as f64 - self.mean[k]) / (self.var[k] + EPS).sqrt()).clamp(-CLIP, CLIP) as f32
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn batched_updates_match_the_statistics_of_all_data() {
        // Dimension 0: 1, 2, 3, 4, 10 (mean 4, population variance 10); dimension 1: constant 5.
        let mut n = ObsNormalizer::new(2);
        n.update(&[1.0, 5.0, 2.0, 5.0]);
        n.update(&[3.0, 5.0, 4.0, 5.0, 10.0, 5.0]);
        assert_eq!(n.count, 5.0);
        assert!((n.mean[0] - 4.0).abs() < 1e-12 && (n.var[0] - 10.0).abs() < 1e-12);
        assert!((n.mean[1] - 5.0).abs() < 1e-12 && n.var[1].abs() < 1e-12);
        let out = n.apply(&[4.0 + 10f32.sqrt(), 5.0]);
        assert!((out[0] - 1.0).abs() < 1e-6, "{out:?}");
        assert_eq!(out[1], 0.0);
        // A value far off a constant dimension is clamped.
        assert_eq!(n.apply(&[0.0, 6.0])[1], CLIP as f32);
    }
}

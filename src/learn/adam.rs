//! Adam (Kingma & Ba 2015) over one flat parameter vector:
//! m <- b1 m + (1 - b1) g,  v <- b2 v + (1 - b2) g^2,
//! theta <- theta - lr (m / (1 - b1^t)) / (sqrt(v / (1 - b2^t)) + eps).
//! Its whole state (m, v: one f32 per parameter; t) is plain data, so a checkpoint saves it and
//! a resumed run continues bit for bit (candle's own `AdamW` keeps its moments private).

#[derive(Debug, Clone, PartialEq)]
pub struct Adam {
    pub lr: f64,
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    /// Steps taken.
    pub t: u64,
    pub m: Vec<f32>,
    pub v: Vec<f32>,
}

impl Adam {
    /// Adam for `n` parameters with PyTorch's defaults (b1 0.9, b2 0.999, eps 1e-8).
    pub fn new(n: usize, lr: f64) -> Self {
        Self {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            t: 0,
            m: vec![0.0; n],
            v: vec![0.0; n],
        }
    }

    /// One step: updates `params` in place from `grad` (same length as the moments).
    pub fn step(&mut self, params: &mut [f32], grad: &[f32]) {
        assert_eq!(params.len(), self.m.len(), "parameter count changed");
        assert_eq!(grad.len(), self.m.len(), "gradient length");
        self.t += 1;
        let (b1, b2) = (self.beta1 as f32, self.beta2 as f32);
        let c1 = (1.0 - self.beta1.powi(self.t as i32)) as f32;
        let c2 = (1.0 - self.beta2.powi(self.t as i32)) as f32;
        let (lr, eps) = (self.lr as f32, self.eps as f32);
        for (((p, g), m), v) in params
            .iter_mut()
            .zip(grad)
            .zip(self.m.iter_mut())
            .zip(self.v.iter_mut())
        {
            *m = b1 * *m + (1.0 - b1) * g;
            *v = b2 * *v + (1.0 - b2) * g * g;
            *p -= lr * (*m / c1) / ((*v / c2).sqrt() + eps);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn first_step_moves_each_parameter_by_lr_against_its_gradient_sign() {
        // t = 1: m_hat = g, v_hat = g^2, so the step is lr g / (|g| + eps) = lr sign(g).
        let mut a = Adam::new(3, 0.1);
        let mut p = [1.0f32, 1.0, 1.0];
        a.step(&mut p, &[2.0, -0.5, 0.0]);
        assert!((p[0] - 0.9).abs() < 1e-6, "{p:?}");
        assert!((p[1] - 1.1).abs() < 1e-6, "{p:?}");
        assert_eq!(p[2], 1.0);
    }

    #[test]
    fn second_step_matches_hand_computed_moments() {
        // g1 = 1, g2 = 3: m = 0.9 * 0.1 + 0.1 * 3 = 0.39, v = 0.999 * 0.001 + 0.001 * 9 = 0.009999;
        // m_hat = 0.39 / 0.19, v_hat = 0.009999 / 0.001999, step = lr m_hat / sqrt(v_hat).
        let mut a = Adam::new(1, 0.01);
        let mut p = [0.0f32];
        a.step(&mut p, &[1.0]);
        a.step(&mut p, &[3.0]);
        let second = 0.01 * (0.39 / 0.19) / (0.009999f64 / 0.001999).sqrt();
        let expected = -0.01 - second;
        assert!(
            (p[0] as f64 - expected).abs() < 1e-6,
            "{} vs {expected}",
            p[0]
        );
        assert_eq!(a.t, 2);
    }
}

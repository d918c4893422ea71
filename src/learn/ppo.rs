//! PPO's clipped surrogate (to minimise): L = -mean(min(rho A, clip(rho, 1 - eps, 1 + eps) A)),
//! rho = exp(log pi_new - log pi_old) from the joint log-probability. Outside the clip range in
//! the direction that would over-exploit A (rho > 1 + eps with A > 0, rho < 1 - eps with A < 0)
//! its gradient is zero.

use candle_core::{Result, Tensor};

/// Mean clipped surrogate loss over all elements; `advantages` broadcasts against `log_new`.
pub fn clipped_surrogate(
    log_new: &Tensor,
    log_old: &Tensor,
    advantages: &Tensor,
    eps: f64,
) -> Result<Tensor> {
    let ratio = (log_new - log_old)?.exp()?;
    let unclipped = ratio.broadcast_mul(advantages)?;
    let clipped = ratio
        .clamp(1.0 - eps, 1.0 + eps)?
        .broadcast_mul(advantages)?;
    unclipped.minimum(&clipped)?.mean_all()?.neg()
}

/// [`clipped_surrogate`] and its gradient in plain Rust, for the learner's hand-written
/// backward pass: joint log-probabilities `log_new`, `log_old` `[B]` and per-agent advantages
/// `advantages` `[B][N]` give the loss and d loss / d log_new `[B]`. Per element,
/// d min(rho A, clip(rho) A) / d log rho is rho A where the unclipped term is the smaller (or
/// they tie, inside the clip range), else 0.
pub fn clipped_surrogate_grad(
    log_new: &[f32],
    log_old: &[f32],
    advantages: &[f32],
    eps: f32,
) -> (f64, Vec<f32>) {
    let b = log_new.len();
    let n = advantages.len() / b.max(1);
    let scale = 1.0 / (b * n) as f32;
    let mut loss = 0.0f64;
    let grad = (0..b)
        .map(|s| {
            let rho = (log_new[s] - log_old[s]).exp();
            let clipped = rho.clamp(1.0 - eps, 1.0 + eps);
            let mut g = 0.0f32;
            for &a in &advantages[s * n..(s + 1) * n] {
                let (u, c) = (rho * a, clipped * a);
                loss -= u.min(c) as f64;
                if u <= c {
                    g += u;
                }
            }
            -g * scale
        })
        .collect();
    (loss * scale as f64, grad)
}

#[cfg(test)]
mod tests {
    use super::*;
    use candle_core::{Device, Var};

    /// d loss / d log_new for one sample with ratio rho and advantage a.
    fn grad(rho: f64, a: f64) -> f64 {
        let dev = Device::Cpu;
        let log_new = Var::new(&[rho.ln()], &dev).unwrap();
        let log_old = Tensor::new(&[0.0f64], &dev).unwrap();
        let adv = Tensor::new(&[a], &dev).unwrap();
        let loss = clipped_surrogate(log_new.as_tensor(), &log_old, &adv, 0.2).unwrap();
        let g = loss.backward().unwrap();
        g.get(log_new.as_tensor())
            .unwrap()
            .to_vec1::<f64>()
            .unwrap()[0]
    }

    #[test]
    fn gradient_vanishes_only_beyond_the_clip_in_the_exploiting_direction() {
        // Inside the range: d(-rho A)/d log rho = -rho A.
        assert!((grad(1.1, 2.0) + 2.2).abs() < 1e-12);
        assert!((grad(0.9, -1.0) - 0.9).abs() < 1e-12);
        // A > 0, rho > 1 + eps: clipped, no gradient; rho < 1 - eps: still pushes rho up.
        assert_eq!(grad(1.5, 2.0), 0.0);
        assert!((grad(0.5, 2.0) + 1.0).abs() < 1e-12);
        // A < 0, rho < 1 - eps: clipped, no gradient; rho > 1 + eps: still pushes rho down.
        assert_eq!(grad(0.5, -1.0), 0.0);
        assert!((grad(1.5, -1.0) - 1.5).abs() < 1e-12);
    }

    #[test]
    fn the_plain_gradient_matches_autograd_on_every_branch() {
        let dev = Device::Cpu;
        // Four samples of three agents: inside the range, clipped above and below, mixed signs.
        let log_new = [0.05f32, 0.6, -0.7, 0.3];
        let log_old = [0.0f32, 0.1, 0.0, 0.35];
        let adv = [
            1.0f32, -2.0, 0.5, 2.0, -1.0, 0.3, -1.5, 1.0, 0.0, 0.7, -0.2, 1.1,
        ];
        let (loss, grad) = clipped_surrogate_grad(&log_new, &log_old, &adv, 0.2);
        let v = Var::new(&log_new, &dev).unwrap();
        let lo = Tensor::new(&log_old, &dev).unwrap();
        let a = Tensor::new(&adv, &dev).unwrap().reshape((4, 3)).unwrap();
        let l = clipped_surrogate(
            &v.as_tensor().reshape((4, 1)).unwrap(),
            &lo.reshape((4, 1)).unwrap(),
            &a,
            0.2,
        )
        .unwrap();
        let want_loss = l.to_scalar::<f32>().unwrap() as f64;
        let want: Vec<f32> = l
            .backward()
            .unwrap()
            .get(v.as_tensor())
            .unwrap()
            .to_vec1()
            .unwrap();
        assert!((loss - want_loss).abs() < 1e-6, "{loss} vs {want_loss}");
        for (g, w) in grad.iter().zip(&want) {
            assert!((g - w).abs() < 1e-6, "{grad:?} vs {want:?}");
        }
        // Sample 1 (rho = e^0.5 > 1.2) keeps only its negative-advantage agent's gradient.
        let rho1 = 0.5f32.exp();
        assert!((grad[1] - rho1 / 12.0).abs() < 1e-6, "{grad:?}");
    }
}

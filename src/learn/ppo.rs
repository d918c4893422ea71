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
}

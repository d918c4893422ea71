//! Closed forms of the diagonal Gaussian policy (the reference the network code is tested
//! against): log N(x; mu, sigma) = -((x - mu) / sigma)^2 / 2 - ln sigma - ln(2 pi) / 2 per
//! dimension, entropy = 1/2 + ln(2 pi) / 2 + ln sigma per dimension. The joint log-probability of
//! a multi-agent action is the sum over agents and dimensions of the raw sample's terms.

const HALF_LN_2PI: f64 = 0.918_938_533_204_672_8;

/// Log-density of the raw sample `x` summed over dimensions.
pub fn log_prob(x: &[f64], mean: &[f64], log_std: &[f64]) -> f64 {
    x.iter()
        .zip(mean)
        .zip(log_std)
        .map(|((x, m), ls)| {
            let z = (x - m) / ls.exp();
            -0.5 * z * z - ls - HALF_LN_2PI
        })
        .sum()
}

/// Entropy summed over dimensions.
pub fn entropy(log_std: &[f64]) -> f64 {
    log_std.iter().map(|ls| 0.5 + HALF_LN_2PI + ls).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standard_normal_values() {
        // ln N(0; 0, 1) = -0.9189385...; ln N(1; 0, 1) = -1.4189385...
        assert!((log_prob(&[0.0], &[0.0], &[0.0]) + 0.918_938_533).abs() < 1e-9);
        assert!((log_prob(&[1.0], &[0.0], &[0.0]) + 1.418_938_533).abs() < 1e-9);
        // sigma = 2 (log_std = ln 2), x - mu = 2: -0.5 - ln 2 - 0.9189385 = -2.1120857.
        assert!((log_prob(&[3.0], &[1.0], &[2f64.ln()]) + 2.112_085_713).abs() < 1e-9);
        // Two dimensions add.
        let two = log_prob(&[0.0, 1.0], &[0.0, 0.0], &[0.0, 0.0]);
        assert!((two + 0.918_938_533 + 1.418_938_533).abs() < 1e-9);
        // Entropy of N(0, 1): 1.4189385; of N(0, e^2) per dim: 3.4189385.
        assert!((entropy(&[0.0]) - 1.418_938_533).abs() < 1e-9);
        assert!((entropy(&[2.0, 0.0]) - (3.418_938_533 + 1.418_938_533)).abs() < 1e-9);
    }
}

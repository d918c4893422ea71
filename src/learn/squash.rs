//! The tanh-squashed Gaussian policy (`train.action_distribution = "tanh"`): the actor's raw
//! sample u ~ N(mean, σ) per action dimension is applied as a = tanh(u), so every applied
//! component lies in (-1, 1) and saturating the mean no longer frees σ.
//!
//! - log π(a) = Σ_d [log N(u_d; mean_d, σ_d) - log(1 - tanh²(u_d))] (change of variables), with
//!   log(1 - tanh² u) = 2 (ln 2 - u - softplus(-2u)), exact and stable for large |u|. The
//!   correction depends on u only, so PPO's ratio π_new(a) / π_old(a) of a stored raw sample u
//!   is the Gaussian's, and so are its gradients.
//! - Entropy H = H(N) + E[Σ_d log(1 - tanh²(u_d))], which has no closed form; the learner
//!   estimates it by a reparameterised Monte Carlo draw of the current policy per row and
//!   dimension, u = mean + σ ε with fresh ε ~ N(0, 1), so d/d mean log(1 - tanh² u) = -2 tanh u
//!   and d/d log σ log(1 - tanh² u) = -2 tanh(u) σ ε. (The minibatch's stored samples are
//!   draws of the policy that collected them, not of the one being updated: used as ε they
//!   bias the σ gradient once the mean moves, and measured on the swarm they drove log σ to
//!   its lower bound within one update.)
//!
//! Buffers: raw samples, means and log σ are `[R, A]` row-major, one row per agent sample.

use crate::config::ActionDistribution;

/// log(1 - tanh²(u)) = 2 (ln 2 - u - softplus(-2u)), finite for every finite u.
pub fn log_one_minus_tanh_sq(u: f32) -> f32 {
    let x = -2.0 * u;
    // softplus(x) = max(x, 0) + ln(1 + e^-|x|)
    let softplus = x.max(0.0) + (-x.abs()).exp().ln_1p();
    2.0 * (std::f32::consts::LN_2 - u - softplus)
}

/// The actions the environment receives for raw samples `raw` `[R][2]`: the samples themselves
/// for the Gaussian policy (the environment clips their norm at 1), tanh of each component for
/// the squashed one.
pub fn applied(dist: ActionDistribution, raw: &[[f32; 2]]) -> Vec<[f32; 2]> {
    match dist {
        ActionDistribution::Gaussian => raw.to_vec(),
        ActionDistribution::Tanh => raw.iter().map(|a| [a[0].tanh(), a[1].tanh()]).collect(),
    }
}

/// Adds the change-of-variables term of each sample to its joint log-probability `lp` `[B]`
/// (raw samples `raw` `[B n, 2]` flat, n agents per sample); nothing for the Gaussian policy.
pub fn correct_log_prob(dist: ActionDistribution, raw: &[f32], n: usize, lp: &mut [f32]) {
    if dist == ActionDistribution::Gaussian {
        return;
    }
    for (l, sample) in lp.iter_mut().zip(raw.chunks(2 * n)) {
        *l -= sample
            .iter()
            .map(|&u| log_one_minus_tanh_sq(u))
            .sum::<f32>();
    }
}

/// The squashing's share of the entropy estimate, per row and dimension, and of its gradient:
/// for each element, (log(1 - tanh² u), d/d mean, d/d log σ) of that term at u = mean + σ ε,
/// with `noise` the draws ε `[R, A]` (see the module header). Zero for the Gaussian policy,
/// which takes no noise.
pub fn entropy_terms<'a>(
    dist: ActionDistribution,
    mean: &'a [f32],
    log_std: &'a [f32],
    noise: &'a [f32],
) -> impl Iterator<Item = (f32, f32, f32)> + 'a {
    let on = dist == ActionDistribution::Tanh;
    let draws = noise.iter().copied().chain(std::iter::repeat(0.0));
    mean.iter()
        .zip(log_std)
        .zip(draws)
        .map(move |((&m, &ls), e)| {
            if on {
                let sigma_eps = ls.exp() * e;
                let t = (m + sigma_eps).tanh();
                (
                    log_one_minus_tanh_sq(m + sigma_eps),
                    -2.0 * t,
                    -2.0 * t * sigma_eps,
                )
            } else {
                (0.0, 0.0, 0.0)
            }
        })
}

/// The draws ε `[rows, 2]` the tanh policy's entropy estimate needs (none for the Gaussian).
pub fn entropy_noise(dist: ActionDistribution, rows: usize, rng: &mut crate::rng::Rng) -> Vec<f32> {
    match dist {
        ActionDistribution::Gaussian => Vec::new(),
        ActionDistribution::Tanh => (0..rows * 2).map(|_| rng.normal() as f32).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HALF_LN_2PI: f64 = 0.918_938_533_204_672_8;

    /// The squashed density of one dimension at a in (-1, 1), by the change of variables:
    /// p(a) = N(atanh a; mean, σ) / (1 - a²).
    fn density(a: f64, mean: f64, sigma: f64) -> f64 {
        ln_density_gauss(a.atanh(), mean, sigma).exp() / (1.0 - a * a)
    }

    fn ln_density_gauss(u: f64, mean: f64, sigma: f64) -> f64 {
        let z = (u - mean) / sigma;
        -0.5 * z * z - sigma.ln() - HALF_LN_2PI
    }

    #[test]
    fn the_correction_matches_the_direct_formula_and_stays_finite() {
        for u in [-3.0f32, -0.5, 0.0, 0.25, 1.0, 4.0] {
            let want = (1.0 - (u as f64).tanh().powi(2)).ln();
            let got = log_one_minus_tanh_sq(u) as f64;
            assert!((got - want).abs() < 1e-5, "{u}: {got} vs {want}");
        }
        // Where 1 - tanh² underflows in f32, the stable form goes on: -2|u| + 2 ln 2 + O(e^-2|u|).
        let far = log_one_minus_tanh_sq(60.0);
        assert!(
            (far - (2.0 * std::f32::consts::LN_2 - 120.0)).abs() < 1e-3,
            "{far}"
        );
        assert_eq!(log_one_minus_tanh_sq(-60.0), log_one_minus_tanh_sq(60.0));
    }

    #[test]
    fn a_hand_computed_log_probability() {
        // N(0, 1) at u = 0.5: -0.125 - 0.9189385 = -1.0439385; tanh 0.5 = 0.4621172, so
        // log(1 - tanh² 0.5) = ln(1 - 0.2135523) = -0.2402290, and log π = -1.0439385 +
        // 0.2402290 = -0.8037095 per dimension, twice that for one agent's two dimensions.
        let mut lp = [-1.043_938_5f32 * 2.0];
        correct_log_prob(ActionDistribution::Tanh, &[0.5, 0.5], 1, &mut lp);
        assert!((lp[0] + 0.803_709_5 * 2.0).abs() < 1e-5, "{}", lp[0]);
        let mut same = [1.5f32];
        correct_log_prob(ActionDistribution::Gaussian, &[0.5, 0.5], 1, &mut same);
        assert_eq!(same, [1.5]);
    }

    #[test]
    fn the_squashed_density_integrates_to_one_and_its_entropy_matches_the_estimate() {
        // Midpoint rules: in a over (-1, 1) for the squashed density's mass and entropy, in u
        // for the Gaussian expectation of the correction the learner's estimate uses.
        for (mean, sigma) in [(0.0, 1.0), (0.7, 0.4), (-1.0, 0.5)] {
            let steps = 400_000;
            let da = 2.0 / steps as f64;
            let (mut mass, mut entropy) = (0.0, 0.0);
            for i in 0..steps {
                let a = -1.0 + (i as f64 + 0.5) * da;
                let p = density(a, mean, sigma);
                if p > 0.0 {
                    mass += p * da;
                    entropy -= p * p.ln() * da;
                }
            }
            let du = 24.0 * sigma / steps as f64;
            let correction: f64 = (0..steps)
                .map(|i| {
                    let u = mean - 12.0 * sigma + (i as f64 + 0.5) * du;
                    ln_density_gauss(u, mean, sigma).exp()
                        * log_one_minus_tanh_sq(u as f32) as f64
                        * du
                })
                .sum();
            assert!((mass - 1.0).abs() < 1e-5, "mass {mass}");
            // H(π) = H(N) + E_N[log(1 - tanh² u)], the identity the estimate rests on.
            let h_gauss = 0.5 + HALF_LN_2PI + sigma.ln();
            assert!(
                (entropy - (h_gauss + correction)).abs() < 1e-4,
                "{entropy} vs {}",
                h_gauss + correction
            );
        }
    }

    #[test]
    fn the_entropy_terms_gradients_match_finite_differences() {
        let (mean, log_std, eps) = (0.3f64, -0.4f64, 0.75f64);
        let term = |m: f64, ls: f64| (1.0 - (m + ls.exp() * eps).tanh().powi(2)).ln();
        let h = 1e-6;
        let d_mean = (term(mean + h, log_std) - term(mean - h, log_std)) / (2.0 * h);
        let d_ls = (term(mean, log_std + h) - term(mean, log_std - h)) / (2.0 * h);
        let (m, ls, e) = ([mean as f32], [log_std as f32], [eps as f32]);
        let (t, gm, gs) = entropy_terms(ActionDistribution::Tanh, &m, &ls, &e)
            .next()
            .unwrap();
        assert!((t as f64 - term(mean, log_std)).abs() < 1e-6);
        assert!((gm as f64 - d_mean).abs() < 1e-5, "{gm} vs {d_mean}");
        assert!((gs as f64 - d_ls).abs() < 1e-5, "{gs} vs {d_ls}");
        let off: Vec<_> = entropy_terms(ActionDistribution::Gaussian, &m, &ls, &[]).collect();
        assert_eq!(off, vec![(0.0, 0.0, 0.0)]);
        let mut rng = crate::rng::Rng::new(1);
        assert!(entropy_noise(ActionDistribution::Gaussian, 5, &mut rng).is_empty());
        assert_eq!(
            entropy_noise(ActionDistribution::Tanh, 5, &mut rng).len(),
            10
        );
    }

    #[test]
    fn applied_actions_are_squashed_only_for_tanh() {
        let raw = [[0.5f32, -3.0], [20.0, 0.0]];
        assert_eq!(applied(ActionDistribution::Gaussian, &raw), raw.to_vec());
        let a = applied(ActionDistribution::Tanh, &raw);
        assert!((a[0][0] - 0.462_117_16).abs() < 1e-6 && (a[0][1] + 0.995_054_8).abs() < 1e-6);
        assert_eq!(a[1], [1.0, 0.0]);
    }
}

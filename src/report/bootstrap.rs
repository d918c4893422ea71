//! The pooled statistics of a variant over its seeds for `report --frontier`
//! ([`super::frontier`]). From S runs with k_s successes in n_s episodes and per-run episode
//! means m_s (progress, energy, smoothness, episode length in control steps and in seconds):
//! - the pooled success rate, sum k / sum n;
//! - each metric, the mean over seeds of m_s;
//! - for each, a 95 % percentile bootstrap over seeds: B resamples of the S seeds with
//!   replacement (SplitMix64 from a given seed), with the 2.5th and 97.5th percentiles
//!   (nearest rank) of the statistic;
//! - for two variants A and B, the difference of each statistic, A − B, with the same
//!   interval from resamples that draw A's seeds and B's seeds independently.

use crate::rng::Rng;

/// One run's evaluation: its successes and episodes, and its mean progress, energy, smoothness
/// and episode length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunEval {
    /// Successful episodes.
    pub successes: usize,
    /// Episodes evaluated.
    pub episodes: usize,
    /// Mean progress, energy, smoothness, episode length (steps) and episode length (seconds,
    /// NaN when the evaluation has no `config.toml`) over the episodes.
    pub means: [f64; METRICS],
}

/// A statistic with its 95 % bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    /// The statistic on the seeds as they are.
    pub value: f64,
    /// 2.5th percentile over the resamples.
    pub lo: f64,
    /// 97.5th percentile over the resamples.
    pub hi: f64,
}

/// The metrics averaged over seeds: progress, energy, smoothness, episode length (steps and
/// seconds).
pub const METRICS: usize = 5;
/// Index of the episode length in control steps in `RunEval::means` and `Pooled::metrics`.
pub const STEPS: usize = 3;
/// Index of the episode length in seconds in `RunEval::means` and `Pooled::metrics`.
pub const SECONDS: usize = 4;

/// The pooled success rate and the metrics over seeds, each with its bootstrap interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pooled {
    /// sum k / sum n.
    pub success: Estimate,
    /// Mean over seeds of progress, energy, smoothness and episode length (steps, seconds).
    pub metrics: [Estimate; METRICS],
}

fn statistic(runs: &[RunEval], pick: &[usize]) -> [f64; METRICS + 1] {
    let (k, n) = pick.iter().fold((0, 0), |(k, n), &i| {
        (k + runs[i].successes, n + runs[i].episodes)
    });
    let mut out = [0.0; METRICS + 1];
    out[0] = k as f64 / n.max(1) as f64;
    for m in 0..METRICS {
        out[m + 1] = pick.iter().map(|&i| runs[i].means[m]).sum::<f64>() / pick.len() as f64;
    }
    out
}

/// The percentile (nearest rank, p in [0, 1]) of sorted values.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    let i = ((p * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len()) - 1;
    sorted[i]
}

/// Indices of `n` runs drawn with replacement.
fn resample(rng: &mut Rng, n: usize) -> Vec<usize> {
    (0..n)
        .map(|_| (rng.next_u64() % n as u64) as usize)
        .collect()
}

/// Each statistic of `point` with the 2.5th and 97.5th percentiles of `draws` resampled values
/// of it from `draw`.
fn intervals(
    point: [f64; METRICS + 1],
    draws: usize,
    seed: u64,
    mut draw: impl FnMut(&mut Rng) -> [f64; METRICS + 1],
) -> Pooled {
    let mut rng = Rng::new(seed);
    let mut samples: [Vec<f64>; METRICS + 1] = Default::default();
    for _ in 0..draws {
        for (v, x) in samples.iter_mut().zip(draw(&mut rng)) {
            v.push(x);
        }
    }
    let est: Vec<Estimate> = samples
        .iter_mut()
        .zip(point)
        .map(|(v, value)| {
            v.sort_by(f64::total_cmp);
            Estimate {
                value,
                lo: percentile(v, 0.025),
                hi: percentile(v, 0.975),
            }
        })
        .collect();
    Pooled {
        success: est[0],
        metrics: [est[1], est[2], est[3], est[4], est[5]],
    }
}

/// The pooled statistics of `runs` with 95 % percentile bootstrap intervals over seeds from
/// `draws` resamples; None for no runs.
pub fn bootstrap(runs: &[RunEval], draws: usize, seed: u64) -> Option<Pooled> {
    if runs.is_empty() {
        return None;
    }
    let all: Vec<usize> = (0..runs.len()).collect();
    let point = statistic(runs, &all);
    Some(intervals(point, draws, seed, |rng| {
        statistic(runs, &resample(rng, runs.len()))
    }))
}

/// The difference `a` − `b` of two variants' pooled statistics (success rate and each metric),
/// with a 95 % percentile bootstrap interval from `draws` resamples that draw each variant's
/// seeds independently (the runs of two variants are independent trainings); None when either
/// has no runs.
pub fn difference(a: &[RunEval], b: &[RunEval], draws: usize, seed: u64) -> Option<Pooled> {
    if a.is_empty() || b.is_empty() {
        return None;
    }
    let minus = |x: [f64; METRICS + 1], y: [f64; METRICS + 1]| std::array::from_fn(|i| x[i] - y[i]);
    let (all_a, all_b): (Vec<usize>, Vec<usize>) = ((0..a.len()).collect(), (0..b.len()).collect());
    let point = minus(statistic(a, &all_a), statistic(b, &all_b));
    Some(intervals(point, draws, seed, |rng| {
        let (pa, pb) = (resample(rng, a.len()), resample(rng, b.len()));
        minus(statistic(a, &pa), statistic(b, &pb))
    }))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A run of `n` episodes with `k` successes and mean `progress`; every episode of the
    /// test directories lasts 10 steps, and with no config.toml its length in seconds is
    /// unknown.
    pub(crate) fn run(k: usize, n: usize, progress: f64) -> RunEval {
        RunEval {
            successes: k,
            episodes: n,
            means: [progress, 0.5, 0.25, 10.0, f64::NAN],
        }
    }

    #[test]
    fn the_pooled_rate_is_successes_over_episodes_and_metrics_average_over_seeds() {
        let runs = [run(10, 40, 1.0), run(30, 40, 3.0), run(20, 20, 8.0)];
        let p = bootstrap(&runs, 2000, 7).unwrap();
        assert_eq!(p.success.value, 60.0 / 100.0);
        assert_eq!(p.metrics[0].value, 4.0);
        assert_eq!(p.metrics[1].value, 0.5);
        // Every resample pools some of the three runs: between 10/40 and 20/20.
        assert!(p.success.lo >= 0.25 && p.success.hi <= 1.0);
        assert!(p.success.lo < p.success.value && p.success.value < p.success.hi);
        // Constant metric across seeds: a zero-width interval.
        assert_eq!((p.metrics[1].lo, p.metrics[1].hi), (0.5, 0.5));
        assert!(bootstrap(&[], 10, 0).is_none());
    }

    #[test]
    fn two_seeds_give_the_hand_computed_bootstrap_distribution() {
        // Two seeds, 0/10 and 10/10: a resample is both of one seed (rate 0 or 1, each with
        // probability 1/4) or one of each (rate 1/2). So the 2.5th percentile is 0 and the
        // 97.5th is 1.
        let runs = [run(0, 10, 0.0), run(10, 10, 1.0)];
        let p = bootstrap(&runs, 20_000, 3).unwrap();
        assert_eq!(
            (p.success.lo, p.success.value, p.success.hi),
            (0.0, 0.5, 1.0)
        );
        // One seed: every resample is that seed.
        let p = bootstrap(&runs[1..], 100, 3).unwrap();
        assert_eq!(
            (p.success.lo, p.success.value, p.success.hi),
            (1.0, 1.0, 1.0)
        );
    }

    #[test]
    fn a_difference_resamples_each_variant_and_subtracts_by_hand() {
        // A: 0/10 and 10/10 (a resample pools to 0, 1/2 or 1); B: one seed at 5/10. So A − B
        // is −1/2, 0 or +1/2 with probabilities 1/4, 1/2, 1/4: the 2.5th percentile is −1/2
        // and the 97.5th +1/2.
        let a = [run(0, 10, 0.0), run(10, 10, 2.0)];
        let b = [run(5, 10, 4.0)];
        let d = difference(&a, &b, 20_000, 5).unwrap();
        assert_eq!(
            (d.success.lo, d.success.value, d.success.hi),
            (-0.5, 0.0, 0.5)
        );
        // Progress: A's mean over seeds 1.0 against B's 4.0; A's resamples give 0, 1 or 2.
        assert_eq!(
            (d.metrics[0].lo, d.metrics[0].value, d.metrics[0].hi),
            (-4.0, -3.0, -2.0)
        );
        // Energy is 0.5 in every run: a difference of exactly 0.
        assert_eq!(
            (d.metrics[1].lo, d.metrics[1].value, d.metrics[1].hi),
            (0.0, 0.0, 0.0)
        );
        // Swapping the variants negates the difference.
        let e = difference(&b, &a, 20_000, 5).unwrap();
        assert_eq!(e.success.value, 0.0);
        assert_eq!(e.metrics[0].value, 3.0);
        assert!(difference(&a, &[], 10, 0).is_none() && difference(&[], &b, 10, 0).is_none());
    }

    #[test]
    fn percentile_is_the_nearest_rank() {
        let v: Vec<f64> = (1..=40).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.025), 1.0);
        assert_eq!(percentile(&v, 0.975), 39.0);
        assert_eq!(percentile(&v, 0.5), 20.0);
    }
}

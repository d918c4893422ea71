//! From run data to curves and numbers: learning curves (per-environment rolling mean over
//! `ROLLING` episodes, then mean +- 1 sigma across environments; mean with a 95 % band across
//! seeds), the key numbers of a group of runs and of a rollout, and per-step swarm metrics
//! averaged over the episodes still running at that step.

use std::collections::BTreeMap;

use super::data::{Episode, RolloutRun, SwarmStep, TrainRun};
use super::stats::{self, Band};

/// Episodes in the rolling mean of a learning curve.
pub const ROLLING: usize = 5;

/// The episode metrics, in the order of `Episode::metrics`.
pub const METRICS: [&str; 3] = ["progress", "energy", "smoothness"];

/// Outcomes in the order reports list them.
pub const OUTCOMES: [&str; 4] = ["success", "failure", "timeout", "diverged"];

/// Each environment's episodes of a run, in episode order.
fn by_env(episodes: &[Episode]) -> BTreeMap<usize, Vec<&Episode>> {
    let mut envs: BTreeMap<usize, Vec<&Episode>> = BTreeMap::new();
    for e in episodes {
        envs.entry(e.env).or_default().push(e);
    }
    for list in envs.values_mut() {
        list.sort_by_key(|e| e.episode);
    }
    envs
}

/// Per environment: (global step of each episode, rolling mean of metric `m`).
pub fn env_series(run: &TrainRun, m: usize) -> Vec<(Vec<f64>, Vec<f64>)> {
    by_env(&run.episodes)
        .values()
        .map(|eps| {
            let x = eps.iter().map(|e| e.global_step as f64).collect();
            let v: Vec<f64> = eps.iter().map(|e| e.metrics[m]).collect();
            (x, stats::rolling_mean(&v, ROLLING))
        })
        .collect()
}

/// One run's learning curve of metric `m`: mean +- 1 sigma across its environments.
pub fn run_curve(run: &TrainRun, m: usize) -> Band {
    stats::across_series_std(&env_series(run, m))
}

/// A group's learning curve: one run's curve, or the mean across runs (seeds) with a 95 %
/// confidence band.
pub fn group_curve(runs: &[TrainRun], m: usize) -> Band {
    let curves: Vec<Band> = runs.iter().map(|r| run_curve(r, m)).collect();
    stats::across_seeds_ci(&curves)
}

/// The key numbers of a group of training runs (one experiment, several seeds).
#[derive(Debug, Clone)]
pub struct TrainSummary {
    /// Number of runs in the group.
    pub runs: usize,
    /// Finished episodes over all runs.
    pub episodes: usize,
    /// Count per outcome, in `OUTCOMES` order.
    pub outcomes: [usize; 4],
    /// Final metrics: each environment's mean over its last `ROLLING` episodes, then mean and
    /// population sigma over all (run, environment) pairs.
    pub final_metrics: [(f64, f64); 3],
    /// Fraction of all episodes that ended in success.
    pub success_rate: f64,
    /// Mean episode length of successful episodes (s); None without any.
    pub mean_time_to_success_s: Option<f64>,
    /// Global steps of each run.
    pub global_steps: Vec<u64>,
    /// Simulation + learning wall time of each run (s).
    pub wall_s: Vec<f64>,
}

fn outcome_counts<'a>(episodes: impl Iterator<Item = &'a Episode>) -> [usize; 4] {
    let mut c = [0; 4];
    for e in episodes {
        if let Some(k) = OUTCOMES.iter().position(|o| *o == e.outcome) {
            c[k] += 1;
        }
    }
    c
}

fn mean_success_time(episodes: &[&Episode], dt: f64) -> Option<f64> {
    let t: Vec<f64> = episodes
        .iter()
        .filter(|e| e.outcome == "success")
        .map(|e| e.steps as f64 * dt)
        .collect();
    (!t.is_empty()).then(|| t.iter().sum::<f64>() / t.len() as f64)
}

/// The key numbers of a group of training runs.
pub fn train_summary(runs: &[TrainRun]) -> TrainSummary {
    let all: Vec<&Episode> = runs.iter().flat_map(|r| &r.episodes).collect();
    let mut final_metrics = [(f64::NAN, f64::NAN); 3];
    for (m, slot) in final_metrics.iter_mut().enumerate() {
        let finals: Vec<f64> = runs
            .iter()
            .flat_map(|r| env_series(r, m))
            .filter_map(|(_, v)| v.last().copied())
            .collect();
        *slot = stats::mean_std(&finals);
    }
    let outcomes = outcome_counts(all.iter().copied());
    let dt = runs.first().map_or(0.0, |r| r.info.control_dt_s);
    TrainSummary {
        runs: runs.len(),
        episodes: all.len(),
        outcomes,
        final_metrics,
        success_rate: outcomes[0] as f64 / all.len().max(1) as f64,
        mean_time_to_success_s: mean_success_time(&all, dt),
        global_steps: runs.iter().map(TrainRun::global_steps).collect(),
        wall_s: runs.iter().map(TrainRun::wall_s).collect(),
    }
}

/// The key numbers of a rollout: metrics mean and population sigma over its episodes.
#[derive(Debug, Clone)]
pub struct RolloutSummary {
    /// The rollout's short name ([`RolloutRun::label`]).
    pub label: String,
    /// Number of finished episodes.
    pub episodes: usize,
    /// Count per outcome, in `OUTCOMES` order.
    pub outcomes: [usize; 4],
    /// Mean episode length (control steps).
    pub mean_steps: f64,
    /// (mean, population sigma) of progress, energy, smoothness over the episodes.
    pub metrics: [(f64, f64); 3],
    /// Mean final swarm x over the episodes (mm).
    pub final_x_com_mm: f64,
    /// Mean episode length of successful episodes (s); None without any.
    pub mean_time_to_success_s: Option<f64>,
}

/// The key numbers of a rollout or eval run.
pub fn rollout_summary(run: &RolloutRun) -> RolloutSummary {
    let eps: Vec<&Episode> = run.episodes.iter().collect();
    let metric = |m: usize| {
        let v: Vec<f64> = eps.iter().map(|e| e.metrics[m]).collect();
        stats::mean_std(&v)
    };
    let steps: Vec<f64> = eps.iter().map(|e| e.steps as f64).collect();
    let x: Vec<f64> = eps.iter().map(|e| e.final_x_com_mm).collect();
    RolloutSummary {
        label: run.label(),
        episodes: eps.len(),
        outcomes: outcome_counts(eps.iter().copied()),
        mean_steps: stats::mean_std(&steps).0,
        metrics: [metric(0), metric(1), metric(2)],
        final_x_com_mm: stats::mean_std(&x).0,
        mean_time_to_success_s: mean_success_time(&eps, run.info.control_dt_s),
    }
}

/// A swarm metric over the time since the episode start, averaged at each step over the
/// episodes still running then: (t_s, metric, inlet centreline velocity in mm/s).
pub fn swarm_over_time(run: &RolloutRun, f: impl Fn(&SwarmStep) -> f64) -> Vec<(f64, f64, f64)> {
    let mut sums: BTreeMap<u64, (f64, f64, f64, usize)> = BTreeMap::new();
    for s in &run.swarm {
        let e = sums.entry(s.step).or_default();
        e.0 += s.t_s;
        e.1 += f(s);
        e.2 += 1e3 * s.inlet_u_m_s;
        e.3 += 1;
    }
    sums.values()
        .map(|&(t, v, u, n)| (t / n as f64, v / n as f64, u / n as f64))
        .collect()
}

/// Rolling mean of a per-update diagnostic over `window` updates, averaged across runs by
/// update index: (global step, value).
pub fn update_series(
    runs: &[TrainRun],
    window: usize,
    f: impl Fn(&super::data::Update) -> f64,
) -> Vec<(f64, f64)> {
    let per_run: Vec<Vec<f64>> = runs
        .iter()
        .map(|r| {
            let v: Vec<f64> = r.updates.iter().map(&f).collect();
            stats::rolling_mean(&v, window)
        })
        .collect();
    let n = per_run.iter().map(Vec::len).min().unwrap_or(0);
    (0..n)
        .map(|i| {
            let x = runs[0].updates[i].global_step as f64;
            let v = per_run.iter().map(|r| r[i]).sum::<f64>() / per_run.len() as f64;
            (x, v)
        })
        .collect()
}

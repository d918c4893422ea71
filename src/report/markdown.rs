//! `report.md`: the figures and the key numbers of the runs (final metrics mean +- sigma over
//! seeds and environments, success rate, mean time to success, diverged episodes, steps, wall
//! time, adapter) and of the rollouts (baselines, before and after learning).

use std::fmt::Write;

use super::analysis::{self, OUTCOMES, ROLLING, RolloutSummary, TrainSummary};
use super::data::TrainRun;
use super::{Loaded, group_label};

const FIGURES: [(&str, &str); 4] = [
    (
        "learning_curves.png",
        "progress, energy and smoothness against global environment steps; baselines as horizontal bands",
    ),
    (
        "gradient_conflicts.png",
        "cosines between the three actor-loss gradients and the fraction of conflicting minibatches over training",
    ),
    (
        "dispersion.png",
        "σ_x and σ_y over the episode with the inlet waveform, before vs after learning",
    ),
    (
        "com_rg.png",
        "centre of mass x_COM and radius of gyration R_g over the episode with the inlet waveform, before vs after learning",
    ),
];

/// `mean ± sd` with `digits` decimals; `—` without values.
pub fn pm(v: (f64, f64), digits: usize) -> String {
    if v.0.is_nan() {
        return "—".into();
    }
    format!("{:.*} ± {:.*}", digits, v.0, digits, v.1)
}

fn outcomes(c: &[usize; 4]) -> String {
    let parts: Vec<String> = OUTCOMES
        .iter()
        .zip(c)
        .filter(|(_, n)| **n > 0)
        .map(|(o, n)| format!("{n} {o}"))
        .collect();
    if parts.is_empty() {
        "none".into()
    } else {
        parts.join(", ")
    }
}

fn time(t: Option<f64>) -> String {
    t.map_or("—".into(), |t| format!("{t:.3}"))
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let v: Vec<f64> = v.collect();
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

/// The text of `report.md` for the loaded runs and the written `figures`.
pub fn report(l: &Loaded, figures: &[String]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# fluxswarm-gpu report\n");
    let _ = writeln!(
        s,
        "Written by fluxswarm-gpu {} on {}.",
        env!("CARGO_PKG_VERSION"),
        chrono::Utc::now().format("%Y-%m-%d %H:%M UTC")
    );
    let mut adapters: Vec<String> = l
        .runs
        .iter()
        .chain(&l.compare)
        .filter_map(|r| r.info.adapter.clone())
        .collect();
    adapters.sort();
    adapters.dedup();
    let _ = writeln!(
        s,
        "Adapter: {}.\n",
        if adapters.is_empty() {
            "not recorded".into()
        } else {
            adapters.join("; ")
        }
    );

    let _ = writeln!(s, "## Figures\n");
    for (name, what) in FIGURES {
        if figures.iter().any(|f| f == name) {
            let _ = writeln!(s, "- [{name}]({name}): {what}");
        }
    }
    let _ = writeln!(s);

    let _ = writeln!(s, "## Training\n");
    let _ = writeln!(
        s,
        "Final metrics: each environment's mean over its last {ROLLING} episodes, then mean ± σ \
         (population) over all runs and environments. Success rate and mean time to success over \
         all training episodes.\n"
    );
    let _ = writeln!(
        s,
        "| experiment | runs | global steps per run | wall time per run (s) | episodes | outcomes | success rate | mean time to success (s) | diverged | progress | energy | smoothness |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|---|");
    for group in [&l.runs, &l.compare] {
        if group.is_empty() {
            continue;
        }
        let t: TrainSummary = analysis::train_summary(group);
        let _ = writeln!(
            s,
            "| {} | {} | {:.0} | {:.0} | {} | {} | {:.1} % | {} | {} | {} | {} | {} |",
            group_label(group),
            t.runs,
            mean(t.global_steps.iter().map(|&g| g as f64)),
            mean(t.wall_s.iter().copied()),
            t.episodes,
            outcomes(&t.outcomes),
            100.0 * t.success_rate,
            time(t.mean_time_to_success_s),
            t.outcomes[3],
            pm(t.final_metrics[0], 2),
            pm(t.final_metrics[1], 3),
            pm(t.final_metrics[2], 3),
        );
    }
    let _ = writeln!(s, "\nPer run:\n");
    let _ = writeln!(
        s,
        "| run | seed | environments | global steps | updates | wall time (s) | episodes | progress | energy | smoothness |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for run in l.runs.iter().chain(&l.compare) {
        per_run_row(&mut s, run);
    }

    let rollouts: Vec<(String, RolloutSummary)> = l
        .baselines
        .iter()
        .map(|b| ("baseline".to_string(), analysis::rollout_summary(b)))
        .chain(l.before_after.iter().flat_map(|(b, a)| {
            [
                ("before learning".to_string(), analysis::rollout_summary(b)),
                ("after learning".to_string(), analysis::rollout_summary(a)),
            ]
        }))
        .collect();
    if !rollouts.is_empty() {
        let _ = writeln!(s, "\n## Rollouts\n");
        let _ = writeln!(
            s,
            "Mean ± σ (population) over each rollout's episodes.\n\n\
             | role | policy | episodes | outcomes | steps | mean time to success (s) | progress | energy | smoothness | final x_COM (mm) |"
        );
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
        for (role, r) in &rollouts {
            let _ = writeln!(
                s,
                "| {role} | {} | {} | {} | {:.1} | {} | {} | {} | {} | {:.2} |",
                r.label,
                r.episodes,
                outcomes(&r.outcomes),
                r.mean_steps,
                time(r.mean_time_to_success_s),
                pm(r.metrics[0], 2),
                pm(r.metrics[1], 3),
                pm(r.metrics[2], 3),
                r.final_x_com_mm,
            );
        }
    }
    s
}

fn per_run_row(s: &mut String, run: &TrainRun) {
    let t = analysis::train_summary(std::slice::from_ref(run));
    let _ = writeln!(
        s,
        "| {} | {} | {} | {} | {} | {:.0} | {} | {} | {} | {} |",
        run.info.dir.display(),
        run.info.seed.map_or("?".into(), |v| v.to_string()),
        run.info.envs.map_or("?".into(), |v| v.to_string()),
        run.global_steps(),
        run.updates.len(),
        run.wall_s(),
        run.episodes.len(),
        pm(t.final_metrics[0], 2),
        pm(t.final_metrics[1], 3),
        pm(t.final_metrics[2], 3),
    );
}

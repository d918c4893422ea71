//! The per-run table of `report --frontier` ([`super::frontier`]): a row per run, by variant and
//! then seed, for every run with an evaluation or a training curve. For the mean action
//! (`deterministic`) and the sampled evaluation of the final policy: k/n, the mean episode length
//! in control steps and in simulated seconds, and the mean progress; and the run's training
//! episodes with how many succeeded (the sum over its curve's bins). `-` for what has not run.

use super::bootstrap::{RunEval, SECONDS, STEPS};
use super::frontier::Row;
use super::training_curve::Curve;

/// The run's evaluation `evaluation` among `rows`, if it ran.
fn find<'a>(rows: &'a [Row], variant: usize, seed: &str, evaluation: &str) -> Option<&'a RunEval> {
    let row = rows
        .iter()
        .find(|r| r.variant == variant && r.evaluation == evaluation)?;
    let i = row.run_seeds.iter().position(|s| s == seed)?;
    row.runs.get(i)
}

/// `k/n | steps (seconds s) | progress`, or dashes.
fn cells(e: Option<&RunEval>) -> String {
    let Some(e) = e else {
        return "- | - | -".into();
    };
    let seconds = e.means[SECONDS];
    let seconds = if seconds.is_nan() {
        "-".to_string()
    } else {
        format!("{seconds:.3} s")
    };
    format!(
        "{}/{} | {:.2} ({seconds}) | {:.1}",
        e.successes, e.episodes, e.means[STEPS], e.means[0]
    )
}

/// Seeds sort as numbers where they are numbers.
fn seed_key(seed: &str) -> (u64, String) {
    (seed.parse().unwrap_or(u64::MAX), seed.to_string())
}

/// The `## Per run` section of `frontier.md`.
pub fn markdown(rows: &[Row], curves: &[Curve]) -> String {
    let mut runs: Vec<(usize, String)> = rows
        .iter()
        .filter(|r| r.evaluation == "sampled" || r.evaluation == "deterministic")
        .flat_map(|r| r.run_seeds.iter().map(|s| (r.variant, s.clone())))
        .chain(curves.iter().map(|c| (c.variant, c.seed.clone())))
        .collect();
    runs.sort_by_key(|(v, s)| (*v, seed_key(s)));
    runs.dedup();
    let mut md = String::from(
        "## Per run\n\nEach run's final policy under the protocol's two evaluations (successes \
         of the episodes, mean episode length in control steps and in simulated seconds, mean \
         progress), and its training episodes with how many succeeded.\n\n\
         | variant | seed | mean action: success | steps (s) | progress | sampled: success | \
         steps (s) | progress | training episodes (successes) |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for (variant, seed) in &runs {
        let training = curves
            .iter()
            .find(|c| c.variant == *variant && &c.seed == seed)
            .map(|c| {
                let n: usize = c.bins.iter().map(|b| b.episodes).sum();
                let k: usize = c.bins.iter().map(|b| b.successes).sum();
                format!("{n} ({k})")
            })
            .unwrap_or_else(|| "-".into());
        md += &format!(
            "| {variant} | {seed} | {} | {} | {training} |\n",
            cells(find(rows, *variant, seed, "deterministic")),
            cells(find(rows, *variant, seed, "sampled")),
        );
    }
    if runs.is_empty() {
        md += "\nNo run is evaluated or done yet.\n";
    }
    md + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::training_curve::{BINS, Bin};

    fn eval(k: usize, n: usize, steps: f64, seconds: f64, progress: f64) -> RunEval {
        RunEval {
            successes: k,
            episodes: n,
            means: [progress, 0.0, 0.0, steps, seconds],
        }
    }

    fn row(variant: usize, evaluation: &str, runs: &[(&str, RunEval)]) -> Row {
        Row {
            variant,
            overrides: String::new(),
            evaluation: evaluation.into(),
            seeds: 5,
            runs: runs.iter().map(|(_, e)| *e).collect(),
            run_seeds: runs.iter().map(|(s, _)| s.to_string()).collect(),
            pooled: None,
        }
    }

    fn curve(variant: usize, seed: &str, bins: &[(usize, usize)]) -> Curve {
        let mut b = [Bin::default(); BINS];
        for (slot, &(successes, episodes)) in b.iter_mut().zip(bins) {
            *slot = Bin {
                successes,
                episodes,
            };
        }
        Curve {
            variant,
            seed: seed.into(),
            bins: b,
            snapshots: Vec::new(),
        }
    }

    #[test]
    fn a_row_per_run_by_variant_then_numeric_seed_with_dashes_for_what_has_not_run() {
        let rows = [
            row(
                1,
                "sampled",
                &[
                    ("10", eval(3, 40, 812.25, 4.0612, -1.26)),
                    ("2", eval(0, 40, 100.0, 0.5, -80.0)),
                ],
            ),
            row(
                1,
                "deterministic",
                &[("2", eval(40, 40, 300.0, f64::NAN, 7.0))],
            ),
            // A neighbour evaluation has no column here.
            row(
                0,
                "neighbours/scale-x0.9",
                &[("1", eval(1, 1, 1.0, 1.0, 1.0))],
            ),
        ];
        // Variant 0 seed 1 is trained, not evaluated: 2 + 4 episodes, 1 success.
        let curves = [curve(0, "1", &[(0, 2), (1, 4)]), curve(1, "2", &[(5, 9)])];
        let md = markdown(&rows, &curves);
        let body: Vec<&str> = md
            .lines()
            .filter(|l| l.starts_with("| 0 ") || l.starts_with("| 1 "))
            .collect();
        assert_eq!(
            body,
            [
                "| 0 | 1 | - | - | - | - | - | - | 6 (1) |",
                "| 1 | 2 | 40/40 | 300.00 (-) | 7.0 | 0/40 | 100.00 (0.500 s) | -80.0 | 9 (5) |",
                "| 1 | 10 | - | - | - | 3/40 | 812.25 (4.061 s) | -1.3 | - |",
            ]
        );
        assert!(markdown(&[], &[]).contains("No run is evaluated or done yet."));
    }
}

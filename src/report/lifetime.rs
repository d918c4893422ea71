//! `report --frontier`'s lifetime section, issue 19's item 4 (docs/controllability.md,
//! amendments of 2026-12-03 18:25 and 2026-12-05 14:09 UTC): where no evaluation episode of any
//! variant or comparator succeeds, as at the paper's setup, the question is whether a trained
//! policy at least outlasts the best non-learned controller. The measure is the mean episode
//! length in simulated seconds, T = steps x `time.control_dt_s`.
//!
//! For each variant and evaluation with T's bootstrap interval [lo, hi] over seeds, against
//! the longest-lived comparator's T_c (the comparators are not learned, so every one counts):
//! - `outlasts it` when lo > T_c;
//! - `shorter` when hi < T_c;
//! - `interval includes it` otherwise.
//!
//! Where any episode succeeds, a success ends its episode early, so the lifetime says nothing
//! and the section is left out.

use super::bootstrap::SECONDS;
use super::frontier::{Comparator, Row, policy_name};
use super::frontier_output::interval;

/// The comparator with the longest mean episode in seconds (ties to the first), None when no
/// comparator's length in seconds is known.
pub fn longest_lived(comparators: &[Comparator]) -> Option<&Comparator> {
    comparators
        .iter()
        .filter(|c| !c.mean_seconds.is_nan())
        .fold(None, |best: Option<&Comparator>, c| match best {
            Some(b) if b.mean_seconds >= c.mean_seconds => Some(b),
            _ => Some(c),
        })
}

/// Whether no evaluated episode of any variant or comparator succeeded (and something was
/// evaluated): the condition for the lifetime to be the measure.
pub fn every_episode_fails(rows: &[Row], comparators: &[Comparator]) -> bool {
    let evaluated = rows.iter().any(|r| !r.runs.is_empty()) || !comparators.is_empty();
    let successes = rows
        .iter()
        .flat_map(|r| &r.runs)
        .map(|e| e.successes)
        .chain(comparators.iter().map(|c| c.successes))
        .sum::<usize>();
    evaluated && successes == 0
}

/// A variant's lifetime interval [lo, hi] against the comparator's `reference`.
pub fn verdict(lo: f64, hi: f64, reference: f64) -> &'static str {
    if lo > reference {
        "outlasts it"
    } else if hi < reference {
        "shorter"
    } else {
        "interval includes it"
    }
}

/// The section's markdown, or an empty string where it does not apply.
pub fn markdown(rows: &[Row], comparators: &[Comparator]) -> String {
    if !every_episode_fails(rows, comparators) {
        return String::new();
    }
    let Some(best) = longest_lived(comparators) else {
        return String::new();
    };
    let mut md = format!(
        "## Lifetime against the longest-lived non-learned controller\n\n\
         No evaluation episode succeeds, so the measure is the mean episode length in simulated \
         seconds (issue 19's item 4). The longest-lived comparator is `{}`: {:.3} s. A variant \
         outlasts it when the lower end of its 95 % interval over seeds is above that, and is \
         shorter when the upper end is below. Until all of a variant's seeds are evaluated \
         (`runs`) its verdict is provisional, and one seed's interval has no width.\n\n\
         | variant | evaluation | runs | seconds | difference | verdict |\n\
         |---|---|---|---|---|---|\n",
        policy_name(&best.policy),
        best.mean_seconds
    );
    for r in rows {
        let Some(p) = &r.pooled else { continue };
        let t = p.metrics[SECONDS];
        if t.value.is_nan() {
            continue;
        }
        md += &format!(
            "| {} | {} | {}/{} | {} | {:+.3} | {} |\n",
            r.variant,
            r.evaluation,
            r.runs.len(),
            r.seeds,
            interval(&t, 3),
            t.value - best.mean_seconds,
            verdict(t.lo, t.hi, best.mean_seconds)
        );
    }
    md + "\n"
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::bootstrap::{RunEval, bootstrap};

    fn comparator(policy: &str, successes: usize, seconds: f64) -> Comparator {
        Comparator {
            policy: policy.into(),
            successes,
            episodes: 40,
            mean_steps: seconds / 0.005,
            mean_seconds: seconds,
        }
    }

    fn run(successes: usize, seconds: f64) -> RunEval {
        RunEval {
            successes,
            episodes: 40,
            means: [-120.0, 0.9, 0.9, seconds / 0.005, seconds],
        }
    }

    fn row(variant: usize, runs: &[RunEval]) -> Row {
        Row {
            variant,
            overrides: String::new(),
            evaluation: "sampled".into(),
            seeds: 5,
            runs: runs.to_vec(),
            run_seeds: (1..=runs.len()).map(|s| s.to_string()).collect(),
            pooled: bootstrap(runs, 1000, 0),
        }
    }

    #[test]
    fn the_longest_lived_comparator_skips_unknown_lengths_and_ties_to_the_first() {
        let cs = [
            comparator("zero", 0, 0.120),
            comparator("wall-angle-40", 0, 0.170),
            comparator("scripted", 0, f64::NAN),
            comparator("wall-angle-60", 0, 0.170),
        ];
        assert_eq!(longest_lived(&cs).unwrap().policy, "wall-angle-40");
        assert!(longest_lived(&cs[2..3]).is_none());
        assert!(longest_lived(&[]).is_none());
    }

    #[test]
    fn the_verdict_reads_the_whole_interval() {
        assert_eq!(verdict(0.171, 0.2, 0.170), "outlasts it");
        assert_eq!(verdict(0.112, 0.169, 0.170), "shorter");
        assert_eq!(verdict(0.160, 0.180, 0.170), "interval includes it");
        // An interval that ends on the reference does not clear it either way.
        assert_eq!(verdict(0.170, 0.180, 0.170), "interval includes it");
        assert_eq!(verdict(0.160, 0.170, 0.170), "interval includes it");
    }

    #[test]
    fn the_section_lists_every_variant_only_where_every_episode_fails() {
        let cs = [
            comparator("wall-angle-40", 0, 0.170),
            comparator("zero", 0, 0.120),
        ];
        // Two seeds at 0.115 s and 0.145 s: mean 0.130, every resample within [0.115, 0.145].
        let rows = [
            row(0, &[run(0, 0.115), run(0, 0.145)]),
            row(1, &[run(0, 0.180), run(0, 0.190)]),
            row(2, &[]),
        ];
        let md = markdown(&rows, &cs);
        assert!(md.contains("`wall-angle:40`: 0.170 s"), "{md}");
        assert!(
            md.contains("| 0 | sampled | 2/5 | 0.130 [0.115, 0.145] | -0.040 | shorter |"),
            "{md}"
        );
        assert!(
            md.contains("| 1 | sampled | 2/5 | 0.185 [0.180, 0.190] | +0.015 | outlasts it |"),
            "{md}"
        );
        // A variant with no evaluated run has no row.
        assert!(!md.contains("| 2 |"), "{md}");
        // One success anywhere, a variant's or a comparator's: no section.
        let won = [row(0, &[run(1, 0.115)])];
        assert_eq!(markdown(&won, &cs), "");
        assert_eq!(markdown(&rows, &[comparator("wall", 1, 6.0)]), "");
        // Nothing evaluated: no section.
        assert_eq!(markdown(&[], &[]), "");
    }
}

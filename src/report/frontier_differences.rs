//! Each variant against the sweep's first (variant 0, in the frontier protocol the paper's
//! learner with PCGrad), for `report --frontier` (issue 19, item 3: PCGrad against its
//! ablation and the controls).
//! - Per evaluation, for each variant v > 0 with evaluated runs: D = S(v) − S(0) for the pooled
//!   success rate and each metric's mean over seeds, with the 95 % percentile bootstrap
//!   interval of [`bootstrap::difference`] (each variant's seeds drawn independently).
//! - Output: a section of `frontier.md` (the success rate in percentage points) and
//!   `frontier_differences.csv` (a row per variant and evaluation, the columns of
//!   `frontier.csv`'s statistics).

use super::bootstrap::{self, METRICS, Pooled, SECONDS, STEPS};
use super::error::{ReportError, Result};
use super::frontier::{DRAWS, Row};

/// One variant's difference from the reference variant under one evaluation.
#[derive(Debug, Clone)]
pub struct Difference {
    /// The variant.
    pub variant: usize,
    /// Its overrides, as sweep.csv gives them.
    pub overrides: String,
    /// The variant it is compared with (the first).
    pub reference: usize,
    /// `sampled`, `deterministic` or a neighbour.
    pub evaluation: String,
    /// Evaluated runs of the variant and of the reference.
    pub runs: (usize, usize),
    /// The variant's statistics minus the reference's, with intervals.
    pub delta: Pooled,
}

/// The difference of every variant from the lowest-numbered one with evaluated runs, per
/// evaluation; variants without evaluated runs are left out.
pub fn against_first(rows: &[Row]) -> Vec<Difference> {
    let mut out = Vec::new();
    let mut evaluations: Vec<&str> = Vec::new();
    for r in rows {
        if !evaluations.contains(&r.evaluation.as_str()) {
            evaluations.push(&r.evaluation);
        }
    }
    for evaluation in evaluations {
        let of: Vec<&Row> = rows
            .iter()
            .filter(|r| r.evaluation == evaluation && !r.runs.is_empty())
            .collect();
        let Some((reference, others)) = of.split_first() else {
            continue;
        };
        for r in others {
            if let Some(delta) = bootstrap::difference(&r.runs, &reference.runs, DRAWS, 0) {
                out.push(Difference {
                    variant: r.variant,
                    overrides: r.overrides.clone(),
                    reference: reference.variant,
                    evaluation: evaluation.to_string(),
                    runs: (r.runs.len(), reference.runs.len()),
                    delta,
                });
            }
        }
    }
    out
}

/// `+value [+lo, +hi]` with `decimals`, scaled by `scale`, or `-` for NaN.
fn signed(e: &bootstrap::Estimate, scale: f64, decimals: usize) -> String {
    if e.value.is_nan() {
        return "-".into();
    }
    format!(
        "{:+.d$} [{:+.d$}, {:+.d$}]",
        scale * e.value,
        scale * e.lo,
        scale * e.hi,
        d = decimals
    )
}

/// The section of `frontier.md`; empty when no variant has a difference.
pub fn markdown(differences: &[Difference]) -> String {
    let Some(first) = differences.first() else {
        return String::new();
    };
    let mut md = format!(
        "## Against the first variant\n\nEach variant's pooled statistics minus those of the \
         first variant with evaluated runs (variant {}), per evaluation: the success rate in \
         percentage points, the other metrics in their units. \
         Each difference comes with its 95 % percentile bootstrap interval ({DRAWS} resamples, \
         each drawing both variants' seeds independently); an interval that excludes 0 is a \
         difference these seeds resolve.\n\n",
        first.reference
    );
    md += "| variant | overrides | evaluation | runs | success (points) | progress | energy | smoothness | steps | seconds |\n";
    md += "|---|---|---|---|---|---|---|---|---|---|\n";
    for d in differences {
        let m = &d.delta.metrics;
        md += &format!(
            "| {} − {} | {} | {} | {} vs {} | {} | {} | {} | {} | {} | {} |\n",
            d.variant,
            d.reference,
            d.overrides,
            d.evaluation,
            d.runs.0,
            d.runs.1,
            signed(&d.delta.success, 100.0, 0),
            signed(&m[0], 1.0, 2),
            signed(&m[1], 1.0, 3),
            signed(&m[2], 1.0, 3),
            signed(&m[STEPS], 1.0, 0),
            signed(&m[SECONDS], 1.0, 3),
        );
    }
    md + "\n"
}

/// The statistics' column names: each of success rate, progress, energy, smoothness, steps
/// and seconds with its `_lo` and `_hi`.
pub(super) fn statistic_header() -> Vec<String> {
    let mut head = Vec::new();
    for m in [
        "success_rate",
        "progress",
        "energy",
        "smoothness",
        "steps",
        "seconds",
    ] {
        head.extend([m.to_string(), format!("{m}_lo"), format!("{m}_hi")]);
    }
    head
}

/// The cells under [`statistic_header`]: six decimals, an empty cell for what could not be
/// computed (NaN seconds), all empty for no statistics.
pub(super) fn statistic_cells(p: Option<&Pooled>) -> Vec<String> {
    match p {
        Some(p) => std::iter::once(p.success)
            .chain(p.metrics)
            .flat_map(|e| {
                [e.value, e.lo, e.hi].map(|v| {
                    if v.is_nan() {
                        String::new()
                    } else {
                        format!("{v:.6}")
                    }
                })
            })
            .collect(),
        None => vec![String::new(); 3 * (1 + METRICS)],
    }
}

/// `frontier_differences.csv`: a row per variant and evaluation.
pub fn csv(differences: &[Difference]) -> Result<Vec<u8>> {
    let bad = |e: csv::Error| ReportError::Invalid(format!("frontier_differences.csv: {e}"));
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut head: Vec<String> = [
        "variant",
        "overrides",
        "reference",
        "evaluation",
        "runs",
        "reference_runs",
    ]
    .map(String::from)
    .to_vec();
    head.extend(statistic_header());
    w.write_record(&head).map_err(bad)?;
    for d in differences {
        let mut row = vec![
            d.variant.to_string(),
            d.overrides.clone(),
            d.reference.to_string(),
            d.evaluation.clone(),
            d.runs.0.to_string(),
            d.runs.1.to_string(),
        ];
        row.extend(statistic_cells(Some(&d.delta)));
        w.write_record(&row).map_err(bad)?;
    }
    w.into_inner()
        .map_err(|e| ReportError::Invalid(format!("frontier_differences.csv: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::bootstrap::{RunEval, tests::run};

    fn row(variant: usize, evaluation: &str, runs: &[RunEval]) -> Row {
        Row {
            variant,
            overrides: format!("--v{variant}"),
            evaluation: evaluation.into(),
            seeds: 2,
            runs: runs.to_vec(),
            run_seeds: (1..=runs.len()).map(|s| s.to_string()).collect(),
            pooled: bootstrap::bootstrap(runs, 10, 0),
        }
    }

    #[test]
    fn every_variant_is_compared_with_the_first_that_has_runs_per_evaluation() {
        let rows = [
            row(0, "sampled", &[run(10, 40, 1.0), run(20, 40, 3.0)]),
            row(1, "sampled", &[run(30, 40, 5.0)]),
            row(0, "deterministic", &[]),
            row(1, "deterministic", &[run(4, 40, 0.0)]),
            // Out of order: an evaluation's rows need not be adjacent.
            row(2, "sampled", &[]),
            row(2, "deterministic", &[run(8, 40, 1.0), run(0, 40, 3.0)]),
        ];
        let d = against_first(&rows);
        let got: Vec<(usize, usize, &str, (usize, usize))> = d
            .iter()
            .map(|d| (d.variant, d.reference, d.evaluation.as_str(), d.runs))
            .collect();
        assert_eq!(
            got,
            [(1, 0, "sampled", (1, 2)), (2, 1, "deterministic", (2, 1))]
        );
        // 30/40 − 30/80 = 0.375; progress 5 − 2 = 3.
        assert_eq!(d[0].delta.success.value, 0.375);
        assert_eq!(d[0].delta.metrics[0].value, 3.0);
        // 8/80 − 4/40 = 0; progress 2 − 0.
        assert_eq!(d[1].delta.success.value, 0.0);
        assert_eq!(d[1].delta.metrics[0].value, 2.0);

        let md = markdown(&d);
        assert!(md.starts_with("## Against the first variant\n"));
        assert!(md.contains("| 1 − 0 | --v1 | sampled | 1 vs 2 | +38 ["));
        assert!(markdown(&[]).is_empty());
        let csv = String::from_utf8(csv(&d).unwrap()).unwrap();
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines.len(), 3);
        assert!(lines[0].starts_with("variant,overrides,reference,evaluation,runs,reference_runs,success_rate,success_rate_lo,"));
        assert!(lines[1].starts_with("1,--v1,0,sampled,1,2,0.375000,"));
        // Seconds are NaN in the test runs: empty cells at the end.
        assert!(lines[1].ends_with(",,,"));
    }
}

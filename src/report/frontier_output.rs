//! `frontier.md` and `frontier.csv` of `report --frontier` ([`super::frontier`]): one row per
//! variant and evaluation (the pooled success rate, progress, energy, smoothness and episode
//! length in control steps and in seconds, each with its 95 % bootstrap interval over seeds,
//! and each seed's successes), the comparators with their Wilson intervals and episode length,
//! the protocol's goal and the variant its rule ranks best,
//! each variant against the first ([`super::frontier_differences`], also
//! `frontier_differences.csv`), each variant's lifetime against the longest-lived comparator
//! where every episode fails ([`super::lifetime`]), then a row per run
//! ([`super::frontier_runs`]) and the training curves ([`super::training_curve`]).

use std::path::Path;

use super::bootstrap::{Estimate, SECONDS, STEPS};
use super::error::{ReportError, Result};
use super::frontier::{
    CONSTANT_BAR, Comparator, DRAWS, GOAL, Row, constants_under_bar, load, policy_name, ranked_best,
};
use super::frontier_differences::{self, statistic_cells, statistic_header};
use super::frontier_runs;
use super::lifetime;
use super::map::is_constant;
use super::stats::wilson95;
use super::training_curve::{self, Curve};

/// `v` with `decimals`, or `-` for a metric that could not be computed (NaN: an episode
/// length in seconds of an evaluation without its `config.toml`).
fn number(v: f64, decimals: usize) -> String {
    if v.is_nan() {
        return "-".into();
    }
    format!("{v:.decimals$}")
}

/// `value [lo, hi]` with `decimals`, or `-` as [`number`].
pub(super) fn interval(e: &Estimate, decimals: usize) -> String {
    if e.value.is_nan() {
        return "-".into();
    }
    format!("{:.d$} [{:.d$}, {:.d$}]", e.value, e.lo, e.hi, d = decimals)
}

fn pct(e: &Estimate) -> String {
    format!(
        "{:.0} % [{:.0}, {:.0}]",
        100.0 * e.value,
        100.0 * e.lo,
        100.0 * e.hi
    )
}

/// Whether the pooled table shows `r`: every sampled and deterministic row, and a neighbour
/// only where the variant has run in it.
fn shown(r: &Row) -> bool {
    !(r.evaluation.starts_with("neighbours/") && r.runs.is_empty())
}

/// `frontier.md`.
pub fn markdown(root: &Path, rows: &[Row], comparators: &[Comparator], curves: &[Curve]) -> String {
    let mut md = format!("# Learning at the frontier: {}\n\n", root.display());
    md += &format!(
        "Per variant and evaluation: the runs evaluated of the variant's seeds; the pooled \
         success rate (sum of successes over sum of episodes); progress, energy, smoothness \
         and the episode length (in control steps, and in simulated seconds: steps times the \
         run's control interval, so that variants with another interval compare) as the mean \
         over seeds of each run's mean. Each comes with its 95 % percentile bootstrap interval \
         over seeds ({DRAWS} resamples). A variant meets the goal when its pooled sampled rate is at least {:.0} % and every constant comparator's is at most \
         {:.0} %. A neighbour appears only for the variants that have run in it (the protocol \
         runs the named variant's); `frontier.csv` lists every variant.\n\n",
        100.0 * GOAL,
        100.0 * CONSTANT_BAR
    );
    md += "| variant | overrides | evaluation | runs | success | per seed | progress | energy | smoothness | steps | seconds |\n";
    md += "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for r in rows.iter().filter(|r| shown(r)) {
        let per_seed: Vec<String> = r
            .runs
            .iter()
            .map(|e| format!("{}/{}", e.successes, e.episodes))
            .collect();
        let cells = match &r.pooled {
            Some(p) => [
                pct(&p.success),
                per_seed.join(" "),
                interval(&p.metrics[0], 2),
                interval(&p.metrics[1], 3),
                interval(&p.metrics[2], 3),
                interval(&p.metrics[STEPS], 0),
                interval(&p.metrics[SECONDS], 3),
            ],
            None => ["-", "-", "-", "-", "-", "-", "-"].map(String::from),
        };
        md += &format!(
            "| {} | {} | {} | {}/{} | {} |\n",
            r.variant,
            r.overrides,
            r.evaluation,
            r.runs.len(),
            r.seeds,
            cells.join(" | ")
        );
    }
    md += "\n## Comparators\n\n| policy | constant | success | steps | seconds |\n|---|---|---|---|---|\n";
    for c in comparators {
        let (lo, hi) = wilson95(c.successes, c.episodes);
        md += &format!(
            "| {} | {} | {}/{} = {:.0} % [{:.0}, {:.0}] | {:.0} | {} |\n",
            policy_name(&c.policy),
            if is_constant(&policy_name(&c.policy)) {
                "yes"
            } else {
                "no"
            },
            c.successes,
            c.episodes,
            100.0 * c.successes as f64 / c.episodes.max(1) as f64,
            100.0 * lo,
            100.0 * hi,
            c.mean_steps,
            number(c.mean_seconds, 3)
        );
    }
    md += "\n## The goal\n\n";
    md += &match constants_under_bar(comparators) {
        None => "The comparators have not run yet.\n".to_string(),
        Some(false) => format!(
            "A constant comparator succeeds in more than {:.0} %, so the scenario does not meet \
             the protocol's bar; the variants are compared with the best constant controller.\n",
            100.0 * CONSTANT_BAR
        ),
        Some(true) => format!(
            "Every constant comparator succeeds in at most {:.0} %.\n",
            100.0 * CONSTANT_BAR
        ),
    };
    if let Some((best, complete)) = ranked_best(rows) {
        md += &format!(
            "The variant ranked best by the protocol's rule (the highest pooled sampled rate, ties \
             to the lower variant; in the frontier scenario it names the committed policy, seed 1, \
             and the neighbours' runs) is **variant {}** ({} over {} of its {} seeds){}.\n\n",
            best.variant,
            best.pooled
                .as_ref()
                .map(|p| pct(&p.success))
                .unwrap_or_default(),
            best.runs.len(),
            best.seeds,
            if complete {
                ""
            } else {
                "; provisional: not every run is evaluated yet"
            }
        );
    }
    for r in rows.iter().filter(|r| r.evaluation == "sampled") {
        if let Some(p) = &r.pooled {
            md += &format!(
                "- variant {}: {} sampled ({} of {} seeds): {}\n",
                r.variant,
                pct(&p.success),
                r.runs.len(),
                r.seeds,
                if p.success.value >= GOAL {
                    "reaches 80 %"
                } else {
                    "below 80 %"
                }
            );
        }
    }
    md + "\n"
        + &frontier_differences::markdown(&frontier_differences::against_first(rows))
        + &lifetime::markdown(rows, comparators)
        + &frontier_runs::markdown(rows, curves)
        + &training_curve::markdown(curves)
}

/// `frontier.csv`: one row per variant and evaluation.
pub fn csv(rows: &[Row]) -> Result<Vec<u8>> {
    let bad = |e: csv::Error| ReportError::Invalid(format!("frontier.csv: {e}"));
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut head: Vec<String> = [
        "variant",
        "overrides",
        "evaluation",
        "runs",
        "seeds",
        "successes",
        "episodes",
    ]
    .map(String::from)
    .to_vec();
    head.extend(statistic_header());
    w.write_record(&head).map_err(bad)?;
    for r in rows {
        let (k, n) = r
            .runs
            .iter()
            .fold((0, 0), |(k, n), e| (k + e.successes, n + e.episodes));
        let mut row = vec![
            r.variant.to_string(),
            r.overrides.clone(),
            r.evaluation.clone(),
            r.runs.len().to_string(),
            r.seeds.to_string(),
            k.to_string(),
            n.to_string(),
        ];
        row.extend(statistic_cells(r.pooled.as_ref()));
        w.write_record(&row).map_err(bad)?;
    }
    w.into_inner()
        .map_err(|e| ReportError::Invalid(format!("frontier.csv: {e}")))
}

/// Writes `frontier.md`, `frontier.csv` and `frontier_differences.csv` into `out`.
pub fn write(root: &Path, out: &Path) -> Result<()> {
    let f = load(root)?;
    let (rows, comparators) = (&f.rows, &f.comparators);
    let (md_path, csv_path) = (out.join("frontier.md"), out.join("frontier.csv"));
    std::fs::write(&md_path, markdown(root, rows, comparators, &f.curves))
        .map_err(ReportError::write(&md_path))?;
    std::fs::write(&csv_path, csv(rows)?).map_err(ReportError::write(&csv_path))?;
    let diff_path = out.join("frontier_differences.csv");
    let differences = frontier_differences::against_first(rows);
    std::fs::write(&diff_path, frontier_differences::csv(&differences)?)
        .map_err(ReportError::write(&diff_path))?;
    Ok(())
}

//! `report --frontier DIR`: the summary of issue 19's protocol (docs/controllability.md) from a
//! sweep directory that `experiments/frontier_learners.sh` filled:
//! - `DIR/sweep.csv`: the runs (point = variant, seed);
//! - `DIR/eval/<run>/{sampled,deterministic}/episodes.csv`;
//! - `DIR/neighbours/<run>/<change>/episodes.csv`;
//! - `DIR/comparators/<policy>/episodes.csv`.
//!
//! For each variant and evaluation (sampled, deterministic, each neighbour), over the S seeds
//! evaluated: the pooled success rate and the mean over seeds of progress, energy, smoothness
//! and the episode length in control steps and in simulated seconds (steps x
//! `time.control_dt_s` of the evaluation's `config.toml`, so that runs with another control
//! interval compare), each with its 95 % bootstrap interval over seeds ([`super::bootstrap`],
//! `DRAWS` resamples from seed 0).
//!
//! Comparators get k/n with their successes. The protocol's bar: a variant passes when its
//! pooled sampled rate is at least 80 % and every constant comparator's is at most 20 %.
//! `frontier_output` writes `frontier.md` and `frontier.csv`; `frontier_runs` adds a row per
//! run, and `training_curve` each done run's training curve from `DIR/runs/<run>/episodes.csv`.

use std::path::{Path, PathBuf};

use super::bootstrap::{METRICS, Pooled, RunEval, SECONDS, STEPS, bootstrap};
use super::data::{RunInfo, read_episodes};
use super::error::Result;
use super::map::is_constant;
use super::sweep_table::{self, SweepRow};
use super::training_curve::{self, Curve};

/// Bootstrap resamples.
pub const DRAWS: usize = 10_000;
/// The bar a variant's pooled sampled success rate must reach.
pub const GOAL: f64 = 0.8;
/// The bar every constant comparator must stay at or under for the goal to mean anything.
pub const CONSTANT_BAR: f64 = 0.2;

/// One evaluation of one run, read from its `episodes.csv` (and `config.toml`, for the
/// control interval); None when `episodes.csv` is absent.
pub fn read_eval(dir: &Path) -> Result<Option<RunEval>> {
    let path = dir.join("episodes.csv");
    if !path.exists() {
        return Ok(None);
    }
    let episodes = read_episodes(&path, false)?;
    if episodes.is_empty() {
        return Ok(None);
    }
    let n = episodes.len() as f64;
    // The control interval, from the config.toml rollout writes beside episodes.csv.
    let dt = if dir.join("config.toml").exists() {
        RunInfo::read(dir)?.control_dt_s
    } else {
        f64::NAN
    };
    // Sums first, divided once, so that a mean of integer step counts is correctly rounded;
    // the length in seconds is that mean times the control interval.
    let mut means = [0.0; METRICS];
    for e in &episodes {
        let values = [e.metrics[0], e.metrics[1], e.metrics[2], e.steps as f64];
        for (s, v) in means.iter_mut().zip(values) {
            *s += v;
        }
    }
    for m in &mut means[..SECONDS] {
        *m /= n;
    }
    means[SECONDS] = means[STEPS] * dt;
    Ok(Some(RunEval {
        successes: episodes.iter().filter(|e| e.outcome == "success").count(),
        episodes: episodes.len(),
        means,
    }))
}

/// One row of the table: a variant under one evaluation.
#[derive(Debug, Clone)]
pub struct Row {
    /// The variant (sweep point).
    pub variant: usize,
    /// Its overrides, as sweep.csv gives them.
    pub overrides: String,
    /// `sampled`, `deterministic` or a neighbour (`neighbours/scale-x0.9`, ...).
    pub evaluation: String,
    /// Runs of the variant in the sweep.
    pub seeds: usize,
    /// Each evaluated run's result.
    pub runs: Vec<RunEval>,
    /// The seed of each of `runs`, as sweep.csv gives it.
    pub run_seeds: Vec<String>,
    /// Pooled over the evaluated runs.
    pub pooled: Option<Pooled>,
}

/// A comparator: its name, successes and episodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Comparator {
    /// The policy, as its directory name (`wall-angle-40`).
    pub policy: String,
    /// Successful episodes.
    pub successes: usize,
    /// Episodes.
    pub episodes: usize,
    /// Mean episode length (control steps).
    pub mean_steps: f64,
    /// Mean episode length (simulated seconds; NaN without the evaluation's `config.toml`).
    pub mean_seconds: f64,
}

fn subdirs(dir: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.is_dir())
        .collect();
    v.sort();
    v
}

/// What `report --frontier` reads under `root`.
#[derive(Debug, Clone)]
pub struct Frontier {
    /// A row per variant and evaluation.
    pub rows: Vec<Row>,
    /// The comparators.
    pub comparators: Vec<Comparator>,
    /// The done runs' training curves.
    pub curves: Vec<Curve>,
}

/// Reads the variants' evaluations, the comparators and the training curves under `root`.
pub fn load(root: &Path) -> Result<Frontier> {
    let runs = sweep_table::read(
        root,
        &format!(
            "is {} the sweep directory of experiments/frontier_learners.sh?",
            root.display()
        ),
    )?
    .rows;
    let mut evaluations = vec!["sampled".to_string(), "deterministic".to_string()];
    let mut changes: Vec<String> = subdirs(&root.join("neighbours"))
        .iter()
        .flat_map(|d| subdirs(d))
        .filter_map(|d| Some(d.file_name()?.to_string_lossy().into_owned()))
        .collect();
    changes.sort();
    changes.dedup();
    evaluations.extend(changes.into_iter().map(|c| format!("neighbours/{c}")));
    let variants = runs.iter().map(|r| r.point + 1).max().unwrap_or(0);
    let mut rows = Vec::new();
    for evaluation in &evaluations {
        for v in 0..variants {
            let of: Vec<&SweepRow> = runs.iter().filter(|r| r.point == v).collect();
            let mut evals = Vec::new();
            let mut run_seeds = Vec::new();
            for r in &of {
                let dir = match evaluation.strip_prefix("neighbours/") {
                    Some(change) => root.join("neighbours").join(r.name()).join(change),
                    None => root.join("eval").join(r.name()).join(evaluation),
                };
                if let Some(e) = read_eval(&dir)? {
                    evals.push(e);
                    run_seeds.push(r.seed.clone());
                }
            }
            rows.push(Row {
                variant: v,
                overrides: of.first().map(|r| r.overrides.clone()).unwrap_or_default(),
                evaluation: evaluation.clone(),
                seeds: of.len(),
                pooled: bootstrap(&evals, DRAWS, 0),
                runs: evals,
                run_seeds,
            });
        }
    }
    let mut comparators = Vec::new();
    for d in subdirs(&root.join("comparators")) {
        if let Some(e) = read_eval(&d)? {
            comparators.push(Comparator {
                policy: d
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned(),
                successes: e.successes,
                episodes: e.episodes,
                mean_steps: e.means[STEPS],
                mean_seconds: e.means[SECONDS],
            });
        }
    }
    let curves = training_curve::load(root, &runs)?;
    Ok(Frontier {
        rows,
        comparators,
        curves,
    })
}

/// The comparator's policy name as the CLI spells it (`wall-angle-40` -> `wall-angle:40`,
/// `heading--40` -> `heading:-40`).
pub fn policy_name(dir_name: &str) -> String {
    for family in ["wall-angle", "heading"] {
        if let Some(deg) = dir_name
            .strip_prefix(family)
            .and_then(|d| d.strip_prefix('-'))
        {
            return format!("{family}:{deg}");
        }
    }
    dir_name.to_string()
}

/// Whether every constant comparator is at or under the bar (None: no constant comparator).
pub fn constants_under_bar(comparators: &[Comparator]) -> Option<bool> {
    let constants: Vec<&Comparator> = comparators
        .iter()
        .filter(|c| is_constant(&policy_name(&c.policy)))
        .collect();
    (!constants.is_empty()).then(|| {
        constants
            .iter()
            .all(|c| c.successes as f64 <= CONSTANT_BAR * c.episodes as f64)
    })
}

/// The variant the protocol names (docs/controllability.md, amendment of 2026-12-03 14:01
/// UTC): the highest pooled sampled success rate, ties to the lower variant; None before any
/// sampled evaluation. The flag says whether every run of every variant is evaluated, that is,
/// whether the ranking is final.
pub fn ranked_best(rows: &[Row]) -> Option<(&Row, bool)> {
    let sampled: Vec<&Row> = rows.iter().filter(|r| r.evaluation == "sampled").collect();
    let complete = sampled.iter().all(|r| r.runs.len() == r.seeds);
    let mut best: Option<(&Row, f64)> = None;
    for r in &sampled {
        let Some(p) = &r.pooled else { continue };
        let better = match best {
            None => true,
            Some((b, rate)) => {
                p.success.value > rate || (p.success.value == rate && r.variant < b.variant)
            }
        };
        if better {
            best = Some((r, p.success.value));
        }
    }
    best.map(|(r, _)| (r, complete))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::bootstrap::tests::run;

    fn row(variant: usize, evaluation: &str, seeds: usize, runs: &[RunEval]) -> Row {
        Row {
            variant,
            overrides: String::new(),
            evaluation: evaluation.into(),
            seeds,
            runs: runs.to_vec(),
            run_seeds: (1..=runs.len()).map(|s| s.to_string()).collect(),
            pooled: bootstrap(runs, 10, 0),
        }
    }

    #[test]
    fn the_named_variant_has_the_best_pooled_sampled_rate_with_ties_to_the_lower() {
        assert!(ranked_best(&[]).is_none());
        let rows = [
            row(0, "sampled", 2, &[run(1, 40, 0.0), run(3, 40, 0.0)]),
            // 4/80 as variant 0, so the tie goes to variant 0.
            row(1, "sampled", 2, &[run(4, 40, 0.0), run(0, 40, 0.0)]),
            // Better with the mean action only: the rule reads the sampled rows.
            row(2, "deterministic", 2, &[run(40, 40, 0.0)]),
            row(2, "sampled", 2, &[run(2, 40, 0.0)]),
            row(3, "sampled", 2, &[]),
        ];
        let (best, complete) = ranked_best(&rows).unwrap();
        assert_eq!((best.variant, complete), (0, false));
        let mut rows = rows.to_vec();
        // Variant 2's second seed, 7/40: (2 + 7)/80 beats 4/80.
        rows[3] = row(2, "sampled", 2, &[run(2, 40, 0.0), run(7, 40, 0.0)]);
        rows[4] = row(3, "sampled", 0, &[]);
        let (best, complete) = ranked_best(&rows).unwrap();
        assert_eq!((best.variant, complete), (2, true));
    }

    #[test]
    fn the_bar_counts_only_constant_controllers() {
        let c = |p: &str, k| Comparator {
            policy: p.into(),
            successes: k,
            episodes: 40,
            mean_steps: 100.0,
            mean_seconds: 0.5,
        };
        assert_eq!(constants_under_bar(&[]), None);
        let mut cs = vec![c("zero", 0), c("wall-angle-40", 8), c("scripted", 30)];
        assert_eq!(constants_under_bar(&cs), Some(true));
        cs.push(c("wall", 9));
        assert_eq!(constants_under_bar(&cs), Some(false));
        assert_eq!(policy_name("wall-angle-40"), "wall-angle:40");
        assert_eq!(policy_name("heading--40"), "heading:-40");
        assert_eq!(policy_name("heading-40"), "heading:40");
        assert!(is_constant(&policy_name("heading--40")));
    }

    fn episodes(dir: &Path, outcomes: &[(&str, f64)]) {
        std::fs::create_dir_all(dir).unwrap();
        let mut text = "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,\
                        energy_sum,smoothness_sum,scalar_return,final_x_com_mm\n"
            .to_string();
        for (i, (outcome, progress)) in outcomes.iter().enumerate() {
            text += &format!("0,{i},10,{outcome},{progress},0.5,0.25,0,0,0,0,50\n");
        }
        std::fs::write(dir.join("episodes.csv"), text).unwrap();
    }

    /// The `config.toml` rollout writes beside `episodes.csv`, cut to the control interval.
    fn control_dt(dir: &Path, seconds: f64) {
        std::fs::write(
            dir.join("config.toml"),
            format!(
                "# fluxswarm-gpu rollout\n[time]\ncontrol_dt_s = {seconds}\n\
                 [domain]\nsuccess_x_m = 0.02\nfailure_x_m = 0.07\n"
            ),
        )
        .unwrap();
    }

    #[test]
    fn load_reads_each_variant_evaluation_and_comparator_from_the_directories() {
        let root = tempfile::tempdir().unwrap();
        let root = root.path();
        std::fs::write(
            root.join("sweep.csv"),
            "point,seed,status,dir,overrides,--steps,commit,backend,threads,host\n\
             0,1,done,runs/p000_a_seed1,--steps=8,8,c,native,1,vm\n\
             0,2,done,runs/p000_a_seed2,--steps=8,8,c,native,1,vm\n\
             1,1,done,runs/p001_b_seed1,\"--steps=8 --no-pcgrad=true\",8,c,native,1,vm\n\
             1,2,pending,runs/p001_b_seed2,\"--steps=8 --no-pcgrad=true\",8,c,,,\n",
        )
        .unwrap();
        let eval = root.join("eval");
        episodes(
            &eval.join("p000_a_seed1/sampled"),
            &[("success", 2.0), ("failure", 0.0)],
        );
        episodes(
            &eval.join("p000_a_seed2/sampled"),
            &[("success", 4.0), ("success", 6.0)],
        );
        episodes(&eval.join("p001_b_seed1/sampled"), &[("timeout", 1.0)]);
        episodes(
            &eval.join("p000_a_seed1/deterministic"),
            &[("failure", -1.0)],
        );
        episodes(
            &root.join("neighbours/p000_a_seed2/scale-x0.9"),
            &[("success", 3.0)],
        );
        episodes(
            &root.join("comparators/wall-angle-40"),
            &[("success", 0.0), ("failure", 0.0)],
        );
        episodes(&root.join("comparators/scripted"), &[("success", 0.0)]);
        // Seconds = steps x the evaluation's control interval: 10 x 0.005 and 10 x 0.02.
        control_dt(&eval.join("p000_a_seed1/sampled"), 0.005);
        control_dt(&eval.join("p000_a_seed2/sampled"), 0.02);
        control_dt(&root.join("comparators/scripted"), 0.005);
        let Frontier {
            rows, comparators, ..
        } = load(root).unwrap();
        let row = |v: usize, e: &str| {
            rows.iter()
                .find(|r| r.variant == v && r.evaluation == e)
                .unwrap()
        };
        let a = row(0, "sampled");
        assert_eq!((a.runs.len(), a.seeds), (2, 2));
        let p = a.pooled.unwrap();
        assert_eq!(p.success.value, 3.0 / 4.0);
        // Seed means 1.0 and 5.0.
        assert_eq!(p.metrics[0].value, 3.0);
        assert_eq!(p.metrics[3].value, 10.0);
        // Seed means 0.05 s and 0.2 s.
        assert!((p.metrics[4].value - 0.125).abs() < 1e-12);
        assert!((p.metrics[4].lo - 0.05).abs() < 1e-12 && (p.metrics[4].hi - 0.2).abs() < 1e-12);
        let b = row(1, "sampled");
        assert_eq!((b.runs.len(), b.seeds), (1, 2));
        assert_eq!(b.overrides, "--steps=8 --no-pcgrad=true");
        assert_eq!(b.pooled.unwrap().success.value, 0.0);
        assert_eq!(row(0, "deterministic").runs.len(), 1);
        assert!(row(1, "deterministic").pooled.is_none());
        let neighbour = &row(0, "neighbours/scale-x0.9").runs;
        assert_eq!(neighbour.len(), 1);
        assert_eq!(neighbour[0].means[..4], run(1, 1, 3.0).means[..4]);
        assert!(neighbour[0].means[4].is_nan());
        assert_eq!(rows.len(), 2 * 3);
        let summary: Vec<(&str, usize, usize, f64)> = comparators
            .iter()
            .map(|c| (c.policy.as_str(), c.successes, c.episodes, c.mean_steps))
            .collect();
        assert_eq!(
            summary,
            [("scripted", 1, 1, 10.0), ("wall-angle-40", 1, 2, 10.0)]
        );
        assert!((comparators[0].mean_seconds - 0.05).abs() < 1e-12);
        assert!(comparators[1].mean_seconds.is_nan());
        assert_eq!(constants_under_bar(&comparators), Some(false));
        let md = super::super::frontier_output::markdown(root, &rows, &comparators, &[]);
        assert!(
            md.contains("| 0 | --steps=8 | sampled | 2/2 | 75 % ["),
            "{md}"
        );
        assert!(md.contains("| wall-angle:40 | yes | 1/2 = 50 %"), "{md}");
        // Variant 0 has run in the neighbour and keeps its row; variant 1 has not and has none
        // in the markdown, but keeps its row in the CSV.
        assert!(
            md.contains("| 0 | --steps=8 | neighbours/scale-x0.9 | 1/2 | 100 % ["),
            "{md}"
        );
        assert!(
            !md.contains("| 1 | --steps=8 --no-pcgrad=true | neighbours/"),
            "{md}"
        );
        // Variant 0 (3/4) over variant 1 (0/1), with variant 1's second seed not evaluated.
        assert!(
            md.contains("is **variant 0** (75 % [")
                && md.contains("over 2 of its 2 seeds); provisional"),
            "{md}"
        );
        assert!(
            md.contains("| scripted | no | 1/1 = 100 % [21, 100] | 10 | 0.050 |"),
            "{md}"
        );
        assert!(
            md.contains("| 10 [10, 10] | 0.125 [0.050, 0.200] |"),
            "{md}"
        );
        // The per-run rows carry sweep.csv's seeds: variant 0 seed 2, 2/2 in 10 steps of 20 ms.
        assert!(
            md.contains("| 0 | 2 | - | - | - | 2/2 | 10.00 (0.200 s) | 5.0 | - |"),
            "{md}"
        );
        // Variant 1's one run has no config.toml: its seconds are unknown, not zero.
        let v1 = md
            .lines()
            .find(|l| l.starts_with("| 1 | --steps=8 --no-pcgrad=true | sampled |"))
            .unwrap();
        assert!(v1.ends_with("| 10 [10, 10] | - |"), "{v1}");
        let csv = String::from_utf8(super::super::frontier_output::csv(&rows).unwrap()).unwrap();
        assert!(
            csv.lines()
                .next()
                .unwrap()
                .ends_with("steps,steps_lo,steps_hi,seconds,seconds_lo,seconds_hi")
        );
        assert!(
            csv.contains("\n1,--steps=8 --no-pcgrad=true,neighbours/scale-x0.9,0,2,0,0,"),
            "{csv}"
        );
        assert!(
            csv.lines()
                .nth(1)
                .unwrap()
                .ends_with(",0.125000,0.050000,0.200000"),
            "{csv}"
        );
    }
}

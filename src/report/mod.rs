//! `fluxswarm-gpu report`: figures and `report.md` from run directories.
//!
//! Inputs: train runs of one experiment (one per seed), optionally the runs of a compared
//! experiment (e.g. without PCGrad), baseline rollouts, and a before/after pair of rollouts.
//! Figures (PNG, `plot::WIDTH` x panels * `plot::PANEL_HEIGHT` px):
//! - `learning_curves.png`: progress, energy and smoothness against global environment steps
//!   (per-environment rolling mean over 5 episodes; mean +- 1 sigma across environments for one
//!   run, the mean across seeds with a 95 % band for several), baselines as horizontal bands;
//! - `gradient_conflicts.png`: the pairwise cosines of the objective gradients and the
//!   fraction of conflicting minibatches over training (rolling mean over 10 updates);
//! - `dispersion.png`: sigma_x and sigma_y over the episode with the inlet waveform, before vs
//!   after learning;
//! - `com_rg.png`: x_COM and R_g over the episode with the inlet waveform, before vs after.

pub mod analysis;
pub mod behaviour;
pub mod behaviour_output;
pub mod bootstrap;
pub mod data;
pub mod error;
pub mod frontier;
pub mod frontier_differences;
pub mod frontier_output;
pub mod frontier_runs;
pub mod heatmap;
pub mod lifetime;
pub mod map;
pub mod map_output;
pub mod markdown;
pub mod plot;
pub mod stats;
pub mod sweep;
pub mod sweep_table;
pub mod thrust;
pub mod thrust_phase;
pub mod training_curve;

use std::path::{Path, PathBuf};

use error::{ReportError, Result, Within};

use analysis::{METRICS, group_curve, swarm_over_time, update_series};
use data::{RolloutRun, SwarmStep, TrainRun};
use plot::{Curve, Panel, Reference, Secondary};

/// Updates in the rolling mean of the gradient diagnostics.
pub const UPDATE_WINDOW: usize = 10;

/// What to report on.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    /// Train run directories of the experiment (one per seed).
    pub runs: Vec<PathBuf>,
    /// Train run directories of a compared experiment (e.g. without PCGrad).
    pub compare: Vec<PathBuf>,
    /// Baseline rollout/eval directories.
    pub baselines: Vec<PathBuf>,
    /// Rollout/eval directory before learning (given with `after`).
    pub before: Option<PathBuf>,
    /// Rollout/eval directory after learning (given with `before`).
    pub after: Option<PathBuf>,
}

/// Everything read, ready to draw and summarise.
pub struct Loaded {
    /// The experiment's train runs.
    pub runs: Vec<TrainRun>,
    /// The compared experiment's train runs.
    pub compare: Vec<TrainRun>,
    /// The baseline rollouts.
    pub baselines: Vec<RolloutRun>,
    /// The (before, after) rollouts, when given.
    pub before_after: Option<(RolloutRun, RolloutRun)>,
}

/// A group's legend label: the experiment (PCGrad or averaged gradients) and the seed count.
pub fn group_label(runs: &[TrainRun]) -> String {
    let name = if runs.first().is_none_or(|r| r.info.pcgrad) {
        "MOMAPPO + PCGrad"
    } else {
        "MOMAPPO, no PCGrad"
    };
    match runs.len() {
        1 => name.to_string(),
        n => format!("{name} ({n} seeds)"),
    }
}

/// Reads every run directory of `inputs`; fails on a missing train run or a lone before/after.
pub fn load(inputs: &Inputs) -> Result<Loaded> {
    if inputs.runs.is_empty() {
        return Err(ReportError::Usage(
            "report needs at least one train run directory".into(),
        ));
    }
    if inputs.before.is_some() != inputs.after.is_some() {
        return Err(ReportError::Usage(
            "--before and --after go together: give both rollout/eval directories, or neither"
                .into(),
        ));
    }
    let train = |dirs: &[PathBuf]| -> Result<Vec<TrainRun>> {
        dirs.iter().map(|d| TrainRun::read(d)).collect()
    };
    let rollout = |d: &Path| -> Result<RolloutRun> {
        RolloutRun::read(d).within(|| format!("{} as a rollout/eval directory", d.display()))
    };
    let before_after = match (&inputs.before, &inputs.after) {
        (Some(b), Some(a)) => Some((rollout(b)?, rollout(a)?)),
        _ => None,
    };
    Ok(Loaded {
        runs: train(&inputs.runs)?,
        compare: train(&inputs.compare)?,
        baselines: inputs
            .baselines
            .iter()
            .map(|d| rollout(d))
            .collect::<Result<_, _>>()?,
        before_after,
    })
}

/// Writes the figures and `report.md` into `out`; returns the figure file names.
pub fn write(loaded: &Loaded, out: &Path) -> Result<Vec<String>> {
    std::fs::create_dir_all(out).map_err(|cause| ReportError::Write {
        path: out.to_path_buf(),
        cause,
        hint: ": choose a writable --out directory".into(),
    })?;
    let mut figures = Vec::new();
    let mut save = |name: &str, panels: Vec<Panel>| -> Result<()> {
        plot::save(&out.join(name), &panels)?;
        figures.push(name.to_string());
        Ok(())
    };
    save("learning_curves.png", learning_panels(loaded))?;
    if loaded.runs.iter().any(|r| !r.updates.is_empty()) {
        save("gradient_conflicts.png", conflict_panels(loaded))?;
    }
    if let Some((before, after)) = &loaded.before_after {
        save(
            "dispersion.png",
            before_after_panels(
                before,
                after,
                &[
                    ("swarm dispersion along the channel", "σ_x (mm)", &|s| {
                        s.sigma_x_mm
                    }),
                    ("swarm dispersion across the channel", "σ_y (mm)", &|s| {
                        s.sigma_y_mm
                    }),
                ],
            ),
        )?;
        save(
            "com_rg.png",
            before_after_panels(
                before,
                after,
                &[
                    ("swarm centre of mass", "x_COM (mm)", &|s| s.x_com_mm),
                    ("radius of gyration", "R_g (mm)", &|s| s.r_g_mm),
                ],
            ),
        )?;
    }
    let md = markdown::report(loaded, &figures);
    let md_path = out.join("report.md");
    std::fs::write(&md_path, md).map_err(ReportError::write(&md_path))?;
    Ok(figures)
}

const METRIC_AXES: [&str; 3] = [
    "progress (per-episode sum)",
    "energy (per-step mean)",
    "smoothness (per-step mean)",
];

fn learning_panels(l: &Loaded) -> Vec<Panel> {
    let spread = |runs: &[TrainRun]| {
        if runs.len() > 1 {
            "mean across seeds, 95 % CI"
        } else {
            "mean ± 1 σ across environments"
        }
    };
    let baseline_colors = [plot::GREEN, plot::PURPLE, plot::BROWN, plot::RED];
    (0..3)
        .map(|m| {
            let mut curves = vec![Curve {
                label: format!("{} ({})", group_label(&l.runs), spread(&l.runs)),
                color: plot::BLUE,
                dashed: false,
                band: group_curve(&l.runs, m),
            }];
            if !l.compare.is_empty() {
                curves.push(Curve {
                    label: format!("{} ({})", group_label(&l.compare), spread(&l.compare)),
                    color: plot::ORANGE,
                    dashed: false,
                    band: group_curve(&l.compare, m),
                });
            }
            let references = l
                .baselines
                .iter()
                .zip(baseline_colors.iter().cycle())
                .map(|(b, &color)| {
                    let s = analysis::rollout_summary(b);
                    let (mean, sd) = s.metrics[m];
                    Reference {
                        label: format!("{} (mean ± 1 σ over {} episodes)", s.label, s.episodes),
                        color,
                        mean,
                        lo: mean - sd,
                        hi: mean + sd,
                    }
                })
                .collect();
            Panel {
                title: format!(
                    "{}: rolling mean over {} episodes per environment",
                    METRICS[m],
                    analysis::ROLLING
                ),
                x_desc: "global environment steps".into(),
                y_desc: METRIC_AXES[m].into(),
                curves,
                references,
                secondary: None,
                legend: m == 0,
            }
        })
        .collect()
}

fn conflict_panels(l: &Loaded) -> Vec<Panel> {
    let pairs = [
        ("progress–energy", plot::BLUE),
        ("progress–smoothness", plot::ORANGE),
        ("energy–smoothness", plot::GREEN),
    ];
    let panel = |title: &str, y: &str, legend: bool, f: &dyn Fn(&data::Update, usize) -> f64| {
        let mut curves = Vec::new();
        for (group, dashed) in [(&l.runs, false), (&l.compare, true)] {
            if group.is_empty() {
                continue;
            }
            for (k, (name, color)) in pairs.iter().enumerate() {
                let pts = update_series(group, UPDATE_WINDOW, |u| f(u, k));
                let mut c = Curve::line(format!("{name}, {}", group_label(group)), *color, &pts);
                c.dashed = dashed;
                curves.push(c);
            }
        }
        Panel {
            title: format!(
                "{title} (rolling mean over {UPDATE_WINDOW} updates, mean across seeds)"
            ),
            x_desc: "global environment steps".into(),
            y_desc: y.into(),
            curves,
            references: vec![Reference {
                label: "zero".into(),
                color: plot::GREY,
                mean: 0.0,
                lo: 0.0,
                hi: 0.0,
            }],
            secondary: None,
            legend,
        }
    };
    vec![
        panel(
            "cosine between the actor-loss gradients",
            "cosine (1)",
            true,
            &|u, k| u.cos[k],
        ),
        panel(
            "minibatches in which the pair conflicts",
            "fraction (1)",
            false,
            &|u, k| u.conflict[k],
        ),
    ]
}

type Metric<'a> = (&'a str, &'a str, &'a dyn Fn(&SwarmStep) -> f64);

fn before_after_panels(before: &RolloutRun, after: &RolloutRun, metrics: &[Metric]) -> Vec<Panel> {
    metrics
        .iter()
        .map(|(title, y, f)| {
            let b = swarm_over_time(before, f);
            let a = swarm_over_time(after, f);
            let pts = |v: &[(f64, f64, f64)]| -> Vec<(f64, f64)> {
                v.iter().map(|q| (q.0, q.1)).collect()
            };
            let longer = if a.len() >= b.len() { &a } else { &b };
            Panel {
                title: format!("{title}: mean over the episodes still running"),
                x_desc: "time since episode start (s)".into(),
                y_desc: (*y).into(),
                curves: vec![
                    Curve::line(
                        format!("before learning ({} episodes)", before.episodes.len()),
                        plot::ORANGE,
                        &pts(&b),
                    ),
                    Curve::line(
                        format!("after learning ({} episodes)", after.episodes.len()),
                        plot::BLUE,
                        &pts(&a),
                    ),
                ],
                references: Vec::new(),
                secondary: Some(Secondary {
                    label: "inlet centreline velocity (right axis)".into(),
                    y_desc: "inlet U (mm/s)".into(),
                    points: longer.iter().map(|q| (q.0, q.2)).collect(),
                }),
                legend: true,
            }
        })
        .collect()
}

//! `report --sweep DIR`: one row per point of a sweep (`fluxswarm_gpu::sweep`), from
//! `DIR/sweep.csv` and each done run's `episodes.csv`. A run's final metrics are those of its
//! last [`FINAL_EPISODES`] episodes (train) or of all its episodes (rollout, eval); per point:
//! - progress, energy and smoothness: the mean over seeds of each run's mean, with a 95 %
//!   t-interval over seeds;
//! - the success rate: successes over all the point's episodes, with the Wilson interval;
//! - time to success: the mean episode length of the successful episodes, in seconds.
//!
//! Writes `report.md`, `sweep_points.csv` (the same table, machine-readable) and, for one grid
//! key, `sweep_lines.png` (success and progress against the key, with bands), for two,
//! `sweep_heatmap.png` (success rate) and `sweep_heatmap_progress.png` (mean progress) over
//! the two keys.

use std::path::Path;

use super::error::{ReportError, Result};

use super::data::{RunInfo, read_episodes};
use super::heatmap::{self, HeatAxes, HeatPanel, Scale};
use super::plot::{self, Curve, Panel};
use super::stats::{Band, mean_ci95, wilson95};
use super::sweep_table;

/// Episodes at the end of a train run that give its final metrics (the window `train`'s
/// progress line reports).
pub const FINAL_EPISODES: usize = 100;

/// One point's summary.
#[derive(Debug, Clone, PartialEq)]
pub struct PointSummary {
    /// Point index in `sweep.csv`.
    pub point: usize,
    /// The point's value of each key, as `sweep.csv` gives it.
    pub values: Vec<String>,
    /// Runs of the point that are done and have finished episodes.
    pub seeds_done: usize,
    /// Runs (seeds) of the point in `sweep.csv`.
    pub seeds: usize,
    /// Successful episodes among those counted in `episodes`.
    pub successes: usize,
    /// Episodes counted over the done runs (a train run's last [`FINAL_EPISODES`]).
    pub episodes: usize,
    /// Progress, energy, smoothness: (mean over seeds, 95 % half-width).
    pub metrics: [(f64, f64); 3],
    /// Mean seconds to success over the successful episodes.
    pub time_to_success_s: Option<f64>,
}

/// A sweep's table, read.
#[derive(Debug, Clone)]
pub struct SweepSummary {
    /// The grid keys, in `sweep.csv` column order.
    pub keys: Vec<String>,
    /// One summary per point, by point index.
    pub points: Vec<PointSummary>,
}

/// Reads `root/sweep.csv` and every done run's episodes.
pub fn load(root: &Path) -> Result<SweepSummary> {
    let table = sweep_table::read(
        root,
        &format!(
            "is {0} a sweep directory? `fluxswarm-gpu sweep --status --out {0}` refreshes the table",
            root.display()
        ),
    )?;
    let path = &table.path;
    let mut points: Vec<PointSummary> = Vec::new();
    let mut per_seed: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut success_steps: Vec<Vec<f64>> = Vec::new();
    for row in &table.rows {
        let point = row.point;
        if point >= points.len() {
            points.resize_with(point + 1, || PointSummary {
                point: 0,
                values: Vec::new(),
                seeds_done: 0,
                seeds: 0,
                successes: 0,
                episodes: 0,
                metrics: [(f64::NAN, 0.0); 3],
                time_to_success_s: None,
            });
            per_seed.resize_with(point + 1, Vec::new);
            success_steps.resize_with(point + 1, Vec::new);
        }
        let p = &mut points[point];
        p.point = point;
        p.values = row.values.clone();
        p.seeds += 1;
        if row.status != "done" {
            continue;
        }
        let dir = root.join(&row.dir);
        let episodes_path = dir.join("episodes.csv");
        let first =
            std::fs::read_to_string(&episodes_path).map_err(ReportError::read(&episodes_path))?;
        let train = first.starts_with("global_step,");
        let mut episodes = read_episodes(&episodes_path, train)?;
        if train && episodes.len() > FINAL_EPISODES {
            episodes.drain(..episodes.len() - FINAL_EPISODES);
        }
        if episodes.is_empty() {
            continue;
        }
        let dt = RunInfo::read(&dir)?.control_dt_s;
        p.seeds_done += 1;
        p.episodes += episodes.len();
        let n = episodes.len() as f64;
        let mut mean = [0.0; 3];
        for e in &episodes {
            for (m, v) in mean.iter_mut().zip(e.metrics) {
                *m += v / n;
            }
            if e.outcome == "success" {
                p.successes += 1;
                success_steps[point].push(e.steps as f64 * dt);
            }
        }
        per_seed[point].push(mean);
    }
    for (p, seeds) in points.iter_mut().zip(&per_seed) {
        for m in 0..3 {
            let values: Vec<f64> = seeds.iter().map(|s| s[m]).collect();
            p.metrics[m] = mean_ci95(&values);
        }
    }
    for (p, t) in points.iter_mut().zip(&success_steps) {
        p.time_to_success_s = (!t.is_empty()).then(|| t.iter().sum::<f64>() / t.len() as f64);
    }
    if points.is_empty() {
        return Err(ReportError::Invalid(format!(
            "{} lists no runs",
            path.display()
        )));
    }
    Ok(SweepSummary {
        keys: table.keys,
        points,
    })
}

fn interval(m: (f64, f64)) -> String {
    if m.0.is_nan() {
        "-".into()
    } else {
        format!("{:.3} ± {:.3}", m.0, m.1)
    }
}

fn success_text(p: &PointSummary) -> String {
    if p.episodes == 0 {
        return "-".into();
    }
    let (lo, hi) = wilson95(p.successes, p.episodes);
    format!(
        "{}/{} = {:.0} % [{:.0}, {:.0}]",
        p.successes,
        p.episodes,
        100.0 * p.successes as f64 / p.episodes as f64,
        100.0 * lo,
        100.0 * hi
    )
}

/// The markdown table of every point.
pub fn markdown(s: &SweepSummary, root: &Path) -> String {
    let mut md = format!("# Sweep {}\n\n", root.display());
    md += &format!(
        "One row per point: runs done of seeds; success over all the point's episodes with its \
         95 % Wilson interval; progress, energy and smoothness as the mean over seeds ± the 95 % \
         t half-width (a train run counts its last {FINAL_EPISODES} episodes); time to success: \
         the mean length of the successful episodes.\n\n"
    );
    let mut head = vec!["point".to_string()];
    head.extend(s.keys.iter().map(|k| format!("`{k}`")));
    head.extend(
        [
            "runs",
            "success",
            "progress",
            "energy",
            "smoothness",
            "time to success (s)",
        ]
        .map(String::from),
    );
    md += &format!("| {} |\n", head.join(" | "));
    md += &format!("|{}\n", "---|".repeat(head.len()));
    for p in &s.points {
        let mut row = vec![p.point.to_string()];
        row.extend(p.values.iter().cloned());
        row.push(format!("{}/{}", p.seeds_done, p.seeds));
        row.push(success_text(p));
        row.extend(p.metrics.iter().map(|&m| interval(m)));
        row.push(
            p.time_to_success_s
                .map_or("-".into(), |t| format!("{t:.3}")),
        );
        md += &format!("| {} |\n", row.join(" | "));
    }
    md
}

/// `sweep_points.csv`.
pub fn points_csv(s: &SweepSummary) -> Result<Vec<u8>> {
    let bad = |e: csv::Error| ReportError::Invalid(format!("sweep_points.csv: {e}"));
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut head = vec!["point".to_string()];
    head.extend(s.keys.iter().cloned());
    head.extend(
        [
            "runs_done",
            "runs",
            "successes",
            "episodes",
            "success_rate",
            "success_lo",
            "success_hi",
            "progress_mean",
            "progress_ci95",
            "energy_mean",
            "energy_ci95",
            "smoothness_mean",
            "smoothness_ci95",
            "time_to_success_s",
        ]
        .map(String::from),
    );
    w.write_record(&head).map_err(bad)?;
    for p in &s.points {
        let (lo, hi) = wilson95(p.successes, p.episodes);
        let rate = if p.episodes > 0 {
            p.successes as f64 / p.episodes as f64
        } else {
            f64::NAN
        };
        let mut row = vec![p.point.to_string()];
        row.extend(p.values.iter().cloned());
        row.extend([p.seeds_done, p.seeds, p.successes, p.episodes].map(|v| v.to_string()));
        row.extend([rate, lo, hi].map(|v| format!("{v:.6}")));
        for m in p.metrics {
            row.extend([format!("{:.6}", m.0), format!("{:.6}", m.1)]);
        }
        row.push(
            p.time_to_success_s
                .map_or(String::new(), |t| format!("{t:.6}")),
        );
        w.write_record(&row).map_err(bad)?;
    }
    w.into_inner()
        .map_err(|e| ReportError::Invalid(format!("sweep_points.csv: {e}")))
}

/// Writes report.md, sweep_points.csv and the figures into `out`; returns the figures' names.
pub fn write(root: &Path, out: &Path) -> Result<Vec<String>> {
    let s = load(root)?;
    let mut figures = Vec::new();
    match s.keys.len() {
        1 => {
            lines(&s, &out.join("sweep_lines.png"))?;
            figures.push("sweep_lines.png".to_string());
        }
        2 => {
            heat(&s, &out.join("sweep_heatmap.png"))?;
            figures.push("sweep_heatmap.png".to_string());
            figures.push("sweep_heatmap_progress.png".to_string());
        }
        _ => {}
    }
    let mut md = markdown(&s, root);
    if figures.is_empty() {
        md += "\nNo figure: the sweep has neither one nor two point keys.\n";
    }
    for f in &figures {
        md += &format!("\n![{f}]({f})\n");
    }
    let (md_path, csv_path) = (out.join("report.md"), out.join("sweep_points.csv"));
    std::fs::write(&md_path, md).map_err(ReportError::write(&md_path))?;
    std::fs::write(&csv_path, points_csv(&s)?).map_err(ReportError::write(&csv_path))?;
    Ok(figures)
}

/// x positions of a key's values: the numbers when every value is one, else 0, 1, 2, ...
fn positions(values: &[String]) -> (Vec<f64>, bool) {
    let parsed: Option<Vec<f64>> = values.iter().map(|v| v.parse().ok()).collect();
    match parsed {
        Some(x) => (x, true),
        None => ((0..values.len()).map(|i| i as f64).collect(), false),
    }
}

fn lines(s: &SweepSummary, path: &Path) -> Result<()> {
    let values: Vec<String> = s.points.iter().map(|p| p.values[0].clone()).collect();
    let (x, numeric) = positions(&values);
    let x_desc = if numeric {
        s.keys[0].clone()
    } else {
        format!(
            "{} ({})",
            s.keys[0],
            values
                .iter()
                .enumerate()
                .map(|(i, v)| format!("{i}: {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    };
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let band = |f: &dyn Fn(&PointSummary) -> (f64, f64, f64)| {
        let mut b = Band::default();
        for &i in &order {
            let (m, lo, hi) = f(&s.points[i]);
            if m.is_finite() {
                b.x.push(x[i]);
                b.mean.push(m);
                b.lo.push(lo);
                b.hi.push(hi);
            }
        }
        b
    };
    let success = band(&|p| {
        let (lo, hi) = wilson95(p.successes, p.episodes);
        let rate = if p.episodes > 0 {
            p.successes as f64 / p.episodes as f64
        } else {
            f64::NAN
        };
        (rate, lo, hi)
    });
    let progress = band(&|p| {
        let (m, h) = p.metrics[0];
        (m, m - h, m + h)
    });
    let panel = |title: &str, y: &str, band: Band, color| Panel {
        title: title.into(),
        x_desc: x_desc.clone(),
        y_desc: y.into(),
        curves: vec![Curve {
            label: y.into(),
            color,
            dashed: false,
            band,
        }],
        references: Vec::new(),
        secondary: None,
        legend: false,
    };
    plot::save(
        path,
        &[
            panel(
                "Success rate (95 % Wilson band)",
                "success rate",
                success,
                plot::BLUE,
            ),
            panel(
                "Progress, mean over seeds (95 % band)",
                "progress",
                progress,
                plot::ORANGE,
            ),
        ],
    )
}

fn heat(s: &SweepSummary, path: &Path) -> Result<()> {
    let distinct = |k: usize| {
        let mut v: Vec<String> = Vec::new();
        for p in &s.points {
            if !v.contains(&p.values[k]) {
                v.push(p.values[k].clone());
            }
        }
        v
    };
    let (xs, ys) = (distinct(1), distinct(0));
    let at = |p: &PointSummary| {
        let i = xs.iter().position(|v| *v == p.values[1]).unwrap_or(0);
        let j = ys.iter().position(|v| *v == p.values[0]).unwrap_or(0);
        (i, j)
    };
    let scale = s
        .points
        .iter()
        .map(|p| p.metrics[0].0.abs())
        .filter(|v| v.is_finite())
        .fold(0.0, f64::max)
        .max(1e-12);
    let mut success = HeatPanel {
        title: "success rate".into(),
        cells: Vec::new(),
    };
    let mut progress = HeatPanel {
        title: format!("mean progress (colour: / {scale:.3})"),
        cells: Vec::new(),
    };
    for p in &s.points {
        let (i, j) = at(p);
        if p.episodes > 0 {
            let rate = p.successes as f64 / p.episodes as f64;
            success
                .cells
                .push((i, j, rate, format!("{}/{}", p.successes, p.episodes)));
        }
        let m = p.metrics[0].0;
        if m.is_finite() {
            progress.cells.push((i, j, m / scale, format!("{m:.2}")));
        }
    }
    let axes = HeatAxes {
        x_labels: &xs,
        y_labels: &ys,
        x_desc: &s.keys[1],
        y_desc: &s.keys[0],
    };
    heatmap::save(
        path,
        &axes,
        &[success],
        1,
        Scale::Sequential,
        "Success rate over all seeds' episodes, white 0 to blue 1",
    )?;
    let name = path.with_file_name("sweep_heatmap_progress.png");
    heatmap::save(
        &name,
        &axes,
        &[progress],
        1,
        Scale::Diverging,
        "Mean progress over seeds (green: upstream, red: downstream)",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const EPISODES_HEADER: &str = "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm";

    fn run(root: &Path, dir: &str, rows: &[(u64, &str, f64, f64, f64)]) {
        let d = root.join(dir);
        std::fs::create_dir_all(&d).unwrap();
        let config = format!(
            "# fluxswarm-gpu 0.1.0 rollout: policy zero, seed 1, 1 environments, 2 episodes, adapter CPU backend\n{}",
            crate::config::PAPER_TOML
        );
        std::fs::write(d.join("config.toml"), config).unwrap();
        let mut text = format!("{EPISODES_HEADER}\n");
        for (i, (steps, outcome, p, e, s)) in rows.iter().enumerate() {
            text += &format!("0,{i},{steps},{outcome},{p},{e},{s},0,0,0,0,0\n");
        }
        std::fs::write(d.join("episodes.csv"), text).unwrap();
    }

    #[test]
    fn a_point_summarises_its_seeds_by_hand() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path();
        std::fs::write(
            root.join("sweep.csv"),
            "point,seed,status,dir,overrides,--policy,commit,backend,threads,host\n\
             0,1,done,runs/a1,--policy=zero,zero,c,native,1,h\n\
             0,2,done,runs/a2,--policy=zero,zero,c,native,1,h\n\
             1,1,failed,runs/b1,--policy=wall,wall,c,native,1,h\n",
        )
        .unwrap();
        run(
            root,
            "runs/a1",
            &[
                (10, "success", 1.0, 0.5, 0.9),
                (30, "failure", -1.0, 0.1, 0.7),
            ],
        );
        run(
            root,
            "runs/a2",
            &[
                (20, "success", 3.0, 0.3, 0.5),
                (40, "success", 1.0, 0.1, 0.5),
            ],
        );
        let s = load(root).unwrap();
        assert_eq!(s.keys, ["--policy"]);
        let p = &s.points[0];
        assert_eq!(
            (p.seeds_done, p.seeds, p.successes, p.episodes),
            (2, 2, 3, 4)
        );
        // Seed means of progress 0 and 2: mean 1, half-width t(0.975, 1) sqrt(2) / sqrt(2) (the
        // t table holds 12.706).
        assert!((p.metrics[0].0 - 1.0).abs() < 1e-12);
        assert!(
            (p.metrics[0].1 - 12.706_204_736).abs() < 1e-3,
            "{:?}",
            p.metrics[0]
        );
        // Energy: seed means 0.3 and 0.2.
        assert!((p.metrics[1].0 - 0.25).abs() < 1e-12);
        // (10 + 20 + 40) / 3 steps of 5 ms.
        let t = p.time_to_success_s.unwrap();
        assert!((t - 70.0 / 3.0 * 0.005).abs() < 1e-12, "{t}");
        let q = &s.points[1];
        assert_eq!((q.seeds_done, q.seeds, q.episodes), (0, 1, 0));
        assert!(q.metrics[0].0.is_nan() && q.time_to_success_s.is_none());
        let md = markdown(&s, root);
        assert!(md.contains("| 0 | zero | 2/2 | 3/4 = 75 % ["), "{md}");
        assert!(md.contains("| 1 | wall | 0/1 | - | - |"), "{md}");
        let out = tempfile::tempdir().unwrap();
        let figures = write(root, out.path()).unwrap();
        assert_eq!(figures, ["sweep_lines.png"]);
        let csv = std::fs::read_to_string(out.path().join("sweep_points.csv")).unwrap();
        assert!(
            csv.lines()
                .nth(1)
                .unwrap()
                .starts_with("0,zero,2,2,3,4,0.750000,"),
            "{csv}"
        );
    }
}

//! What `fluxswarm-gpu map` writes from the cells of [`super::map`]:
//! - `controllability_map.csv`: one row per controller per scenario point (the columns of [`MAP_HEADER`]);
//! - `controllability_points.csv`: one row per point: the best constant controller (zero, random and the
//!   wall-angle family, upstream and wall included), the best wall angle, `scripted` (or one
//!   `scripted:CALM:STORM:START:END` cell, tuned for another grid), and the
//!   gap = scripted rate - best constant rate;
//! - `controllability_map.png` (success rate of every controller over flow scale x thrust),
//!   `controllability_map_gap.png` (the gap and the best constant controller) and
//!   `controllability_map_dimensionless.png` (the points placed at F_max / peak wall drag and
//!   the fraction of the cycle in which thrust beats that drag).

use std::fmt::Write as _;
use std::path::Path;

use super::error::{Result, Within};

use super::heatmap::{self, HeatAxes, HeatPanel, Scale, ScatterPanel};
use super::map::{Cell, WallDrag, is_constant, is_scripted, probe_for, wall_angle_deg};

/// Header row of `controllability_map.csv`.
pub const MAP_HEADER: &str = "inlet_scale,peak_inlet_m_s,max_thrust_nN,policy,episodes,successes,success_rate,success_lo,success_hi,systole_episodes,systole_successes,systole_lo,systole_hi,diastole_episodes,diastole_successes,diastole_lo,diastole_hi,failures,timeouts,mean_success_time_s,median_cycles,upstream_mm_per_cycle,peak_wall_drag_nN,thrust_over_peak_drag,thrust_beats_drag_fraction";

/// Header row of `controllability_points.csv`.
pub const POINTS_HEADER: &str = "inlet_scale,max_thrust_nN,episodes,best_constant,best_constant_rate,best_constant_lo,best_constant_hi,best_angle_deg,best_angle_rate,scripted_rate,scripted_lo,scripted_hi,gap";

/// The best constant controller, the best wall angle and `scripted` at one point.
#[derive(Debug, Clone, PartialEq)]
pub struct Point<'a> {
    /// Flow scale `inlet.scale` of the point.
    pub scale: f64,
    /// Thrust bound F_max of the point (N).
    pub max_thrust_n: f64,
    /// The constant controller with the most successes.
    pub best_constant: &'a Cell,
    /// The wall-angle controller with the most successes, if any ran.
    pub best_angle: Option<&'a Cell>,
    /// The `scripted` controller's cell, if it ran.
    pub scripted: Option<&'a Cell>,
}

impl Point<'_> {
    /// scripted rate - best constant rate (NaN without `scripted`).
    pub fn gap(&self) -> f64 {
        self.scripted.map_or(f64::NAN, |s| s.all.rate()) - self.best_constant.all.rate()
    }
}

/// Most successes first; ties go to the smaller wall angle, then the name.
fn better(a: &Cell, b: &Cell) -> bool {
    let key = |c: &Cell| (c.all.k, -wall_angle_deg(&c.policy).unwrap_or(-1.0));
    let (ka, kb) = (key(a), key(b));
    ka.0 > kb.0 || (ka.0 == kb.0 && (ka.1 > kb.1 || (ka.1 == kb.1 && a.policy < b.policy)))
}

/// The points of the map (scale, thrust), in order, each with its comparators.
pub fn points(cells: &[Cell]) -> Vec<Point<'_>> {
    let mut keys: Vec<(f64, f64)> = cells.iter().map(|c| (c.scale, c.max_thrust_n)).collect();
    keys.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
    keys.dedup();
    keys.into_iter()
        .filter_map(|(s, f)| {
            let here: Vec<&Cell> = cells
                .iter()
                .filter(|c| c.scale == s && c.max_thrust_n == f)
                .collect();
            let pick = |keep: &dyn Fn(&Cell) -> bool| {
                here.iter()
                    .copied()
                    .filter(|c| keep(c))
                    .fold(None, |best: Option<&Cell>, c| match best {
                        Some(b) if !better(c, b) => Some(b),
                        _ => Some(c),
                    })
            };
            Some(Point {
                scale: s,
                max_thrust_n: f,
                best_constant: pick(&|c| is_constant(&c.policy))?,
                best_angle: pick(&|c| wall_angle_deg(&c.policy).is_some()),
                scripted: pick(&|c| is_scripted(&c.policy)),
            })
        })
        .collect()
}

fn f(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        String::new()
    }
}

/// controllability_map.csv: every cell with the wall-drag columns of its point (empty without a probe).
pub fn map_csv(cells: &[Cell], probes: &[WallDrag]) -> String {
    let mut s = format!("{MAP_HEADER}\n");
    for c in cells {
        let probe = probe_for(probes, c.scale);
        let peak = probe.map_or(f64::NAN, WallDrag::peak_n);
        let beaten = probe.map_or(f64::NAN, |p| p.beaten_fraction(c.max_thrust_n));
        let r = |r: &super::map::Rate| format!("{},{},{},{}", r.n, r.k, f(r.lo, 4), f(r.hi, 4));
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            c.scale,
            f(c.peak_inlet_m_s, 4),
            f(c.max_thrust_n * 1e9, 1),
            c.policy,
            c.all.n,
            c.all.k,
            f(c.all.rate(), 4),
            format_args!("{},{}", f(c.all.lo, 4), f(c.all.hi, 4)),
            r(&c.systole),
            r(&c.diastole),
            c.failures,
            c.timeouts,
            f(c.mean_success_time_s, 3),
            f(c.median_cycles, 3),
            f(c.upstream_mm_per_cycle, 3),
            f(peak * 1e9, 1),
            format_args!("{},{}", f(c.max_thrust_n / peak, 4), f(beaten, 4)),
        );
    }
    s
}

/// controllability_points.csv: one row per point.
pub fn points_csv(points: &[Point]) -> String {
    let mut s = format!("{POINTS_HEADER}\n");
    for p in points {
        let b = p.best_constant;
        let angle = p.best_angle;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{}",
            p.scale,
            f(p.max_thrust_n * 1e9, 1),
            b.all.n,
            b.policy,
            f(b.all.rate(), 4),
            f(b.all.lo, 4),
            f(b.all.hi, 4),
            angle
                .and_then(|a| wall_angle_deg(&a.policy))
                .map_or(String::new(), |d| d.to_string()),
            f(angle.map_or(f64::NAN, |a| a.all.rate()), 4),
            f(p.scripted.map_or(f64::NAN, |c| c.all.rate()), 4),
            f(p.scripted.map_or(f64::NAN, |c| c.all.lo), 4),
            f(p.scripted.map_or(f64::NAN, |c| c.all.hi), 4),
            f(p.gap(), 4),
        );
    }
    s
}

/// Display order of the controllers: zero, random, the wall angles upwards, scripted, others.
fn policy_order(policy: &str) -> (u8, f64, String) {
    match (policy, wall_angle_deg(policy)) {
        ("zero", _) => (0, 0.0, String::new()),
        ("random", _) => (1, 0.0, String::new()),
        (_, Some(d)) => (2, d, String::new()),
        (p, _) if is_scripted(p) => (3, 0.0, p.to_string()),
        (p, _) => (4, 0.0, p.to_string()),
    }
}

/// Short names for the cells of the gap figure.
fn short(policy: &str) -> String {
    match (policy, wall_angle_deg(policy)) {
        ("upstream", _) => "up".into(),
        ("wall", _) => "wall".into(),
        ("random", _) => "rand".into(),
        (_, Some(d)) => format!("{d}°"),
        (p, _) => p.chars().take(5).collect(),
    }
}

fn label(v: f64) -> String {
    let v = (v * 1e6).round() / 1e6;
    format!("{v}")
}

/// Writes the three figures into `out`; returns their file names.
pub fn figures(cells: &[Cell], probes: &[WallDrag], out: &Path) -> Result<Vec<String>> {
    let mut scales: Vec<f64> = cells.iter().map(|c| c.scale).collect();
    let mut thrusts: Vec<f64> = cells.iter().map(|c| c.max_thrust_n).collect();
    for v in [&mut scales, &mut thrusts] {
        v.sort_by(f64::total_cmp);
        v.dedup();
    }
    let ix = |c: &Cell| {
        let i = scales.iter().position(|&s| s == c.scale).unwrap_or(0);
        let j = thrusts
            .iter()
            .position(|&t| t == c.max_thrust_n)
            .unwrap_or(0);
        (i, j)
    };
    let x_labels: Vec<String> = scales.iter().map(|&s| label(s)).collect();
    let y_labels: Vec<String> = thrusts.iter().map(|&t| label(t * 1e9)).collect();
    let axes = HeatAxes {
        x_labels: &x_labels,
        y_labels: &y_labels,
        x_desc: "inlet.scale (peak 400 mm/s x scale)",
        y_desc: "max thrust (nN)",
    };
    let mut policies: Vec<&str> = cells.iter().map(|c| c.policy.as_str()).collect();
    policies.sort_by(|a, b| {
        let (x, y) = (policy_order(a), policy_order(b));
        x.0.cmp(&y.0).then(x.1.total_cmp(&y.1)).then(x.2.cmp(&y.2))
    });
    policies.dedup();
    let n = cells.iter().map(|c| c.all.n).max().unwrap_or(0);
    let panels: Vec<HeatPanel> = policies
        .iter()
        .map(|p| HeatPanel {
            title: p.to_string(),
            cells: cells
                .iter()
                .filter(|c| c.policy == *p)
                .map(|c| {
                    let (i, j) = ix(c);
                    (i, j, c.all.rate(), format!("{}/{}", c.all.k, c.all.n))
                })
                .collect(),
        })
        .collect();
    let mut written = Vec::new();
    let name = "controllability_map.png";
    heatmap::save(
        &out.join(name),
        &axes,
        &panels,
        3,
        Scale::Sequential,
        &format!(
            "Success rate (successes/episodes, up to {n} per cell; random phase and start jitter), white 0 to blue 1"
        ),
    )
    .within(|| format!("drawing {name}"))?;
    written.push(name.to_string());

    let pts = points(cells);
    let gap_panels = [
        HeatPanel {
            title: "scripted - best constant controller".into(),
            cells: pts
                .iter()
                .filter(|p| p.scripted.is_some())
                .map(|p| {
                    let (i, j) = ix(p.best_constant);
                    let g = p.gap();
                    (i, j, g, format!("{:+.0}", 100.0 * g))
                })
                .collect(),
        },
        HeatPanel {
            title: "best constant controller".into(),
            cells: pts
                .iter()
                .map(|p| {
                    let (i, j) = ix(p.best_constant);
                    let b = p.best_constant;
                    let text = format!("{} {:.0}", short(&b.policy), 100.0 * b.all.rate());
                    (i, j, b.all.rate(), text)
                })
                .collect(),
        },
    ];
    let name = "controllability_map_gap.png";
    heatmap::save(
        &out.join(name),
        &axes,
        &gap_panels[..1],
        1,
        Scale::Diverging,
        "scripted minus the best constant controller, success-rate points (green: scripted better)",
    )?;
    written.push(name.to_string());
    let name = "controllability_map_best_constant.png";
    heatmap::save(
        &out.join(name),
        &axes,
        &gap_panels[1..],
        1,
        Scale::Sequential,
        "The best constant controller at each point and its success rate (%)",
    )?;
    written.push(name.to_string());

    if !probes.is_empty() {
        let place = |c: &Cell| -> Option<(f64, f64)> {
            let p = probe_for(probes, c.scale)?;
            Some((
                c.max_thrust_n / p.peak_n(),
                p.beaten_fraction(c.max_thrust_n),
            ))
        };
        let scatter = |title: &str, chosen: Vec<&Cell>| ScatterPanel {
            title: title.into(),
            points: chosen
                .into_iter()
                .filter_map(|c| {
                    let (x, y) = place(c)?;
                    Some((x, y, c.all.rate(), format!("{}/{}", c.all.k, c.all.n)))
                })
                .collect(),
        };
        let mut panels = vec![scatter(
            "best constant controller",
            pts.iter().map(|p| p.best_constant).collect(),
        )];
        if pts.iter().any(|p| p.scripted.is_some()) {
            panels.push(scatter(
                "scripted",
                pts.iter().filter_map(|p| p.scripted).collect(),
            ));
        }
        let name = "controllability_map_dimensionless.png";
        heatmap::save_scatter(
            &out.join(name),
            &panels,
            (
                "F_max / peak streamwise force on a member pinned at the wall",
                "fraction of the cycle with F_max above that force",
            ),
            Scale::Sequential,
            "Each map point placed by its wall-drag probe; colour and label: success rate",
        )?;
        written.push(name.to_string());
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::super::map::Rate;
    use super::*;

    fn cell(policy: &str, scale: f64, k: usize) -> Cell {
        Cell {
            scale,
            peak_inlet_m_s: 0.4 * scale,
            max_thrust_n: 8.5e-7,
            policy: policy.into(),
            all: Rate::of(k, 20),
            systole: Rate::of(0, 0),
            diastole: Rate::of(k, 20),
            failures: 20 - k,
            timeouts: 0,
            mean_success_time_s: f64::NAN,
            median_cycles: 1.0,
            upstream_mm_per_cycle: 0.0,
        }
    }

    #[test]
    fn a_scripted_cell_with_explicit_parameters_is_the_points_positive_control() {
        let cells = vec![
            cell("wall-angle:40", 0.875, 4),
            cell("scripted:30:60:0.9:0.15", 0.875, 11),
        ];
        let pts = points(&cells);
        assert_eq!(pts[0].scripted.unwrap().policy, "scripted:30:60:0.9:0.15");
        assert_eq!(pts[0].best_constant.policy, "wall-angle:40");
        assert!((pts[0].gap() - 0.35).abs() < 1e-12);
    }

    #[test]
    fn each_point_gets_its_best_constant_its_best_angle_and_the_gap() {
        let cells = vec![
            cell("zero", 0.9, 0),
            cell("upstream", 0.9, 2),
            cell("wall", 0.9, 5),
            cell("wall-angle:60", 0.9, 5),
            cell("scripted", 0.9, 15),
            cell("random", 1.0, 1),
            cell("wall-angle:30", 1.0, 0),
        ];
        let pts = points(&cells);
        assert_eq!(pts.len(), 2);
        // A tie (5 and 5) goes to the smaller angle.
        assert_eq!(pts[0].best_constant.policy, "wall");
        assert_eq!(pts[0].best_angle.unwrap().policy, "wall");
        assert!((pts[0].gap() - 0.5).abs() < 1e-12);
        assert_eq!(pts[1].best_constant.policy, "random");
        assert_eq!(pts[1].best_angle.unwrap().policy, "wall-angle:30");
        assert!(pts[1].scripted.is_none() && pts[1].gap().is_nan());
        let csv = points_csv(&pts);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[0], POINTS_HEADER);
        assert!(
            rows[1].starts_with("0.9,850.0,20,wall,0.2500,"),
            "{}",
            rows[1]
        );
        // Wilson intervals of 5/20 and 15/20 worked out by hand.
        assert!(
            rows[1].contains(",0.2500,0.1119,0.4687,45,0.2500,"),
            "{}",
            rows[1]
        );
        assert!(
            rows[1].ends_with(",0.7500,0.5313,0.8881,0.5000"),
            "{}",
            rows[1]
        );
        let probe = WallDrag {
            scale: 0.9,
            force_n: vec![1e-6, 1e-8],
        };
        let map = map_csv(&cells, &[probe]);
        let first: Vec<&str> = map.lines().nth(1).unwrap().split(',').collect();
        assert_eq!(first.len(), MAP_HEADER.split(',').count());
        assert_eq!(&first[first.len() - 3..], ["1000.0", "0.8500", "0.5000"]);
    }
}

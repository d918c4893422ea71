//! `report --behaviour DIR...` ([`super::behaviour`]): `behaviour.md` and `behaviour.csv`, one
//! row per directory (the first is the subject, the others compare with it, e.g. a baseline),
//! and the figures of the subject's longest finished episode:
//! - `ratchet.png`: x_COM against time with the inlet, and x_COM - x_COM(cycle start) against
//!   the phase, one curve per cycle;
//! - `throttling.png`: sigma_x and sigma_y against time with the inlet and, with `gap.csv`, the
//!   peak fluid u_x within the swarm's extent against the inlet centreline velocity;
//! - `approach.png` (with `trajectories.csv` and a success): every member's x over the last
//!   second of the subject's longest successful episode, with the success line;
//! - `thrust_phase.png` and `thrust_phase.csv` (with `trajectories.csv`): every directory's
//!   thrust angle by phase of the cycle ([`super::thrust_phase`]).

use std::collections::BTreeMap;
use std::path::Path;

use super::behaviour::{self, APPROACH_S, Behaviour};
use super::data::Csv;
use super::error::{ReportError, Result};
use super::plot::{self, Curve, Panel, Reference, Secondary};
use super::{thrust, thrust_phase};

const PALETTE: [plotters::style::RGBColor; 7] = [
    plot::BLUE,
    plot::ORANGE,
    plot::GREEN,
    plot::PURPLE,
    plot::BROWN,
    plot::RED,
    plot::GREY,
];

/// The time shown in `approach.png` (s).
const APPROACH_WINDOW_S: f64 = 1.0;

/// `v` with `digits` decimals, or "-" when it is not finite.
pub(super) fn num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        "-".into()
    }
}

/// Per directory: (complete cycles, ratchet cycles, mean D_fwd, mean D_rest).
fn ratchet_numbers(b: &Behaviour) -> (usize, usize, f64, f64) {
    let n = b.cycles.len();
    let ratchet = b.cycles.iter().filter(|c| c.is_ratchet()).count();
    let mean = |f: fn(&behaviour::CycleShift) -> f64| {
        if n == 0 {
            f64::NAN
        } else {
            b.cycles.iter().map(f).sum::<f64>() / n as f64
        }
    };
    (n, ratchet, mean(|c| c.forward_mm), mean(|c| c.rest_mm))
}

/// The directory's successful episodes.
fn successes(b: &Behaviour) -> usize {
    b.run
        .episodes
        .iter()
        .filter(|e| e.outcome == "success")
        .count()
}

/// `behaviour.md`.
pub fn markdown(list: &[Behaviour], figures: &[String]) -> String {
    let mut md = String::from("# Emergent behaviours\n\n");
    md += &format!(
        "Measured in rollout or eval directories (finished episodes only). An interval is \
         forward flow when its mean inlet velocity exceeds half the largest in its directory. \
         A complete cycle is a ratchet cycle when x_COM moves downstream over its forward \
         intervals (D_fwd > 0) and upstream over the rest (D_rest < 0); x grows downstream. \
         The final approach compares sigma_x and R_g over a success's last {APPROACH_S} s \
         with the steps before. Diverged episodes are left out. Definitions: \
         `src/report/behaviour.rs`.\n\n"
    );
    md += "| directory | policy | episodes | successes | complete cycles | ratchet cycles | mean D_fwd (mm) | mean D_rest (mm) |\n|---|---|---|---|---|---|---|---|\n";
    for b in list {
        let (n, r, f, rest) = ratchet_numbers(b);
        let successes = successes(b);
        md += &format!(
            "| {} | {} | {} | {successes} | {n} | {r} | {} | {} |\n",
            b.run.info.dir.display(),
            b.run.label(),
            b.run.episodes.len(),
            num(f, 3),
            num(rest, 3)
        );
    }
    md += "\n## Throttling (means over forward-flow steps)\n\n| directory | steps | gap rows | sigma_y (mm) | sigma_x (mm) | peak u_x in the swarm (mm/s) | peak / inlet | mean blocked | largest blocked |\n|---|---|---|---|---|---|---|---|---|\n";
    for b in list {
        let t = &b.throttling;
        let g = t
            .gap
            .map_or(["-".to_string(), "-".into(), "-".into(), "-".into()], |g| {
                [num(g[0], 0), num(g[1], 2), num(g[2], 3), num(g[3], 3)]
            });
        md += &format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            b.run.info.dir.display(),
            t.steps,
            t.gap_steps,
            num(t.sigma_y_mm, 3),
            num(t.sigma_x_mm, 3),
            g.join(" | ")
        );
    }
    md += "\n## Thrust direction (member-steps with thrust, from trajectories.csv)\n\nThe angle from upstream (0: upstream, 90: across the flow) and the shares of member-steps pushing towards the member's nearer wall and towards the lower wall (y = 0), in forward flow and in the rest.\n\n| directory | forward: member-steps | angle (deg, mean ± sd) | nearer wall | lower wall | rest: member-steps | angle (deg, mean ± sd) | nearer wall | lower wall |\n|---|---|---|---|---|---|---|---|---|\n";
    for b in list {
        let cells = |d: Option<&thrust::Direction>| match d.filter(|d| d.member_steps > 0) {
            Some(d) => format!(
                "{} | {} ± {} | {} | {}",
                d.member_steps,
                num(d.mean_deg, 1),
                num(d.sd_deg, 1),
                num(d.nearer_wall, 2),
                num(d.lower_wall, 2)
            ),
            None => format!("{} | - | - | -", d.map_or(0, |d| d.member_steps)),
        };
        let t = b.thrust.as_ref();
        md += &format!(
            "| {} | {} | {} |\n",
            b.run.info.dir.display(),
            cells(t.map(|t| &t.forward)),
            cells(t.map(|t| &t.rest))
        );
    }
    md += &thrust_phase::markdown(list);
    md += &format!(
        "\n## Final approach (successes of at least {} s)\n\n| directory | episodes | steps in the last {APPROACH_S} s | sigma_x last / before | R_g last / before | spreading (ratio > 1) |\n|---|---|---|---|---|---|\n",
        2.0 * APPROACH_S
    );
    for b in list {
        let cells = b.approach.as_ref().map_or(
            ["0".to_string(), "-".into(), "-".into(), "-".into()],
            |a| {
                [
                    a.episodes.to_string(),
                    num(a.sigma_x_ratio, 2),
                    num(a.r_g_ratio, 2),
                    format!("{}/{}", a.spreading, a.episodes),
                ]
            },
        );
        md += &format!(
            "| {} | {} | {} |\n",
            b.run.info.dir.display(),
            cells[0],
            [b.approach_steps.to_string(), cells[1..].join(" | ")].join(" | ")
        );
    }
    if let Some((env, episode)) = list
        .first()
        .and_then(|b| behaviour::shown_episode(&b.run, None))
    {
        md += &format!(
            "\nFigures: environment {env}, episode {episode} of the first directory (its longest \
             finished episode); `approach.png`: its longest successful episode; \
             `thrust_phase.png`: every directory.\n\n"
        );
        for f in figures {
            md += &format!("![{f}]({f})\n");
        }
    }
    md
}

/// `behaviour.csv`: one row per directory.
pub fn csv(list: &[Behaviour]) -> String {
    let mut out = String::from(
        "dir,policy,episodes,successes,cycles,ratchet_cycles,mean_forward_mm,mean_rest_mm,forward_steps,gap_steps,sigma_y_mm,sigma_x_mm,peak_u_mm_s,peak_over_inlet,mean_blocked,max_blocked,approach_episodes,approach_sigma_x_ratio,approach_r_g_ratio,thrust_forward_steps,thrust_forward_deg,thrust_forward_sd_deg,thrust_forward_nearer_wall,thrust_forward_lower_wall,thrust_rest_steps,thrust_rest_deg,thrust_rest_sd_deg,thrust_rest_nearer_wall,thrust_rest_lower_wall\n",
    );
    for b in list {
        let (n, r, f, rest) = ratchet_numbers(b);
        let t = &b.throttling;
        let g = t.gap.unwrap_or([f64::NAN; 4]);
        let a = b.approach.as_ref();
        let successes = successes(b);
        out += &format!(
            "{},{},{},{successes},{n},{r},{f:.4},{rest:.4},{},{},{:.4},{:.4},{:.1},{:.4},{:.4},{:.4},{},{:.4},{:.4}\n",
            b.run.info.dir.display(),
            b.run.label(),
            b.run.episodes.len(),
            t.steps,
            t.gap_steps,
            t.sigma_y_mm,
            t.sigma_x_mm,
            g[0],
            g[1],
            g[2],
            g[3],
            a.map_or(0, |a| a.episodes),
            a.map_or(f64::NAN, |a| a.sigma_x_ratio),
            a.map_or(f64::NAN, |a| a.r_g_ratio),
        );
        // The thrust columns, appended so that older readers keep their columns.
        out.pop();
        for d in [
            b.thrust.as_ref().map(|t| &t.forward),
            b.thrust.as_ref().map(|t| &t.rest),
        ] {
            let nan = f64::NAN;
            let (n, m, sd, near, low) = d.map_or((0, nan, nan, nan, nan), |d| {
                (
                    d.member_steps,
                    d.mean_deg,
                    d.sd_deg,
                    d.nearer_wall,
                    d.lower_wall,
                )
            });
            out += &format!(",{n},{m:.2},{sd:.2},{near:.4},{low:.4}");
        }
        out.push('\n');
    }
    out
}

fn inlet(points: Vec<(f64, f64)>) -> Option<Secondary> {
    Some(Secondary {
        label: "inlet centreline velocity (right axis)".into(),
        y_desc: "inlet U (mm/s)".into(),
        points,
    })
}

fn panel(title: &str, x_desc: &str, y_desc: &str, curves: Vec<Curve>) -> Panel {
    Panel {
        title: title.into(),
        x_desc: x_desc.into(),
        y_desc: y_desc.into(),
        curves,
        references: Vec::new(),
        secondary: None,
        legend: true,
    }
}

/// Every member's x (mm) by step, over the episode `(env, episode)` of `dir/trajectories.csv`.
fn member_tracks(dir: &Path, env: usize, episode: u64) -> Result<BTreeMap<usize, Vec<(u64, f64)>>> {
    let c = Csv::read(&dir.join("trajectories.csv"))?;
    let (e, ep, step, member, x) = (
        c.column::<usize>("env")?,
        c.column::<u64>("episode")?,
        c.column::<u64>("step")?,
        c.column::<usize>("member")?,
        c.column::<f64>("x_mm")?,
    );
    let mut tracks: BTreeMap<usize, Vec<(u64, f64)>> = BTreeMap::new();
    for r in (0..c.rows.len()).filter(|&r| e[r] == env && ep[r] == episode) {
        tracks.entry(member[r]).or_default().push((step[r], x[r]));
    }
    Ok(tracks)
}

/// Draws the subject's figures into `out`; returns their file names.
fn figures(b: &Behaviour, out: &Path) -> Result<Vec<String>> {
    let Some(key) = behaviour::shown_episode(&b.run, None) else {
        return Ok(Vec::new());
    };
    let episodes = behaviour::by_episode(&b.run.swarm);
    let missing = |key: (usize, u64)| {
        ReportError::Invalid(format!(
            "{}: swarm.csv has no rows of episode {} of environment {}",
            b.run.info.dir.display(),
            key.1,
            key.0
        ))
    };
    let rows = episodes.get(&key).ok_or_else(|| missing(key))?;
    let phase0 = b.start_phase[&key];
    let series = |f: fn(&super::data::SwarmStep) -> f64| -> Vec<(f64, f64)> {
        rows.iter().map(|s| (s.t_s, f(s))).collect()
    };
    let inlet_mm: Vec<(f64, f64)> = rows.iter().map(|s| (s.t_s, 1e3 * s.inlet_u_m_s)).collect();
    let mut names = Vec::new();

    // The ratchet.
    let mut com = panel(
        "centre of mass",
        "time since the episode start (s)",
        "x_COM (mm)",
        vec![Curve::line("x_COM", plot::BLUE, &series(|s| s.x_com_mm))],
    );
    com.secondary = inlet(inlet_mm.clone());
    let mut per_cycle: BTreeMap<i64, Vec<(f64, f64)>> = BTreeMap::new();
    for s in rows {
        let abs = phase0 + s.t_s;
        let cycle = behaviour::cycle_of(abs, b.period_s);
        per_cycle
            .entry(cycle)
            .or_default()
            .push((abs - cycle as f64 * b.period_s, s.x_com_mm));
    }
    let cycles: Vec<Curve> = per_cycle
        .iter()
        .enumerate()
        .map(|(i, (c, pts))| {
            let x0 = pts[0].1;
            let shifted: Vec<(f64, f64)> = pts.iter().map(|&(p, x)| (p, x - x0)).collect();
            Curve::line(format!("cycle {c}"), PALETTE[i % PALETTE.len()], &shifted)
        })
        .collect();
    let phase = panel(
        "x_COM against the phase, one curve per cycle (+ = downstream)",
        "phase in the cycle (s)",
        "x_COM - x_COM at the cycle's first step (mm)",
        cycles,
    );
    plot::save(&out.join("ratchet.png"), &[com, phase])?;
    names.push("ratchet.png".to_string());

    // Throttling.
    let mut spread = panel(
        "spread",
        "time since the episode start (s)",
        "mm",
        vec![
            Curve::line("sigma_x", plot::BLUE, &series(|s| s.sigma_x_mm)),
            Curve::line("sigma_y", plot::ORANGE, &series(|s| s.sigma_y_mm)),
        ],
    );
    spread.secondary = inlet(inlet_mm.clone());
    let mut panels = vec![spread];
    let gap: Vec<_> = b
        .gap
        .iter()
        .filter(|g| (g.env, g.episode) == key && g.peak_u_m_s.is_finite())
        .collect();
    if !gap.is_empty() {
        let dt = rows.get(1).map_or(0.0, |s| s.t_s) - rows[0].t_s;
        let t = |step: u64| step as f64 * dt;
        let mut flow = panel(
            "flow past the swarm",
            "time since the episode start (s)",
            "u_x (mm/s)",
            vec![
                Curve::line(
                    "peak fluid u_x within the swarm's extent",
                    plot::RED,
                    &gap.iter()
                        .map(|g| (t(g.step), 1e3 * g.peak_u_m_s))
                        .collect::<Vec<_>>(),
                ),
                Curve::line("inlet centreline U", plot::GREY, &inlet_mm),
            ],
        );
        flow.secondary = Some(Secondary {
            label: "mean blocked fraction of the extent's columns (right axis)".into(),
            y_desc: "blocked fraction".into(),
            points: gap.iter().map(|g| (t(g.step), g.mean_blocked)).collect(),
        });
        panels.push(flow);
    }
    plot::save(&out.join("throttling.png"), &panels)?;
    names.push("throttling.png".to_string());

    // The final approach, in the longest success.
    let dir = &b.run.info.dir;
    let success = behaviour::shown_episode(&b.run, Some("success"));
    if let (true, Some(key)) = (dir.join("trajectories.csv").exists(), success) {
        let tracks = member_tracks(dir, key.0, key.1)?;
        let rows = episodes.get(&key).ok_or_else(|| missing(key))?;
        let last = rows.last().map_or(0, |s| s.step);
        let dt = b.run.info.control_dt_s;
        let from = last.saturating_sub(behaviour::steps_in(APPROACH_WINDOW_S, dt) as u64);
        let curves: Vec<Curve> = tracks
            .iter()
            .map(|(m, pts)| {
                let pts: Vec<(f64, f64)> = pts
                    .iter()
                    .filter(|p| p.0 >= from)
                    .map(|&(s, x)| (s as f64 * dt, x))
                    .collect();
                Curve::line(format!("member {m}"), PALETTE[m % PALETTE.len()], &pts)
            })
            .collect();
        let mut p = panel(
            "members over the last second of the longest successful episode",
            "time since the episode start (s)",
            "x (mm)",
            curves,
        );
        p.legend = false;
        let xs = b.run.info.success_x_mm;
        p.references = vec![Reference {
            label: "success line".into(),
            color: plot::GREY,
            mean: xs,
            lo: xs,
            hi: xs,
        }];
        plot::save(&out.join("approach.png"), &[p])?;
        names.push("approach.png".to_string());
    }
    Ok(names)
}

/// Reads `dirs` (the first is the subject) and writes `behaviour.md`, `behaviour.csv` and the
/// subject's figures into `out`.
pub fn write(dirs: &[std::path::PathBuf], out: &Path) -> Result<Vec<String>> {
    if dirs.is_empty() {
        return Err(ReportError::Usage(
            "--behaviour needs at least one rollout or eval directory written with traces".into(),
        ));
    }
    let list: Vec<Behaviour> = dirs
        .iter()
        .map(|d| behaviour::load(d))
        .collect::<Result<_>>()?;
    let mut names = figures(&list[0], out)?;
    names.extend(thrust_phase::figure(&list, out, &PALETTE)?);
    thrust_phase::write_csv(&list, out)?;
    let md_path = out.join("behaviour.md");
    std::fs::write(&md_path, markdown(&list, &names)).map_err(ReportError::write(&md_path))?;
    let csv_path = out.join("behaviour.csv");
    std::fs::write(&csv_path, csv(&list)).map_err(ReportError::write(&csv_path))?;
    Ok(names)
}

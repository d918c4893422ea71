//! The thrust direction against the phase of the inlet cycle (issue 19, item 5: does a policy
//! turn with the flow, and when?), for `report --behaviour`.
//! - A member-step's phase is the fraction of the cycle phi = frac((phi_0 + t) / T), phi_0 the
//!   episode's start phase and t the step's time (`starts.csv`, `swarm.csv`), T the period;
//!   the cycle is counted as the ratchet measure counts it (`behaviour::cycle_of`).
//! - The cycle is cut into [`PHASE_BINS`] equal bins [i/B, (i+1)/B); each gets the
//!   [`Direction`] of its member-steps with thrust (angle from upstream, shares towards the
//!   nearer and the lower wall) and their mean inlet velocity.
//! - Output: a table in `behaviour.md` (a row per directory, a column per bin),
//!   `thrust_phase.csv` (a row per directory and bin) and `thrust_phase.png` (the mean angle of
//!   each directory against the phase, with the first directory's mean inlet per bin).

use std::path::Path;

use super::behaviour::{Behaviour, cycle_of};
use super::behaviour_output::num;
use super::error::{ReportError, Result};
use super::plot::{self, Curve, Panel, Secondary};
use super::thrust::{Direction, Push, direction_of};

/// The number of phase bins: tenths of the cycle.
pub const PHASE_BINS: usize = 10;

/// The thrust direction over the member-steps of one phase bin.
#[derive(Debug, Clone, PartialEq)]
pub struct PhaseBin {
    /// The bin's first phase (fraction of the cycle).
    pub from: f64,
    /// The bin's end (fraction of the cycle, excluded).
    pub to: f64,
    /// The mean inlet velocity over the bin's member-steps (m/s; NaN when it has none).
    pub inlet_u_m_s: f64,
    /// The direction of their thrust.
    pub direction: Direction,
}

/// The fraction of the cycle, in [0, 1), at `abs_s` seconds from phase 0 of a cycle of
/// `period_s`: the time since the start of the cycle [`cycle_of`] counts it in, so a step
/// that the ratchet measure puts in the next cycle is at phase 0 here, not just below 1.
pub fn cycle_fraction(abs_s: f64, period_s: f64) -> f64 {
    (abs_s / period_s - cycle_of(abs_s, period_s) as f64).max(0.0)
}

/// The thrust direction of `pushes` (member-steps with thrust) in `bins` equal bins of the
/// phase, in a channel of mid-height `mid_y_mm`; an empty bin has no member-steps and NaNs.
pub fn by_phase(pushes: &[&Push], mid_y_mm: f64, bins: usize) -> Vec<PhaseBin> {
    let mut groups: Vec<Vec<&Push>> = vec![Vec::new(); bins];
    for p in pushes {
        let b = ((p.phase * bins as f64) as usize).min(bins - 1);
        groups[b].push(p);
    }
    groups
        .iter()
        .enumerate()
        .map(|(i, g)| PhaseBin {
            from: i as f64 / bins as f64,
            to: (i + 1) as f64 / bins as f64,
            inlet_u_m_s: match g.len() {
                0 => f64::NAN,
                n => g.iter().map(|p| p.inlet_u_m_s).sum::<f64>() / n as f64,
            },
            direction: direction_of(g, mid_y_mm),
        })
        .collect()
}

fn bins_of(b: &Behaviour) -> &[PhaseBin] {
    b.thrust.as_ref().map_or(&[], |t| &t.by_phase)
}

/// The `behaviour.md` section: the first directory's mean inlet per bin, then per directory
/// the mean angle and the lower-wall share of each bin.
pub fn markdown(list: &[Behaviour]) -> String {
    let heads: Vec<String> = (0..PHASE_BINS)
        .map(|i| {
            format!(
                "{:.1}-{:.1}",
                i as f64 / PHASE_BINS as f64,
                (i + 1) as f64 / PHASE_BINS as f64
            )
        })
        .collect();
    let mut md = format!(
        "\n## Thrust by phase (member-steps with thrust, from trajectories.csv)\n\nThe phase is \
         the fraction of the inlet cycle. A cell gives the mean angle from upstream (deg) and, \
         in brackets, the share towards the lower wall; `-`: no member-steps in the bin. The \
         first row is the first directory's mean inlet centreline velocity (mm/s) over the \
         bin's member-steps. All columns per directory and bin are in `thrust_phase.csv`.\n\n\
         | directory | {} |\n|---|{}\n",
        heads.join(" | "),
        "---|".repeat(PHASE_BINS)
    );
    let Some(first) = list.first() else {
        return md;
    };
    let inlet: Vec<String> = bins_of(first)
        .iter()
        .map(|p| num(1e3 * p.inlet_u_m_s, 1))
        .collect();
    md += &format!("| inlet (mm/s) | {} |\n", inlet.join(" | "));
    for b in list {
        let cells: Vec<String> = match bins_of(b) {
            [] => vec!["-".into(); PHASE_BINS],
            bins => bins
                .iter()
                .map(|p| match p.direction.member_steps {
                    0 => "-".into(),
                    _ => format!(
                        "{} ({})",
                        num(p.direction.mean_deg, 1),
                        num(p.direction.lower_wall, 2)
                    ),
                })
                .collect(),
        };
        md += &format!("| {} | {} |\n", b.run.info.dir.display(), cells.join(" | "));
    }
    md
}

/// `thrust_phase.csv`: a row per directory and phase bin.
pub fn csv(list: &[Behaviour]) -> String {
    let mut out = String::from(
        "dir,policy,phase_from,phase_to,member_steps,inlet_u_mm_s,deg,sd_deg,nearer_wall,lower_wall\n",
    );
    for b in list {
        for p in bins_of(b) {
            let d = &p.direction;
            out += &format!(
                "{},{},{:.2},{:.2},{},{:.2},{:.2},{:.2},{:.4},{:.4}\n",
                b.run.info.dir.display(),
                b.run.label(),
                p.from,
                p.to,
                d.member_steps,
                1e3 * p.inlet_u_m_s,
                d.mean_deg,
                d.sd_deg,
                d.nearer_wall,
                d.lower_wall
            );
        }
    }
    out
}

/// Draws `thrust_phase.png` into `out` when some directory has thrust; returns its file name.
pub fn figure(
    list: &[Behaviour],
    out: &Path,
    palette: &[plotters::style::RGBColor],
) -> Result<Option<String>> {
    let centre = |p: &PhaseBin| 0.5 * (p.from + p.to);
    let curves: Vec<Curve> = list
        .iter()
        .enumerate()
        .filter(|(_, b)| !bins_of(b).is_empty())
        .map(|(i, b)| {
            let pts: Vec<(f64, f64)> = bins_of(b)
                .iter()
                .filter(|p| p.direction.member_steps > 0)
                .map(|p| (centre(p), p.direction.mean_deg))
                .collect();
            Curve::line(b.run.label(), palette[i % palette.len()], &pts)
        })
        .collect();
    if curves.is_empty() {
        return Ok(None);
    }
    let inlet: Vec<(f64, f64)> = list.first().map_or(Vec::new(), |b| {
        bins_of(b)
            .iter()
            .filter(|p| p.inlet_u_m_s.is_finite())
            .map(|p| (centre(p), 1e3 * p.inlet_u_m_s))
            .collect()
    });
    let panel = Panel {
        title: "thrust angle against the phase (bin means)".into(),
        x_desc: "phase (fraction of the inlet cycle)".into(),
        y_desc: "angle from upstream (deg; 90 = across the flow)".into(),
        curves,
        references: Vec::new(),
        secondary: Some(Secondary {
            label: format!(
                "mean inlet centreline velocity, {} (right axis)",
                list[0].run.label()
            ),
            y_desc: "inlet U (mm/s)".into(),
            points: inlet,
        }),
        legend: true,
    };
    let name = "thrust_phase.png";
    plot::save(&out.join(name), &[panel])?;
    Ok(Some(name.to_string()))
}

/// Writes `thrust_phase.csv` into `out`.
pub fn write_csv(list: &[Behaviour], out: &Path) -> Result<()> {
    let path = out.join("thrust_phase.csv");
    std::fs::write(&path, csv(list)).map_err(ReportError::write(&path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn push(phase: f64, deg: f64, down: bool) -> Push {
        let (c, s) = (deg.to_radians().cos(), deg.to_radians().sin());
        Push {
            inlet_u_m_s: if phase < 0.25 { 0.4 } else { 0.01 },
            y_mm: 0.5,
            phase,
            a: [-c, if down { -s } else { s }],
        }
    }

    #[test]
    fn the_fraction_of_the_cycle_wraps() {
        assert!((cycle_fraction(0.8 + 0.3, 1.0) - 0.1).abs() < 1e-12);
        assert!((cycle_fraction(0.2 + 0.75, 0.5) - 0.9).abs() < 1e-12);
        assert_eq!(cycle_fraction(2.0, 1.0), 0.0);
        assert!((cycle_fraction(-0.25, 1.0) - 0.75).abs() < 1e-12);
        // Just below a cycle's end, where `cycle_of` already counts the next cycle.
        assert_eq!(cycle_of(3.0 - 1e-12, 1.0), 3);
        assert_eq!(cycle_fraction(3.0 - 1e-12, 1.0), 0.0);
    }

    #[test]
    fn bins_by_hand() {
        // Four bins of a quarter cycle. Bin 0: two pushes at 60 and 80 deg towards y = 0;
        // bin 2: one at 40 deg upwards; bins 1 and 3 empty.
        let pushes = [
            push(0.05, 60.0, true),
            push(0.2, 80.0, true),
            push(0.6, 40.0, false),
        ];
        let refs: Vec<&Push> = pushes.iter().collect();
        let b = by_phase(&refs, 1.0, 4);
        assert_eq!(b.len(), 4);
        assert_eq!((b[0].from, b[0].to, b[3].to), (0.0, 0.25, 1.0));
        assert_eq!(b[0].direction.member_steps, 2);
        assert!((b[0].direction.mean_deg - 70.0).abs() < 1e-9);
        assert!((b[0].direction.sd_deg - 10.0).abs() < 1e-9);
        assert_eq!(b[0].direction.lower_wall, 1.0);
        // Member below mid-height pushing down: towards its nearer wall.
        assert_eq!(b[0].direction.nearer_wall, 1.0);
        assert!((b[0].inlet_u_m_s - 0.4).abs() < 1e-12);
        assert_eq!(b[2].direction.member_steps, 1);
        assert!((b[2].direction.mean_deg - 40.0).abs() < 1e-9);
        assert_eq!(
            (b[2].direction.lower_wall, b[2].direction.nearer_wall),
            (0.0, 0.0)
        );
        for empty in [&b[1], &b[3]] {
            assert_eq!(empty.direction.member_steps, 0);
            assert!(empty.direction.mean_deg.is_nan() && empty.inlet_u_m_s.is_nan());
        }
        // A phase that rounds up to 1 stays in the last bin.
        let last = push(1.0, 30.0, true);
        assert_eq!(by_phase(&[&last], 1.0, 4)[3].direction.member_steps, 1);
    }
}

//! The direction of the thrust a controller applies, in forward flow and in the rest (issue 19,
//! item 5: does a policy act as a constant wall-angle controller, or switch with the flow as
//! `scripted` does?), from `trajectories.csv`'s actions (a_x, a_y) and member heights y.
//! - The angle from upstream is theta = atan2(|a_y|, -a_x) in degrees: 0 straight upstream,
//!   90 across the flow, 180 downstream (the norm clip at 1 does not change it).
//! - A member-step points *towards the nearer wall* when a_y (y - H/2) > 0, and *towards the
//!   lower wall* when a_y < 0 (a one-sided policy pushes every member the same way).
//! - A member-step is forward flow when its step's inlet velocity (`swarm.csv`) exceeds the
//!   directory's threshold ([`super::behaviour`]). Member-steps without thrust (a = 0) are
//!   left out.
//! - The same by phase of the inlet cycle: [`super::thrust_phase`].

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use super::data::{Csv, SwarmStep};
use super::error::{ReportError, Result};
use super::thrust_phase::{self, PHASE_BINS, PhaseBin};

/// The thrust direction over one set of member-steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Direction {
    /// Member-steps with thrust counted.
    pub member_steps: usize,
    /// Mean and standard deviation of the angle from upstream (deg).
    pub mean_deg: f64,
    /// Standard deviation of that angle (deg).
    pub sd_deg: f64,
    /// Share pointing towards the member's nearer wall.
    pub nearer_wall: f64,
    /// Share pointing towards the lower wall (y = 0).
    pub lower_wall: f64,
}

/// The thrust direction in forward flow and in the rest.
#[derive(Debug, Clone, PartialEq)]
pub struct Thrust {
    /// Member-steps whose inlet velocity exceeds the threshold.
    pub forward: Direction,
    /// The other member-steps.
    pub rest: Direction,
    /// All of them by phase of the cycle, in [`PHASE_BINS`] bins.
    pub by_phase: Vec<PhaseBin>,
}

/// One member's action at one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Push {
    /// The step's inlet velocity (m/s).
    pub inlet_u_m_s: f64,
    /// The member's height (mm).
    pub y_mm: f64,
    /// The step's fraction of the inlet cycle, in [0, 1).
    pub phase: f64,
    /// The action (a_x, a_y).
    pub a: [f64; 2],
}

/// The angle from upstream (deg) of the action `a`: 0 upstream, 90 across, 180 downstream.
pub fn angle_deg(a: [f64; 2]) -> f64 {
    a[1].abs().atan2(-a[0]).to_degrees()
}

/// The direction of `pushes` in a channel of mid-height `mid_y_mm`; none (0 member-steps,
/// NaNs) when there are none.
pub fn direction_of(pushes: &[&Push], mid_y_mm: f64) -> Direction {
    let n = pushes.len();
    if n == 0 {
        return Direction {
            member_steps: 0,
            mean_deg: f64::NAN,
            sd_deg: f64::NAN,
            nearer_wall: f64::NAN,
            lower_wall: f64::NAN,
        };
    }
    let share =
        |f: &dyn Fn(&Push) -> bool| pushes.iter().filter(|p| f(p)).count() as f64 / n as f64;
    let angles: Vec<f64> = pushes.iter().map(|p| angle_deg(p.a)).collect();
    let mean = angles.iter().sum::<f64>() / n as f64;
    let var = angles.iter().map(|t| (t - mean).powi(2)).sum::<f64>() / n as f64;
    Direction {
        member_steps: n,
        mean_deg: mean,
        sd_deg: var.sqrt(),
        nearer_wall: share(&|p| p.a[1] * (p.y_mm - mid_y_mm) > 0.0),
        lower_wall: share(&|p| p.a[1] < 0.0),
    }
}

/// The thrust direction of `pushes` in forward flow (inlet above `threshold`, m/s) and in the
/// rest, in a channel of mid-height `mid_y_mm`; `None` when no member-step has thrust.
pub fn measure(pushes: &[Push], threshold: f64, mid_y_mm: f64) -> Option<Thrust> {
    let with_thrust: Vec<&Push> = pushes.iter().filter(|p| p.a != [0.0, 0.0]).collect();
    if with_thrust.is_empty() {
        return None;
    }
    let by_phase = thrust_phase::by_phase(&with_thrust, mid_y_mm, PHASE_BINS);
    let (forward, rest): (Vec<&Push>, Vec<&Push>) = with_thrust
        .into_iter()
        .partition(|p| p.inlet_u_m_s > threshold);
    Some(Thrust {
        forward: direction_of(&forward, mid_y_mm),
        rest: direction_of(&rest, mid_y_mm),
        by_phase,
    })
}

/// The pushes of `dir/trajectories.csv` in the episodes of `keep` (episode -> start phase, s),
/// each with its step's inlet velocity and phase in a cycle of `period_s` from `swarm`; none
/// when the file is absent or has no action columns.
pub fn read_pushes(
    dir: &Path,
    swarm: &[SwarmStep],
    keep: &BTreeMap<(usize, u64), f64>,
    period_s: f64,
) -> Result<Vec<Push>> {
    let path = dir.join("trajectories.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let c = Csv::read(&path)?;
    let (Ok(ax), Ok(ay), Ok(y)) = (
        c.column::<f64>("ax"),
        c.column::<f64>("ay"),
        c.column::<f64>("y_mm"),
    ) else {
        return Ok(Vec::new());
    };
    let (env, episode, step) = (
        c.column::<usize>("env")?,
        c.column::<u64>("episode")?,
        c.column::<u64>("step")?,
    );
    let inlet: HashMap<(usize, u64, u64), (f64, f64)> = swarm
        .iter()
        .map(|s| ((s.env, s.episode, s.step), (s.inlet_u_m_s, s.t_s)))
        .collect();
    let mut out = Vec::new();
    for r in 0..c.rows.len() {
        let Some(&phase0) = keep.get(&(env[r], episode[r])) else {
            continue;
        };
        let Some(&(u, t_s)) = inlet.get(&(env[r], episode[r], step[r])) else {
            return Err(ReportError::Invalid(format!(
                "{}: step {} of episode {} of environment {} has no swarm.csv row",
                path.display(),
                step[r],
                episode[r],
                env[r]
            )));
        };
        out.push(Push {
            inlet_u_m_s: u,
            y_mm: y[r],
            phase: thrust_phase::cycle_fraction(phase0 + t_s, period_s),
            a: [ax[r], ay[r]],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_from_upstream() {
        assert_eq!(angle_deg([-1.0, 0.0]), 0.0);
        assert!((angle_deg([-0.5, -(0.75f64).sqrt()]) - 60.0).abs() < 1e-9);
        assert!((angle_deg([-0.5, (0.75f64).sqrt()]) - 60.0).abs() < 1e-9);
        assert!((angle_deg([0.0, 1.0]) - 90.0).abs() < 1e-12);
        assert!((angle_deg([1.0, 0.0]) - 180.0).abs() < 1e-12);
    }

    #[test]
    fn forward_and_rest_by_hand() {
        let (c40, s40) = (40f64.to_radians().cos(), 40f64.to_radians().sin());
        let (c60, s60) = (0.5, (0.75f64).sqrt());
        let pushes = [
            // Forward flow: both members 60 deg towards y = 0; member 0 sits below mid-height
            // (1 mm), so only its push points to its nearer wall.
            Push {
                inlet_u_m_s: 0.4,
                y_mm: 0.5,
                phase: 0.1,
                a: [-c60, -s60],
            },
            Push {
                inlet_u_m_s: 0.4,
                y_mm: 1.5,
                phase: 0.1,
                a: [-c60, -s60],
            },
            // The rest: 40 and 20 deg, each towards its nearer wall; one member-step without
            // thrust, left out.
            Push {
                inlet_u_m_s: 0.01,
                y_mm: 0.5,
                phase: 0.5,
                a: [-c40, -s40],
            },
            Push {
                inlet_u_m_s: 0.01,
                y_mm: 1.5,
                phase: 0.5,
                a: [-(20f64.to_radians().cos()), 20f64.to_radians().sin()],
            },
            Push {
                inlet_u_m_s: 0.01,
                y_mm: 1.5,
                phase: 0.5,
                a: [0.0, 0.0],
            },
        ];
        let t = measure(&pushes, 0.2, 1.0).unwrap();
        assert_eq!(t.forward.member_steps, 2);
        assert!((t.forward.mean_deg - 60.0).abs() < 1e-9 && t.forward.sd_deg < 1e-6);
        assert_eq!((t.forward.nearer_wall, t.forward.lower_wall), (0.5, 1.0));
        assert_eq!(t.rest.member_steps, 2);
        assert!((t.rest.mean_deg - 30.0).abs() < 1e-9 && (t.rest.sd_deg - 10.0).abs() < 1e-9);
        assert_eq!((t.rest.nearer_wall, t.rest.lower_wall), (1.0, 0.5));
        assert_eq!(measure(&pushes[4..], 0.2, 1.0), None);
        let only_rest = measure(&pushes[2..4], 0.2, 1.0).unwrap();
        assert_eq!(only_rest.forward.member_steps, 0);
        assert!(only_rest.forward.mean_deg.is_nan());
    }
}

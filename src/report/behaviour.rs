//! The paper's three emergent behaviours, measured in rollout or eval directories (issue 19,
//! item 5). Each is a claim with a test that can fail:
//! - **Ratchet** (x_COM moves downstream in forward flow and recovers upstream in low and
//!   reverse flow, cycle by cycle). A step interval [k-1, k] is *forward* when the mean of its
//!   two inlet velocities exceeds half the largest inlet velocity in the directory. Per complete
//!   cycle (the episode covers its phases 0..T), D_fwd and D_rest sum the x_COM shifts
//!   x_k - x_(k-1) (mm, + = downstream) of its forward and other intervals; a *ratchet cycle* has
//!   D_fwd > 0 and D_rest < 0. The interval's cycle is floor((phi_0 + t_(k-1)) / T), phi_0 the
//!   episode's start phase (`starts.csv`).
//! - **Throttling** (the swarm occupies more of the height and lowers the peak local velocity
//!   in forward flow): the means over forward steps (inlet above the same threshold) of
//!   sigma_y, sigma_x and, from `gap.csv`, the peak fluid u_x within the swarm's extent, its
//!   ratio to the inlet centreline velocity and the blocked fraction.
//! - **Final approach** (spreading grows near the target): per successful episode of at least
//!   2 `APPROACH_S`, the mean sigma_x and R_g over its last `APPROACH_S` (in control steps,
//!   rounded) divided by their mean over the steps before.
//!
//! - **Thrust direction** ([`super::thrust`], with `trajectories.csv`): the angle of the applied
//!   thrust from upstream and the shares towards the nearer and the lower wall, in forward
//!   flow and the rest: a constant controller keeps them, `scripted` switches them; and by
//!   phase of the cycle ([`super::thrust_phase`]).
//!
//! Only finished episodes count (`RolloutRun` drops the rest), and not the diverged ones, whose
//! last rows hold no finite positions.

use std::collections::BTreeMap;
use std::path::Path;

use super::data::{Csv, RolloutRun, SwarmStep};
use super::error::{ReportError, Result, Within};
use super::thrust::{self, Thrust};

/// The final approach (s): 40 control steps of 5 ms.
pub const APPROACH_S: f64 = 0.2;

/// `seconds` in control steps of `dt_s` (at least one).
pub fn steps_in(seconds: f64, dt_s: f64) -> usize {
    ((seconds / dt_s).round() as usize).max(1)
}

/// The cycle of the waveform at absolute time `t_s` (the start phase plus the time since the
/// episode's start): floor(t / T), robust to rounding at the boundaries.
pub fn cycle_of(t_s: f64, period_s: f64) -> i64 {
    ((t_s + 1e-9 * period_s) / period_s).floor() as i64
}

/// The x_COM shifts of one complete cycle of one episode.
#[derive(Debug, Clone, PartialEq)]
pub struct CycleShift {
    /// Environment index.
    pub env: usize,
    /// Episode index.
    pub episode: u64,
    /// Cycle index since the waveform's t = 0 (the episode's start phase counts).
    pub cycle: i64,
    /// Sum of the shifts over the forward intervals (mm, + = downstream).
    pub forward_mm: f64,
    /// Sum of the shifts over the other intervals (mm).
    pub rest_mm: f64,
}

impl CycleShift {
    /// Downstream in forward flow and upstream in the rest.
    pub fn is_ratchet(&self) -> bool {
        self.forward_mm > 0.0 && self.rest_mm < 0.0
    }
}

/// One row of `gap.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct GapStep {
    /// Environment index.
    pub env: usize,
    /// Episode index.
    pub episode: u64,
    /// Control step.
    pub step: u64,
    /// Inlet centreline velocity (m/s).
    pub inlet_u_m_s: f64,
    /// Peak fluid u_x within the swarm's extent (m/s; NaN when none).
    pub peak_u_m_s: f64,
    /// Mean blocked fraction of the extent's columns.
    pub mean_blocked: f64,
    /// Largest blocked fraction.
    pub max_blocked: f64,
}

/// The throttling numbers over forward steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Throttling {
    /// Forward steps counted.
    pub steps: usize,
    /// Forward `gap.csv` rows counted (an episode's last step has none).
    pub gap_steps: usize,
    /// Mean sigma_y (mm).
    pub sigma_y_mm: f64,
    /// Mean sigma_x (mm).
    pub sigma_x_mm: f64,
    /// From `gap.csv`: mean peak u_x (mm/s) and mean peak / inlet centreline (over the rows
    /// with fluid cells in the swarm's extent), mean blocked fraction and largest blocked
    /// fraction (over every row).
    pub gap: Option<[f64; 4]>,
}

/// The final-approach ratios over successful episodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Approach {
    /// Successful episodes long enough to count.
    pub episodes: usize,
    /// Mean over them of (sigma_x over the last steps) / (sigma_x before).
    pub sigma_x_ratio: f64,
    /// The same for R_g.
    pub r_g_ratio: f64,
    /// Episodes whose sigma_x ratio exceeds 1.
    pub spreading: usize,
}

/// Everything measured in one directory.
pub struct Behaviour {
    /// The directory's rollout (episodes and swarm rows).
    pub run: RolloutRun,
    /// Each episode's start phase (s), by (env, episode).
    pub start_phase: BTreeMap<(usize, u64), f64>,
    /// The waveform's period (s).
    pub period_s: f64,
    /// The forward-flow threshold (m/s): half the largest inlet velocity.
    pub threshold_m_s: f64,
    /// `gap.csv`'s rows of finished episodes (empty without the file).
    pub gap: Vec<GapStep>,
    /// Every complete cycle's shifts.
    pub cycles: Vec<CycleShift>,
    /// The throttling numbers.
    pub throttling: Throttling,
    /// The thrust direction in forward flow and the rest (None without actions in
    /// `trajectories.csv`, or without thrust).
    pub thrust: Option<Thrust>,
    /// The final-approach numbers (None without a long enough success).
    pub approach: Option<Approach>,
    /// The final approach in control steps (`APPROACH_S` at this directory's control step).
    pub approach_steps: usize,
}

/// Each finished episode's swarm rows in step order, by (env, episode).
pub fn by_episode(swarm: &[SwarmStep]) -> BTreeMap<(usize, u64), Vec<&SwarmStep>> {
    let mut out: BTreeMap<(usize, u64), Vec<&SwarmStep>> = BTreeMap::new();
    for s in swarm {
        out.entry((s.env, s.episode)).or_default().push(s);
    }
    for rows in out.values_mut() {
        rows.sort_by_key(|s| s.step);
    }
    out
}

/// The complete cycles of one episode's rows (in step order) that started at phase `phase0`.
pub fn episode_cycles(
    rows: &[&SwarmStep],
    phase0: f64,
    period_s: f64,
    threshold: f64,
) -> Vec<CycleShift> {
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return Vec::new();
    };
    let eps = 1e-9 * period_s;
    let (t0, t1) = (phase0 + first.t_s, phase0 + last.t_s);
    let mut sums: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
    for w in rows.windows(2) {
        let (a, b) = (w[0], w[1]);
        let cycle = cycle_of(phase0 + a.t_s, period_s);
        let shift = b.x_com_mm - a.x_com_mm;
        let e = sums.entry(cycle).or_default();
        if 0.5 * (a.inlet_u_m_s + b.inlet_u_m_s) > threshold {
            e.0 += shift;
        } else {
            e.1 += shift;
        }
    }
    sums.into_iter()
        .filter(|&(c, _)| c as f64 * period_s >= t0 - eps && (c + 1) as f64 * period_s <= t1 + eps)
        .map(|(cycle, (forward_mm, rest_mm))| CycleShift {
            env: first.env,
            episode: first.episode,
            cycle,
            forward_mm,
            rest_mm,
        })
        .collect()
}

fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { s / n as f64 }
}

/// The throttling numbers of `swarm` and `gap` rows above `threshold` (m/s).
pub fn throttling(swarm: &[SwarmStep], gap: &[GapStep], threshold: f64) -> Throttling {
    let fwd: Vec<&SwarmStep> = swarm.iter().filter(|s| s.inlet_u_m_s > threshold).collect();
    let g: Vec<&GapStep> = gap.iter().filter(|s| s.inlet_u_m_s > threshold).collect();
    let peaks = || g.iter().filter(|s| s.peak_u_m_s.is_finite());
    Throttling {
        steps: fwd.len(),
        gap_steps: g.len(),
        sigma_y_mm: mean(fwd.iter().map(|s| s.sigma_y_mm)),
        sigma_x_mm: mean(fwd.iter().map(|s| s.sigma_x_mm)),
        gap: (!g.is_empty()).then(|| {
            [
                mean(peaks().map(|s| 1e3 * s.peak_u_m_s)),
                mean(peaks().map(|s| s.peak_u_m_s / s.inlet_u_m_s)),
                mean(g.iter().map(|s| s.mean_blocked)),
                g.iter().map(|s| s.max_blocked).fold(0.0, f64::max),
            ]
        }),
    }
}

/// The final-approach ratios of the episodes `successful` among `episodes`' rows: the last
/// `k` steps against the steps before, for episodes of at least 2k steps (2k + 1 rows: step 0
/// is the start).
pub fn approach(
    episodes: &BTreeMap<(usize, u64), Vec<&SwarmStep>>,
    successful: &[(usize, u64)],
    k: usize,
) -> Option<Approach> {
    let mut ratios = Vec::new();
    for key in successful {
        let Some(rows) = episodes.get(key) else {
            continue;
        };
        if rows.len() < 2 * k + 1 {
            continue;
        }
        let (before, last) = rows.split_at(rows.len() - k);
        let ratio = |f: fn(&SwarmStep) -> f64| {
            mean(last.iter().map(|s| f(s))) / mean(before.iter().map(|s| f(s)))
        };
        ratios.push((ratio(|s| s.sigma_x_mm), ratio(|s| s.r_g_mm)));
    }
    (!ratios.is_empty()).then(|| Approach {
        episodes: ratios.len(),
        sigma_x_ratio: mean(ratios.iter().map(|r| r.0)),
        r_g_ratio: mean(ratios.iter().map(|r| r.1)),
        spreading: ratios.iter().filter(|r| r.0 > 1.0).count(),
    })
}

/// The longest finished episode with outcome `outcome` (any with None; ties: the lowest env,
/// then episode): the one drawn.
pub fn shown_episode(run: &RolloutRun, outcome: Option<&str>) -> Option<(usize, u64)> {
    run.episodes
        .iter()
        .filter(|e| outcome.is_none_or(|o| e.outcome == o) && e.outcome != "diverged")
        .max_by(|a, b| {
            a.steps
                .cmp(&b.steps)
                .then_with(|| (b.env, b.episode).cmp(&(a.env, a.episode)))
        })
        .map(|e| (e.env, e.episode))
}

/// The positive number `section.key` of `dir/config.toml`.
fn read_config_number(dir: &Path, section: &str, key: &str) -> Result<f64> {
    let path = dir.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(ReportError::read(&path))?;
    let value: toml::Value = toml::from_str(&text)
        .map_err(|e| ReportError::Invalid(format!("parsing {}: {e}", path.display())))?;
    value
        .get(section)
        .and_then(|s| s.get(key))
        .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        .filter(|p| *p > 0.0)
        .ok_or_else(|| {
            ReportError::Invalid(format!(
                "{} has no positive {section}.{key}: a rollout writes the whole configuration",
                path.display()
            ))
        })
}

fn read_starts(dir: &Path) -> Result<BTreeMap<(usize, u64), f64>> {
    let c = Csv::read(&dir.join("starts.csv"))?;
    let (env, episode, phase) = (
        c.column::<usize>("env")?,
        c.column::<u64>("episode")?,
        c.column::<f64>("start_phase_s")?,
    );
    Ok((0..c.rows.len())
        .map(|r| ((env[r], episode[r]), phase[r]))
        .collect())
}

/// `gap.csv`'s rows of the episodes in `keep` (none when the file is absent).
fn read_gap(dir: &Path, keep: &BTreeMap<(usize, u64), f64>) -> Result<Vec<GapStep>> {
    let path = dir.join("gap.csv");
    if !path.exists() {
        return Ok(Vec::new());
    }
    let c = Csv::read(&path)?;
    let (env, episode, step) = (
        c.column::<usize>("env")?,
        c.column::<u64>("episode")?,
        c.column::<u64>("step")?,
    );
    let f = |n: &str| c.column::<f64>(n);
    let (inlet, peak, mean_b, max_b) = (
        f("inlet_u_m_s")?,
        f("peak_u_m_s")?,
        f("mean_blocked")?,
        f("max_blocked")?,
    );
    Ok((0..c.rows.len())
        .filter(|&r| keep.contains_key(&(env[r], episode[r])))
        .map(|r| GapStep {
            env: env[r],
            episode: episode[r],
            step: step[r],
            inlet_u_m_s: inlet[r],
            peak_u_m_s: peak[r],
            mean_blocked: mean_b[r],
            max_blocked: max_b[r],
        })
        .collect())
}

/// Reads a rollout or eval directory written with traces (and optionally `--gap`) and
/// measures the three behaviours.
pub fn load(dir: &Path) -> Result<Behaviour> {
    let within = || format!("{} as a rollout/eval directory with traces", dir.display());
    let mut run = RolloutRun::read(dir).within(within)?;
    let diverged: std::collections::HashSet<(usize, u64)> = run
        .episodes
        .iter()
        .filter(|e| e.outcome == "diverged")
        .map(|e| (e.env, e.episode))
        .collect();
    run.swarm
        .retain(|s| !diverged.contains(&(s.env, s.episode)));
    let period_s = read_config_number(dir, "inlet", "period_s")?;
    let starts = read_starts(dir)?;
    let finished: BTreeMap<(usize, u64), f64> = run
        .episodes
        .iter()
        .filter(|e| e.outcome != "diverged")
        .filter_map(|e| Some(((e.env, e.episode), *starts.get(&(e.env, e.episode))?)))
        .collect();
    if finished.len() < run.episodes.len() - diverged.len() {
        return Err(ReportError::Invalid(format!(
            "{}: starts.csv lacks the start of some finished episodes",
            dir.display()
        )));
    }
    let gap = read_gap(dir, &finished)?;
    let threshold_m_s = 0.5 * run.swarm.iter().map(|s| s.inlet_u_m_s).fold(0.0, f64::max);
    let episodes = by_episode(&run.swarm);
    if let Some(key) = finished.keys().find(|k| !episodes.contains_key(k)) {
        return Err(ReportError::Invalid(format!(
            "{}: swarm.csv has no rows of episode {} of environment {}, which episodes.csv \
             lists (was the rollout killed before it flushed?)",
            dir.display(),
            key.1,
            key.0
        )));
    }
    let cycles = episodes
        .iter()
        .flat_map(|(key, rows)| episode_cycles(rows, finished[key], period_s, threshold_m_s))
        .collect();
    let successful: Vec<(usize, u64)> = run
        .episodes
        .iter()
        .filter(|e| e.outcome == "success")
        .map(|e| (e.env, e.episode))
        .collect();
    let throttling = throttling(&run.swarm, &gap, threshold_m_s);
    let mid_y_mm = 0.5e3 * read_config_number(dir, "domain", "height_m")?;
    let pushes = thrust::read_pushes(dir, &run.swarm, &finished, period_s)?;
    let thrust = thrust::measure(&pushes, threshold_m_s, mid_y_mm);
    let k = steps_in(APPROACH_S, run.info.control_dt_s);
    let approach = approach(&episodes, &successful, k);
    Ok(Behaviour {
        start_phase: finished,
        period_s,
        threshold_m_s,
        gap,
        cycles,
        throttling,
        thrust,
        approach,
        approach_steps: k,
        run,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(step: u64, inlet: f64, x: f64, sx: f64, sy: f64) -> SwarmStep {
        SwarmStep {
            env: 0,
            episode: 0,
            step,
            t_s: step as f64 * 0.25,
            inlet_u_m_s: inlet,
            x_com_mm: x,
            sigma_x_mm: sx,
            sigma_y_mm: sy,
            r_g_mm: sx,
        }
    }

    #[test]
    fn cycles_split_shifts_by_flow_and_keep_only_complete_ones() {
        // Period 1 s, steps of 0.25 s, start phase 0.5 s: the rows span phases 0.5 .. 2.75,
        // so only cycle 1 (phases 1.0 .. 2.0) is complete. The inlet is 1 m/s at each cycle's
        // phase 0 (steps 2 and 6), 0 otherwise; the threshold is 0.5.
        let inlet = |k: u64| if (k + 2).is_multiple_of(4) { 1.0 } else { 0.0 };
        let xs = [50.0, 51.0, 53.0, 52.0, 51.5, 51.0, 54.0, 53.0, 52.0, 52.5];
        let rows: Vec<SwarmStep> = xs
            .iter()
            .enumerate()
            .map(|(k, &x)| row(k as u64, inlet(k as u64), x, 1.0, 0.2))
            .collect();
        let refs: Vec<&SwarmStep> = rows.iter().collect();
        let c = episode_cycles(&refs, 0.5, 1.0, 0.5);
        assert_eq!(c.len(), 1);
        assert_eq!(c[0].cycle, 1);
        // Cycle 1 holds intervals 2-3, 3-4, 4-5, 5-6 (phases 1.0, 1.25, 1.5, 1.75). Step 2 has
        // inlet 1 and step 3 has 0: the 2-3 interval's mean is 0.5, not above 0.5, so it is
        // rest; 5-6 has mean 0.5 too (step 6 is forward). All four are rest:
        // (52-53) + (51.5-52) + (51-51.5) + (54-51) = +1.0.
        assert_eq!(c[0].forward_mm, 0.0);
        assert!((c[0].rest_mm - 1.0).abs() < 1e-12);
        assert!(!c[0].is_ratchet());
    }

    #[test]
    fn an_interval_is_forward_when_its_mean_inlet_exceeds_the_threshold() {
        let rows = [
            row(0, 1.0, 50.0, 1.0, 0.2),
            row(1, 1.0, 52.0, 1.0, 0.2),
            row(2, 0.0, 51.0, 1.0, 0.2),
            row(3, 0.0, 49.0, 1.0, 0.2),
            row(4, 1.0, 49.5, 1.0, 0.2),
        ];
        let refs: Vec<&SwarmStep> = rows.iter().collect();
        // Start phase 0, steps 0.25 s: cycle 0 spans steps 0..4 exactly.
        let c = episode_cycles(&refs, 0.0, 1.0, 0.4);
        assert_eq!(c.len(), 1);
        // Means 1.0, 0.5, 0.0, 0.5 > 0.4 for intervals 0-1, 1-2 and 3-4.
        assert!((c[0].forward_mm - (2.0 - 1.0 + 0.5)).abs() < 1e-12);
        assert!((c[0].rest_mm + 2.0).abs() < 1e-12);
        assert!(c[0].is_ratchet());
    }

    #[test]
    fn throttling_averages_forward_steps_and_the_gap_ratio() {
        let swarm = [row(0, 0.4, 50.0, 1.0, 0.2), row(1, 0.1, 50.0, 3.0, 0.6)];
        let gap = [
            GapStep {
                env: 0,
                episode: 0,
                step: 0,
                inlet_u_m_s: 0.4,
                peak_u_m_s: 0.6,
                mean_blocked: 0.25,
                max_blocked: 0.5,
            },
            GapStep {
                env: 0,
                episode: 0,
                step: 1,
                inlet_u_m_s: 0.1,
                peak_u_m_s: 0.9,
                mean_blocked: 0.75,
                max_blocked: 1.0,
            },
            // Forward, every cell of the extent blocked: no peak, but it counts as blocked.
            GapStep {
                env: 0,
                episode: 0,
                step: 2,
                inlet_u_m_s: 0.4,
                peak_u_m_s: f64::NAN,
                mean_blocked: 1.0,
                max_blocked: 1.0,
            },
        ];
        let t = throttling(&swarm, &gap, 0.2);
        assert_eq!((t.steps, t.gap_steps), (1, 2));
        assert_eq!((t.sigma_x_mm, t.sigma_y_mm), (1.0, 0.2));
        let g = t.gap.unwrap();
        assert!((g[0] - 600.0).abs() < 1e-9 && (g[1] - 1.5).abs() < 1e-12);
        assert_eq!((g[2], g[3]), (0.625, 1.0));
    }

    #[test]
    fn approach_compares_the_last_steps_with_the_ones_before() {
        let k = 40;
        // 2k steps (2k + 1 rows): sigma_x 1 mm before the last k steps, 3 mm in them: ratio 3.
        let rows: Vec<SwarmStep> = (0..=2 * k)
            .map(|s| {
                let sx = if s > k { 3.0 } else { 1.0 };
                row(s as u64, 0.0, 50.0, sx, 0.2)
            })
            .collect();
        let map = by_episode(&rows);
        let a = approach(&map, &[(0, 0)], k).unwrap();
        assert_eq!((a.episodes, a.spreading), (1, 1));
        assert!((a.sigma_x_ratio - 3.0).abs() < 1e-12 && (a.r_g_ratio - 3.0).abs() < 1e-12);
        // One step shorter (2k rows) is too short to count.
        let short = by_episode(&rows[..2 * k]);
        assert!(approach(&short, &[(0, 0)], k).is_none());
        // The window in steps follows the control step.
        assert_eq!(
            (steps_in(APPROACH_S, 0.005), steps_in(APPROACH_S, 0.02)),
            (40, 10)
        );
    }
}

//! The controllability map (`fluxswarm-gpu map DIR`): every rollout directory below DIR (one
//! controller at one flow scale s and thrust bound F_max, `rollout --no-traces`) becomes one
//! cell of `controllability_map.csv`.
//!
//! Per cell, over its n episodes:
//! - the success rate k/n with its 95 % Wilson score interval
//!   (p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n), z = 1.96, overall and
//!   stratified by start phase: a systole start has its phase in [0, systole_end_s);
//! - the mean time to success (s), the median episode length in waveform cycles ("cycles
//!   survived") and the net upstream speed over all its simulated time,
//!   sum (start x_COM - final x_COM) / sum cycles, in mm per cycle (pooled, so that short
//!   failures do not dominate as a mean of per-episode ratios would).
//!
//! Wall-drag probes (`DIR/wall_drag/*`, a rollout of one member pinned at the lower wall with
//! zero thrust for one cycle) give the dimensionless axes: F_max / max_t F_x(t) and the fraction
//! of the cycle in which F_max > F_x(t), with F_x the member's hydrodynamic plus drag force
//! along the flow.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use super::error::{ReportError, Result, Within};

use super::data::Csv;
use super::stats::{mean_std, wilson95};

/// One episode of a map run: `episodes.csv` joined with `starts.csv` on (env, episode).
#[derive(Debug, Clone, PartialEq)]
pub struct MapEpisode {
    /// Control steps in the episode.
    pub steps: u64,
    /// `success`, `failure`, `timeout` or `diverged`.
    pub outcome: String,
    /// Waveform phase at the episode start (s into the period).
    pub start_phase_s: f64,
    /// Swarm mean x at the episode start (mm).
    pub start_x_com_mm: f64,
    /// Swarm mean x at the episode end (mm).
    pub final_x_com_mm: f64,
}

/// One rollout directory: a controller at one scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct MapRun {
    /// The rollout directory.
    pub dir: PathBuf,
    /// The controller's name from the config header.
    pub policy: String,
    /// Flow scale `inlet.scale` (1 when absent).
    pub scale: f64,
    /// Peak |U| of the scaled waveform (NaN when the points come from a CSV file).
    pub peak_inlet_m_s: f64,
    /// Thrust bound F_max, `swarm.max_thrust_n` (N).
    pub max_thrust_n: f64,
    /// Control step (s).
    pub control_dt_s: f64,
    /// Waveform period (s).
    pub period_s: f64,
    /// The run's finished episodes.
    pub episodes: Vec<MapEpisode>,
}

/// The success count and interval of one stratum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    /// Episodes in the stratum.
    pub n: usize,
    /// Successful episodes among them.
    pub k: usize,
    /// Lower end of the 95 % Wilson interval of k/n.
    pub lo: f64,
    /// Upper end of the 95 % Wilson interval of k/n.
    pub hi: f64,
}

impl Rate {
    /// The rate of `k` successes in `n` episodes with its Wilson interval.
    pub fn of(k: usize, n: usize) -> Self {
        let (lo, hi) = wilson95(k, n);
        Self { n, k, lo, hi }
    }

    /// k/n; NaN for n = 0.
    pub fn rate(&self) -> f64 {
        if self.n == 0 {
            f64::NAN
        } else {
            self.k as f64 / self.n as f64
        }
    }
}

/// One row of `map.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct Cell {
    /// Flow scale `inlet.scale`.
    pub scale: f64,
    /// Peak |U| of the scaled waveform (m/s); NaN when the points come from a CSV file.
    pub peak_inlet_m_s: f64,
    /// Thrust bound F_max (N).
    pub max_thrust_n: f64,
    /// The controller's name.
    pub policy: String,
    /// Success rate over all episodes.
    pub all: Rate,
    /// Success rate of episodes started in systole (phase in [0, systole_end_s)).
    pub systole: Rate,
    /// Success rate of the other episodes.
    pub diastole: Rate,
    /// Episodes that ended in failure.
    pub failures: usize,
    /// Episodes that ended in timeout.
    pub timeouts: usize,
    /// Mean episode length of successful episodes (s); NaN without any.
    pub mean_success_time_s: f64,
    /// Median episode length (waveform cycles).
    pub median_cycles: f64,
    /// Net upstream swarm displacement per simulated cycle, pooled over episodes (mm per cycle).
    pub upstream_mm_per_cycle: f64,
}

/// The text after "policy " in a run header, up to ", seed" or a parenthesis.
fn header_policy(header: &str) -> Option<String> {
    let (_, rest) = header.split_once(" policy ")?;
    let end = rest.find(", seed ").unwrap_or(rest.len());
    let policy = rest[..end].split(" (").next()?.trim();
    Some(policy.to_string())
}

fn number(value: &toml::Value, section: &str, key: &str, path: &Path) -> Result<f64> {
    value
        .get(section)
        .and_then(|s| s.get(key))
        .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
        .ok_or_else(|| {
            ReportError::Invalid(format!("{} has no number {section}.{key}", path.display()))
        })
}

/// A run directory's config.toml: its path, its text (the header is the first line) and its
/// parsed values.
fn read_config(dir: &Path) -> Result<(PathBuf, String, toml::Value)> {
    let path = dir.join("config.toml");
    let text = std::fs::read_to_string(&path).map_err(ReportError::read(&path))?;
    let value = toml::from_str(&text)
        .map_err(|e| ReportError::Invalid(format!("parsing {}: {e}", path.display())))?;
    Ok((path, text, value))
}

/// `inlet.scale`, 1 when absent (configurations saved before the key existed).
fn inlet_scale(value: &toml::Value) -> f64 {
    value
        .get("inlet")
        .and_then(|s| s.get("scale"))
        .and_then(toml::Value::as_float)
        .unwrap_or(1.0)
}

impl MapRun {
    /// Reads a rollout directory written with `starts.csv` (this version's `rollout`).
    pub fn read(dir: &Path) -> Result<Self> {
        let (path, text, value) = read_config(dir)?;
        let header = text.lines().next().unwrap_or("");
        // Commas would split the policy's CSV field (older scripted:A,B,C,D names).
        let policy = header_policy(header)
            .map(|p| p.replace(',', ":"))
            .ok_or_else(|| {
                ReportError::Invalid(format!(
                    "{}: the first line names no policy: is it a rollout directory?",
                    path.display()
                ))
            })?;
        let scale = inlet_scale(&value);
        let peak = value
            .get("inlet")
            .and_then(|s| s.get("points"))
            .and_then(toml::Value::as_array)
            .map(|pts| {
                pts.iter()
                    .filter_map(|p| p.get(1)?.as_float())
                    .fold(0.0f64, |m, u| m.max(u.abs()))
            })
            .unwrap_or(f64::NAN);
        let episodes = Csv::read(&dir.join("episodes.csv"))?;
        let starts = Csv::read(&dir.join("starts.csv")).within(|| {
            format!(
                "{} has no starts.csv: re-run it with this version's rollout",
                dir.display()
            )
        })?;
        let key = |c: &Csv| -> Result<Vec<(u64, u64)>> {
            let env = c.column::<u64>("env")?;
            Ok(env.into_iter().zip(c.column::<u64>("episode")?).collect())
        };
        let start_of: BTreeMap<(u64, u64), (f64, f64)> = key(&starts)?
            .into_iter()
            .zip(
                starts
                    .column::<f64>("start_phase_s")?
                    .into_iter()
                    .zip(starts.column::<f64>("start_x_com_mm")?),
            )
            .collect();
        let (steps, outcome, x) = (
            episodes.column::<u64>("steps")?,
            episodes.column::<String>("outcome")?,
            episodes.column::<f64>("final_x_com_mm")?,
        );
        let mut list = Vec::with_capacity(steps.len());
        for (r, k) in key(&episodes)?.into_iter().enumerate() {
            let &(phase, x0) = start_of.get(&k).ok_or_else(|| {
                ReportError::Invalid(format!(
                    "{}: episode {} of environment {} has no row in starts.csv",
                    dir.display(),
                    k.1,
                    k.0
                ))
            })?;
            list.push(MapEpisode {
                steps: steps[r],
                outcome: outcome[r].clone(),
                start_phase_s: phase,
                start_x_com_mm: x0,
                final_x_com_mm: x[r],
            });
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            policy,
            scale,
            peak_inlet_m_s: peak * scale,
            max_thrust_n: number(&value, "swarm", "max_thrust_n", &path)?,
            control_dt_s: number(&value, "time", "control_dt_s", &path)?,
            period_s: number(&value, "inlet", "period_s", &path)?,
            episodes: list,
        })
    }

    /// The cell of this run, a systole start being one with its phase in [0, systole_end_s).
    pub fn cell(&self, systole_end_s: f64) -> Cell {
        let es = &self.episodes;
        let success = |e: &&MapEpisode| e.outcome == "success";
        let systole = |e: &&MapEpisode| e.start_phase_s < systole_end_s;
        let rate = |f: &dyn Fn(&&MapEpisode) -> bool| {
            let chosen: Vec<&MapEpisode> = es.iter().filter(|e| f(e)).collect();
            Rate::of(chosen.iter().filter(|e| success(e)).count(), chosen.len())
        };
        let cycles = |e: &MapEpisode| e.steps as f64 * self.control_dt_s / self.period_s;
        let times: Vec<f64> = es
            .iter()
            .filter(success)
            .map(|e| e.steps as f64 * self.control_dt_s)
            .collect();
        let mut lengths: Vec<f64> = es.iter().map(cycles).collect();
        lengths.sort_by(f64::total_cmp);
        let moved: f64 = es.iter().map(|e| e.start_x_com_mm - e.final_x_com_mm).sum();
        let simulated: f64 = es.iter().map(cycles).sum();
        Cell {
            scale: self.scale,
            peak_inlet_m_s: self.peak_inlet_m_s,
            max_thrust_n: self.max_thrust_n,
            policy: self.policy.clone(),
            all: rate(&|_| true),
            systole: rate(&systole),
            diastole: rate(&|e| !systole(e)),
            failures: es.iter().filter(|e| e.outcome == "failure").count(),
            timeouts: es.iter().filter(|e| e.outcome == "timeout").count(),
            mean_success_time_s: mean_std(&times).0,
            median_cycles: median(&lengths),
            upstream_mm_per_cycle: if simulated > 0.0 {
                moved / simulated
            } else {
                f64::NAN
            },
        }
    }
}

/// Median of sorted values (NaN for none).
fn median(sorted: &[f64]) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => sorted[n / 2],
        n => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

/// The streamwise force on a member pinned at the wall over one cycle, from a probe rollout.
#[derive(Debug, Clone, PartialEq)]
pub struct WallDrag {
    /// Flow scale `inlet.scale` of the probe.
    pub scale: f64,
    /// F_x = f_hydro_x + f_drag_x at each control step of the cycle (N).
    pub force_n: Vec<f64>,
}

impl WallDrag {
    /// Reads a probe directory (`trajectories.csv` of member 0, steps 1 and later).
    pub fn read(dir: &Path) -> Result<Self> {
        let scale = inlet_scale(&read_config(dir)?.2);
        let t = Csv::read(&dir.join("trajectories.csv"))?;
        let (step, member) = (t.column::<u64>("step")?, t.column::<u64>("member")?);
        let (h, d) = (
            t.column::<f64>("f_hydro_x_nN")?,
            t.column::<f64>("f_drag_x_nN")?,
        );
        let force_n: Vec<f64> = (0..step.len())
            .filter(|&r| member[r] == 0 && step[r] > 0)
            .map(|r| (h[r] + d[r]) * 1e-9)
            .collect();
        if force_n.is_empty() {
            return Err(ReportError::Invalid(format!(
                "{}: trajectories.csv has no steps of member 0",
                dir.display()
            )));
        }
        Ok(Self { scale, force_n })
    }

    /// Largest streamwise force over the cycle (N).
    pub fn peak_n(&self) -> f64 {
        self.force_n
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Fraction of the cycle's steps in which `thrust_n` exceeds the streamwise force.
    pub fn beaten_fraction(&self, thrust_n: f64) -> f64 {
        let k = self.force_n.iter().filter(|&&f| thrust_n > f).count();
        k as f64 / self.force_n.len() as f64
    }
}

/// Every run directory below `root` (a directory holding episodes.csv and starts.csv), in
/// path order, and the wall-drag probes under `root/wall_drag`.
pub fn load(root: &Path) -> Result<(Vec<MapRun>, Vec<WallDrag>)> {
    let mut runs = Vec::new();
    let mut probes = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let listing = |cause| ReportError::Read {
            path: dir.clone(),
            cause,
            hint: " (listing the directory)".into(),
        };
        for entry in std::fs::read_dir(&dir).map_err(listing)? {
            let path = entry.map_err(listing)?.path();
            if path.is_dir() {
                stack.push(path);
            }
        }
        let is_probe = dir.parent().and_then(Path::file_name) == Some("wall_drag".as_ref());
        if is_probe && dir.join("trajectories.csv").exists() {
            probes.push(WallDrag::read(&dir)?);
        } else if dir.join("starts.csv").exists() && dir.join("episodes.csv").exists() {
            runs.push(MapRun::read(&dir)?);
        }
    }
    if runs.is_empty() {
        return Err(ReportError::Usage(format!(
            "{} holds no rollout directories with episodes.csv and starts.csv: run \
             experiments/controllability_map.sh first",
            root.display()
        )));
    }
    runs.sort_by(|a, b| a.dir.cmp(&b.dir));
    probes.sort_by(|a, b| a.scale.total_cmp(&b.scale));
    Ok((runs, probes))
}

/// The probe of flow scale `scale`, if one was run.
pub fn probe_for(probes: &[WallDrag], scale: f64) -> Option<&WallDrag> {
    probes.iter().find(|p| (p.scale - scale).abs() < 1e-9)
}

/// The wall-angle family (upstream = 0 degrees, wall = 45) a policy name belongs to.
pub fn wall_angle_deg(policy: &str) -> Option<f64> {
    match policy {
        "upstream" => Some(0.0),
        "wall" => Some(45.0),
        p => p.strip_prefix("wall-angle:")?.parse().ok(),
    }
}

/// Constant controllers: everything but `scripted` and trained policies.
pub fn is_constant(policy: &str) -> bool {
    matches!(policy, "zero" | "random")
        || wall_angle_deg(policy).is_some()
        || policy
            .strip_prefix("heading:")
            .is_some_and(|d| d.parse::<f64>().is_ok())
}

/// The phase-aware positive control: `scripted` (the tuned parameters),
/// `scripted:CALM:STORM:START:END` (parameters tuned for another grid, e.g. the refined one) or
/// its one-wall form `scripted-heading:CALM:STORM:START:END`.
pub fn is_scripted(policy: &str) -> bool {
    policy == "scripted"
        || policy.starts_with("scripted:")
        || policy.starts_with("scripted-heading:")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ep(steps: u64, outcome: &str, phase: f64, x0: f64, x1: f64) -> MapEpisode {
        MapEpisode {
            steps,
            outcome: outcome.into(),
            start_phase_s: phase,
            start_x_com_mm: x0,
            final_x_com_mm: x1,
        }
    }

    #[test]
    fn a_cell_counts_strata_times_and_speeds_by_hand() {
        let run = MapRun {
            dir: PathBuf::from("x"),
            policy: "wall".into(),
            scale: 0.9,
            peak_inlet_m_s: 0.36,
            max_thrust_n: 8.5e-7,
            control_dt_s: 0.005,
            period_s: 1.0,
            episodes: vec![
                ep(400, "success", 0.05, 50.0, 20.0), // systole start, 2 cycles, +30 mm
                ep(100, "failure", 0.5, 50.0, 70.0),  // 0.5 cycles, -20 mm
                ep(600, "success", 0.9, 50.0, 20.0),  // 3 cycles, +30 mm
                ep(2000, "timeout", 0.1, 50.0, 40.0), // systole, 10 cycles, +10 mm
            ],
        };
        let c = run.cell(0.15);
        assert_eq!((c.all.k, c.all.n), (2, 4));
        assert_eq!((c.systole.k, c.systole.n), (1, 2));
        assert_eq!((c.diastole.k, c.diastole.n), (1, 2));
        assert_eq!((c.failures, c.timeouts), (1, 1));
        assert!((c.mean_success_time_s - 2.5).abs() < 1e-12);
        assert!((c.median_cycles - 2.5).abs() < 1e-12);
        // (30 - 20 + 30 + 10) mm over (2 + 0.5 + 3 + 10) cycles.
        assert!((c.upstream_mm_per_cycle - 50.0 / 15.5).abs() < 1e-12);
    }

    #[test]
    fn header_policy_reads_names_with_parameters() {
        let h = "# fluxswarm-gpu 0.1.0 rollout: policy scripted:10:80:0.95:0.15 (privileged, x), seed 3, 4 environments";
        assert_eq!(
            header_policy(h).as_deref(),
            Some("scripted:10:80:0.95:0.15")
        );
        let h = "# fluxswarm-gpu 0.1.0 rollout: policy wall-angle:30, seed 1, 4 environments";
        assert_eq!(header_policy(h).as_deref(), Some("wall-angle:30"));
        assert_eq!(wall_angle_deg("wall"), Some(45.0));
        assert_eq!(wall_angle_deg("wall-angle:70"), Some(70.0));
        assert!(is_constant("zero") && !is_constant("scripted"));
        assert!(is_scripted("scripted") && is_scripted("scripted:30:60:0.9:0.15"));
        assert!(
            is_scripted("scripted-heading:45:60:0.9:0.15")
                && !is_constant("scripted-heading:45:60:0.9:0.15")
        );
        assert!(
            !is_scripted("wall") && !is_scripted("scriptedx") && !is_constant("scripted:1:2:3:4")
        );
    }

    #[test]
    fn the_wall_drag_probe_gives_peak_and_beaten_fraction() {
        let p = WallDrag {
            scale: 1.0,
            force_n: vec![1e-7, 5e-6, 2e-6, -1e-8],
        };
        assert_eq!(p.peak_n(), 5e-6);
        assert_eq!(p.beaten_fraction(8.5e-7), 0.5);
        assert_eq!(p.beaten_fraction(1e-5), 1.0);
    }
}

//! Reading run directories for `report`: `episodes.csv`, `updates.csv` (train), `swarm.csv`
//! (rollout, eval) and the `config.toml` a run wrote (its `# fluxswarm-gpu …` header names the
//! seed, batch, policy and adapter). Columns are found by their SPEC section 7 names, so extra
//! or reordered columns are fine and a missing one is named in the error.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::error::{ReportError, Result};

/// A CSV file with a header row (no quoting: none of our files needs it).
pub struct Csv {
    /// The file read.
    pub path: PathBuf,
    columns: HashMap<String, usize>,
    /// The data rows, each split into its cells.
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    /// Reads the CSV file at `path`; fails when it has no header row.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).map_err(ReportError::read(path))?;
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = lines.next().ok_or_else(|| {
            ReportError::Invalid(format!("{} is empty (no header row)", path.display()))
        })?;
        let columns = header
            .split(',')
            .enumerate()
            .map(|(i, c)| (c.trim().to_string(), i))
            .collect();
        let rows = lines
            .map(|l| l.split(',').map(|c| c.trim().to_string()).collect())
            .collect();
        Ok(Self {
            path: path.to_path_buf(),
            columns,
            rows,
        })
    }

    fn index(&self, name: &str) -> Result<usize> {
        self.columns.get(name).copied().ok_or_else(|| {
            ReportError::Invalid(format!(
                "{} has no column `{name}`: is it a fluxswarm-gpu file of this version?",
                self.path.display()
            ))
        })
    }

    /// Column `name` of every row, parsed.
    pub fn column<T: std::str::FromStr>(&self, name: &str) -> Result<Vec<T>> {
        let i = self.index(name)?;
        self.rows
            .iter()
            .enumerate()
            .map(|(r, row)| {
                let cell = row.get(i).map(String::as_str).unwrap_or("");
                cell.parse().map_err(|_| {
                    ReportError::Invalid(format!(
                        "{} row {}: `{name}` = {cell:?} is not a number of the expected kind",
                        self.path.display(),
                        r + 2
                    ))
                })
            })
            .collect()
    }
}

/// One finished episode (a row of `episodes.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct Episode {
    /// Global step at the end of the update the episode ended in (train only, else 0).
    pub global_step: u64,
    /// Environment index.
    pub env: usize,
    /// Episode index within its environment.
    pub episode: u64,
    /// Control steps in the episode.
    pub steps: u64,
    /// `success`, `failure`, `timeout` or `diverged`.
    pub outcome: String,
    /// progress, energy, smoothness (the SPEC section 3 episode metrics).
    pub metrics: [f64; 3],
    /// Swarm mean x at the episode's end (mm).
    pub final_x_com_mm: f64,
}

/// One PPO update (a row of `updates.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct Update {
    /// Update index.
    pub update: u64,
    /// Global environment steps at the end of the update.
    pub global_step: u64,
    /// Cosines between the objective gradients: progress-energy, progress-smoothness,
    /// energy-smoothness.
    pub cos: [f64; 3],
    /// Fraction of minibatches in which that pair conflicted.
    pub conflict: [f64; 3],
    /// Wall time inside the environment step during the iteration (s).
    pub sim_s: f64,
    /// Wall time of everything else in the iteration: acting, GAE, the update (s).
    pub learn_s: f64,
}

/// One control step of one episode (a row of `swarm.csv`).
#[derive(Debug, Clone, PartialEq)]
pub struct SwarmStep {
    /// Environment index.
    pub env: usize,
    /// Episode index within its environment.
    pub episode: u64,
    /// Control step within the episode (0 = the state at reset).
    pub step: u64,
    /// Time since the episode start (s).
    pub t_s: f64,
    /// Inlet centreline velocity (m/s).
    pub inlet_u_m_s: f64,
    /// Swarm mean x (mm).
    pub x_com_mm: f64,
    /// Standard deviation of the members' x (mm).
    pub sigma_x_mm: f64,
    /// Standard deviation of the members' y (mm).
    pub sigma_y_mm: f64,
    /// Radius of gyration of the swarm (mm).
    pub r_g_mm: f64,
}

/// What a run's `config.toml` says about it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunInfo {
    /// The run directory.
    pub dir: PathBuf,
    /// Seed from the header, if it names one.
    pub seed: Option<u64>,
    /// Number of environments from the header, if it names them.
    pub envs: Option<usize>,
    /// The policy of a rollout/eval (`upstream`, a checkpoint path, …).
    pub policy: Option<String>,
    /// What ran the control step, from the header's `adapter` entry.
    pub adapter: Option<String>,
    /// Whether the run trained with PCGrad (`train.pcgrad`, true when absent).
    pub pcgrad: bool,
    /// Control step (s).
    pub control_dt_s: f64,
    /// Success line x_s (mm).
    pub success_x_mm: f64,
    /// Failure line x_f (mm).
    pub failure_x_mm: f64,
}

impl RunInfo {
    /// Reads `dir/config.toml`: its header line and its time and domain tables.
    pub fn read(dir: &Path) -> Result<Self> {
        let path = dir.join("config.toml");
        let text = std::fs::read_to_string(&path).map_err(|cause| ReportError::Read {
            path: path.clone(),
            cause,
            hint: format!(": is {} a fluxswarm-gpu run directory?", dir.display()),
        })?;
        let header = text.lines().next().unwrap_or("");
        let after = |key: &str| -> Option<String> {
            let (_, rest) = header.split_once(&format!(" {key} "))?;
            Some(rest.to_string())
        };
        let word =
            |key: &str| after(key).and_then(|r| r.split([',', ' ']).next().map(String::from));
        let value: toml::Value = toml::from_str(&text)
            .map_err(|e| ReportError::Invalid(format!("parsing {}: {e}", path.display())))?;
        let get = |section: &str, key: &str| value.get(section).and_then(|s| s.get(key));
        let num = |section: &str, key: &str| -> Result<f64> {
            get(section, key)
                .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)))
                .ok_or_else(|| {
                    ReportError::Invalid(format!(
                        "{} has no number {section}.{key}",
                        path.display()
                    ))
                })
        };
        let envs = header
            .split(", ")
            .find_map(|part| part.strip_suffix(" environments")?.parse().ok());
        Ok(Self {
            dir: dir.to_path_buf(),
            seed: word("seed").and_then(|s| s.parse().ok()),
            envs,
            policy: word("policy"),
            adapter: after("adapter").map(|a| a.trim().to_string()),
            pcgrad: get("train", "pcgrad")
                .and_then(toml::Value::as_bool)
                .unwrap_or(true),
            control_dt_s: num("time", "control_dt_s")?,
            success_x_mm: 1e3 * num("domain", "success_x_m")?,
            failure_x_mm: 1e3 * num("domain", "failure_x_m")?,
        })
    }
}

/// A training run directory: its episodes and updates.
#[derive(Debug, Clone)]
pub struct TrainRun {
    /// What the run's `config.toml` says.
    pub info: RunInfo,
    /// Rows of `episodes.csv`.
    pub episodes: Vec<Episode>,
    /// Rows of `updates.csv`.
    pub updates: Vec<Update>,
}

/// A rollout or eval directory: its episodes and the per-step swarm metrics of those episodes.
#[derive(Debug, Clone)]
pub struct RolloutRun {
    /// What the run's `config.toml` says.
    pub info: RunInfo,
    /// Rows of `episodes.csv`.
    pub episodes: Vec<Episode>,
    /// Rows of `swarm.csv` of the finished episodes.
    pub swarm: Vec<SwarmStep>,
}

impl TrainRun {
    /// Reads a train run directory (`config.toml`, `episodes.csv`, `updates.csv`).
    pub fn read(dir: &Path) -> Result<Self> {
        let info = RunInfo::read(dir)?;
        let updates_path = dir.join("updates.csv");
        if !updates_path.exists() {
            return Err(ReportError::Usage(format!(
                "{} has no updates.csv: give train run directories as RUN_DIR/--compare, rollout or eval directories as --baseline/--before/--after",
                dir.display()
            )));
        }
        let episodes = read_episodes(&dir.join("episodes.csv"), true)?;
        let u = Csv::read(&updates_path)?;
        let (update, global, sim, learn) = (
            u.column::<u64>("update")?,
            u.column::<u64>("global_step")?,
            u.column::<f64>("sim_s")?,
            u.column::<f64>("learn_s")?,
        );
        let cols = |names: [&str; 3]| -> Result<Vec<[f64; 3]>> {
            let c: Vec<Vec<f64>> = names
                .iter()
                .map(|n| u.column::<f64>(n))
                .collect::<Result<_, _>>()?;
            Ok((0..u.rows.len())
                .map(|r| [c[0][r], c[1][r], c[2][r]])
                .collect())
        };
        let cos = cols(["cos_pe", "cos_ps", "cos_es"])?;
        let conflict = cols(["conflict_pe", "conflict_ps", "conflict_es"])?;
        let updates = (0..u.rows.len())
            .map(|r| Update {
                update: update[r],
                global_step: global[r],
                cos: cos[r],
                conflict: conflict[r],
                sim_s: sim[r],
                learn_s: learn[r],
            })
            .collect();
        Ok(Self {
            info,
            episodes,
            updates,
        })
    }

    /// Global environment steps done (the last update's).
    pub fn global_steps(&self) -> u64 {
        self.updates.last().map_or(0, |u| u.global_step)
    }

    /// Wall time of simulation and learning, summed over the updates (s).
    pub fn wall_s(&self) -> f64 {
        self.updates.iter().map(|u| u.sim_s + u.learn_s).sum()
    }
}

impl RolloutRun {
    /// Reads a rollout or eval directory (`config.toml`, `episodes.csv`, `swarm.csv`).
    pub fn read(dir: &Path) -> Result<Self> {
        let info = RunInfo::read(dir)?;
        let episodes = read_episodes(&dir.join("episodes.csv"), false)?;
        let s = Csv::read(&dir.join("swarm.csv"))?;
        let (env, episode, step) = (
            s.column::<usize>("env")?,
            s.column::<u64>("episode")?,
            s.column::<u64>("step")?,
        );
        let f = |n: &str| s.column::<f64>(n);
        let (t, inlet, x, sx, sy, rg) = (
            f("t_s")?,
            f("inlet_u_m_s")?,
            f("x_com_mm")?,
            f("sigma_x_mm")?,
            f("sigma_y_mm")?,
            f("r_g_mm")?,
        );
        // swarm.csv also holds the start of episodes that had not finished when the rollout
        // stopped: keep the finished ones only.
        let finished: std::collections::HashSet<(usize, u64)> =
            episodes.iter().map(|e| (e.env, e.episode)).collect();
        let swarm = (0..s.rows.len())
            .filter(|&r| finished.contains(&(env[r], episode[r])))
            .map(|r| SwarmStep {
                env: env[r],
                episode: episode[r],
                step: step[r],
                t_s: t[r],
                inlet_u_m_s: inlet[r],
                x_com_mm: x[r],
                sigma_x_mm: sx[r],
                sigma_y_mm: sy[r],
                r_g_mm: rg[r],
            })
            .collect();
        Ok(Self {
            info,
            episodes,
            swarm,
        })
    }

    /// A short name: the policy from the header (a checkpoint path shortened to its run
    /// directory's name), else the directory's name.
    pub fn label(&self) -> String {
        let dir_name = || {
            self.info
                .dir
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| self.info.dir.display().to_string())
        };
        match self.info.policy.as_deref() {
            Some("upstream") => "direct-upstream".into(),
            Some("wall") => "wall-hugging".into(),
            Some("zero") => "zero action".into(),
            Some("random") => "uniform random".into(),
            _ => dir_name(),
        }
    }
}

/// The rows of an `episodes.csv` (`global_step`: the file is a train run's, which has it).
pub fn read_episodes(path: &Path, global_step: bool) -> Result<Vec<Episode>> {
    let c = Csv::read(path)?;
    let global: Vec<u64> = if global_step {
        c.column("global_step")?
    } else {
        vec![0; c.rows.len()]
    };
    let (env, episode, steps, outcome) = (
        c.column::<usize>("env")?,
        c.column::<u64>("episode")?,
        c.column::<u64>("steps")?,
        c.column::<String>("outcome")?,
    );
    let (p, e, s) = (
        c.column::<f64>("progress")?,
        c.column::<f64>("energy")?,
        c.column::<f64>("smoothness")?,
    );
    let x = c.column::<f64>("final_x_com_mm")?;
    Ok((0..c.rows.len())
        .map(|r| Episode {
            global_step: global[r],
            env: env[r],
            episode: episode[r],
            steps: steps[r],
            outcome: outcome[r].clone(),
            metrics: [p[r], e[r], s[r]],
            final_x_com_mm: x[r],
        })
        .collect())
}

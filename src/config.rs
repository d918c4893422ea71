//! Run configuration: TOML mirrored by serde structs (`deny_unknown_fields`), SI units, each key
//! named with its unit. `configs/paper.toml` is embedded as the default; a user file is merged
//! over it key by key, then `--set section.key=value` overrides are applied, then everything is
//! validated (ranges, waveform, diffusion number, CFL number) before any GPU work.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::waveform::{Waveform, WaveformError};

/// The paper's setup, embedded.
pub const PAPER_TOML: &str = include_str!("../configs/paper.toml");

/// Largest explicit-diffusion number nu dt (1/dx^2 + 1/dy^2) / 2 accepted (FTCS stability).
pub const MAX_DIFFUSION_NUMBER: f64 = 0.25;
/// Largest CFL number U_peak dt_sub / dx accepted: a departure point never leaves the
/// neighbouring cells, so the one-cell-deep boundary ghosts of the advection stay valid.
pub const MAX_CFL: f64 = 1.0;
/// Relative allowance for decimal rounding when comparing the CFL number to its limit (the
/// paper's setup is exactly CFL = 1, which in f64 evaluates to 1 + 2e-16).
pub const CFL_ROUNDING_ALLOWANCE: f64 = 1e-9;

/// Largest ny on the CPU backend (the WGSL pressure kernels hold fewer per column:
/// `sim::fluid::WGSL_MAX_NY`).
pub const MAX_NY: u32 = 256;

/// Keys that may be absent from the default configuration but can be set.
const OPTIONAL_KEYS: &[(&str, &str)] = &[("inlet", "csv")];

#[derive(Debug, Error)]
pub enum ConfigError {
    #[error("cannot read config file {path}: {source}")]
    Read {
        path: String,
        source: std::io::Error,
    },
    #[error("config file {path} is not valid TOML: {message}")]
    Syntax { path: String, message: String },
    #[error("--set {arg}: {message}")]
    Set { arg: String, message: String },
    #[error("config key `{key}`: {message}")]
    Key { key: String, message: String },
    #[error("config key `{key}` = {value}: {message}")]
    Range {
        key: String,
        value: String,
        message: String,
    },
    #[error(transparent)]
    Waveform(#[from] WaveformError),
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub domain: Domain,
    pub fluid: Fluid,
    pub time: Time,
    pub inlet: Inlet,
    pub swarm: Swarm,
    pub env: EnvConfig,
    pub train: Train,
    pub solver: Solver,
}

/// Learner hyperparameters (SPEC section 5); `Default` is the embedded paper configuration's.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Train {
    pub rollout_steps: u32,
    pub epochs: u32,
    pub minibatches: u32,
    pub gamma: f64,
    pub lambda: f64,
    pub learning_rate: f64,
    pub clip: f64,
    pub entropy_coef: f64,
    pub max_grad_norm: f64,
    pub pcgrad: bool,
    pub normalize_advantages: bool,
    /// Running mean/std normalisation of the networks' inputs (saved with checkpoints).
    pub normalize_observations: bool,
}

/// Episode settings of the environment (SPEC section 3).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EnvConfig {
    /// Control steps after which an episode is truncated.
    pub max_steps: u32,
    /// Half-width of the uniform jitter added to each member's start, in x and y (m).
    pub position_jitter_m: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    pub length_m: f64,
    pub height_m: f64,
    pub nx: u32,
    pub ny: u32,
    pub success_x_m: f64,
    pub failure_x_m: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    pub density_kg_m3: f64,
    pub viscosity_pa_s: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Time {
    pub control_dt_s: f64,
    pub substeps: u32,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Inlet {
    pub period_s: f64,
    #[serde(default)]
    pub points: Vec<[f64; 2]>,
    /// CSV file of control points (header `t_s,u_m_per_s`); replaces `points` when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub csv: Option<PathBuf>,
    #[serde(default)]
    pub random_phase: bool,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Advection {
    /// First-order semi-Lagrangian (the paper's scheme).
    SemiLagrangian,
    /// Second-order MacCormack with the Selle et al. (2008) extrema clamp.
    Maccormack,
}

impl Default for Train {
    fn default() -> Self {
        Config::paper().train
    }
}

/// How the members are placed at reset.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `grid_rows` rows of count / grid_rows members, `grid_spacing_m` apart, centred at
    /// (`grid_centre_x_m`, H / 2).
    Grid,
    /// One `positions_m` entry per member.
    Explicit,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Swarm {
    pub count: u32,
    pub radius_m: f64,
    pub density_kg_m3: f64,
    pub max_thrust_n: f64,
    pub layout: Layout,
    pub grid_rows: u32,
    pub grid_spacing_m: f64,
    pub grid_centre_x_m: f64,
    #[serde(default)]
    pub positions_m: Vec<[f64; 2]>,
    #[serde(default)]
    pub pinned: Vec<u32>,
    pub drag: bool,
}

/// Most members per environment (one workgroup of 64 threads moves a swarm).
pub const MAX_MEMBERS: u32 = 64;

impl Swarm {
    /// Initial member centres (m), in member order.
    pub fn initial_positions(&self, height_m: f64) -> Vec<[f64; 2]> {
        match self.layout {
            Layout::Explicit => self.positions_m.clone(),
            Layout::Grid => {
                let rows = self.grid_rows.max(1) as usize;
                let cols = self.count as usize / rows;
                let s = self.grid_spacing_m;
                (0..rows)
                    .flat_map(|r| (0..cols).map(move |c| (r, c)))
                    .map(|(r, c)| {
                        [
                            self.grid_centre_x_m + s * (c as f64 - (cols as f64 - 1.0) / 2.0),
                            height_m / 2.0 + s * (r as f64 - (rows as f64 - 1.0) / 2.0),
                        ]
                    })
                    .collect()
            }
        }
    }

    /// Mass of one member: the 3D sphere, 4/3 pi r^3 rho_s (kg).
    pub fn mass_kg(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius_m.powi(3) * self.density_kg_m3
    }
}

/// Order of the semi-Lagrangian backtrace (departure point of a trajectory).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Backtrace {
    /// One Euler step with the velocity at the arrival point (the paper's scheme).
    Euler,
    /// Midpoint rule: a second velocity sample half-way back.
    Rk2,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Solver {
    pub advection: Advection,
    pub backtrace: Backtrace,
    /// Where the control step runs (default: the adapter).
    #[serde(default)]
    pub backend: Backend,
    /// How the kernels solve each y-mode's tridiagonal system along x (default: auto).
    #[serde(default)]
    pub pressure_sweep: PressureSweep,
}

/// The kernel for the tridiagonal solve of each y-mode along x (both exact, same factors).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PressureSweep {
    /// `scan` on a GPU, `sequential` on a software adapter.
    #[default]
    Auto,
    /// `pressure_solve.wgsl`: one thread per (environment, mode) runs the Thomas sweeps, 2 nx
    /// dependent steps. Fastest on lavapipe, where threads are few and barriers dear.
    Sequential,
    /// `pressure_scan.wgsl`: one workgroup of 256 threads per (environment, mode) runs each
    /// sweep as a parallel scan of affine maps, at most 4 ceil(nx / 256) dependent steps per
    /// thread plus 2 x 8 barrier steps. For GPUs, where a dependent step costs a memory latency.
    Scan,
}

impl PressureSweep {
    /// Whether the batch uses the scan kernel on an adapter that is (or is not) software.
    pub fn uses_scan(self, software_adapter: bool) -> bool {
        match self {
            Self::Auto => !software_adapter,
            Self::Sequential => false,
            Self::Scan => true,
        }
    }
}

/// Where the fluid and swarm control step runs.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// The WGSL kernels on a real GPU (after a start-up self-check against the CPU step),
    /// the CPU backend otherwise (SPEC section 8).
    #[default]
    Auto,
    /// The WGSL kernels on the wgpu adapter, whatever it is (a GPU, or lavapipe on the CPU).
    Adapter,
    /// `sim::cpu`: the control step in plain Rust on the CPU cores (rayon, one environment
    /// per task); needs no adapter.
    Native,
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Auto => "auto",
            Self::Adapter => "adapter",
            Self::Native => "native",
        })
    }
}

/// A validated configuration with its waveform resolved.
#[derive(Debug, Clone)]
pub struct Resolved {
    pub config: Config,
    pub waveform: Waveform,
}

impl Config {
    /// The embedded paper configuration.
    pub fn paper() -> Self {
        toml::from_str(PAPER_TOML).expect("embedded configs/paper.toml is valid")
    }

    /// Default <- optional file <- `--set` overrides, then validation.
    pub fn load(file: Option<&Path>, sets: &[String]) -> Result<Resolved, ConfigError> {
        let mut table: toml::Table = PAPER_TOML
            .parse()
            .expect("embedded configs/paper.toml is valid");
        let mut base_dir = PathBuf::from(".");
        if let Some(path) = file {
            let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
                path: path.display().to_string(),
                source,
            })?;
            let user: toml::Table =
                text.parse()
                    .map_err(|e: toml::de::Error| ConfigError::Syntax {
                        path: path.display().to_string(),
                        message: e.message().to_string(),
                    })?;
            merge(&mut table, user);
            if let Some(dir) = path.parent() {
                base_dir = dir.to_path_buf();
            }
        }
        for arg in sets {
            apply_set(&mut table, arg)?;
        }
        let mut config: Config = serde_path_to_error::deserialize(toml::Value::Table(table))
            .map_err(|e| ConfigError::Key {
                key: e.path().to_string(),
                message: e.into_inner().message().to_string(),
            })?;
        if let Some(csv) = &config.inlet.csv
            && csv.is_relative()
        {
            config.inlet.csv = Some(base_dir.join(csv));
        }
        config.resolve()
    }

    /// A configuration saved by this program (a checkpoint's or a run's `config.toml`), loaded
    /// as written: no defaults merged in, every key required.
    pub fn from_saved(text: &str) -> Result<Resolved, ConfigError> {
        let de = toml::de::Deserializer::parse(text).map_err(|e| ConfigError::Syntax {
            path: "saved configuration".into(),
            message: e.message().to_string(),
        })?;
        let config: Config =
            serde_path_to_error::deserialize(de).map_err(|e| ConfigError::Key {
                key: e.path().to_string(),
                message: e.into_inner().message().to_string(),
            })?;
        config.resolve()
    }

    /// Validates every range and builds the waveform.
    pub fn resolve(self) -> Result<Resolved, ConfigError> {
        let d = &self.domain;
        positive("domain.length_m", d.length_m)?;
        positive("domain.height_m", d.height_m)?;
        at_least("domain.nx", d.nx, 4)?;
        at_least("domain.ny", d.ny, 2)?;
        if d.ny > MAX_NY {
            return Err(range(
                "domain.ny",
                d.ny,
                format!(
                    "is above {MAX_NY}, the most cells across the channel the solver holds per \
                     column: use a coarser grid across the height"
                ),
            ));
        }
        if !(d.success_x_m > 0.0 && d.success_x_m < d.length_m) {
            return Err(range(
                "domain.success_x_m",
                d.success_x_m,
                format!(
                    "must lie inside the channel, 0 < x < length_m = {}",
                    d.length_m
                ),
            ));
        }
        if !(d.failure_x_m > d.success_x_m && d.failure_x_m < d.length_m) {
            return Err(range(
                "domain.failure_x_m",
                d.failure_x_m,
                format!(
                    "must lie between success_x_m = {} and length_m = {}",
                    d.success_x_m, d.length_m
                ),
            ));
        }
        positive("fluid.density_kg_m3", self.fluid.density_kg_m3)?;
        positive("fluid.viscosity_pa_s", self.fluid.viscosity_pa_s)?;
        positive("time.control_dt_s", self.time.control_dt_s)?;
        at_least("time.substeps", self.time.substeps, 1)?;
        positive("inlet.period_s", self.inlet.period_s)?;
        self.validate_swarm()?;
        at_least("env.max_steps", self.env.max_steps, 1)?;
        let tr = &self.train;
        at_least("train.rollout_steps", tr.rollout_steps, 1)?;
        at_least("train.epochs", tr.epochs, 1)?;
        at_least("train.minibatches", tr.minibatches, 1)?;
        for (key, v) in [("train.gamma", tr.gamma), ("train.lambda", tr.lambda)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(range(key, v, "must lie in [0, 1]".into()));
            }
        }
        positive("train.learning_rate", tr.learning_rate)?;
        positive("train.clip", tr.clip)?;
        positive("train.max_grad_norm", tr.max_grad_norm)?;
        if !(tr.entropy_coef >= 0.0 && tr.entropy_coef.is_finite()) {
            return Err(range(
                "train.entropy_coef",
                tr.entropy_coef,
                "must be non-negative".into(),
            ));
        }
        if !(self.env.position_jitter_m >= 0.0 && self.env.position_jitter_m.is_finite()) {
            return Err(range(
                "env.position_jitter_m",
                self.env.position_jitter_m,
                "must be a non-negative, finite length".into(),
            ));
        }

        let waveform = match &self.inlet.csv {
            Some(path) => Waveform::from_csv(path, self.inlet.period_s)?,
            None => Waveform::new(
                self.inlet.points.iter().map(|p| (p[0], p[1])).collect(),
                self.inlet.period_s,
            )?,
        };

        let diffusion = self.diffusion_number();
        if diffusion > MAX_DIFFUSION_NUMBER {
            return Err(range(
                "time.substeps",
                self.time.substeps,
                format!(
                    "gives a diffusion number nu dt_sub (1/dx^2 + 1/dy^2) / 2 = {diffusion:.4}, above \
                     the explicit-diffusion limit {MAX_DIFFUSION_NUMBER}: raise time.substeps, lower \
                     time.control_dt_s or use a coarser grid"
                ),
            ));
        }
        let cfl = self.cfl_number(&waveform);
        if cfl > MAX_CFL * (1.0 + CFL_ROUNDING_ALLOWANCE) {
            return Err(range(
                "time.substeps",
                self.time.substeps,
                format!(
                    "gives a CFL number U_peak dt_sub / dx = {:.4} m/s x {:.4e} s / {:.4e} m = {cfl:.4}, \
                     above the limit {MAX_CFL}: raise time.substeps, lower time.control_dt_s or the \
                     inlet velocity, or use a coarser grid",
                    waveform.peak_abs(),
                    self.dt_sub(),
                    self.dx()
                ),
            ));
        }
        Ok(Resolved {
            config: self,
            waveform,
        })
    }

    fn validate_swarm(&self) -> Result<(), ConfigError> {
        let s = &self.swarm;
        let (length, height) = (self.domain.length_m, self.domain.height_m);
        if s.count > MAX_MEMBERS {
            return Err(range(
                "swarm.count",
                s.count,
                format!("is above {MAX_MEMBERS}, the most members one environment holds"),
            ));
        }
        if s.count == 0 {
            return Ok(());
        }
        positive("swarm.radius_m", s.radius_m)?;
        positive("swarm.density_kg_m3", s.density_kg_m3)?;
        positive("swarm.max_thrust_n", s.max_thrust_n)?;
        if 2.0 * s.radius_m >= height {
            return Err(range(
                "swarm.radius_m",
                s.radius_m,
                format!("gives a diameter that does not fit the channel height {height} m"),
            ));
        }
        if s.layout == Layout::Grid {
            at_least("swarm.grid_rows", s.grid_rows, 1)?;
            if !s.count.is_multiple_of(s.grid_rows) {
                return Err(range(
                    "swarm.count",
                    s.count,
                    format!("must be a multiple of swarm.grid_rows = {}", s.grid_rows),
                ));
            }
            positive("swarm.grid_spacing_m", s.grid_spacing_m)?;
        } else if s.positions_m.len() != s.count as usize {
            return Err(range(
                "swarm.positions_m",
                format!("{} entries", s.positions_m.len()),
                format!("needs one [x, y] per member (swarm.count = {})", s.count),
            ));
        }
        let r = s.radius_m;
        let pos = s.initial_positions(height);
        for (k, p) in pos.iter().enumerate() {
            if !(p[0] >= r && p[0] <= length - r && p[1] >= r && p[1] <= height - r) {
                return Err(range(
                    "swarm",
                    format!("member {k} at ({:.6}, {:.6}) m", p[0], p[1]),
                    format!(
                        "lies less than a radius from a wall or an end of the channel \
                         ({length} x {height} m): move the grid or the explicit positions"
                    ),
                ));
            }
            for (j, q) in pos.iter().enumerate().take(k) {
                if (p[0] - q[0]).hypot(p[1] - q[1]) < 2.0 * r {
                    return Err(range(
                        "swarm",
                        format!("members {j} and {k}"),
                        "overlap at reset: increase swarm.grid_spacing_m or move them".into(),
                    ));
                }
            }
        }
        if let Some(&bad) = s.pinned.iter().find(|&&i| i >= s.count) {
            return Err(range(
                "swarm.pinned",
                bad,
                format!("is not a member index (0..{})", s.count),
            ));
        }
        Ok(())
    }

    pub fn dx(&self) -> f64 {
        self.domain.length_m / self.domain.nx as f64
    }

    pub fn dy(&self) -> f64 {
        self.domain.height_m / self.domain.ny as f64
    }

    pub fn dt_sub(&self) -> f64 {
        self.time.control_dt_s / self.time.substeps as f64
    }

    pub fn kinematic_viscosity(&self) -> f64 {
        self.fluid.viscosity_pa_s / self.fluid.density_kg_m3
    }

    /// nu dt_sub (1/dx^2 + 1/dy^2) / 2; equals nu dt / dx^2 on a square grid.
    pub fn diffusion_number(&self) -> f64 {
        let (dx, dy) = (self.dx(), self.dy());
        0.5 * self.kinematic_viscosity() * self.dt_sub() * (1.0 / (dx * dx) + 1.0 / (dy * dy))
    }

    /// U_peak dt_sub / dx from the peak inlet centreline velocity, in f64.
    pub fn cfl_number(&self, waveform: &Waveform) -> f64 {
        waveform.peak_abs() * self.dt_sub() / self.dx()
    }

    /// The resolved configuration as TOML text.
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }
}

fn range(key: &str, value: impl std::fmt::Display, message: String) -> ConfigError {
    ConfigError::Range {
        key: key.into(),
        value: value.to_string(),
        message,
    }
}

fn positive(key: &str, value: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(range(
            key,
            value,
            "must be a positive, finite number".into(),
        ))
    }
}

fn at_least(key: &str, value: u32, min: u32) -> Result<(), ConfigError> {
    if value >= min {
        Ok(())
    } else {
        Err(range(key, value, format!("must be at least {min}")))
    }
}

/// Deep merge: tables merge key by key, anything else is replaced.
fn merge(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Applies one `section.key=value` override. The value is read as TOML (numbers, booleans,
/// arrays, quoted strings); anything that is not valid TOML is taken as a bare string.
fn apply_set(table: &mut toml::Table, arg: &str) -> Result<(), ConfigError> {
    let err = |message: String| ConfigError::Set {
        arg: arg.into(),
        message,
    };
    let (path, raw) = arg
        .split_once('=')
        .ok_or_else(|| err("expected section.key=value".into()))?;
    let (section, key) = path
        .trim()
        .split_once('.')
        .ok_or_else(|| err("expected section.key=value, e.g. domain.nx=500".into()))?;
    let raw = raw.trim();
    let value = match format!("v = {raw}").parse::<toml::Table>() {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_) => toml::Value::String(raw.into()),
    };
    let sections: Vec<String> = table.keys().cloned().collect();
    let Some(toml::Value::Table(sec)) = table.get_mut(section) else {
        return Err(err(format!(
            "unknown section `{section}`; sections are: {}",
            sections.join(", ")
        )));
    };
    let optional = OPTIONAL_KEYS.contains(&(section, key));
    if !sec.contains_key(key) && !optional {
        let mut known: Vec<&str> = sec.keys().map(String::as_str).collect();
        known.extend(OPTIONAL_KEYS.iter().filter(|o| o.0 == section).map(|o| o.1));
        return Err(err(format!(
            "unknown key `{key}` in [{section}]; known keys: {}",
            known.join(", ")
        )));
    }
    sec.insert(key.into(), value);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_config_loads_at_cfl_one() {
        let r = Config::load(None, &[]).unwrap();
        let cfl = r.config.cfl_number(&r.waveform);
        assert!((cfl - 1.0).abs() < 1e-12, "{cfl}");
        assert!((r.config.diffusion_number() - 0.0707).abs() < 1e-3);
        assert_eq!(r.config, Config::paper());
    }

    #[test]
    fn set_overrides_and_merges() {
        let r = Config::load(
            None,
            &[
                "domain.nx=500".into(),
                "solver.advection=semi_lagrangian".into(),
                "inlet.points=[[0.0, 0.1], [0.5, 0.2]]".into(),
            ],
        )
        .unwrap();
        assert_eq!(r.config.domain.nx, 500);
        assert_eq!(r.config.solver.advection, Advection::SemiLagrangian);
        assert!((r.waveform.at(0.25) - 0.15).abs() < 1e-12);
    }
}

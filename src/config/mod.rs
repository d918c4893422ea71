//! Run configuration: TOML mirrored by serde structs (`deny_unknown_fields`), SI units, each key
//! named with its unit. `configs/paper.toml` is embedded as the default; a user file is merged
//! over it key by key, then `--set section.key=value` overrides are applied, then everything is
//! validated (ranges, waveform, diffusion number, CFL number) before any GPU work.
//! The keys are `schema`, the checks `validate`, file merging and `--set` `overrides`.

mod overrides;
mod schema;
mod validate;

pub use schema::*;

use overrides::{apply_set, merge};

use std::path::{Path, PathBuf};

use thiserror::Error;

use crate::waveform::{Waveform, WaveformError};

/// Keys a run saved with its checkpoint may still change: how the control step runs, not what
/// it computes (the backends agree within the kernel tests' tolerance).
pub const RUN_KEYS: [&str; 2] = ["solver.backend", "solver.pressure_sweep"];

/// Keys a trained policy may be rolled out with changed (`rollout --policy RUN --set`), to test
/// how it transfers: the flow's strength, the thrust and the resolution around the policy, not
/// what it observes or how its actions are applied (the members, their layout and the
/// observation's scales stay as trained).
pub const TRANSFER_KEYS: [&str; 6] = [
    "inlet.scale",
    "swarm.max_thrust_n",
    "domain.nx",
    "domain.ny",
    "time.substeps",
    "swarm.drag",
];

/// Text of `configs/paper.toml`, the default configuration, embedded at compile time.
pub const PAPER_TOML: &str = include_str!("../../configs/paper.toml");

/// Largest explicit-diffusion number nu dt (1/dx^2 + 1/dy^2) / 2 accepted (FTCS stability).
pub const MAX_DIFFUSION_NUMBER: f64 = 0.25;
/// Largest CFL number U_peak dt_sub / dx accepted: a departure point never leaves the
/// neighbouring cells, so the one-cell-deep boundary ghosts of the advection stay valid.
pub const MAX_CFL: f64 = 1.0;
/// Relative allowance for decimal rounding when comparing the CFL number to its limit (the
/// paper's setup is exactly CFL = 1, which in f64 evaluates to 1 + 2e-16).
pub const CFL_ROUNDING_ALLOWANCE: f64 = 1e-9;

/// Largest ny, on both backends (the WGSL column kernels pick their workgroup layout from ny:
/// `gpu::kernels::Columns`).
pub const MAX_NY: u32 = 256;

/// Keys that may be absent from the default configuration but can be set.
const OPTIONAL_KEYS: &[(&str, &str)] = &[("inlet", "csv")];

/// Why a configuration could not be loaded, merged or validated.
#[derive(Debug, Error)]
pub enum ConfigError {
    /// The configuration file could not be read.
    #[error("cannot read config file {path}: {source}")]
    Read {
        /// Path of the file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file (or a saved configuration) is not valid TOML.
    #[error("config file {path} is not valid TOML: {message}")]
    Syntax {
        /// Path of the file, or `saved configuration`.
        path: String,
        /// The TOML parser's message.
        message: String,
    },
    /// A `--set` override is malformed or names an unknown section or key.
    #[error("--set {arg}: {message}")]
    Set {
        /// The override as given, `section.key=value`.
        arg: String,
        /// What is wrong with it.
        message: String,
    },
    /// A key is unknown, missing or of the wrong type when the table is deserialised.
    #[error("config key `{key}`: {message}")]
    Key {
        /// Dotted path of the key.
        key: String,
        /// The deserialiser's message.
        message: String,
    },
    /// A value lies outside its range or is inconsistent with other keys.
    #[error("config key `{key}` = {value}: {message}")]
    Range {
        /// Dotted key (or section) that fails.
        key: String,
        /// The offending value, as text.
        value: String,
        /// The limit broken, or the fix.
        message: String,
    },
    /// The inlet waveform is invalid.
    #[error(transparent)]
    Waveform(#[from] WaveformError),
}

/// A validated configuration with its waveform resolved.
#[derive(Debug, Clone)]
pub struct Resolved {
    /// The validated configuration.
    pub config: Config,
    /// The inlet centreline-velocity waveform, already scaled by `inlet.scale`.
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

    /// This configuration with `section.key=value` overrides applied, validated again (a saved
    /// configuration changed for a transfer test, [`TRANSFER_KEYS`]).
    pub fn with_sets(&self, sets: &[String]) -> Result<Resolved, ConfigError> {
        let mut table = self.to_table();
        for arg in sets {
            apply_set(&mut table, arg)?;
        }
        let config: Config =
            serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
                ConfigError::Key {
                    key: e.path().to_string(),
                    message: e.into_inner().message().to_string(),
                }
            })?;
        config.resolve()
    }

    /// Cell width along x, L / nx (m).
    pub fn dx(&self) -> f64 {
        self.domain.length_m / self.domain.nx as f64
    }

    /// Cell height across the channel, H / ny (m).
    pub fn dy(&self) -> f64 {
        self.domain.height_m / self.domain.ny as f64
    }

    /// Fluid substep, control_dt_s / substeps (s).
    pub fn dt_sub(&self) -> f64 {
        self.time.control_dt_s / self.time.substeps as f64
    }

    /// Kinematic viscosity nu = mu / rho (m^2/s).
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

    /// The keys (`section.key`) whose values differ between this configuration and `other`,
    /// in file order, each with this value and the other's as TOML text.
    pub fn differences(&self, other: &Config) -> Vec<(String, String, String)> {
        let mut out = Vec::new();
        diff_tables("", &self.to_table(), &other.to_table(), &mut out);
        out
    }

    /// The resolved configuration as a TOML table, one sub-table per section.
    fn to_table(&self) -> toml::Table {
        self.to_toml()
            .parse()
            .expect("a configuration serialises to valid TOML")
    }
}

/// Appends to `out` every leaf key under `prefix` whose value differs between `a` and `b`
/// (a key missing on one side shows as `(none)`).
fn diff_tables(
    prefix: &str,
    a: &toml::Table,
    b: &toml::Table,
    out: &mut Vec<(String, String, String)>,
) {
    let keys = a.keys().chain(b.keys().filter(|k| !a.contains_key(*k)));
    for key in keys {
        let name = format!("{prefix}{key}");
        match (a.get(key), b.get(key)) {
            (Some(toml::Value::Table(x)), Some(toml::Value::Table(y))) => {
                diff_tables(&format!("{name}."), x, y, out)
            }
            (x, y) if x != y => {
                let show = |v: Option<&toml::Value>| v.map_or("(none)".into(), |v| v.to_string());
                out.push((name, show(x), show(y)));
            }
            _ => {}
        }
    }
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

    #[test]
    fn with_sets_changes_only_the_set_keys_and_validates_again() {
        let base = Config::load(None, &[]).unwrap().config;
        let r = base
            .with_sets(&["inlet.scale=0.5".into(), "swarm.max_thrust_n=1e-6".into()])
            .unwrap();
        let mut expected = base.clone();
        expected.inlet.scale = 0.5;
        expected.swarm.max_thrust_n = 1e-6;
        assert_eq!(r.config, expected);
        // 0.5 of the paper's 400 mm/s peak.
        assert!((r.waveform.peak_abs() - 0.2).abs() < 1e-12);
        // Validated again: the paper's grid is at CFL 1, so a faster flow is refused.
        assert!(matches!(
            base.with_sets(&["inlet.scale=1.5".into()]),
            Err(ConfigError::Range { key, .. }) if key == "time.substeps"
        ));
        assert!(base.with_sets(&["swarm.nope=1".into()]).is_err());
    }

    #[test]
    fn differences_name_each_changed_key_with_both_values() {
        let base = Config::paper();
        assert!(base.differences(&base.clone()).is_empty());
        let mut other = base.clone();
        other.train.learning_rate = 0.0;
        other.domain.nx = 500;
        // The paper's learning rate is 1e-3 and its grid 1000 cells long (configs/paper.toml).
        assert_eq!(
            base.differences(&other),
            vec![
                (
                    "domain.nx".to_string(),
                    "1000".to_string(),
                    "500".to_string()
                ),
                (
                    "train.learning_rate".to_string(),
                    "0.001".to_string(),
                    "0.0".to_string()
                ),
            ]
        );
    }

    #[test]
    fn inlet_scale_multiplies_every_velocity_and_the_peak() {
        let r = Config::load(None, &["inlet.scale=0.8".into()]).unwrap();
        // (0.030, 400 mm/s) and (0.150, -15 mm/s) scaled by 0.8; 0.09 s lies on the plateau.
        assert!((r.waveform.at(0.09) - 0.32).abs() < 1e-12);
        assert!((r.waveform.at(0.2) + 0.012).abs() < 1e-12);
        assert!((r.waveform.peak_abs() - 0.32).abs() < 1e-12);
        assert!((r.config.cfl_number(&r.waveform) - 0.8).abs() < 1e-12);
        let err = Config::load(None, &["inlet.scale=0".into()])
            .unwrap_err()
            .to_string();
        assert!(err.contains("inlet.scale"), "{err}");
    }
}

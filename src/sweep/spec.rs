//! The sweep specification (SPEC section 8): a TOML file naming the command every run calls,
//! the arguments passed to all of them, the seeds, fixed `[set]` overrides and either a `[grid]`
//! (its cartesian product is the set of points) or an explicit `[[points]]` list. A key of a
//! point is a configuration key (`inlet.scale`, passed as `--set inlet.scale=V`) or, when it
//! starts with `--`, a command-line flag (`"--policy" = ["wall"]`; `true` / `false` turn a
//! switch such as `--no-pcgrad` on or off). `[slurm]` holds the job-array options, which do not
//! change what the sweep computes and so are left out of its hash.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::SweepError;

/// The commands a sweep can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SweepCommand {
    /// `fluxswarm-gpu train`.
    Train,
    /// `fluxswarm-gpu rollout`.
    Rollout,
    /// `fluxswarm-gpu eval`.
    Eval,
}

impl SweepCommand {
    /// The command's name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SweepCommand::Train => "train",
            SweepCommand::Rollout => "rollout",
            SweepCommand::Eval => "eval",
        }
    }
}

/// Options of the Slurm job array (`[slurm]` in the spec; the `sweep --slurm` flags override
/// them).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SlurmOptions {
    /// `--cpus-per-task` (default 2); each run gets as many threads.
    pub cpus_per_task: Option<u32>,
    /// GPUs per task (`--gres=gpu:N`); none by default.
    pub gpus: Option<u32>,
    /// `--time`, e.g. "04:00:00".
    pub time: Option<String>,
    /// `--partition`.
    pub partition: Option<String>,
    /// `--account`.
    pub account: Option<String>,
    /// `--mem`, e.g. "4G".
    pub mem: Option<String>,
    /// The cluster's `MaxArraySize` (default 1001): larger sweeps pack several runs per task.
    pub max_array_size: Option<usize>,
    /// At most this many tasks at once (`--array=0-N%K`).
    pub max_running: Option<usize>,
    /// Further `#SBATCH` lines, verbatim (e.g. "--qos=long").
    #[serde(default)]
    pub extra: Vec<String>,
}

/// A parsed sweep specification.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spec {
    /// The command every run calls.
    pub command: SweepCommand,
    /// Arguments passed to every run.
    #[serde(default)]
    pub args: Vec<String>,
    /// One run per seed per point, passed as `--seed` (default `[0]`).
    #[serde(default = "default_seeds")]
    pub seeds: Vec<u64>,
    /// `[set]`: overrides for every run, passed as `--set key=value`.
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    /// `[grid]`: key -> values; their cartesian product is the set of points.
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<toml::Value>>,
    /// `[[points]]`: explicit points instead of a grid.
    #[serde(default)]
    pub points: Vec<BTreeMap<String, toml::Value>>,
    /// `[slurm]`: job-array options, left out of the hash.
    #[serde(default, skip_serializing)]
    pub slurm: SlurmOptions,
}

fn default_seeds() -> Vec<u64> {
    vec![0]
}

/// Flags the sweep itself passes to every run, which the spec may not give.
const OWN_FLAGS: [&str; 4] = ["--out", "--seed", "--resume", "--set"];

impl Spec {
    /// Parses and checks a specification; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Spec, SweepError> {
        let de = toml::Deserializer::parse(text).map_err(|e| SweepError::Spec {
            origin: origin.into(),
            message: e.to_string(),
        })?;
        let spec: Spec = serde_path_to_error::deserialize(de).map_err(|e| SweepError::Spec {
            origin: origin.into(),
            message: format!("{}: {}", e.path(), e.inner()),
        })?;
        spec.check().map_err(|message| SweepError::Spec {
            origin: origin.into(),
            message,
        })?;
        Ok(spec)
    }

    fn check(&self) -> Result<(), String> {
        if self.seeds.is_empty() {
            return Err("`seeds` is empty: give at least one, e.g. seeds = [1]".into());
        }
        let mut seen = std::collections::BTreeSet::new();
        if let Some(s) = self.seeds.iter().find(|s| !seen.insert(**s)) {
            return Err(format!("seed {s} is listed twice in `seeds`"));
        }
        for a in &self.args {
            let flag = a.split('=').next().unwrap_or(a);
            if OWN_FLAGS.contains(&flag) {
                return Err(format!(
                    "`args` gives {flag}, which the sweep sets for each run: put overrides in [set] \
                     or [grid], seeds in `seeds`; the run directories are under --out"
                ));
            }
        }
        if !self.grid.is_empty() && !self.points.is_empty() {
            return Err("give either [grid] or [[points]], not both".into());
        }
        for (key, values) in &self.grid {
            if values.is_empty() {
                return Err(format!("[grid] key {key:?} has no values"));
            }
        }
        for key in self.set.keys() {
            if !is_config_key(key) {
                return Err(format!(
                    "[set] key {key:?} is not a configuration key (section.key, e.g. \
                     \"inlet.scale\"); flags for every run go in `args`"
                ));
            }
        }
        for key in self.point_keys() {
            if !is_config_key(&key) && !key.starts_with("--") {
                return Err(format!(
                    "point key {key:?} is neither a configuration key (section.key) nor a flag \
                     (--name)"
                ));
            }
            if self.set.contains_key(&key) {
                return Err(format!(
                    "{key:?} is both in [set] and in the points: keep one"
                ));
            }
            if OWN_FLAGS.contains(&key.as_str()) {
                return Err(format!("{key} is set by the sweep for each run"));
            }
        }
        Ok(())
    }

    /// The keys of the points, sorted (the grid's, or the union over `[[points]]`).
    pub fn point_keys(&self) -> Vec<String> {
        let mut keys: Vec<String> = self.grid.keys().cloned().collect();
        for p in &self.points {
            keys.extend(p.keys().cloned());
        }
        keys.sort();
        keys.dedup();
        keys
    }

    /// The hash of what the sweep computes (everything but `[slurm]`), as 16 hex digits.
    pub fn hash(&self) -> String {
        let canonical = toml::to_string(self).unwrap_or_default();
        let crc = crc::Crc::<u64>::new(&crc::CRC_64_XZ);
        format!("{:016x}", crc.checksum(canonical.as_bytes()))
    }
}

fn is_config_key(key: &str) -> bool {
    let mut parts = key.split('.');
    let ok = |s: Option<&str>| {
        s.is_some_and(|s| !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
    };
    ok(parts.next()) && ok(parts.next()) && parts.next().is_none()
}

/// A value as a command line gives it: strings bare, numbers in their shortest form, anything
/// else (arrays, tables) in TOML.
pub fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Float(f) => float_text(*f),
        other => other.to_string(),
    }
}

fn float_text(f: f64) -> String {
    if f != 0.0 && !(1e-3..1e6).contains(&f.abs()) {
        format!("{f:e}")
    } else {
        format!("{f:?}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SPEC: &str = r#"
command = "train"
args = ["--envs", "4", "--steps", "20000"]
seeds = [1, 2, 3]
[set]
"solver.backend" = "native"
[grid]
"inlet.scale" = [0.6, 0.8, 1.0]
"swarm.max_thrust_n" = [8.5e-7, 2.5e-6]
[slurm]
time = "01:00:00"
"#;

    #[test]
    fn the_spec_example_parses() {
        let s = Spec::parse(SPEC, "spec").unwrap();
        assert_eq!(s.command, SweepCommand::Train);
        assert_eq!(s.seeds, [1, 2, 3]);
        assert_eq!(s.point_keys(), ["inlet.scale", "swarm.max_thrust_n"]);
        assert_eq!(s.slurm.time.as_deref(), Some("01:00:00"));
    }

    #[test]
    fn the_hash_ignores_slurm_options_and_formatting_but_not_values() {
        let a = Spec::parse(SPEC, "a").unwrap();
        let b = Spec::parse(
            &SPEC
                .replace("01:00:00", "09:00:00")
                .replace("[0.6, 0.8, 1.0]", "[ 0.6,0.8,  1.0 ] # scales"),
            "b",
        )
        .unwrap();
        assert_eq!(a.hash(), b.hash());
        let c = Spec::parse(&SPEC.replace("0.6, 0.8", "0.6, 0.7"), "c").unwrap();
        assert_ne!(a.hash(), c.hash());
    }

    #[test]
    fn bad_specs_say_what_to_fix() {
        let cases = [
            (SPEC.replace("\"train\"", "\"simulate\""), "command"),
            (SPEC.replace("seeds = [1, 2, 3]", "seeds = []"), "seeds"),
            (SPEC.replace("seeds = [1, 2, 3]", "seeds = [1, 1]"), "twice"),
            (
                SPEC.replace("\"4\",", "\"4\", \"--seed\", \"3\","),
                "--seed",
            ),
            (SPEC.replace("[0.6, 0.8, 1.0]", "[]"), "no values"),
            (SPEC.replace("\"inlet.scale\" =", "\"scale\" ="), "neither"),
            (
                SPEC.replace("[grid]", "[[points]]\n\"inlet.scale\" = 1.0\n[grid]"),
                "not both",
            ),
            (SPEC.replace("time =", "hours ="), "hours"),
            (
                SPEC.replace("\"swarm.max_thrust_n\"", "\"solver.backend\""),
                "both in [set]",
            ),
        ];
        for (text, needle) in cases {
            let e = Spec::parse(&text, "spec.toml").unwrap_err().to_string();
            assert!(
                e.contains(needle) && e.contains("spec.toml"),
                "{needle}: {e}"
            );
        }
    }

    #[test]
    fn values_read_as_on_a_command_line() {
        assert_eq!(value_text(&toml::Value::Float(8.5e-7)), "8.5e-7");
        assert_eq!(value_text(&toml::Value::Float(0.8)), "0.8");
        assert_eq!(value_text(&toml::Value::Float(1.0)), "1.0");
        assert_eq!(value_text(&toml::Value::Float(2500.0)), "2500.0");
        assert_eq!(value_text(&toml::Value::Integer(64)), "64");
        assert_eq!(value_text(&toml::Value::String("wall".into())), "wall");
        let arr: toml::Value = toml::Value::Array(vec![0.05.into(), 0.00025.into()]);
        assert_eq!(value_text(&arr), "[0.05, 0.00025]");
    }
}

//! A sweep's runs: every point (the grid's cartesian product in key order, the last key
//! fastest, or the `[[points]]` in order) times every seed, run `index = point x seeds + seed
//! index`. Each run has its own readable directory under `runs/`, e.g.
//! `runs/p004_scale=0.8_max_thrust_n=2.5e-6_seed1`, and its command line: fresh (the spec's
//! command and args, `--seed`, the `[set]` and the point's overrides, `--out`) or, for a train
//! run with a checkpoint, `train --resume DIR` with the flags a resumed run accepts.

use std::path::Path;

use super::SweepError;
use super::spec::{Spec, SweepCommand, value_text};
use crate::config::RUN_KEYS;

/// One point of the sweep: its values, one per key of [`Plan::keys`] (None where an explicit
/// point leaves a key out).
#[derive(Clone, Debug, PartialEq)]
pub struct Point {
    /// One value per key of [`Plan::keys`]; None where an explicit point leaves the key out.
    pub values: Vec<Option<toml::Value>>,
}

/// One run: a point at a seed.
#[derive(Clone, Debug, PartialEq)]
pub struct Run {
    /// Run index: point x seeds + seed index (also the task index of a one-run task).
    pub index: usize,
    /// Index of the run's point in [`Plan::points`].
    pub point: usize,
    /// Seed passed as `--seed`.
    pub seed: u64,
    /// Relative to the sweep directory.
    pub dir: String,
}

/// The expanded sweep.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The parsed spec.
    pub spec: Spec,
    /// The point keys, sorted (grid keys or the union over `[[points]]`).
    pub keys: Vec<String>,
    /// The points, in run order.
    pub points: Vec<Point>,
    /// Every point at every seed, in index order.
    pub runs: Vec<Run>,
}

/// Flags of `args` a resumed train run keeps (each takes a value).
const RESUME_FLAGS: [&str; 3] = ["--steps", "--checkpoint-every", "--adapter"];

impl Plan {
    /// Expands `spec` into its points and runs; fails when two runs would share a directory.
    pub fn new(spec: Spec) -> Result<Plan, SweepError> {
        let keys = spec.point_keys();
        let points: Vec<Point> = if spec.points.is_empty() {
            let lists: Vec<&Vec<toml::Value>> = keys.iter().map(|k| &spec.grid[k]).collect();
            let total: usize = lists.iter().map(|l| l.len()).product();
            (0..total)
                .map(|mut i| {
                    let mut values = vec![None; lists.len()];
                    for (slot, list) in values.iter_mut().zip(&lists).rev() {
                        *slot = Some(list[i % list.len()].clone());
                        i /= list.len();
                    }
                    Point { values }
                })
                .collect()
        } else {
            spec.points
                .iter()
                .map(|p| Point {
                    values: keys.iter().map(|k| p.get(k).cloned()).collect(),
                })
                .collect()
        };
        let width = points.len().saturating_sub(1).to_string().len().max(3);
        let mut runs = Vec::with_capacity(points.len() * spec.seeds.len());
        for (p, point) in points.iter().enumerate() {
            let slug = slug(&keys, point);
            for &seed in &spec.seeds {
                runs.push(Run {
                    index: runs.len(),
                    point: p,
                    seed,
                    dir: format!("runs/p{p:0width$}{slug}_seed{seed}"),
                });
            }
        }
        let mut dirs: Vec<&str> = runs.iter().map(|r| r.dir.as_str()).collect();
        dirs.sort();
        if let Some(w) = dirs.windows(2).find(|w| w[0] == w[1]) {
            return Err(SweepError::Plan(format!(
                "two runs share the directory {}",
                w[0]
            )));
        }
        Ok(Plan {
            spec,
            keys,
            points,
            runs,
        })
    }

    /// The point's overrides as `key=value` (configuration keys and flags alike), in key order.
    pub fn overrides(&self, point: usize) -> Vec<String> {
        self.keys
            .iter()
            .zip(&self.points[point].values)
            .filter_map(|(k, v)| v.as_ref().map(|v| format!("{k}={}", value_text(v))))
            .collect()
    }

    /// The point's value of each key as text ("" where it has none), in key order.
    pub fn point_values(&self, point: usize) -> Vec<String> {
        self.points[point]
            .values
            .iter()
            .map(|v| v.as_ref().map(value_text).unwrap_or_default())
            .collect()
    }

    /// The command line of a fresh run (without the program's name).
    pub fn fresh_args(&self, run: &Run, root: &Path) -> Vec<String> {
        let spec = &self.spec;
        let mut a = vec![spec.command.name().to_string()];
        a.extend(spec.args.iter().cloned());
        a.extend(["--seed".to_string(), run.seed.to_string()]);
        for (k, v) in &spec.set {
            a.extend(["--set".to_string(), format!("{k}={}", value_text(v))]);
        }
        for (k, v) in self.keys.iter().zip(&self.points[run.point].values) {
            match v {
                None => {}
                Some(toml::Value::Boolean(true)) if k.starts_with("--") => a.push(k.clone()),
                Some(toml::Value::Boolean(false)) if k.starts_with("--") => {}
                Some(v) if k.starts_with("--") => a.extend([k.clone(), value_text(v)]),
                Some(v) => a.extend(["--set".to_string(), format!("{k}={}", value_text(v))]),
            }
        }
        a.extend([
            "--out".to_string(),
            root.join(&run.dir).display().to_string(),
        ]);
        a
    }

    /// The command line that continues a train run from its checkpoint: `train --resume DIR`
    /// with the budget, checkpoint interval, adapter and the run keys (how the step runs) of the
    /// spec; the rest of the run is in its checkpoint.
    pub fn resume_args(&self, run: &Run, root: &Path) -> Vec<String> {
        debug_assert_eq!(self.spec.command, SweepCommand::Train);
        let mut a = vec![
            "train".to_string(),
            "--resume".to_string(),
            root.join(&run.dir).display().to_string(),
        ];
        let args = &self.spec.args;
        let mut i = 0;
        while i < args.len() {
            let (flag, inline) = match args[i].split_once('=') {
                Some((f, v)) => (f, Some(v.to_string())),
                None => (args[i].as_str(), None),
            };
            if RESUME_FLAGS.contains(&flag) {
                a.push(flag.to_string());
                match inline {
                    Some(v) => a.push(v),
                    None => {
                        if let Some(v) = args.get(i + 1) {
                            a.push(v.clone());
                            i += 1;
                        }
                    }
                }
            }
            i += 1;
        }
        for (k, v) in &self.spec.set {
            if RUN_KEYS.contains(&k.as_str()) {
                a.extend(["--set".to_string(), format!("{k}={}", value_text(v))]);
            }
        }
        for (k, v) in self.keys.iter().zip(&self.points[run.point].values) {
            if let (true, Some(v)) = (RUN_KEYS.contains(&k.as_str()), v) {
                a.extend(["--set".to_string(), format!("{k}={}", value_text(v))]);
            }
        }
        a
    }
}

/// `_scale=0.8_max_thrust_n=2.5e-6`: each key's last part and its value, characters a path
/// should not hold replaced by `-`, at most 80 characters.
fn slug(keys: &[String], point: &Point) -> String {
    let mut s = String::new();
    for (k, v) in keys.iter().zip(&point.values) {
        let Some(v) = v else { continue };
        let short = k.trim_start_matches('-').rsplit('.').next().unwrap_or(k);
        s += &format!("_{short}={}", value_text(v));
    }
    let mut clean: String = s
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._=+-".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect();
    if clean.len() > 80 {
        clean.truncate(80);
    }
    clean
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(text: &str) -> Plan {
        Plan::new(Spec::parse(text, "spec").unwrap()).unwrap()
    }

    const GRID: &str = r#"
command = "train"
args = ["--envs", "2", "--steps=640", "--checkpoint-every", "1", "--no-pcgrad"]
seeds = [1, 2]
[set]
"solver.backend" = "native"
"env.max_steps" = 40
[grid]
"inlet.scale" = [0.6, 0.8, 1.0]
"swarm.max_thrust_n" = [8.5e-7, 2.5e-6]
"#;

    #[test]
    fn the_grid_is_a_product_with_the_last_key_fastest_and_seeds_innermost() {
        let p = plan(GRID);
        assert_eq!(p.points.len(), 6);
        assert_eq!(p.runs.len(), 12);
        assert_eq!(
            p.overrides(1),
            ["inlet.scale=0.6", "swarm.max_thrust_n=2.5e-6"]
        );
        assert_eq!(
            p.overrides(4),
            ["inlet.scale=1.0", "swarm.max_thrust_n=8.5e-7"]
        );
        let r = &p.runs[3];
        assert_eq!((r.index, r.point, r.seed), (3, 1, 2));
        assert_eq!(r.dir, "runs/p001_scale=0.6_max_thrust_n=2.5e-6_seed2");
    }

    #[test]
    fn a_fresh_run_gets_every_override_and_a_resumed_one_only_what_resume_takes() {
        let p = plan(GRID);
        let root = Path::new("/s");
        let fresh = p.fresh_args(&p.runs[3], root).join(" ");
        assert_eq!(
            fresh,
            "train --envs 2 --steps=640 --checkpoint-every 1 --no-pcgrad --seed 2 \
             --set env.max_steps=40 --set solver.backend=native --set inlet.scale=0.6 \
             --set swarm.max_thrust_n=2.5e-6 --out /s/runs/p001_scale=0.6_max_thrust_n=2.5e-6_seed2"
        );
        let resumed = p.resume_args(&p.runs[3], root).join(" ");
        assert_eq!(
            resumed,
            "train --resume /s/runs/p001_scale=0.6_max_thrust_n=2.5e-6_seed2 --steps 640 \
             --checkpoint-every 1 --set solver.backend=native"
        );
    }

    #[test]
    fn flags_as_keys_and_explicit_points() {
        let p = plan(
            r#"
command = "rollout"
args = ["--episodes", "4"]
[[points]]
"--policy" = "wall-angle:30"
"inlet.scale" = 0.9
[[points]]
"--policy" = "zero"
"--no-traces" = true
"#,
        );
        assert_eq!(p.keys, ["--no-traces", "--policy", "inlet.scale"]);
        assert_eq!(p.runs.len(), 2);
        assert_eq!(
            p.runs[0].dir,
            "runs/p000_policy=wall-angle-30_scale=0.9_seed0"
        );
        let a = p.fresh_args(&p.runs[0], Path::new("d")).join(" ");
        assert_eq!(
            a,
            "rollout --episodes 4 --seed 0 --policy wall-angle:30 --set inlet.scale=0.9 --out d/runs/p000_policy=wall-angle-30_scale=0.9_seed0"
        );
        let b = p.fresh_args(&p.runs[1], Path::new("d")).join(" ");
        assert!(b.contains("--no-traces --policy zero --out"), "{b}");
        assert_eq!(p.point_values(1), ["true", "zero", ""]);
    }

    #[test]
    fn no_grid_is_one_point() {
        let p = plan("command = \"eval\"\nseeds = [5, 6]\n");
        assert_eq!(p.points.len(), 1);
        assert_eq!(p.runs[1].dir, "runs/p000_seed6");
    }
}

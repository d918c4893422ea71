//! The Slurm job array (`sweep --slurm`): `DIR/sweep.sbatch`, one array task per run (or, when
//! the sweep has more runs than the cluster's `MaxArraySize`, `pack` consecutive runs per
//! task). Each task `exec`s `<exe> sweep --task I --pack P --out DIR`, which runs its runs
//! in-process: so Slurm's signals (`--signal=B:TERM@120` before the time limit, SIGTERM on
//! `scancel`, preemption or `scontrol requeue`) reach the run itself, which writes a
//! checkpoint and records itself pending; `--requeue` lets Slurm run the task again, and the
//! task then resumes the run from that checkpoint. `--open-mode=append` keeps every attempt's
//! output in one file per task, `logs/task-<array job>_<index>.out`.

use std::path::Path;

use super::SweepError;
use super::spec::SlurmOptions;

/// The array's shape: `tasks` tasks of `pack` runs each (the last may hold fewer).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Number of array tasks.
    pub tasks: usize,
    /// Consecutive runs per task.
    pub pack: usize,
}

/// Slurm's default `MaxArraySize`: indices 0 to 1000.
pub const DEFAULT_MAX_ARRAY_SIZE: usize = 1001;

impl Shape {
    /// The smallest pack that fits `runs` runs into at most `max_array_size` tasks.
    pub fn new(runs: usize, max_array_size: usize) -> Shape {
        let max = max_array_size.max(1);
        let pack = runs.div_ceil(max).max(1);
        Shape {
            tasks: runs.div_ceil(pack),
            pack,
        }
    }

    /// The runs of task `task`.
    pub fn runs_of(&self, task: usize, runs: usize) -> std::ops::Range<usize> {
        (task * self.pack).min(runs)..((task + 1) * self.pack).min(runs)
    }
}

/// The text of `sweep.sbatch` for a sweep of `runs` runs in `root` (absolute), run by `exe`.
pub fn script(
    root: &Path,
    exe: &Path,
    runs: usize,
    opts: &SlurmOptions,
) -> Result<String, SweepError> {
    if runs == 0 {
        return Err(SweepError::Slurm("the sweep has no runs".into()));
    }
    if root.display().to_string().chars().any(char::is_whitespace) {
        return Err(SweepError::Slurm(format!(
            "{}: #SBATCH lines cannot hold a path with spaces; choose an --out without them",
            root.display()
        )));
    }
    let shape = Shape::new(runs, opts.max_array_size.unwrap_or(DEFAULT_MAX_ARRAY_SIZE));
    let quote = |p: &Path| shell_quote(&p.display().to_string());
    let name = root
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    let mut s = String::from("#!/bin/bash\n");
    s += "# fluxswarm-gpu sweep: one array task per run (docs/experiments.md, \"Sweeps on Slurm\").\n";
    s += &format!(
        "# Submit with: sbatch {}\n",
        quote(&root.join("sweep.sbatch"))
    );
    let mut line = |l: String| s += &format!("#SBATCH {l}\n");
    line(format!("--job-name=fluxswarm-{}", sanitize(&name)));
    let array = match opts.max_running {
        Some(k) => format!("0-{}%{k}", shape.tasks - 1),
        None => format!("0-{}", shape.tasks - 1),
    };
    line(format!("--array={array}"));
    line(format!(
        "--cpus-per-task={}",
        opts.cpus_per_task.unwrap_or(2)
    ));
    if let Some(g) = opts.gpus.filter(|&g| g > 0) {
        line(format!("--gres=gpu:{g}"));
    }
    for (flag, v) in [
        ("time", &opts.time),
        ("partition", &opts.partition),
        ("account", &opts.account),
        ("mem", &opts.mem),
    ] {
        if let Some(v) = v {
            line(format!("--{flag}={v}"));
        }
    }
    line(format!(
        "--output={}",
        root.join("logs").join("task-%A_%a.out").display()
    ));
    line("--open-mode=append".into());
    line("--requeue".into());
    line("--signal=B:TERM@120".into());
    for extra in &opts.extra {
        line(extra.trim().to_string());
    }
    s += "\nset -eu\n";
    s += "export RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-1}\"\n";
    s += &format!(
        "exec {} sweep --task \"$SLURM_ARRAY_TASK_ID\" --pack {} --out {}\n",
        quote(exe),
        shape.pack,
        quote(root)
    );
    Ok(s)
}

fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "._-".contains(c) {
                c
            } else {
                '-'
            }
        })
        .collect()
}

fn shell_quote(s: &str) -> String {
    if s.chars()
        .all(|c| c.is_ascii_alphanumeric() || "/._-+=:".contains(c))
    {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sweeps_past_max_array_size_pack_runs_into_tasks() {
        assert_eq!(Shape::new(4, 1001), Shape { tasks: 4, pack: 1 });
        assert_eq!(
            Shape::new(1001, 1001),
            Shape {
                tasks: 1001,
                pack: 1
            }
        );
        assert_eq!(
            Shape::new(1002, 1001),
            Shape {
                tasks: 501,
                pack: 2
            }
        );
        assert_eq!(
            Shape::new(5000, 1001),
            Shape {
                tasks: 1000,
                pack: 5
            }
        );
        let s = Shape::new(5000, 1001);
        assert_eq!(s.runs_of(999, 5000), 4995..5000);
        let covered: usize = (0..s.tasks).map(|t| s.runs_of(t, 5000).len()).sum();
        assert_eq!(covered, 5000);
    }

    #[test]
    fn the_script_has_the_array_the_signal_and_the_exec() {
        let opts = SlurmOptions {
            gpus: Some(1),
            time: Some("02:00:00".into()),
            partition: Some("gpu".into()),
            max_running: Some(8),
            extra: vec!["--qos=long".into()],
            ..SlurmOptions::default()
        };
        let s = script(
            Path::new("/scratch/sw1"),
            Path::new("/opt/my bin/fluxswarm-gpu"),
            12,
            &opts,
        )
        .unwrap();
        for want in [
            "#SBATCH --array=0-11%8\n",
            "#SBATCH --cpus-per-task=2\n",
            "#SBATCH --gres=gpu:1\n",
            "#SBATCH --time=02:00:00\n",
            "#SBATCH --partition=gpu\n",
            "#SBATCH --requeue\n",
            "#SBATCH --signal=B:TERM@120\n",
            "#SBATCH --open-mode=append\n",
            "#SBATCH --qos=long\n",
            "#SBATCH --output=/scratch/sw1/logs/task-%A_%a.out\n",
            "#SBATCH --job-name=fluxswarm-sw1\n",
            "exec '/opt/my bin/fluxswarm-gpu' sweep --task \"$SLURM_ARRAY_TASK_ID\" --pack 1 --out /scratch/sw1\n",
        ] {
            assert!(s.contains(want), "missing {want:?} in\n{s}");
        }
        assert!(!s.contains("--account"));
        let e = script(Path::new("/a b"), Path::new("/x"), 1, &opts).unwrap_err();
        assert!(e.to_string().contains("spaces"), "{e}");
    }
}

//! The sweep's Slurm path against a real single-node Slurm (scripts/slurm-local.sh, started by
//! scripts/test and CI, which set FLUXSWARM_SLURM=1 and SLURM_CONF): a 4-task job array of tiny
//! train runs ends with every run `done`, and a running task requeued with `scontrol requeue`
//! resumes its run from the checkpoint its SIGTERM wrote instead of starting again. Without
//! FLUXSWARM_SLURM=1 the test says it is skipped (CI sets FLUXSWARM_REQUIRE_SLURM=1 so that a
//! Slurm that cannot start fails the run instead).

mod common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::cli::{SWEEP_SET, bin, text};

fn spec_text() -> String {
    format!(
        r#"command = "train"
args = ["--envs", "2", "--checkpoint-every", "1"]
seeds = [1, 2]
{SWEEP_SET}[grid]
"--steps" = [16, 4000]
"#
    )
}

fn record(root: &Path, dir: &str) -> toml::Table {
    std::fs::read_to_string(root.join(dir).join("sweep-task.toml"))
        .ok()
        .and_then(|t| t.parse().ok())
        .unwrap_or_default()
}

fn str_of<'a>(t: &'a toml::Table, key: &str) -> &'a str {
    t.get(key).and_then(|v| v.as_str()).unwrap_or("")
}

/// Cancels the job array when the test ends, however it ends.
struct Cancel(String);

impl Drop for Cancel {
    fn drop(&mut self) {
        let _ = Command::new("scancel").arg(&self.0).status();
    }
}

fn wait_for(what: &str, mut done: impl FnMut() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(
            start.elapsed() < Duration::from_secs(600),
            "guard: {what} not within 10 min"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn a_slurm_job_array_runs_every_point_and_a_requeued_task_resumes() {
    if std::env::var("FLUXSWARM_SLURM").as_deref() != Ok("1") {
        eprintln!(
            "skipped: no local Slurm (scripts/test starts one with scripts/slurm-local.sh and \
             sets FLUXSWARM_SLURM=1)"
        );
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let spec = tmp.path().join("spec.toml");
    std::fs::write(&spec, spec_text()).unwrap();
    let root = tmp.path().join("sw");
    let root_s = root.to_str().unwrap();
    let o = bin(&[
        "sweep",
        spec.to_str().unwrap(),
        "--out",
        root_s,
        "--slurm",
        "--submit",
        "--cpus-per-task",
        "1",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let job = String::from_utf8_lossy(&o.stdout).trim().to_string();
    assert!(
        job.parse::<u64>().is_ok(),
        "sbatch --parsable printed {job:?}"
    );
    let _cancel = Cancel(job.clone());
    let dirs: Vec<String> = std::fs::read_to_string(root.join("sweep.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(3).unwrap().to_string())
        .collect();
    assert_eq!(dirs.len(), 4);
    // Requeue a long run (4,000 steps) once it runs and has a checkpoint.
    let long = dirs
        .iter()
        .find(|d| d.contains("steps=4000"))
        .unwrap()
        .clone();
    wait_for("the long run checkpointing under Slurm", || {
        let r = record(&root, &long);
        str_of(&r, "status") == "running"
            && !fluxswarm_gpu::checkpoint::list(&root.join(&long).join("checkpoints")).is_empty()
    });
    let task = str_of(&record(&root, &long), "slurm_task").to_string();
    assert!(task.starts_with(&format!("{job}_")), "{task}");
    let o = Command::new("scontrol")
        .args(["requeue", &task])
        .output()
        .unwrap();
    assert!(o.status.success(), "scontrol requeue {task}: {}", text(&o));
    wait_for("every run done", || {
        let o = bin(&["sweep", "--status", "--out", root_s]);
        text(&o).contains("4 done")
    });
    let csv = std::fs::read_to_string(root.join("sweep.csv")).unwrap();
    assert_eq!(
        csv.lines().skip(1).filter(|l| l.contains(",done,")).count(),
        4,
        "{csv}"
    );
    let r = record(&root, &long);
    assert_eq!(r["attempts"].as_integer(), Some(2), "{r:?}");
    let from = r["resumed_from_update"].as_integer().unwrap();
    assert!(from > 0, "{r:?}");
    // Resumed, not restarted: one row per update of the 4,000-step run, none twice.
    let updates = std::fs::read_to_string(root.join(&long).join("updates.csv")).unwrap();
    let numbers: Vec<u64> = updates
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(numbers, (1..=500).collect::<Vec<u64>>());
    let log = std::fs::read_dir(root.join("logs"))
        .unwrap()
        .flatten()
        .map(|e| std::fs::read_to_string(e.path()).unwrap_or_default())
        .find(|t| t.contains(&long) && t.contains("(attempt 2)"))
        .expect("the requeued task's log holds both attempts");
    assert!(log.contains("interrupted by SIGTERM"), "{log}");
    assert!(
        log.contains(&format!("resuming {}", root.join(&long).display())),
        "{log}"
    );
}

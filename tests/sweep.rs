//! `fluxswarm-gpu sweep` on the local pool, as a user meets it: a sweep of tiny runs ends with
//! every run `done` and a second call redoes nothing; a sweep stopped by SIGTERM or killed
//! (kill -9) resumes, its interrupted train runs continued with --resume to the same logs as
//! an uninterrupted sweep; a failing run is recorded with its error and the others go on; a
//! changed spec is refused; `--slurm` writes the job array. (The real Slurm is in
//! tests/sweep_slurm.rs.)

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::cli::{SWEEP_SET, bin, text};

/// A tiny train sweep: 2 environments, 4-step rollouts in a 30 mm channel, `steps` global
/// steps, a checkpoint every update.
fn train_spec(steps: u32, grid: &str, seeds: &str) -> String {
    format!(
        r#"command = "train"
args = ["--envs", "2", "--steps", "{steps}", "--checkpoint-every", "1"]
seeds = {seeds}
{SWEEP_SET}[grid]
{grid}
"#
    )
}

const FOUR_POINTS: &str = "\"swarm.max_thrust_n\" = [8.5e-7, 2.5e-6]\n\"inlet.scale\" = [0.5, 1.0]";

fn write_spec(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn table(root: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(root.join("sweep.csv")).unwrap();
    text.lines()
        .map(|l| l.split(',').map(String::from).collect())
        .collect()
}

fn statuses(root: &Path) -> Vec<String> {
    table(root)[1..].iter().map(|r| r[2].clone()).collect()
}

fn record(root: &Path, dir: &str) -> toml::Table {
    let text = std::fs::read_to_string(root.join(dir).join("sweep-task.toml")).unwrap();
    text.parse().unwrap()
}

fn run_dirs(root: &Path) -> Vec<String> {
    table(root)[1..].iter().map(|r| r[3].clone()).collect()
}

fn sweep(args: &[&str]) -> std::process::Output {
    let mut a = vec!["sweep"];
    a.extend_from_slice(args);
    bin(&a)
}

/// updates.csv without its two timing columns.
fn updates_without_timing(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("updates.csv"))
        .unwrap()
        .lines()
        .map(|l| l.rsplitn(3, ',').nth(2).unwrap_or(l).to_string())
        .collect()
}

#[test]
fn a_local_sweep_finishes_every_point_and_a_second_call_redoes_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = write_spec(tmp.path(), "spec.toml", &train_spec(16, FOUR_POINTS, "[3]"));
    let root = tmp.path().join("sw");
    let (spec_s, root_s) = (spec.to_str().unwrap(), root.to_str().unwrap());
    let o = sweep(&[spec_s, "--out", root_s, "--jobs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    let t = table(&root);
    assert_eq!(
        t[0].join(","),
        "point,seed,status,dir,overrides,inlet.scale,swarm.max_thrust_n,commit,backend,threads,host"
    );
    assert_eq!(statuses(&root), ["done"; 4]);
    assert_eq!(t[2][3], "runs/p001_scale=0.5_max_thrust_n=2.5e-6_seed3");
    assert_eq!(t[2][4], "inlet.scale=0.5 swarm.max_thrust_n=2.5e-6");
    assert_eq!((t[2][5].as_str(), t[2][6].as_str()), ("0.5", "2.5e-6"));
    assert_eq!(t[2][8], "native");
    assert_eq!(t[2][9], "1", "2 jobs on 2 cores: one thread each");
    for dir in run_dirs(&root) {
        // Each run got its own overrides and seed.
        let config = std::fs::read_to_string(root.join(&dir).join("config.toml")).unwrap();
        assert!(config.lines().next().unwrap().contains("seed 3,"), "{dir}");
        let scale = if dir.contains("scale=0.5") {
            "0.5"
        } else {
            "1.0"
        };
        assert!(
            config.contains(&format!("scale = {scale}")),
            "{dir}: {config}"
        );
        assert_eq!(record(&root, &dir)["attempts"].as_integer(), Some(1));
    }
    // Again: nothing to do, nothing rerun.
    let o = sweep(&[spec_s, "--out", root_s]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("0 runs to do"), "{}", text(&o));
    for dir in run_dirs(&root) {
        assert_eq!(record(&root, &dir)["attempts"].as_integer(), Some(1));
    }
    // --status and a resume without the spec read the directory's own copy.
    let o = sweep(&["--status", "--out", root_s]);
    assert!(
        text(&o).contains("4 runs of `train`: 4 done"),
        "{}",
        text(&o)
    );
    // report --sweep: one row per point, and a heatmap for the two keys.
    let rep = tmp.path().join("report");
    let o = bin(&["report", "--sweep", root_s, "--out", rep.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    let md = std::fs::read_to_string(rep.join("report.md")).unwrap();
    assert_eq!(
        md.lines()
            .filter(|l| l.starts_with("| ") && l.contains(" | 1/1 | "))
            .count(),
        4,
        "{md}"
    );
    for f in [
        "sweep_points.csv",
        "sweep_heatmap.png",
        "sweep_heatmap_progress.png",
    ] {
        assert!(rep.join(f).is_file(), "{f}");
    }
    // A changed spec is refused, naming both hashes and the way out.
    let changed = write_spec(
        tmp.path(),
        "changed.toml",
        &train_spec(16, &FOUR_POINTS.replace("0.5", "0.6"), "[3]"),
    );
    let o = sweep(&[changed.to_str().unwrap(), "--out", root_s]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("different spec") && t.contains("sweep.toml"),
        "{t}"
    );
}

/// Starts a sweep of two 800-step train runs and returns the child (piped output).
fn start_sweep(spec: &Path, root: &Path) -> std::process::Child {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"));
    cmd.args([
        "sweep",
        spec.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--jobs",
        "2",
    ])
    .env("RUST_LOG", "info")
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    common::cli::default_sighup(&mut cmd);
    cmd.spawn().unwrap()
}

fn every_run_has_a_checkpoint(root: &Path) -> bool {
    let runs = root.join("runs");
    let dirs: Vec<_> = std::fs::read_dir(&runs)
        .into_iter()
        .flatten()
        .flatten()
        .collect();
    dirs.len() == 2
        && dirs
            .iter()
            .all(|d| !fluxswarm_gpu::checkpoint::list(&d.path().join("checkpoints")).is_empty())
}

const TWO_POINTS: &str = "\"swarm.max_thrust_n\" = [8.5e-7, 2.5e-6]";

#[cfg(unix)]
#[test]
fn a_sigterm_stopped_sweep_resumes_to_the_uninterrupted_result() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = write_spec(tmp.path(), "spec.toml", &train_spec(800, TWO_POINTS, "[4]"));
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let child = start_sweep(&spec, &b);
    let o = common::cli::signal_after(child, &[libc::SIGTERM], || every_run_has_a_checkpoint(&b));
    assert_eq!(o.status.code(), Some(143), "{}", text(&o));
    assert!(text(&o).contains("resume with"), "{}", text(&o));
    assert_eq!(statuses(&b), ["pending"; 2]);
    for dir in run_dirs(&b) {
        let r = record(&b, &dir);
        let error = r["error"].as_str().unwrap();
        assert!(error.contains("interrupted by SIGTERM"), "{dir}: {error}");
    }
    let o = sweep(&["--out", b.to_str().unwrap(), "--jobs", "2"]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(statuses(&b), ["done"; 2]);
    let o = sweep(&[
        spec.to_str().unwrap(),
        "--out",
        a.to_str().unwrap(),
        "--jobs",
        "2",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for dir in run_dirs(&b) {
        let r = record(&b, &dir);
        assert_eq!(r["attempts"].as_integer(), Some(2), "{dir}");
        assert!(r["resumed_from_update"].as_integer().unwrap() > 0, "{dir}");
        assert_eq!(
            updates_without_timing(&a.join(&dir)),
            updates_without_timing(&b.join(&dir))
        );
        let episodes = |root: &Path| std::fs::read(root.join(&dir).join("episodes.csv")).unwrap();
        assert_eq!(episodes(&a), episodes(&b), "{dir}");
    }
}

/// kill -9 of the pool: each task sees its parent gone, sends itself one SIGTERM, checkpoints
/// and records itself pending; the next call resumes them.
#[cfg(unix)]
#[test]
fn a_killed_sweep_resumes() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = write_spec(tmp.path(), "spec.toml", &train_spec(800, TWO_POINTS, "[4]"));
    let root = tmp.path().join("k");
    let child = start_sweep(&spec, &root);
    let o = common::cli::signal_after(child, &[libc::SIGKILL], || {
        every_run_has_a_checkpoint(&root)
    });
    assert_eq!(o.status.code(), None, "killed: {}", text(&o));
    // The orphaned tasks finish their update and record themselves (a guard, not a timing).
    let start = std::time::Instant::now();
    let still_running = |d: &String| {
        let r = record(&root, d);
        let pid = r["pid"].as_integer().unwrap_or(0) as libc::pid_t;
        // SAFETY: signal 0 only asks whether the process exists.
        r["status"].as_str() == Some("running") && unsafe { libc::kill(pid, 0) } == 0
    };
    while run_dirs(&root).iter().any(still_running) {
        assert!(
            start.elapsed().as_secs() < 600,
            "the tasks never recorded their stop"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let o = sweep(&["--out", root.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(statuses(&root), ["done"; 2]);
    for dir in run_dirs(&root) {
        let r = record(&root, &dir);
        assert!(r["resumed_from_update"].as_integer().unwrap() > 0, "{dir}");
        let log = std::fs::read_to_string(
            root.join("logs")
                .join(format!("{}.log", dir.trim_start_matches("runs/"))),
        )
        .unwrap();
        assert!(
            log.contains("pool (pid") && log.contains("interrupted by SIGTERM"),
            "{log}"
        );
        let updates = updates_without_timing(&root.join(&dir));
        assert_eq!(
            updates.len(),
            1 + 100,
            "{dir}: one row per update, none twice"
        );
    }
}

#[test]
fn a_failing_run_is_recorded_and_the_others_go_on() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = format!(
        r#"command = "rollout"
args = ["--episodes", "1", "--envs", "1", "--no-traces"]
{SWEEP_SET}[grid]
"--policy" = ["/nonexistent/policy.safetensors", "zero", "wall-angle:30"]
"#
    );
    let spec = write_spec(tmp.path(), "spec.toml", &spec);
    let root = tmp.path().join("f");
    let o = sweep(&[
        spec.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--jobs",
        "1",
    ]);
    assert!(!o.status.success());
    let t = text(&o);
    assert!(
        t.contains("1 of 3 runs failed") && t.contains("re-running"),
        "{t}"
    );
    assert_eq!(statuses(&root), ["failed", "done", "done"]);
    let dirs = run_dirs(&root);
    let error = record(&root, &dirs[0])["error"]
        .as_str()
        .unwrap()
        .to_string();
    assert!(error.contains("/nonexistent/policy.safetensors"), "{error}");
    assert!(t.contains(&error), "the error is printed: {t}");
    // A typo in a key fails before anything runs, naming the point.
    let typo = write_spec(
        tmp.path(),
        "typo.toml",
        &train_spec(16, "\"inlet.scal\" = [0.5]", "[1]"),
    );
    let o = sweep(&[
        typo.to_str().unwrap(),
        "--out",
        tmp.path().join("t").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("point 0 (inlet.scal=0.5)"),
        "{}",
        text(&o)
    );
    assert!(!tmp.path().join("t").join("runs").exists());
    // The check reads a point's flags as train does: --no-pcgrad allows unequal weights.
    let weighted = write_spec(
        tmp.path(),
        "weighted.toml",
        &train_spec(
            16,
            "\"--no-pcgrad\" = [true]\n\"train.objective_weights\" = [[1.0, 0.0, 0.0]]",
            "[1]",
        ),
    );
    let o = sweep(&[
        weighted.to_str().unwrap(),
        "--out",
        tmp.path().join("w").to_str().unwrap(),
        "--dry-run",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("--no-pcgrad --set train.objective_weights=[1.0, 0.0, 0.0]"),
        "{}",
        text(&o)
    );
}

#[test]
fn slurm_mode_writes_a_job_array_of_one_task_per_run() {
    let tmp = tempfile::tempdir().unwrap();
    let spec = write_spec(
        tmp.path(),
        "spec.toml",
        &train_spec(16, TWO_POINTS, "[1, 2]"),
    );
    let root = tmp.path().join("s");
    let o = sweep(&[
        spec.to_str().unwrap(),
        "--out",
        root.to_str().unwrap(),
        "--slurm",
        "--time",
        "00:10:00",
        "--cpus-per-task",
        "1",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let script = std::fs::read_to_string(root.join("sweep.sbatch")).unwrap();
    for want in [
        "#SBATCH --array=0-3\n",
        "#SBATCH --cpus-per-task=1\n",
        "#SBATCH --time=00:10:00\n",
        "#SBATCH --signal=B:TERM@120\n",
        "#SBATCH --requeue\n",
        " sweep --task \"$SLURM_ARRAY_TASK_ID\" --pack 1 --out ",
    ] {
        assert!(script.contains(want), "{want:?} missing:\n{script}");
    }
    assert_eq!(statuses(&root), ["pending"; 4]);
    // A task run by hand (as Slurm would) runs its run and records it.
    let o = sweep(&["--task", "2", "--out", root.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(statuses(&root), ["pending", "pending", "done", "pending"]);
    let o = sweep(&["--task", "4", "--out", root.to_str().unwrap()]);
    assert!(
        text(&o).contains("outside this sweep's 4 tasks"),
        "{}",
        text(&o)
    );
}

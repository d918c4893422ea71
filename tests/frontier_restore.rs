//! `experiments/frontier_learners.sh`'s `restore` stage, as a fresh checkout meets it: the
//! committed results of issue 19's sweep (`assets/results/frontier_learners/`) rebuild an empty
//! sweep directory with every done run marked done (so no worker trains it again) and every
//! complete evaluation, comparator and kept policy snapshot in place; a second call changes
//! nothing; a row of another sweep is skipped with a message. The `results` stage keeps the
//! snapshots of the curve's points only.

use std::path::Path;
use std::process::{Command, Output};

const RESULTS: &str = "assets/results/frontier_learners";

/// The script's STAGE between the sweep directory and the results directory.
fn stage(stage: &str, sweep: &Path, results: &Path, env: &[(&str, &str)]) -> Output {
    let root = env!("CARGO_MANIFEST_DIR");
    Command::new("bash")
        .arg(Path::new(root).join("experiments/frontier_learners.sh"))
        .arg(sweep)
        .env("FRONTIER_STAGES", stage)
        .env("FRONTIER_RESULTS", results)
        .env("FLUXSWARM_BIN", env!("CARGO_BIN_EXE_fluxswarm-gpu"))
        .envs(env.iter().copied())
        .current_dir(root)
        .output()
        .expect("bash runs")
}

fn restore(sweep: &Path, results: &Path) -> Output {
    stage("restore", sweep, results, &[])
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `(status, dir)` of each row of a `sweep.csv` (the two columns before the quoted overrides).
fn rows(csv: &Path) -> Vec<(String, String)> {
    std::fs::read_to_string(csv)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.splitn(5, ',').collect();
            (f[2].to_string(), f[3].to_string())
        })
        .collect()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

#[test]
fn restore_rebuilds_the_sweep_from_committed_results_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    // A copy of the committed results with one row of another sweep added.
    let results = tmp.path().join("results");
    copy_dir(&root.join(RESULTS), &results);
    let committed = rows(&results.join("sweep.csv"));
    let done: Vec<&String> = committed
        .iter()
        .filter(|r| r.0 == "done")
        .map(|r| &r.1)
        .collect();
    assert!(!done.is_empty(), "the committed sweep has done runs");
    let stray = "runs/p099_elsewhere_seed1";
    let mut csv = std::fs::read_to_string(results.join("sweep.csv")).unwrap();
    csv.push_str(&format!("99,1,done,{stray},,,,,,,,,,,,abc,native,1,vm\n"));
    std::fs::write(results.join("sweep.csv"), csv).unwrap();

    let sweep = tmp.path().join("sweep");
    let o = restore(&sweep, &results);
    assert!(o.status.success(), "{}", stderr(&o));
    let said = stderr(&o);
    assert!(
        said.contains(&format!("restore: {} run(s) restored", done.len())),
        "{said}"
    );
    assert!(said.contains(&format!("{stray} is not a run of")), "{said}");
    assert!(!sweep.join(stray).exists());

    // Every committed done run reads as done, with its curve, and the pending ones stay so.
    let restored = rows(&sweep.join("sweep.csv"));
    assert_eq!(restored.len(), committed.len());
    for (status, dir) in &restored {
        let was_done = done.contains(&dir);
        assert_eq!(status == "done", was_done, "{dir}: {status}");
        if was_done {
            let name = Path::new(dir).file_name().unwrap();
            assert_eq!(
                std::fs::read(sweep.join(dir).join("episodes.csv")).unwrap(),
                std::fs::read(results.join("runs").join(name).join("episodes.csv")).unwrap()
            );
            let record = std::fs::read_to_string(sweep.join(dir).join("sweep-task.toml")).unwrap();
            assert!(record.contains("status = \"done\""), "{record}");
        }
    }
    // The complete evaluations and comparators are back where the eval stage looks.
    for d in ["eval", "comparators"] {
        for e in std::fs::read_dir(results.join(d)).unwrap() {
            let name = e.unwrap().file_name();
            assert!(sweep.join(d).join(&name).exists(), "{d}/{name:?}");
        }
    }

    // Every kept policy snapshot is back in its run's policies/, byte for byte.
    if let Ok(kept) = std::fs::read_dir(results.join("snapshots")) {
        for run in kept.map(|e| e.unwrap().path()).filter(|p| p.is_dir()) {
            for f in std::fs::read_dir(&run).unwrap() {
                let f = f.unwrap();
                let back = sweep
                    .join("runs")
                    .join(run.file_name().unwrap())
                    .join("policies")
                    .join(f.file_name());
                assert_eq!(
                    std::fs::read(&back).unwrap(),
                    std::fs::read(f.path()).unwrap()
                );
            }
        }
    }

    // Again: nothing to do, nothing overwritten.
    let record = sweep.join(done[0]).join("sweep-task.toml");
    std::fs::write(&record, "status = \"done\"\nhost = \"kept\"\n").unwrap();
    let o = restore(&sweep, &results);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("restore: 0 run(s) restored"),
        "{}",
        stderr(&o)
    );
    assert!(std::fs::read_to_string(&record).unwrap().contains("kept"));
}

#[test]
fn restore_without_results_says_so_and_fails() {
    let tmp = tempfile::tempdir().unwrap();
    let o = restore(&tmp.path().join("sweep"), &tmp.path().join("none"));
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("sweep.csv is missing"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn results_keep_only_the_curve_points_snapshots_and_restore_brings_them_back() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let sweep = tmp.path().join("sweep");
    let o = restore(&sweep, &root.join(RESULTS));
    assert!(o.status.success(), "{}", stderr(&o));
    // One done run of point 0 and one of point 3 get a snapshot each (the bytes need not be a
    // policy: results and restore only copy them).
    let done: Vec<String> = rows(&sweep.join("sweep.csv"))
        .into_iter()
        .filter(|r| r.0 == "done")
        .map(|r| r.1)
        .collect();
    let of_point = |p: &str| done.iter().find(|d| d.starts_with(p)).unwrap().clone();
    let (kept, dropped) = (of_point("runs/p003_"), of_point("runs/p000_"));
    for (dir, bytes) in [
        (&kept, b"kept".as_slice()),
        (&dropped, b"dropped".as_slice()),
    ] {
        let policies = sweep.join(dir).join("policies");
        std::fs::create_dir_all(&policies).unwrap();
        std::fs::write(policies.join("update-0000007.safetensors"), bytes).unwrap();
    }

    let results = tmp.path().join("results");
    let o = stage(
        "results",
        &sweep,
        &results,
        &[("FRONTIER_CURVE_POINTS", "3")],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let name = |d: &String| Path::new(d).file_name().unwrap().to_owned();
    let snap = |run| {
        results
            .join("snapshots")
            .join(run)
            .join("update-0000007.safetensors")
    };
    assert_eq!(std::fs::read(snap(name(&kept))).unwrap(), b"kept");
    assert!(
        !snap(name(&dropped)).exists(),
        "point 0 is not a curve point"
    );

    // A fresh sweep directory gets the kept snapshot back, and only it.
    let fresh = tmp.path().join("fresh");
    let o = restore(&fresh, &results);
    assert!(o.status.success(), "{}", stderr(&o));
    let back = |d: &String| fresh.join(d).join("policies/update-0000007.safetensors");
    assert_eq!(std::fs::read(back(&kept)).unwrap(), b"kept");
    assert!(!back(&dropped).exists());
}

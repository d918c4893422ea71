//! The long commands where no terminal is and under a signal: without a TTY, `train` prints
//! plain progress lines on stderr (every update with `FLUXSWARM_PROGRESS_SECS=0`, else the
//! first and the last at least), and SIGTERM stops `rollout` and `simulate` after the step in
//! hand with status 143 and every file they were writing flushed and whole. (SIGTERM and
//! SIGINT during `train`, and resuming after them, are in `tests/checkpoints.rs`.)

mod common;

use std::path::Path;

use common::cli::{SMALL_SWARM, bin_env, text};

/// `train` of 4 updates of 2 x 4 steps; `vars` for its environment.
fn train(out: &Path, vars: &[(&str, &str)]) -> std::process::Output {
    let args = [
        "train",
        "--envs",
        "2",
        "--steps",
        "32",
        "--seed",
        "5",
        "--out",
        out.to_str().unwrap(),
        "--set",
        "train.rollout_steps=4",
        "--set",
        "train.minibatches=2",
    ];
    let o = bin_env(&[&args[..], SMALL_SWARM].concat(), vars);
    assert!(o.status.success(), "{}", text(&o));
    // Only the directory goes to stdout, for scripts that capture it.
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        out.to_str().unwrap()
    );
    o
}

fn progress_lines(o: &std::process::Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stderr)
        .lines()
        .filter(|l| l.starts_with("train: "))
        .map(str::to_string)
        .collect()
}

#[test]
fn train_without_a_terminal_prints_plain_progress_lines() {
    let dir = tempfile::tempdir().unwrap();
    let o = train(
        &dir.path().join("every"),
        &[("FLUXSWARM_PROGRESS_SECS", "0")],
    );
    let lines = progress_lines(&o);
    assert_eq!(lines.len(), 4, "one line per update: {}", text(&o));
    for (i, l) in lines.iter().enumerate() {
        let head = format!(
            "train: {}/32 steps ({:.1} %), ",
            8 * (i + 1),
            25.0 * (i + 1) as f64
        );
        assert!(l.starts_with(&head), "{l:?} should start with {head:?}");
        assert!(
            l.contains(" steps/s, eta ") && l.contains(&format!("update {}", i + 1)),
            "{l}"
        );
    }
    assert!(lines[3].contains("eta 0s"), "{}", lines[3]);

    // The default interval (10 s) still gives the first update's line and the last one.
    let o = train(&dir.path().join("default"), &[]);
    let lines = progress_lines(&o);
    assert!(
        (2..=4).contains(&lines.len())
            && lines[0].starts_with("train: 8/32 steps")
            && lines[lines.len() - 1].starts_with("train: 32/32 steps (100.0 %)"),
        "{}",
        text(&o)
    );
}

/// Lines of `path`, checked to be whole: a newline at the end and the header's field count on
/// every line.
#[cfg(unix)]
fn whole_csv(path: &Path) -> Vec<String> {
    let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(s.ends_with('\n'), "{} ends mid-line", path.display());
    let lines: Vec<String> = s.lines().map(str::to_string).collect();
    let fields = lines[0].split(',').count();
    for l in &lines {
        assert_eq!(l.split(',').count(), fields, "{}: {l}", path.display());
    }
    lines
}

/// The number N in "interrupted by SIGTERM: N of ...", checked to be the whole message's.
#[cfg(unix)]
fn stopped_after(o: &std::process::Output, what: &str) -> usize {
    let t = text(o);
    assert_eq!(o.status.code(), Some(143), "{t}");
    let line = t
        .lines()
        .find(|l| l.starts_with("interrupted by SIGTERM: "))
        .unwrap_or_else(|| panic!("no interruption message: {t}"));
    let rest = &line["interrupted by SIGTERM: ".len()..];
    let (n, tail) = rest.split_once(" of ").unwrap();
    assert!(tail.ends_with(what), "{line}");
    n.parse().unwrap()
}

#[cfg(unix)]
#[test]
fn sigterm_stops_rollout_and_simulate_with_their_files_flushed() {
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let _lock = common::gpu().0;
    let spawn = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_fluxswarm-gpu"))
            .args(args)
            .env("NODEVICE_SELECT", "1")
            .env("RUST_LOG", "info")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };

    // rollout: one environment, 3-step episodes, far more than it will run.
    let out = dir.path().join("ro");
    let args = [
        "rollout",
        "--policy",
        "upstream",
        "--episodes",
        "1000000",
        "--out",
        out.to_str().unwrap(),
    ];
    let child = spawn(&[&args[..], SMALL_SWARM].concat());
    let o = common::cli::signal_after(child, &[libc::SIGTERM], || {
        std::fs::read_to_string(out.join("episodes.csv")).is_ok_and(|s| s.lines().count() >= 3)
    });
    let finished = stopped_after(&o, "episodes written");
    assert!(text(&o).contains("rollout: "), "a plain progress line");
    let episodes = whole_csv(&out.join("episodes.csv"));
    assert!(
        finished >= 2 && episodes.len() == 1 + finished,
        "{finished}"
    );
    // Every finished episode's start and steps 0..=3, and the one under way's start and the
    // steps it made (0 to 2 of them) before the step the signal stopped after.
    let starts = whole_csv(&out.join("starts.csv"));
    assert_eq!(starts.len(), 1 + finished + 1);
    let swarm = whole_csv(&out.join("swarm.csv"));
    let under_way = swarm.len() - 1 - 4 * finished;
    assert!((1..=3).contains(&under_way), "{} rows", swarm.len());
    let traj = whole_csv(&out.join("trajectories.csv"));
    assert_eq!(traj.len() - 1, 2 * (swarm.len() - 1), "two members a row");

    // simulate: its fields are written as it goes, so their files show that it runs.
    let out = dir.path().join("sim");
    let args = [
        "simulate",
        "--seconds",
        "1000",
        "--frames-every",
        "0",
        "--fields-every",
        "1",
        "--out",
        out.to_str().unwrap(),
    ];
    let child = spawn(&[&args[..], common::cli::SMALL].concat());
    let o = common::cli::signal_after(child, &[libc::SIGTERM], || {
        out.join("fields").join("p_000002.npy").exists()
    });
    let done = stopped_after(&o, "control steps written");
    let summary = whole_csv(&out.join("summary.csv"));
    assert!(done >= 2 && summary.len() == 1 + 1 + done, "{done}");
    assert!(summary[1 + done].starts_with(&format!("{done},")));
}

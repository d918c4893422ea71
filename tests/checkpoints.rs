//! Checkpoints as a user meets them: `train --resume` after a lost checkpoint continues exactly
//! as an uninterrupted run (logs and final state bit for bit, on one adapter), Ctrl-C and
//! SIGTERM write a checkpoint the run resumes from (after SIGTERM, to the same result as an
//! uninterrupted run), a second signal stops at once, `eval` and `rollout --policy` run a
//! trained checkpoint, and damaged or misused checkpoints fail with the file named and a way
//! out.

mod common;

use std::path::{Path, PathBuf};

use common::cli::{SMALL_SWARM, bin, text};
use fluxswarm_gpu::checkpoint::{self, Archive};

/// 4-step rollouts, 2 minibatches: an update is 8 global steps at 2 environments.
fn train_args<'a>(out: &'a str, steps: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec![
        "train",
        "--envs",
        "2",
        "--steps",
        steps,
        "--seed",
        "5",
        "--checkpoint-every",
        "2",
        "--out",
        out,
        "--set",
        "train.rollout_steps=4",
        "--set",
        "train.minibatches=2",
        "--set",
        "train.normalize_observations=true",
    ];
    a.extend_from_slice(extra);
    a.extend_from_slice(SMALL_SWARM);
    a
}

fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// updates.csv without its two timing columns.
fn updates_without_timing(dir: &Path) -> Vec<String> {
    read(&dir.join("updates.csv"))
        .lines()
        .map(|l| l.rsplitn(3, ',').nth(2).unwrap_or(l).to_string())
        .collect()
}

fn newest(dir: &Path) -> PathBuf {
    checkpoint::locate(dir).unwrap()
}

#[test]
fn resume_after_a_lost_checkpoint_matches_an_uninterrupted_run() {
    resume_matches_an_uninterrupted_run(&[]);
}

/// The same with the native backend, which takes a resumed run's state back from the device
/// buffers the checkpoint restored.
#[test]
fn native_backend_resume_matches_an_uninterrupted_run() {
    resume_matches_an_uninterrupted_run(&["--set", "solver.backend=native"]);
}

/// The same with a critic that reads the inlet phase (its input layer is wider, and the
/// phase of every environment must come back with the checkpoint).
#[test]
fn critic_phase_resume_matches_an_uninterrupted_run() {
    resume_matches_an_uninterrupted_run(&[
        "--set",
        "solver.backend=native",
        "--set",
        "train.critic_phase=true",
        "--set",
        "inlet.random_phase=true",
    ]);
}

/// The same with actors that read the inlet phase too (train.actor_phase).
#[test]
fn actor_phase_resume_matches_an_uninterrupted_run() {
    resume_matches_an_uninterrupted_run(&[
        "--set",
        "solver.backend=native",
        "--set",
        "train.critic_phase=true",
        "--set",
        "train.actor_phase=true",
        "--set",
        "inlet.random_phase=true",
    ]);
}

fn resume_matches_an_uninterrupted_run(extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    let (a_s, b_s) = (a.to_str().unwrap(), b.to_str().unwrap());
    let o = bin(&train_args(a_s, "48", extra));
    assert!(o.status.success(), "{}", text(&o));
    // b stops after 5 updates (checkpoints at 2, 4 and 5); losing the last checkpoint leaves
    // update 5 in the logs with no state behind it.
    let o = bin(&train_args(b_s, "40", extra));
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(updates_without_timing(&b).len(), 1 + 5);
    std::fs::remove_file(b.join("checkpoints").join(checkpoint::file_name(5))).unwrap();
    let o = bin(&["train", "--resume", b_s, "--steps", "48"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("resuming") && text(&o).contains("update 4"));
    assert_same_run(&a, &b, 6);
    // Only the newest three checkpoints are kept.
    assert_eq!(checkpoint::list(&a.join("checkpoints")).len(), 3);
}

/// Runs a and b logged the same `updates` updates and episodes and ended in the same state,
/// bit for bit: networks, optimiser, normaliser, RNGs, fields, members, episode clocks.
fn assert_same_run(a: &Path, b: &Path, updates: u64) {
    assert_eq!(read(&a.join("episodes.csv")), read(&b.join("episodes.csv")));
    let ua = updates_without_timing(a);
    assert_eq!(ua.len() as u64, 1 + updates);
    assert_eq!(ua, updates_without_timing(b));
    let (ca, cb) = (
        Archive::load(&newest(a)).unwrap(),
        Archive::load(&newest(b)).unwrap(),
    );
    assert_eq!(ca.meta("update").unwrap(), updates.to_string());
    for name in [
        "learner.param.actor.l1.weight",
        "learner.param.critic.l2.bias",
        "learner.adam.actor.m",
        "learner.adam.critic.v",
        "learner.obs_norm.var",
        "env.fluid.u",
        "env.fluid.p",
        "env.fluid.members",
        "env.previous_action",
        "train.obs",
    ] {
        let (x, y) = if name.contains("obs_norm") || name == "env.previous_action" {
            let f = |c: &Archive| {
                c.f64(name, None)
                    .unwrap()
                    .iter()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>()
            };
            (f(&ca), f(&cb))
        } else {
            let f = |c: &Archive| {
                c.f32(name, None)
                    .unwrap()
                    .iter()
                    .map(|v| v.to_bits() as u64)
                    .collect::<Vec<_>>()
            };
            (f(&ca), f(&cb))
        };
        assert!(!x.is_empty(), "{name}");
        assert_eq!(x, y, "{name} differs after resume");
    }
    for name in ["learner.rng", "env.rng", "env.episode", "env.episode_step"] {
        assert_eq!(
            ca.u64(name, None).unwrap(),
            cb.u64(name, None).unwrap(),
            "{name}"
        );
    }
}

/// The runs stopped by a signal (sent with kill(2), so Unix only).
#[cfg(unix)]
mod signalled {
    use std::process::{Command, Output};

    use super::*;

    /// Starts a long training run into `out` that writes no checkpoint of its own, sends it
    /// `signals` (one right after the other) once it has logged two updates, and returns what it
    /// printed and its exit status.
    fn train_until_signalled(out: &Path, signals: &[i32]) -> Output {
        train_until_signalled_under(&[], out, signals)
    }

    /// [`train_until_signalled`] started through `wrapper` (e.g. `nohup`, which execs it).
    fn train_until_signalled_under(wrapper: &[&str], out: &Path, signals: &[i32]) -> Output {
        let mut args = train_args(out.to_str().unwrap(), "1000000", &[]);
        args[8] = "1000"; // --checkpoint-every: only the signal writes one
        let bin = env!("CARGO_BIN_EXE_fluxswarm-gpu");
        let mut cmd = Command::new(wrapper.first().copied().unwrap_or(bin));
        common::cli::default_sighup(&mut cmd);
        if !wrapper.is_empty() {
            cmd.args(&wrapper[1..]).arg(bin);
        }
        let child = cmd
            .args(&args)
            .env("NODEVICE_SELECT", "1")
            .env("RUST_LOG", "info")
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        common::cli::signal_after(child, signals, || {
            std::fs::read_to_string(out.join("updates.csv")).is_ok_and(|s| s.lines().count() >= 3)
        })
    }

    /// The update of run `out`'s newest checkpoint, which must be its last logged update.
    fn checkpointed_update(out: &Path) -> u64 {
        let ck = Archive::load(&newest(out)).unwrap();
        let update: u64 = ck.meta_parse("update").unwrap();
        let logged = read(&out.join("updates.csv")).lines().count() as u64 - 1;
        assert!(
            update >= 2 && update == logged,
            "checkpoint {update}, logged {logged}"
        );
        update
    }

    #[test]
    fn ctrl_c_checkpoints_and_the_run_resumes_from_there() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let out_s = out.to_str().unwrap();
        let lock = common::gpu().0;
        let o = train_until_signalled(&out, &[libc::SIGINT]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(130), "{t}");
        assert!(
            t.contains("interrupted by SIGINT") && t.contains("--resume"),
            "says how to continue: {t}"
        );
        let update = checkpointed_update(&out);
        drop(lock);
        let target = ((update + 2) * 8).to_string();
        let o = bin(&["train", "--resume", out_s, "--steps", &target]);
        assert!(o.status.success(), "{}", text(&o));
        assert_eq!(
            read(&out.join("updates.csv")).lines().count() as u64,
            1 + update + 2
        );
    }

    /// What Slurm's time limit, `timeout` and `docker stop` send: the same checkpoint as Ctrl-C,
    /// status 143, and the resumed run ends as an uninterrupted one of the same length.
    #[test]
    fn sigterm_checkpoints_and_the_resumed_run_equals_an_uninterrupted_one() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        let lock = common::gpu().0;
        let o = train_until_signalled(&b, &[libc::SIGTERM]);
        drop(lock);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(143), "{t}");
        assert!(t.contains("SIGTERM: finishing this update"), "{t}");
        let hint = format!(
            "continue with `fluxswarm-gpu train --resume {}`",
            b.display()
        );
        assert!(
            t.contains("interrupted by SIGTERM") && t.contains(&hint),
            "{t}"
        );
        assert_eq!(
            String::from_utf8_lossy(&o.stdout).trim(),
            b.to_str().unwrap()
        );
        let update = checkpointed_update(&b);

        // Two updates past the signal, against a run that went there in one go.
        let target = ((update + 2) * 8).to_string();
        let o = bin(&train_args(a.to_str().unwrap(), &target, &[]));
        assert!(o.status.success(), "{}", text(&o));
        let o = bin(&["train", "--resume", b.to_str().unwrap(), "--steps", &target]);
        assert!(o.status.success(), "{}", text(&o));
        assert!(text(&o).contains(&format!("resuming {} at update {update}", b.display())));
        assert_same_run(&a, &b, update + 2);
    }

    /// SIGHUP stops a run as SIGTERM does, with 129; under `nohup` it is ignored, so a SIGTERM
    /// right after it is the first signal and stops the run cleanly (were SIGHUP handled, the
    /// SIGTERM would be a second signal and stop it at once, with no checkpoint).
    #[test]
    fn sighup_stops_a_run_unless_nohup_ignores_it() {
        let dir = tempfile::tempdir().unwrap();
        let lock = common::gpu().0;
        let out = dir.path().join("hup");
        let o = train_until_signalled(&out, &[libc::SIGHUP]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(129), "{t}");
        assert!(
            t.contains("interrupted by SIGHUP") && t.contains("--resume"),
            "{t}"
        );
        checkpointed_update(&out);

        let out = dir.path().join("nohup");
        let o = train_until_signalled_under(&["nohup"], &out, &[libc::SIGHUP, libc::SIGTERM]);
        drop(lock);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(143), "{t}");
        assert!(
            t.contains("interrupted by SIGTERM") && t.contains("--resume"),
            "{t}"
        );
        assert!(!t.contains("SIGHUP"), "{t}");
        checkpointed_update(&out);
    }

    /// A second signal while the first is being honoured stops at once, with no checkpoint.
    #[test]
    fn a_second_signal_stops_at_once() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("run");
        let lock = common::gpu().0;
        let o = train_until_signalled(&out, &[libc::SIGTERM, libc::SIGINT]);
        drop(lock);
        let t = text(&o);
        // The status is that of the signal handled second (Linux handles pending signals lowest
        // number first, so that may be either).
        assert!(
            matches!(o.status.code(), Some(130 | 143)),
            "{:?}: {t}",
            o.status
        );
        assert!(!t.contains("--resume"), "{t}");
        assert!(checkpoint::list(&out.join("checkpoints")).is_empty(), "{t}");
    }
}

#[test]
fn eval_and_rollout_run_a_trained_checkpoint() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let o = bin(&train_args(run.to_str().unwrap(), "16", &[]));
    assert!(o.status.success(), "{}", text(&o));
    let mut episodes = Vec::new();
    for name in ["e1", "e2"] {
        let out = dir.path().join(name);
        let o = bin(&[
            "eval",
            "--checkpoint",
            run.to_str().unwrap(),
            "--episodes",
            "2",
            "--envs",
            "2",
            "--deterministic",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        for f in [
            "episodes.csv",
            "swarm.csv",
            "trajectories.csv",
            "config.toml",
        ] {
            assert!(out.join(f).exists(), "{f}");
        }
        episodes.push(read(&out.join("episodes.csv")));
    }
    assert_eq!(episodes[0], episodes[1], "the mean action is deterministic");
    assert_eq!(episodes[0].lines().count(), 1 + 2);
    // rollout takes the checkpoint file as its policy, in the checkpoint's configuration.
    let out = dir.path().join("r");
    let file = newest(&run);
    let o = bin(&[
        "rollout",
        "--policy",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(read(&out.join("config.toml")).contains("count = 2"));
    let o = bin(&[
        "rollout",
        "--policy",
        file.to_str().unwrap(),
        "--set",
        "swarm.count=3",
    ]);
    assert!(
        !o.status.success()
            && text(&o).contains("drop --config/--set")
            && text(&o).contains("inlet.scale, swarm.max_thrust_n"),
        "{}",
        text(&o)
    );
    // The scenario around it may change (a transfer test), and config.toml records it.
    let moved = dir.path().join("moved");
    let o = bin(&[
        "rollout",
        "--policy",
        file.to_str().unwrap(),
        "--set",
        "inlet.scale=0.75",
        "--set",
        "swarm.max_thrust_n=1.25e-6",
        "--out",
        moved.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let saved = read(&moved.join("config.toml"));
    assert!(
        saved.contains("scale = 0.75") && saved.contains("max_thrust_n = 0.00000125"),
        "{saved}"
    );
    assert!(saved.contains("count = 2"), "the members stay as trained");
}

/// A train run writes `policy.safetensors` (SPEC section 8) beside its checkpoints: the actor,
/// the normaliser and the configuration, a fraction of a checkpoint's size. `eval` and
/// `rollout --policy` take it and act as with the checkpoint; `--seed` drives sampling.
#[test]
fn a_train_run_writes_its_policy_file_and_eval_runs_it() {
    policy_file_runs_as_its_checkpoint(&[]);
}

/// The same for a policy that reads the inlet phase (train.actor_phase): eval and rollout give
/// its actor each environment's phase.
#[test]
fn a_phase_reading_policy_file_runs_as_its_checkpoint() {
    policy_file_runs_as_its_checkpoint(&[
        "--set",
        "train.critic_phase=true",
        "--set",
        "train.actor_phase=true",
        "--set",
        "inlet.random_phase=true",
    ]);
}

fn policy_file_runs_as_its_checkpoint(extra: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let o = bin(&train_args(run.to_str().unwrap(), "16", extra));
    assert!(o.status.success(), "{}", text(&o));
    let policy = run.join("policy.safetensors");
    let archive = Archive::load(&policy).unwrap();
    assert_eq!(archive.meta("kind").unwrap(), "policy");
    assert!(archive.meta("config").unwrap().contains("[swarm]"));
    assert_eq!(archive.meta("update").unwrap(), "2");
    let (p_len, c_len) = (
        std::fs::metadata(&policy).unwrap().len(),
        std::fs::metadata(newest(&run)).unwrap().len(),
    );
    assert!(
        p_len < 1 << 20 && 4 * p_len < c_len,
        "policy {p_len} B, checkpoint {c_len} B"
    );
    let eval = |from: &Path, seed: &str, name: &str| {
        let out = dir.path().join(name);
        let o = bin(&[
            "eval",
            "--checkpoint",
            from.to_str().unwrap(),
            "--episodes",
            "4",
            "--envs",
            "2",
            "--seed",
            seed,
            "--no-traces",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", text(&o));
        read(&out.join("episodes.csv"))
    };
    let from_checkpoint = eval(&run, "7", "c7");
    assert_eq!(eval(&policy, "7", "p7"), from_checkpoint);
    assert_ne!(
        eval(&policy, "8", "p8"),
        from_checkpoint,
        "the seed drives sampling"
    );
    let out = dir.path().join("r");
    let o = bin(&[
        "rollout",
        "--policy",
        policy.to_str().unwrap(),
        "--episodes",
        "2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
}

/// `--policy-every K` keeps the policy of every checkpoint at a multiple of K updates in
/// `policies/`: the actor and normaliser of that checkpoint; none with K = 0.
#[test]
fn policy_snapshots_are_the_policies_of_their_updates() {
    let dir = tempfile::tempdir().unwrap();
    let (run, none) = (dir.path().join("run"), dir.path().join("none"));
    // 8 global steps an update: 6 updates, checkpoints at 2, 4 and 6 (all three kept), a
    // snapshot at 4 only.
    let o = bin(&train_args(
        run.to_str().unwrap(),
        "48",
        &["--policy-every", "4"],
    ));
    assert!(o.status.success(), "{}", text(&o));
    let names = |d: &Path| {
        let mut v: Vec<String> = std::fs::read_dir(d.join("policies"))
            .map(|r| {
                r.map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
                    .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    assert_eq!(names(&run), ["update-0000004.safetensors"]);
    let snapshot = Archive::load(&run.join("policies/update-0000004.safetensors")).unwrap();
    let checkpoint = Archive::load(&run.join("checkpoints/update-0000004.safetensors")).unwrap();
    let last = Archive::load(&run.join("policy.safetensors")).unwrap();
    assert_eq!(snapshot.meta("kind").unwrap(), "policy");
    assert_eq!(snapshot.meta("update").unwrap(), "4");
    for layer in ["l1", "l2", "head"] {
        for part in ["weight", "bias"] {
            let name = format!("learner.param.actor.{layer}.{part}");
            let at4 = snapshot.f32(&name, None).unwrap();
            assert_eq!(at4, checkpoint.f32(&name, None).unwrap(), "{name}");
            assert_ne!(
                at4,
                last.f32(&name, None).unwrap(),
                "{name} moved after update 4"
            );
        }
    }
    for stat in ["mean", "var"] {
        let name = format!("learner.obs_norm.{stat}");
        assert_eq!(
            snapshot.f64(&name, None).unwrap(),
            checkpoint.f64(&name, None).unwrap(),
            "{name}"
        );
    }
    let o = bin(&train_args(
        none.to_str().unwrap(),
        "48",
        &["--policy-every", "0"],
    ));
    assert!(o.status.success(), "{}", text(&o));
    assert!(names(&none).is_empty() && !none.join("policies").exists());
}

#[test]
fn damaged_and_misused_checkpoints_fail_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let run_s = run.to_str().unwrap();
    let o = bin(&train_args(run_s, "32", &[]));
    assert!(o.status.success(), "{}", text(&o));
    let files = checkpoint::list(&run.join("checkpoints"));
    assert_eq!(files.len(), 2, "updates 2 and 4");

    // A truncated newest checkpoint: resume warns and falls back to the one before.
    let bytes = std::fs::read(&files[0]).unwrap();
    std::fs::write(&files[0], &bytes[..bytes.len() - 100]).unwrap();
    let o = bin(&["train", "--resume", run_s, "--steps", "32"]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("is corrupt") && t.contains("update 2"), "{t}");

    // An edited config.toml would silently not apply: resume names the key and changes nothing.
    let record = run.join("config.toml");
    let original = read(&record);
    let edited = original.replace("learning_rate = 0.001", "learning_rate = 0.0005");
    assert_ne!(
        edited, original,
        "the record holds the paper's learning rate"
    );
    std::fs::write(&record, &edited).unwrap();
    let before = checkpoint::list(&run.join("checkpoints"));
    let o = bin(&["train", "--resume", run_s, "--steps", "48"]);
    let t = text(&o);
    assert!(!o.status.success(), "{t}");
    assert!(
        t.contains("train.learning_rate = 0.0005 (saved: 0.001)") && t.contains("--config"),
        "{t}"
    );
    assert_eq!(checkpoint::list(&run.join("checkpoints")), before);
    assert_eq!(read(&record), edited);
    std::fs::write(&record, &original).unwrap();

    // Every checkpoint damaged: a clear error naming the file.
    for f in checkpoint::list(&run.join("checkpoints")) {
        let mut b = std::fs::read(&f).unwrap();
        let last = b.len() - 1;
        b[last] ^= 0x40;
        std::fs::write(&f, b).unwrap();
    }
    let o = bin(&["train", "--resume", run_s, "--steps", "40"]);
    let t = text(&o);
    assert!(!o.status.success());
    assert!(
        t.contains("corrupt") && t.contains("checksum") && t.contains("update-"),
        "{t}"
    );
    let o = bin(&["eval", "--checkpoint", run_s]);
    assert!(
        !o.status.success() && text(&o).contains("corrupt"),
        "{}",
        text(&o)
    );

    // Resume may not change the run, a fresh run may not overwrite one, and a directory
    // without checkpoints is not a run.
    let o = bin(&["train", "--resume", run_s, "--envs", "3"]);
    assert!(text(&o).contains("--envs cannot change it"), "{}", text(&o));
    let o = bin(&train_args(run_s, "8", &[]));
    assert!(
        text(&o).contains("already holds a training run"),
        "{}",
        text(&o)
    );
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let o = bin(&["train", "--resume", empty.to_str().unwrap()]);
    assert!(text(&o).contains("no checkpoints"), "{}", text(&o));
}

#[test]
fn zero_steps_writes_the_untrained_policy_only() {
    let dir = tempfile::tempdir().unwrap();
    let mut params = Vec::new();
    for name in ["a", "b"] {
        let run = dir.path().join(name);
        let o = bin(&train_args(run.to_str().unwrap(), "0", &[]));
        assert!(o.status.success(), "{}", text(&o));
        let files = fluxswarm_gpu::checkpoint::list(&run.join("checkpoints"));
        assert_eq!(files.len(), 1);
        assert!(
            files[0].ends_with("update-0000000.safetensors"),
            "{files:?}"
        );
        assert_eq!(read(&run.join("updates.csv")).lines().count(), 1);
        let a = fluxswarm_gpu::checkpoint::Archive::load(&files[0]).unwrap();
        assert_eq!(a.meta("update").unwrap(), "0");
        assert_eq!(a.meta("global_step").unwrap(), "0");
        let bytes = std::fs::read(&files[0]).unwrap();
        let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
        let mut p: Vec<(String, Vec<u8>)> = st
            .tensors()
            .into_iter()
            .filter(|(n, _)| n.starts_with("learner.param.") || n.starts_with("env.fluid."))
            .map(|(n, t)| (n, t.data().to_vec()))
            .collect();
        p.sort();
        assert!(p.iter().any(|(n, _)| n.starts_with("learner.param.actor")));
        params.push(p);
    }
    // The same seed gives the same untrained policy (and environments).
    assert_eq!(params[0], params[1]);
    let out = dir.path().join("e");
    let o = bin(&[
        "eval",
        "--checkpoint",
        dir.path().join("a").to_str().unwrap(),
        "--episodes",
        "1",
        "--envs",
        "1",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(read(&out.join("episodes.csv")).lines().count(), 2);
}

#[test]
fn a_checkpoint_before_the_first_episode_keeps_the_episodes_header() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let run_s = run.to_str().unwrap();
    // One update of 2 x 4 steps, episodes of up to 50 steps: none ends before the checkpoint.
    let mut args = train_args(run_s, "8", &[]);
    args.extend(["--set", "env.max_steps=50"]); // after SMALL_SWARM's, so it wins
    let o = bin(&args);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(read(&run.join("episodes.csv")).lines().count(), 1);
    let o = bin(&["train", "--resume", run_s, "--steps", "8"]);
    assert!(o.status.success(), "{}", text(&o));
    let episodes = read(&run.join("episodes.csv"));
    assert!(
        episodes.starts_with("global_step,env,episode,"),
        "episodes.csv lost its header: {episodes:?}"
    );
}

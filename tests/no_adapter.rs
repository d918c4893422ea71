//! With no Vulkan driver and no GPU at all, every command runs on the CPU backend (`auto`
//! picks it and says why): train with checkpoints, resume, rollout with frames, eval of the
//! trained checkpoint, simulate with fields, bench, info. A run trained on the WGSL kernels
//! resumes on the CPU backend.

mod common;

use common::cli::{NO_ADAPTER, SMALL, SMALL_SWARM, bin, bin_env, text};

/// A short training run (4 updates of 4 steps x 2 environments) of the small swarm into `out`.
fn train_args<'a>(out: &'a str, seed: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "train",
        "--envs",
        "2",
        "--steps",
        "16",
        "--seed",
        seed,
        "--out",
        out,
        "--set",
        "train.rollout_steps=4",
        "--set",
        "train.minibatches=2",
    ];
    args.extend_from_slice(extra);
    args.extend_from_slice(SMALL_SWARM);
    args
}

fn ok(args: &[&str]) -> String {
    let o = bin_env(args, NO_ADAPTER);
    let t = text(&o);
    assert!(o.status.success(), "{args:?}: {t}");
    t
}

#[test]
fn info_says_there_is_no_adapter_and_what_runs() {
    let t = ok(&["info"]);
    assert!(t.contains("adapters found: 0"), "{t}");
    assert!(t.contains("control step: CPU backend"), "{t}");
    assert!(t.contains("no GPU adapter found"), "{t}");
    // Forcing the kernels without an adapter is a clear error, not a crash.
    let o = bin_env(
        &[
            "simulate",
            "--seconds",
            "0.005",
            "--set",
            "solver.backend=adapter",
        ],
        NO_ADAPTER,
    );
    assert!(!o.status.success());
    assert!(text(&o).contains("no usable adapter found"), "{}", text(&o));
}

#[test]
fn train_resume_rollout_eval_simulate_and_bench_run_without_an_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("train");
    let run_s = run.to_str().unwrap();
    let t = ok(&train_args(run_s, "3", &[]));
    assert!(t.contains("control step: CPU backend"), "{t}");
    let config = std::fs::read_to_string(run.join("config.toml")).unwrap();
    assert!(
        config
            .lines()
            .next()
            .unwrap()
            .contains("adapter CPU backend"),
        "{config}"
    );
    assert!(run.join("checkpoints/update-0000002.safetensors").exists());
    ok(&["train", "--resume", run_s, "--steps", "24"]);
    assert!(run.join("checkpoints/update-0000003.safetensors").exists());

    let roll = dir.path().join("rollout");
    let roll_s = roll.to_str().unwrap();
    let t = ok(&[
        &[
            "rollout",
            "--policy",
            "upstream",
            "--episodes",
            "2",
            "--envs",
            "2",
            "--frames-every",
            "1",
            "--out",
            roll_s,
        ][..],
        SMALL_SWARM,
    ]
    .concat());
    assert!(t.contains("control step: CPU backend"), "{t}");
    assert!(std::fs::read_dir(roll.join("frames")).unwrap().count() > 0);
    assert!(
        std::fs::read_to_string(roll.join("episodes.csv"))
            .unwrap()
            .lines()
            .count()
            >= 3
    );

    let eval = dir.path().join("eval");
    ok(&[
        "eval",
        "--checkpoint",
        run_s,
        "--episodes",
        "2",
        "--envs",
        "2",
        "--out",
        eval.to_str().unwrap(),
    ]);
    assert!(eval.join("episodes.csv").exists());

    let sim = dir.path().join("sim");
    let sim_s = sim.to_str().unwrap();
    ok(&[
        &[
            "simulate",
            "--seconds",
            "0.01",
            "--fields-every",
            "1",
            "--frames-every",
            "1",
            "--out",
            sim_s,
        ][..],
        SMALL,
    ]
    .concat());
    assert!(sim.join("fields/ux_000002.npy").exists());
    assert!(sim.join("frames/env0_s000002.png").exists());

    let bench = dir.path().join("bench");
    let bench_s = bench.to_str().unwrap();
    ok(&[
        &["bench", "--envs", "2", "--seconds", "0.2", "--out", bench_s][..],
        SMALL,
    ]
    .concat());
    let csv = std::fs::read_to_string(bench.join("bench.csv")).unwrap();
    assert!(
        csv.lines().nth(1).unwrap().contains("\"CPU backend, "),
        "{csv}"
    );
}

/// A run trained on the WGSL kernels (lavapipe here) resumes on the CPU backend on a machine
/// without any adapter, with `--set solver.backend=native`.
#[test]
fn a_run_trained_on_the_kernels_resumes_on_the_cpu_backend() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("train");
    let run_s = run.to_str().unwrap();
    let o = bin(&train_args(
        run_s,
        "4",
        &["--set", "solver.backend=adapter"],
    ));
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("WGSL kernels on"), "{}", text(&o));
    // Without an adapter the saved backend cannot run: the error says what to do.
    let o = bin_env(&["train", "--resume", run_s, "--steps", "24"], NO_ADAPTER);
    assert!(!o.status.success());
    let t = ok(&[
        "train",
        "--resume",
        run_s,
        "--steps",
        "24",
        "--set",
        "solver.backend=native",
    ]);
    assert!(t.contains("control step: CPU backend"), "{t}");
    let updates = std::fs::read_to_string(run.join("updates.csv")).unwrap();
    assert_eq!(updates.lines().count(), 1 + 3, "{updates}");
    // Other keys still cannot change a resumed run.
    let o = bin_env(
        &[
            "train",
            "--resume",
            run_s,
            "--set",
            "fluid.density_kg_m3=1000",
        ],
        NO_ADAPTER,
    );
    assert!(!o.status.success());
    assert!(text(&o).contains("cannot change it"), "{}", text(&o));
}

//! The tests that docs/extending.md's recipes point to, one per recipe, each doing what its
//! recipe asks a new piece to pass: a reward term wired into the step, a controller run
//! through the library's rollout runner, a WGSL kernel registered with its entry table, and a
//! configuration key that old configurations load without.

mod common;

use fluxswarm_gpu::config::{Config, EnergyReward};
use fluxswarm_gpu::env::policy::Controller;
use fluxswarm_gpu::env::{SwarmEnv, reward};
use fluxswarm_gpu::gpu::kernels::ENTRIES;
use fluxswarm_gpu::gpu::shaders;
use fluxswarm_gpu::rollout::{self, Discard, Policy};
use fluxswarm_gpu::sim::CpuBatch;

const POS_MM: [[f64; 2]; 3] = [[14.0, 0.6], [15.0, 1.4], [16.0, 0.6]];

fn cpu_env(extra: &[&str], n_env: usize) -> SwarmEnv {
    let mut sets = vec!["solver.backend=native"];
    sets.extend_from_slice(extra);
    let r = common::swarm_config(300, 20, &POS_MM, &sets);
    SwarmEnv::new(Box::new(CpuBatch::new(&r, n_env).unwrap()), &r, 3).unwrap()
}

/// Recipe "Add a reward term", step 3: the reward of a real step is the term's function of
/// that step's thrust and displacement (here the upstream-only energy term).
#[test]
fn a_reward_term_of_a_real_step_is_its_function_of_force_and_displacement() {
    let mut env = cpu_env(&["env.energy_reward=\"upstream\""], 1);
    assert_eq!(
        env.resolved().config.env.energy_reward,
        EnergyReward::Upstream
    );
    let f_max = env.resolved().config.swarm.max_thrust_n;
    env.reset().unwrap();
    // Member 0 pushes upstream, 1 towards the wall at half thrust, 2 downstream.
    let actions = [[-1.0f32, 0.0], [-0.3, 0.4], [1.0, 0.0]];
    let (mut checked, mut distinct) = (0, 0);
    for _ in 0..3 {
        let before: Vec<[f64; 2]> = env
            .batch()
            .members()
            .iter()
            .map(|m| [m.pos[0] as f64, m.pos[1] as f64])
            .collect();
        let step = env.step(&actions).unwrap();
        if step.episodes[0].is_some() {
            break;
        }
        for (i, a) in actions.iter().enumerate() {
            let now = step.members[i].pos;
            let dr = [now[0] as f64 - before[i][0], now[1] as f64 - before[i][1]];
            let a = [a[0] as f64, a[1] as f64];
            let s = f_max / a[0].hypot(a[1]).max(1.0);
            let force = [s * a[0], s * a[1]];
            let want = reward::energy_upstream(force, dr, f_max);
            distinct += usize::from((want - reward::energy(force, dr, f_max)).abs() > 1e-6);
            let got = step.rewards[i * 3 + 1] as f64;
            assert!(
                (got - want).abs() <= 1e-6 * want.abs().max(1e-3),
                "member {i}: {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(
        checked >= 3,
        "the episode ended before a step could be checked"
    );
    // The check tells the two energy terms apart (the step did not use the paper's).
    assert!(distinct > 0, "no step where the terms differ");
}

/// Recipe "Add a scripted policy", step 1: a controller tried as a function through the
/// library's runner acts exactly as the named controller it copies.
#[test]
fn a_custom_policy_runs_through_the_rollout_runner_like_a_named_controller() {
    let run = |policy: &mut Policy| {
        let mut env = cpu_env(&["env.max_steps=6"], 2);
        rollout::run(&mut env, policy, 3, &mut Discard, &|| false, &mut |_| {}).unwrap()
    };
    let named = run(&mut Policy::controller(Controller::Upstream, 1));
    let custom = run(&mut Policy::custom(|obs, _env| {
        vec![[-1.0, 0.0]; obs.len() / fluxswarm_gpu::env::OBS_DIM]
    }));
    assert_eq!(named.episodes.len(), 3);
    assert_eq!(named.env_steps, custom.env_steps);
    for (a, b) in named.episodes.iter().zip(&custom.episodes) {
        assert_eq!((a.env, a.steps, a.outcome), (b.env, b.steps, b.outcome));
        assert_eq!(a.progress, b.progress);
        assert_eq!(a.energy, b.energy);
    }
}

/// Recipe "Add a WGSL kernel with its CPU stage", step 2: every compute entry point of every
/// file in `shaders/` has its table in `ENTRIES` (whose tables `gpu::kernels::tests` check
/// against naga), except the start-up probe that is not part of the step. Unlike that unit
/// test's fixed list of files, this finds a new file too.
#[test]
fn every_compute_shader_is_registered_in_the_entry_tables() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("shaders");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let file = path.file_name().unwrap().to_string_lossy().to_string();
        if file == "loop_probe.wgsl" {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        for name in shaders::entry_points(&text) {
            assert!(
                ENTRIES.iter().any(|e| e.file == file && e.name == name),
                "{file}: entry point {name} has no table in gpu::kernels::ENTRIES"
            );
            seen += 1;
        }
    }
    assert_eq!(
        seen,
        ENTRIES.len(),
        "a table names an entry point no file has"
    );
}

/// Recipe "Add a configuration key", steps 2 and 4: the key has a default that a configuration
/// saved before it existed gets, `--set` reaches it, and the saved `config.toml` keeps it.
#[test]
fn a_config_key_defaults_for_old_files_and_round_trips_through_the_saved_config() {
    let saved = Config::load(None, &[]).unwrap().config.to_toml();
    let old: String = saved
        .lines()
        .filter(|l| !l.trim_start().starts_with("scale ="))
        .collect::<Vec<_>>()
        .join("\n");
    assert!(!old.contains("scale ="));
    assert_eq!(Config::from_saved(&old).unwrap().config.inlet.scale, 1.0);
    let set = Config::load(None, &["inlet.scale=0.8".to_string()]).unwrap();
    assert_eq!(set.config.inlet.scale, 0.8);
    let back = Config::from_saved(&set.config.to_toml()).unwrap();
    assert_eq!(back.config.inlet.scale, 0.8);
    let err = Config::load(None, &["inlet.scael=0.8".to_string()]).unwrap_err();
    assert!(err.to_string().contains("scael"), "{err}");
}

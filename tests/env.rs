//! The batched environment: success, failure, truncation and divergence endings with
//! auto-reset and final observations, rewards through a real step, determinism from a seed,
//! and environment k of a batch equal to the same environment alone.

mod common;

use fluxswarm_gpu::config::Resolved;
use fluxswarm_gpu::env::policy::Controller;
use fluxswarm_gpu::env::{OBS_DIM, Outcome};
use fluxswarm_gpu::gpu::kernels::FieldBinding;
use fluxswarm_gpu::rng::Rng;

/// A 30 x 2 mm channel (success line 6 mm, failure line 24 mm) with members at `pos_mm`.
fn config(pos_mm: &[[f64; 2]], extra: &[&str]) -> Resolved {
    common::swarm_config(300, 20, pos_mm, extra)
}

const MID: [[f64; 2]; 3] = [[14.0, 0.6], [15.0, 1.4], [16.0, 0.6]];

#[test]
fn a_swarm_past_the_success_line_terminates_with_success() {
    let (_lock, ctx) = common::gpu();
    let mut env = common::gpu_env(
        &ctx,
        &config(&[[4.0, 0.6], [5.0, 1.4], [6.5, 0.6]], &[]),
        1,
        0,
    );
    env.reset().unwrap();
    let s = env.step(&[[0.0; 2]; 3]).unwrap();
    assert!(s.terminated[0] && !s.truncated[0] && !s.diverged[0]);
    let ep = s.episodes[0].as_ref().unwrap();
    assert_eq!(ep.outcome, Outcome::Success);
    assert_eq!(ep.steps, 1);
    // Two members past x_s earn +10 each, the third (6.5 mm) its displacement reward.
    assert_eq!(s.rewards[0], 10.0);
    assert_eq!(s.rewards[3], 10.0);
    assert!(s.rewards[6] < 10.0);
    assert_eq!(s.final_obs[0].as_ref().unwrap().len(), 3 * OBS_DIM);
    // Auto-reset: the new episode starts from the configured positions.
    let x0 = s.obs[0];
    assert!((x0 - ((4.0 - 15.0) / 9.0)).abs() < 1e-4, "{x0}");
    assert_eq!(s.episode[0], 0);
}

#[test]
fn a_member_past_the_failure_line_terminates_with_failure() {
    let (_lock, ctx) = common::gpu();
    let mut env = common::gpu_env(
        &ctx,
        &config(&[[14.0, 0.6], [15.0, 1.4], [24.5, 0.6]], &[]),
        1,
        0,
    );
    env.reset().unwrap();
    let s = env.step(&[[0.0; 2]; 3]).unwrap();
    assert!(s.terminated[0]);
    assert_eq!(s.episodes[0].as_ref().unwrap().outcome, Outcome::Failure);
    assert_eq!(s.rewards[6], -10.0);
}

#[test]
fn episodes_truncate_after_max_steps_with_a_final_observation() {
    let (_lock, ctx) = common::gpu();
    let default = fluxswarm_gpu::config::Config::paper();
    assert_eq!(default.env.max_steps, 2000, "10 s of 5 ms control steps");
    let mut env = common::gpu_env(&ctx, &config(&MID, &["env.max_steps=3"]), 1, 0);
    env.reset().unwrap();
    for k in 1..=3 {
        let s = env.step(&[[0.0; 2]; 3]).unwrap();
        assert!(!s.terminated[0]);
        assert_eq!(s.truncated[0], k == 3, "step {k}");
        if k == 3 {
            let ep = s.episodes[0].as_ref().unwrap();
            assert_eq!((ep.outcome, ep.steps, ep.episode), (Outcome::Timeout, 3, 0));
            // Zero actions: smoothness 1 every step; no thrust, so energy 0.
            assert_eq!(ep.smoothness, 1.0);
            assert_eq!(ep.energy, 0.0);
            assert!(s.final_obs[0].is_some());
        }
    }
    let s = env.step(&[[0.0; 2]; 3]).unwrap();
    assert_eq!(
        (s.episode[0], s.episode_step[0]),
        (1, 1),
        "a new episode after the reset"
    );
}

#[test]
fn a_diverged_environment_ends_alone_and_the_others_continue_unchanged() {
    let (_lock, ctx) = common::gpu();
    let r = config(&MID, &[]);
    let actions = |k: usize| [[-1.0, 0.1 * k as f32], [0.3, 0.2], [0.0, -1.0]];
    let mut pair = common::gpu_env(&ctx, &r, 2, 3);
    let mut alone = common::gpu_env(&ctx, &r, 1, 3);
    pair.reset().unwrap();
    alone.reset().unwrap();
    for k in 0..6 {
        if k == 2 {
            let b = pair.batch_mut().as_gpu_mut().unwrap();
            let mut u = b.read_env(FieldBinding::UIn, 1).unwrap();
            u[500] = f32::NAN;
            b.write_env(FieldBinding::UIn, 1, &u).unwrap();
        }
        let a = actions(k);
        let both: Vec<[f32; 2]> = a.iter().chain(a.iter()).copied().collect();
        let s = pair.step(&both).unwrap();
        let t = alone.step(&a).unwrap();
        assert_eq!(s.diverged[1], k == 2, "step {k}");
        if k == 2 {
            assert!(!s.terminated[1] && !s.truncated[1]);
            assert_eq!(s.episodes[1].as_ref().unwrap().outcome, Outcome::Diverged);
            assert!(
                s.rewards[9..18].iter().all(|&x| x == 0.0),
                "no rewards from a garbage state"
            );
        }
        assert_eq!(
            &s.obs[..3 * OBS_DIM],
            &t.obs[..],
            "step {k}: environment 0 changed"
        );
        assert_eq!(&s.rewards[..9], &t.rewards[..]);
        assert!(
            s.obs[3 * OBS_DIM..].iter().all(|x| x.is_finite()),
            "environment 1 was reset"
        );
    }
}

#[test]
fn the_same_seed_gives_the_same_trajectory_and_k_of_a_batch_equals_k_alone() {
    let (_lock, ctx) = common::gpu();
    let r = config(
        &MID,
        &["inlet.random_phase=true", "env.position_jitter_m=0.0001"],
    );
    let run = |seed: u64, envs: usize| {
        let mut env = common::gpu_env(&ctx, &r, envs, seed);
        let mut rng = Rng::new(seed);
        let mut obs = env.reset().unwrap();
        let mut trace = obs.clone();
        for _ in 0..4 {
            let a = Controller::Random.act_all(&obs, &[0.0; 2], 1.0, &mut rng);
            let s = env.step(&a).unwrap();
            obs = s.transition.obs;
            trace.extend(&obs);
            trace.extend(&s.transition.rewards);
        }
        trace
    };
    let a = run(11, 2);
    assert_eq!(a, run(11, 2), "same seed, same trajectory");
    assert_ne!(a, run(12, 2), "another seed, another start");

    // Without random starts, environment 1 of a batch equals the same environment alone.
    let r = config(&MID, &[]);
    let a = [[-0.5f32, 0.2], [1.2, -0.7], [0.1, 0.9]];
    let mut pair = common::gpu_env(&ctx, &r, 2, 0);
    let mut alone = common::gpu_env(&ctx, &r, 1, 0);
    pair.reset().unwrap();
    alone.reset().unwrap();
    for _ in 0..4 {
        let zero = [[0.0f32; 2]; 3];
        let both: Vec<[f32; 2]> = zero.iter().chain(a.iter()).copied().collect();
        let s = pair.step(&both).unwrap();
        let t = alone.step(&a).unwrap();
        assert_eq!(&s.obs[3 * OBS_DIM..], &t.obs[..]);
        assert_eq!(&s.rewards[9..], &t.rewards[..]);
    }
}

#[test]
fn the_critics_global_state_is_the_inlet_phase_and_goes_with_the_final_observation() {
    use fluxswarm_gpu::learn::env::MultiAgentEnv;
    use fluxswarm_gpu::sim::CpuBatch;
    let r = config(
        &MID,
        &[
            "env.max_steps=3",
            "inlet.random_phase=true",
            "solver.backend=native",
        ],
    );
    let mut env =
        fluxswarm_gpu::env::SwarmEnv::new(Box::new(CpuBatch::new(&r, 2).unwrap()), &r, 5).unwrap();
    MultiAgentEnv::reset(&mut env).unwrap();
    assert_eq!(env.global_state_dim(), 2);
    let period = r.config.inlet.period_s;
    let dt = env.batch().control_dt();
    // (sin, cos) of 2 pi ((start phase + k dt) mod T) / T, by hand.
    let by_hand = |start: f64, k: u32| {
        let angle = std::f64::consts::TAU * (start + k as f64 * dt).rem_euclid(period) / period;
        [angle.sin() as f32, angle.cos() as f32]
    };
    let starts: Vec<f64> = (0..2).map(|e| env.batch().phase_s(e)).collect();
    assert!(starts[0] != starts[1], "random phases differ: {starts:?}");
    let close = |a: &[f32], b: [f32; 2]| (a[0] - b[0]).abs() < 1e-5 && (a[1] - b[1]).abs() < 1e-5;
    let g = env.global_state();
    for e in 0..2 {
        assert!(close(&g[2 * e..2 * e + 2], by_hand(starts[e], 0)), "{g:?}");
    }
    for k in 1..=3 {
        let s = env.step(&[[0.0; 2]; 6]).unwrap();
        for e in 0..2 {
            if k < 3 {
                assert!(s.final_global_state[e].is_none());
                let g = env.global_state();
                assert!(
                    close(&g[2 * e..2 * e + 2], by_hand(starts[e], k)),
                    "step {k}"
                );
            } else {
                // The truncated episode's last state, before the reset drew a new phase.
                let last = s.final_global_state[e].as_ref().unwrap();
                assert!(close(last, by_hand(starts[e], 3)), "{last:?}");
                let g = env.global_state();
                assert!(close(
                    &g[2 * e..2 * e + 2],
                    by_hand(env.batch().phase_s(e), 0)
                ));
            }
        }
    }
}

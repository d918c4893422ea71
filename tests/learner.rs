//! The learner learns: on the CPU point-mass environment (a known optimum: push straight to
//! the target, smoothly), a bounded training run improves every objective's episode metric
//! clearly over the random policy, with and without PCGrad, and with the tanh-squashed policy.

use fluxswarm_gpu::config::ActionDistribution;
use fluxswarm_gpu::learn::env::MultiAgentEnv;
use fluxswarm_gpu::learn::mappo::{Learner, TrainConfig};
use fluxswarm_gpu::rng::Rng;
use fluxswarm_gpu::testing::PointMasses;

const ENVS: usize = 8;
const AGENTS: usize = 2;

/// Mean (progress, energy, smoothness) over the first `episodes` finished episodes.
fn evaluate(
    mut policy: impl FnMut(&[f32]) -> Vec<[f32; 2]>,
    episodes: usize,
    seed: u64,
) -> [f64; 3] {
    let mut env = PointMasses::new(ENVS, AGENTS, seed);
    let mut obs = env.reset().unwrap();
    let mut done = Vec::new();
    while done.len() < episodes {
        let t = env.step(&policy(&obs)).unwrap();
        done.extend(t.episodes.into_iter().flatten());
        obs = t.obs;
    }
    let n = episodes as f64;
    done[..episodes].iter().fold([0.0; 3], |m, ep| {
        [
            m[0] + ep.progress / n,
            m[1] + ep.energy / n,
            m[2] + ep.smoothness / n,
        ]
    })
}

fn train_and_compare(pcgrad: bool, action_distribution: ActionDistribution) {
    let mut rng = Rng::new(3);
    let random = evaluate(
        |o| {
            (0..o.len() / 8)
                .map(|_| [rng.range(-1.0, 1.0) as f32, rng.range(-1.0, 1.0) as f32])
                .collect()
        },
        48,
        1,
    );
    // SPEC defaults except 4 minibatches per epoch (bounds the test's time).
    let cfg = TrainConfig {
        pcgrad,
        action_distribution,
        minibatches: 4,
        ..Default::default()
    };
    let mut learner = Learner::new(AGENTS, 8, cfg, 7).unwrap();
    let mut env = PointMasses::new(ENVS, AGENTS, 11);
    let mut obs = env.reset().unwrap();
    for it in 0..50 {
        let stats = learner.iterate(&mut env, &mut obs).unwrap().stats;
        assert!(
            stats.value_loss.is_finite() && stats.entropy.is_finite(),
            "update {it}"
        );
        if pcgrad {
            assert!(stats.conflict.iter().all(|c| (0.0..=1.0).contains(c)));
        }
    }
    let trained = evaluate(
        |o| {
            let raw = learner.act(o, true).unwrap().0;
            learner.applied(&raw)
        },
        48,
        1,
    );
    println!(
        "pcgrad {pcgrad}, {action_distribution:?}: random {random:.3?} -> trained {trained:.3?} (progress, energy, smoothness)"
    );
    assert!(
        trained[0] > random[0] + 3.0,
        "progress: {trained:?} vs {random:?}"
    );
    assert!(
        trained[1] > random[1] + 0.3,
        "energy: {trained:?} vs {random:?}"
    );
    assert!(
        trained[2] > random[2] + 0.3,
        "smoothness: {trained:?} vs {random:?}"
    );
}

#[test]
fn learns_with_pcgrad() {
    train_and_compare(true, ActionDistribution::Gaussian);
}

#[test]
fn learns_without_pcgrad() {
    train_and_compare(false, ActionDistribution::Gaussian);
}

#[test]
fn learns_with_the_tanh_policy() {
    train_and_compare(true, ActionDistribution::Tanh);
}

//! The learner learns: on the CPU point-mass environment (a known optimum: push straight to
//! the target, smoothly), a bounded training run improves every objective's episode metric
//! clearly over the random policy, with and without PCGrad, and with the tanh-squashed policy.
//! On a phase clock (zero observations, a reward driven by a hidden phase) a critic that reads
//! the phase predicts the return, and an actor that reads it learns the phase-dependent best
//! action, which no phase-blind actor can.

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
            let raw = learner.act(o, &[], true).unwrap().0;
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

/// E environments of N agents whose observations are all zero and whose progress reward at
/// control step t is sin(2 pi (t0 + t) / P), with a random start t0 per episode and truncation
/// after `MAX` steps: only a critic that reads the phase (the global state) can predict the
/// return.
struct PhaseClock {
    envs: usize,
    agents: usize,
    /// Pay for the action instead: progress a_x sin(2 pi (t0 + t) / P) - a_x^2 / 2, best at
    /// a_x = sin(...), which only an actor that reads the phase can follow.
    pays_action: bool,
    t: Vec<u32>,
    start: Vec<u32>,
    rng: Rng,
}

impl PhaseClock {
    const PERIOD: u32 = 16;
    const MAX: u32 = 40;

    fn new(envs: usize) -> Self {
        Self {
            envs,
            agents: 2,
            pays_action: false,
            t: vec![0; envs],
            start: vec![0; envs],
            rng: Rng::new(9),
        }
    }

    fn angle(&self, e: usize, t: u32) -> f64 {
        std::f64::consts::TAU * ((self.start[e] + t) % Self::PERIOD) as f64 / Self::PERIOD as f64
    }
    fn features(&self, e: usize, t: u32) -> Vec<f32> {
        let a = self.angle(e, t);
        vec![a.sin() as f32, a.cos() as f32]
    }
    fn restart(&mut self, e: usize) {
        self.t[e] = 0;
        self.start[e] = (self.rng.next_u64() % Self::PERIOD as u64) as u32;
    }
}

impl MultiAgentEnv for PhaseClock {
    fn n_env(&self) -> usize {
        self.envs
    }
    fn n_agents(&self) -> usize {
        self.agents
    }
    fn obs_dim(&self) -> usize {
        8
    }
    fn reset(&mut self) -> Result<Vec<f32>, fluxswarm_gpu::learn::env::EnvError> {
        (0..self.envs).for_each(|e| self.restart(e));
        Ok(vec![0.0; self.envs * self.agents * 8])
    }
    fn step(
        &mut self,
        actions: &[[f32; 2]],
    ) -> Result<fluxswarm_gpu::learn::env::Transition, fluxswarm_gpu::learn::env::EnvError> {
        let (ne, n) = (self.envs, self.agents);
        let mut tr = fluxswarm_gpu::learn::env::Transition::empty(ne, n);
        tr.obs.resize(ne * n * 8, 0.0);
        for e in 0..ne {
            let r = self.angle(e, self.t[e]).sin() as f32;
            for i in 0..n {
                let a = actions[e * n + i][0];
                tr.rewards[(e * n + i) * 3] = match self.pays_action {
                    true => a * r - 0.5 * a * a,
                    false => r,
                };
            }
            self.t[e] += 1;
            if self.t[e] >= Self::MAX {
                tr.truncated[e] = true;
                tr.final_obs[e] = Some(vec![0.0; n * 8]);
                tr.final_global_state[e] = Some(self.features(e, self.t[e]));
                self.restart(e);
            }
        }
        Ok(tr)
    }
    fn save_state(
        &self,
        _: &mut fluxswarm_gpu::checkpoint::Archive,
    ) -> Result<(), fluxswarm_gpu::learn::env::EnvError> {
        Ok(())
    }
    fn load_state(
        &mut self,
        _: &fluxswarm_gpu::checkpoint::Archive,
    ) -> Result<(), fluxswarm_gpu::learn::env::EnvError> {
        Ok(())
    }
    fn global_state_dim(&self) -> usize {
        2
    }
    fn global_state(&self) -> Vec<f32> {
        (0..self.envs)
            .flat_map(|e| self.features(e, self.t[e]))
            .collect()
    }
}

/// Mean value loss over the last 5 of 30 updates on [`PhaseClock`], with a critic that reads
/// `global` global-state inputs (0 or 2).
fn phase_clock_value_loss(global: usize) -> f64 {
    let cfg = TrainConfig {
        gamma: 0.9,
        minibatches: 4,
        ..Default::default()
    };
    let mut learner = Learner::with_global_state(2, 8, global, cfg, 3).unwrap();
    let mut env = PhaseClock::new(4);
    let mut obs = env.reset().unwrap();
    let losses: Vec<f64> = (0..30)
        .map(|_| {
            learner
                .iterate(&mut env, &mut obs)
                .unwrap()
                .stats
                .value_loss
        })
        .collect();
    losses[25..].iter().sum::<f64>() / 5.0
}

#[test]
fn a_critic_that_reads_the_phase_predicts_a_phase_driven_return() {
    // The discounted return of sin(2 pi (phi + k) / 16) at gamma 0.9 swings by about +-2.6
    // with phi: the phase-blind critic can only learn its mean (value loss near
    // 1.5 x 2.6^2 / 2 / 3 = 1.7 over the three heads), the phase-reading one the swing.
    let blind = phase_clock_value_loss(0);
    let reading = phase_clock_value_loss(2);
    println!("value loss: phase-blind {blind:.3}, phase-reading {reading:.3}");
    assert!(
        blind > 0.5,
        "the blind critic cannot fit the swing: {blind}"
    );
    assert!(reading < 0.2 * blind, "{reading} vs {blind}");
}

#[test]
fn a_critic_made_for_another_global_state_length_is_refused() {
    let mut learner = Learner::with_global_state(2, 8, 3, TrainConfig::default(), 3).unwrap();
    let mut env = PhaseClock::new(2);
    let mut obs = env.reset().unwrap();
    let err = learner.iterate(&mut env, &mut obs).unwrap_err().to_string();
    assert!(
        err.contains("reads 3 global-state inputs but the environment offers 2"),
        "{err}"
    );
}

/// Mean progress reward per agent and step of `learner`'s mean action over 64 steps of a fresh
/// action-paying [`PhaseClock`] (its best is E[sin^2] / 2 = 0.25; a phase-blind policy's best
/// is 0, at a_x = 0).
fn phase_clock_action_reward(learner: &mut Learner) -> f64 {
    let mut env = PhaseClock::new(4);
    env.pays_action = true;
    env.rng = Rng::new(77);
    let mut obs = env.reset().unwrap();
    let mut total = 0.0;
    for _ in 0..64 {
        let global = match learner.actor_reads_global() {
            true => env.global_state(),
            false => Vec::new(),
        };
        let a = learner
            .act(&learner.normalize(&obs), &global, true)
            .unwrap()
            .0;
        let t = env.step(&learner.applied(&a)).unwrap();
        total += t.rewards.iter().step_by(3).map(|&r| r as f64).sum::<f64>();
        obs = t.obs;
    }
    total / (64 * 4 * 2) as f64
}

/// Trains 120 updates on the action-paying [`PhaseClock`] with a critic that reads the phase,
/// and an actor that reads it too when `actor_phase`; returns the trained mean action's reward.
fn phase_clock_trained_reward(actor_phase: bool) -> f64 {
    let cfg = TrainConfig {
        gamma: 0.9,
        minibatches: 4,
        critic_phase: true,
        actor_phase,
        ..Default::default()
    };
    let mut learner = Learner::with_global_state(2, 8, 2, cfg, 3).unwrap();
    let mut env = PhaseClock::new(4);
    env.pays_action = true;
    let mut obs = env.reset().unwrap();
    for _ in 0..120 {
        learner.iterate(&mut env, &mut obs).unwrap();
    }
    phase_clock_action_reward(&mut learner)
}

#[test]
fn an_actor_that_reads_the_phase_learns_a_phase_dependent_action() {
    // Zero observations: the best phase-blind action is a_x = 0 (reward 0: the 64 evaluated
    // steps are 4 whole periods, over which sin sums to 0), the best phase-reading one
    // a_x = sin(phi) (reward 0.25 per step).
    let blind = phase_clock_trained_reward(false);
    let reading = phase_clock_trained_reward(true);
    println!("mean reward per step: phase-blind actor {blind:.3}, phase-reading {reading:.3}");
    assert!(blind <= 0.01, "a blind actor cannot beat a_x = 0: {blind}");
    assert!(
        reading > 0.15,
        "the phase-reading actor follows sin(phi): {reading}"
    );
}

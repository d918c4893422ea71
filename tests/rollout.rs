//! The library's rollout runner (`fluxswarm_gpu::rollout`, behind `rollout`, `eval` and the
//! Python package): each environment's quota of episodes, a recorder that sees every start,
//! step and end of the episodes that count, and a stop between steps.

mod common;

use std::collections::BTreeMap;

use fluxswarm_gpu::env::SwarmEnv;
use fluxswarm_gpu::env::policy::Controller;
use fluxswarm_gpu::learn::transition::{EpisodeSummary, Outcome};
use fluxswarm_gpu::rollout::{self, Discard, Policy, Recorder, RolloutError, StepView};
use fluxswarm_gpu::sim::CpuBatch;

/// Per (environment, episode): starts seen, the steps seen in order, and the summary.
#[derive(Default)]
struct Log {
    starts: BTreeMap<(usize, u64), u32>,
    steps: BTreeMap<(usize, u64), Vec<u32>>,
    ends: Vec<EpisodeSummary>,
}

impl Recorder for Log {
    fn start(&mut self, _: &SwarmEnv, e: usize, episode: u64) -> Result<(), RolloutError> {
        *self.starts.entry((e, episode)).or_default() += 1;
        Ok(())
    }
    fn step(&mut self, _: &SwarmEnv, v: &StepView) -> Result<(), RolloutError> {
        assert_eq!(v.members.len(), 3);
        assert_eq!(v.actions.len(), 3);
        // Every episode times out after 4 steps: the 4th is its last.
        assert_eq!(v.last, v.step == 4, "step {} of env {}", v.step, v.env);
        self.steps
            .entry((v.env, v.episode))
            .or_default()
            .push(v.step);
        Ok(())
    }
    fn finish(&mut self, s: &EpisodeSummary) -> Result<(), RolloutError> {
        self.ends.push(s.clone());
        Ok(())
    }
}

/// Three environments of a 30 x 2 mm channel whose episodes time out after 4 steps.
fn env() -> SwarmEnv {
    let r = common::swarm_config(
        300,
        20,
        &[[14.0, 0.6], [15.0, 1.4], [16.0, 0.6]],
        &["env.max_steps=4", "solver.backend=native"],
    );
    SwarmEnv::new(Box::new(CpuBatch::new(&r, 3).unwrap()), &r, 7).unwrap()
}

#[test]
fn the_quota_gives_the_remainder_to_the_first_environments() {
    assert_eq!(rollout::quota(7, 3), vec![3, 2, 2]);
    assert_eq!(rollout::quota(2, 4), vec![1, 1, 0, 0]);
    assert_eq!(rollout::quota(8, 4), vec![2, 2, 2, 2]);
}

#[test]
fn a_rollout_collects_each_environments_quota_and_records_every_step() {
    let mut env = env();
    let mut policy = Policy::controller(Controller::Zero, 1);
    let mut log = Log::default();
    let mut calls = 0;
    let stats = rollout::run(&mut env, &mut policy, 7, &mut log, &|| false, &mut |p| {
        calls += 1;
        assert!(p.finished <= 7);
    })
    .unwrap();
    // Environment 0 runs 3 episodes, 1 and 2 run 2 each, at 4 steps an episode: 12 steps of
    // the batch of 3.
    assert_eq!(stats.episodes.len(), 7);
    assert_eq!(stats.env_steps, 12 * 3);
    assert_eq!(calls, 12);
    let per_env = |e: usize| stats.episodes.iter().filter(|s| s.env == e).count();
    assert_eq!([per_env(0), per_env(1), per_env(2)], [3, 2, 2]);
    assert!(stats.episodes.iter().all(|s| s.outcome == Outcome::Timeout));
    assert_eq!(log.ends.len(), 7);
    // Every counted episode was started once and seen at steps 1..=4; none beyond the quota.
    let counted: Vec<(usize, u64)> = stats.episodes.iter().map(|s| (s.env, s.episode)).collect();
    assert_eq!(log.starts.keys().copied().collect::<Vec<_>>().len(), 7);
    for key in &counted {
        assert_eq!(log.starts.get(key), Some(&1), "{key:?}");
        assert_eq!(log.steps.get(key), Some(&vec![1, 2, 3, 4]), "{key:?}");
    }
    assert_eq!(log.steps.len(), 7);
}

#[test]
fn a_stop_before_the_first_step_collects_nothing() {
    let mut env = env();
    let mut policy = Policy::controller(Controller::Upstream, 1);
    let stats = rollout::run(
        &mut env,
        &mut policy,
        5,
        &mut Discard,
        &|| true,
        &mut |_| panic!("no step was taken"),
    )
    .unwrap();
    assert!(stats.episodes.is_empty());
    assert_eq!(stats.env_steps, 0);
}

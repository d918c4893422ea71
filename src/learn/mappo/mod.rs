//! MOMAPPO with PCGrad (SPEC section 5): rollouts of T steps x E environments, GAE per
//! objective and agent, the joint PPO ratio, one clipped surrogate per objective, PCGrad over
//! the three actor gradients (a random projection order per minibatch), plus the entropy
//! bonus's gradient; the critic learns from 0.5 x the sum of its three heads' MSE. The actor's
//! and the critic's gradients are clipped separately; Adam for both.
//! The four actor gradients come from one forward and one batched backward pass
//! ([`mlp::actor::backward`]): each surrogate's gradient is d loss_k / d lp (per sample, plain
//! Rust in [`clipped_surrogate_grad`]) times the shared d lp / d output, and the entropy bonus
//! is a second set of output gradients. Tests hold both against candle's autograd of the losses.
//! The networks run by hand on flat f32 parameter vectors ([`mlp`]: whole-minibatch matrix
//! products, no tensor per operation); candle's variables (`var_map`) hold the same values
//! after every update, for checkpoints and the candle reference networks of the tests.
//! Samples are joint transitions (one environment at one step); each epoch splits them into
//! `minibatches` random minibatches.
//! The learner's state and construction are here; acting and the rollout (`rollout`), the
//! update (`update`) and checkpoints (`state`) are its other jobs.

mod rollout;
mod state;
mod update;

use candle_core::{DType, Device, Tensor, Var};
use candle_nn::{VarBuilder, VarMap};

use super::adam::Adam;
use super::env::MultiAgentEnv;
use super::error::LearnError;
use super::gae::{Rollout, gae};
use super::mlp::{self, Layout, actor::ActorActs};
#[cfg(test)]
use super::nets::ActorPass;
use super::nets::{Actor, Critic};
use super::normalizer::ObsNormalizer;
use super::pcgrad::{combine, dot, plan};
use super::ppo::clipped_surrogate_grad;
use super::squash;
#[cfg(test)]
use super::surgery::flatten;
use super::surgery::{named_vars, set_values, values};
use super::transition::EpisodeSummary;
use crate::checkpoint::Archive;
use crate::config::ActionDistribution;
use crate::rng::Rng;

/// Hyperparameters: the `[train]` table of the configuration (SPEC section 5).
pub use crate::config::Train as TrainConfig;

/// What one update logs (the `updates.csv` columns it owns).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UpdateStats {
    /// Mean surrogate loss per objective (progress, energy, smoothness).
    pub loss: [f64; 3],
    /// Mean value loss (0.5 x the sum of the three heads' MSE) over minibatches.
    pub value_loss: f64,
    /// Mean policy entropy per agent (summed over the 2 action dims) over minibatches.
    pub entropy: f64,
    /// Mean log-std of the Gaussian policy over minibatches.
    pub mean_log_std: f64,
    /// Mean cosine between the objective gradients: (p,e), (p,s), (e,s).
    pub cosine: [f64; 3],
    /// Fraction of minibatches in which that pair conflicted.
    pub conflict: [f64; 3],
}

/// One rollout and update.
#[derive(Debug, Clone)]
pub struct Iteration {
    /// Statistics of the update.
    pub stats: UpdateStats,
    /// Episodes that ended during the rollout.
    pub episodes: Vec<EpisodeSummary>,
    /// Environment steps collected (rollout_steps x E).
    pub env_steps: usize,
    /// Wall time inside `env.step` and everything else (acting, GAE, the update) (s).
    pub sim_s: f64,
    /// Wall time of everything outside `env.step` in this iteration (s).
    pub learn_s: f64,
}

/// What [`Learner::actor_gradients`] returns: flat gradients in `actor_vars` order.
struct ActorGradients {
    /// One per objective (progress, energy, smoothness).
    objectives: Vec<Vec<f32>>,
    /// The entropy bonus's (already times -entropy_coef).
    entropy_bonus: Vec<f32>,
    /// Mean entropy per agent and mean log σ of the minibatch.
    entropy: f64,
    mean_log_std: f64,
}

/// The MOMAPPO learner: actor, critic, their Adam states, the normaliser and the RNG.
pub struct Learner {
    /// Hyperparameters it trains with.
    pub cfg: TrainConfig,
    agents: usize,
    obs_dim: usize,
    /// Global-state inputs G of the critic after the joint observations (0 unless the learner
    /// was made by [`Learner::with_global_state`]).
    global_dim: usize,
    /// Global-state inputs of the actor after each agent's observation: G with
    /// `train.actor_phase`, else 0.
    actor_global: usize,
    map: VarMap,
    /// candle's actor on the same variables: the reference the tests hold the hand-written
    /// passes to (training never runs it).
    #[cfg(test)]
    actor: Actor,
    actor_vars: Vec<(String, Var)>,
    critic_vars: Vec<(String, Var)>,
    /// The parameters the learner trains, flat in `actor_vars` / `critic_vars` order (the
    /// layouts of [`mlp::actor::layout`] and [`mlp::critic::layout`]); copied into the
    /// variables after every update ([`Self::sync_vars`]).
    actor_layout: Layout,
    critic_layout: Layout,
    actor_p: Vec<f32>,
    critic_p: Vec<f32>,
    opt_actor: Adam,
    opt_critic: Adam,
    /// Running observation statistics when `normalize_observations` is on.
    normalizer: Option<ObsNormalizer>,
    rng: Rng,
    /// A rayon pool of [`learner_threads`] threads (default one) that runs the networks' work
    /// (`act`, `values`, the update); the matrix products split over its threads when it has
    /// more than one (with the same result). The global pool stays free for the native fluid
    /// step.
    pool: std::sync::Arc<rayon::ThreadPool>,
}

/// The critic's inputs `[B][J + G]`: each row's joint observations `x` `[B][J]`, then its
/// global state `global` `[B][G]` (borrowed as it is when G = 0).
fn joint_states<'a>(
    x: &'a [f32],
    joint: usize,
    global: &[f32],
    g: usize,
) -> std::borrow::Cow<'a, [f32]> {
    if g == 0 {
        return std::borrow::Cow::Borrowed(x);
    }
    let rows = x.len() / joint;
    assert_eq!(global.len(), rows * g, "one global state per row");
    let mut out = Vec::with_capacity(rows * (joint + g));
    for (row, state) in x.chunks_exact(joint).zip(global.chunks_exact(g)) {
        out.extend_from_slice(row);
        out.extend_from_slice(state);
    }
    std::borrow::Cow::Owned(out)
}

/// The actor's inputs `[E][N][D + G]`: each agent's row of `x` `[E][N][D]`, then its
/// environment's global state `global` `[E][G]` (borrowed as it is when G = 0).
fn agent_inputs<'a>(
    x: &'a [f32],
    d: usize,
    agents: usize,
    global: &[f32],
    g: usize,
) -> std::borrow::Cow<'a, [f32]> {
    if g == 0 {
        return std::borrow::Cow::Borrowed(x);
    }
    let envs = x.len() / (agents * d);
    assert_eq!(global.len(), envs * g, "one global state per environment");
    let mut out = Vec::with_capacity(envs * agents * (d + g));
    for (rows, state) in x.chunks_exact(agents * d).zip(global.chunks_exact(g)) {
        for row in rows.chunks_exact(d) {
            out.extend_from_slice(row);
            out.extend_from_slice(state);
        }
    }
    std::borrow::Cow::Owned(out)
}

fn adam(vars: &[(String, Var)], lr: f64) -> Adam {
    Adam::new(vars.iter().map(|v| v.1.elem_count()).sum(), lr)
}

/// Re-initialises every parameter from `rng` (candle cannot seed its CPU generator), with
/// candle's own laws: weights [out, in] Kaiming-normal, N(0, 2 / in); biases uniform in
/// +-1 / sqrt(in) of their layer. Parameters are visited in name order, so a seed fixes them.
pub fn seed_parameters(map: &VarMap, rng: &mut Rng) -> candle_core::Result<()> {
    let vars = named_vars(map, "");
    let fan_in = |layer: &str| {
        vars.iter()
            .find(|(k, _)| k == &format!("{layer}.weight"))
            .map(|(_, v)| v.dims()[1])
            .unwrap_or(1)
    };
    for (name, var) in &vars {
        let (layer, kind) = name.rsplit_once('.').unwrap_or(("", name));
        let n_in = fan_in(layer) as f64;
        let values: Vec<f32> = (0..var.elem_count())
            .map(|_| {
                if kind == "weight" {
                    ((2.0 / n_in).sqrt() * rng.normal()) as f32
                } else {
                    rng.range(-1.0, 1.0) as f32 / n_in.sqrt() as f32
                }
            })
            .collect();
        var.set(&Tensor::from_vec(values, var.shape(), var.device())?.to_dtype(var.dtype())?)?;
    }
    Ok(())
}

/// The factor that clips a gradient of squared norm `norm_sq` to norm `max`, none where it is
/// within (the gradient is then used as it is).
fn clip_scale(norm_sq: f64, max: f64) -> Option<f32> {
    let norm = norm_sq.sqrt();
    (norm > max).then(|| (max / norm) as f32)
}

/// Threads of the learner's own pool: `FLUXSWARM_LEARNER_THREADS`, default 1; the matrix
/// products of the hand-written networks split over them (with the same result). On the 2-core
/// development VM a second thread gained nothing, with candle's networks and with the
/// hand-written ones (docs/performance.md, "The learner's cost"); many-core machines may gain
/// from more at large batches.
pub fn learner_threads() -> Result<usize, LearnError> {
    match std::env::var("FLUXSWARM_LEARNER_THREADS") {
        Err(_) => Ok(1),
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(LearnError::Threads { value: v }),
        },
    }
}

impl Learner {
    /// A learner for `agents` agents with `obs_dim` observations, parameters seeded from `seed`.
    pub fn new(
        agents: usize,
        obs_dim: usize,
        cfg: TrainConfig,
        seed: u64,
    ) -> Result<Self, LearnError> {
        Self::with_global_state(agents, obs_dim, 0, cfg, seed)
    }

    /// As [`Self::new`], with a critic that also reads `global_dim` inputs of the environment's
    /// global state ([`MultiAgentEnv::global_state`]) after the joint observations; the
    /// environment it iterates must offer exactly that many. With `cfg.actor_phase` the actor
    /// reads them too, after each agent's observation (`global_dim` must then be above 0).
    pub fn with_global_state(
        agents: usize,
        obs_dim: usize,
        global_dim: usize,
        cfg: TrainConfig,
        seed: u64,
    ) -> Result<Self, LearnError> {
        if cfg.actor_phase && global_dim == 0 {
            return Err(LearnError::ActorPhase);
        }
        let actor_global = if cfg.actor_phase { global_dim } else { 0 };
        let dev = Device::Cpu;
        let map = VarMap::new();
        let vb = VarBuilder::from_varmap(&map, DType::F32, &dev);
        let _actor = Actor::new(vb.pp("actor"), obs_dim + actor_global, 2)?;
        // candle's critic only creates its variables (the checkpoints' names and shapes).
        Critic::new(vb.pp("critic"), agents, obs_dim, global_dim)?;
        let mut rng = Rng::new(seed);
        seed_parameters(&map, &mut rng)?;
        let actor_vars = named_vars(&map, "actor");
        let critic_vars = named_vars(&map, "critic");
        let actor_layout = mlp::actor::layout(obs_dim + actor_global, 2);
        let critic_layout = mlp::critic::layout(agents, obs_dim, global_dim);
        for (tag, layout, vars) in [
            ("actor", &actor_layout, &actor_vars),
            ("critic", &critic_layout, &critic_vars),
        ] {
            let want: Vec<(String, Vec<usize>)> = layout
                .params()
                .iter()
                .map(|(n, s)| (format!("{tag}.{n}"), s.clone()))
                .collect();
            let have: Vec<(String, Vec<usize>)> = vars
                .iter()
                .map(|(n, v)| (n.clone(), v.dims().to_vec()))
                .collect();
            if want != have {
                return Err(LearnError::Layout {
                    net: tag,
                    want,
                    have,
                });
            }
        }
        let actor_p = values(&actor_vars)?;
        let critic_p = values(&critic_vars)?;
        let opt_actor = adam(&actor_vars, cfg.learning_rate);
        let opt_critic = adam(&critic_vars, cfg.learning_rate);
        let normalizer = cfg
            .normalize_observations
            .then(|| ObsNormalizer::new(obs_dim));
        Ok(Self {
            cfg,
            agents,
            obs_dim,
            global_dim,
            actor_global,
            map,
            #[cfg(test)]
            actor: _actor,
            actor_vars,
            critic_vars,
            actor_layout,
            critic_layout,
            actor_p,
            critic_p,
            opt_actor,
            opt_critic,
            normalizer,
            rng,
            pool: std::sync::Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(learner_threads()?)
                    .build()?,
            ),
        })
    }

    /// Observations `[rows][D]` as the networks see them (normalised when that is on).
    pub fn normalize(&self, obs: &[f32]) -> Vec<f32> {
        match &self.normalizer {
            Some(n) => n.apply(obs),
            None => obs.to_vec(),
        }
    }

    /// candle's variables (actor and critic), updated after every update.
    pub fn var_map(&self) -> &VarMap {
        &self.map
    }

    /// Copies the trained flat parameters into candle's variables.
    fn sync_vars(&self) -> candle_core::Result<()> {
        set_values(&self.actor_vars, &self.actor_p)?;
        set_values(&self.critic_vars, &self.critic_p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::surgery::values;

    #[test]
    fn a_seed_fixes_the_parameters() {
        let a = Learner::new(3, 8, TrainConfig::default(), 42).unwrap();
        let b = Learner::new(3, 8, TrainConfig::default(), 42).unwrap();
        let c = Learner::new(3, 8, TrainConfig::default(), 43).unwrap();
        let flat = |l: &Learner| values(&named_vars(l.var_map(), "")).unwrap();
        assert_eq!(flat(&a), flat(&b));
        assert_ne!(flat(&a), flat(&c));
        // Kaiming-normal first layer: variance 2 / 8.
        let w: Vec<f32> = named_vars(a.var_map(), "actor.l1.weight")[0]
            .1
            .as_tensor()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap();
        let var = w.iter().map(|x| (*x as f64).powi(2)).sum::<f64>() / w.len() as f64;
        assert!((var - 0.25).abs() < 0.03, "{var}");
    }

    #[test]
    fn the_batched_actor_gradients_equal_autograd_of_each_loss() {
        use super::super::nets::{gaussian_entropy, gaussian_log_prob};
        use super::super::ppo::clipped_surrogate;
        let (b, n) = (5, 3);
        let learner = Learner::new(n, 8, TrainConfig::default(), 2).unwrap();
        let mut rng = Rng::new(9);
        let mut noise = |len: usize, s: f64| -> Vec<f32> {
            (0..len).map(|_| (s * rng.normal()) as f32).collect()
        };
        let obs = noise(b * n * 8, 1.0);
        let actions = noise(b * n * 2, 1.5);
        let adv = noise(b * n * 3, 1.0);
        let dev = Device::Cpu;
        let o = Tensor::from_slice(&obs, (b * n, 8), &dev).unwrap();
        let a = Tensor::from_slice(&actions, (b * n, 2), &dev).unwrap();
        let pass = learner.actor.forward_pass(&o).unwrap();
        let lp = gaussian_log_prob(&a, &pass.mean, &pass.log_std)
            .unwrap()
            .reshape((b, n))
            .unwrap()
            .sum_keepdim(1)
            .unwrap();
        // Old log-probabilities off by up to +-0.5, so some ratios leave the clip range.
        let lp_now: Vec<f32> = lp.flatten_all().unwrap().to_vec1().unwrap();
        let lp_old: Vec<f32> = lp_now
            .iter()
            .zip(noise(b, 0.3))
            .map(|(l, e)| l + e)
            .collect();
        let lp_old_t = Tensor::from_slice(&lp_old, (b, 1), &dev).unwrap();
        let adv_t = Tensor::from_slice(&adv, (b, n, 3), &dev).unwrap();
        let d_lp: Vec<Vec<f32>> = (0..3)
            .map(|k| {
                let adv_k: Vec<f32> = adv.iter().skip(k).step_by(3).copied().collect();
                clipped_surrogate_grad(&lp_now, &lp_old, &adv_k, 0.2).1
            })
            .collect();
        let got = learner
            .actor_gradients(&pass, &actions, &d_lp, &[], b, n)
            .unwrap();
        // The reference: candle's autograd through each loss, as the update once did it.
        let mut want = Vec::new();
        for k in 0..3 {
            let adv_k = adv_t.narrow(2, k, 1).unwrap().squeeze(2).unwrap();
            let loss = clipped_surrogate(&lp, &lp_old_t, &adv_k, 0.2).unwrap();
            want.push(flatten(&loss.backward().unwrap(), &learner.actor_vars).unwrap());
        }
        let h = gaussian_entropy(&pass.log_std).unwrap().mean_all().unwrap();
        want.push(
            flatten(
                &h.affine(-0.01, 0.0).unwrap().backward().unwrap(),
                &learner.actor_vars,
            )
            .unwrap(),
        );
        let all = got.objectives.iter().chain([&got.entropy_bonus]);
        for (k, (got, want)) in all.zip(&want).enumerate() {
            let scale = want.iter().fold(0f32, |m, x| m.max(x.abs()));
            assert!(scale > 0.0, "loss {k} has a gradient");
            for (x, y) in got.iter().zip(want) {
                assert!((x - y).abs() <= 1e-5 * scale, "loss {k}: {x} vs {y}");
            }
        }
        assert!((got.entropy - h.to_scalar::<f32>().unwrap() as f64).abs() < 1e-5);
        let mls = pass.log_std.mean_all().unwrap().to_scalar::<f32>().unwrap() as f64;
        assert!((got.mean_log_std - mls).abs() < 1e-6);
    }

    fn small_cfg() -> TrainConfig {
        TrainConfig {
            rollout_steps: 8,
            minibatches: 2,
            epochs: 2,
            normalize_observations: true,
            ..TrainConfig::default()
        }
    }

    #[test]
    fn a_checkpoint_restores_learner_and_environment_exactly() {
        use crate::testing::PointMasses;
        let mut env = PointMasses::new(3, 2, 11);
        let mut a = Learner::new(2, 8, small_cfg(), 4).unwrap();
        let mut obs = env.reset().unwrap();
        for _ in 0..2 {
            a.iterate(&mut env, &mut obs).unwrap();
        }
        let mut archive = Archive::new();
        a.save_state(&mut archive).unwrap();
        env.save_state(&mut archive).unwrap();
        let bytes = archive.to_bytes();
        let loaded = Archive::from_bytes(&bytes, std::path::Path::new("mem")).unwrap();
        // A learner with another seed and a fresh environment, restored.
        let mut b = Learner::new(2, 8, small_cfg(), 99).unwrap();
        let mut env_b = PointMasses::new(3, 2, 0);
        env_b.reset().unwrap();
        b.load_state(&loaded).unwrap();
        env_b.load_state(&loaded).unwrap();
        assert_eq!(a.normalizer, b.normalizer);
        assert!(a.normalizer.as_ref().unwrap().count > 0.0);
        let mut obs_b = obs.clone();
        let ia = a.iterate(&mut env, &mut obs).unwrap();
        let ib = b.iterate(&mut env_b, &mut obs_b).unwrap();
        assert_eq!(ia.stats, ib.stats);
        assert_eq!(ia.episodes, ib.episodes);
        assert_eq!(obs, obs_b);
        let flat = |l: &Learner| values(&named_vars(l.var_map(), "")).unwrap();
        assert_eq!(flat(&a), flat(&b));
        assert_eq!(a.opt_actor, b.opt_actor);
    }

    #[test]
    fn a_checkpoint_of_another_swarm_size_or_setting_is_refused() {
        let a = Learner::new(2, 8, small_cfg(), 4).unwrap();
        let mut archive = Archive::new();
        a.save_state(&mut archive).unwrap();
        let mut three = Learner::new(3, 8, small_cfg(), 4).unwrap();
        let before = values(&named_vars(three.var_map(), "")).unwrap();
        let e = three.load_state(&archive).unwrap_err().to_string();
        assert!(e.contains("does not fit") && e.contains("2 agents"), "{e}");
        assert_eq!(before, values(&named_vars(three.var_map(), "")).unwrap());
        let plain = TrainConfig {
            normalize_observations: false,
            ..small_cfg()
        };
        let mut b = Learner::new(2, 8, plain, 4).unwrap();
        let e = b.load_state(&archive).unwrap_err().to_string();
        assert!(e.contains("normalize_observations"), "{e}");
        // A critic that reads the inlet phase cannot take a phase-blind critic's weights, nor
        // the other way round; the policy (the actor) loads either way.
        let mut phased = Learner::with_global_state(2, 8, 2, small_cfg(), 4).unwrap();
        let e = phased.load_state(&archive).unwrap_err().to_string();
        assert!(e.contains("train.critic_phase = false"), "{e}");
        phased.load_policy(&archive).unwrap();
        let mut phased_archive = Archive::new();
        phased.save_state(&mut phased_archive).unwrap();
        let mut blind = Learner::new(2, 8, small_cfg(), 4).unwrap();
        let e = blind.load_state(&phased_archive).unwrap_err().to_string();
        assert!(e.contains("read 2 global-state inputs"), "{e}");
        Learner::with_global_state(2, 8, 2, small_cfg(), 5)
            .unwrap()
            .load_state(&phased_archive)
            .unwrap();
    }

    #[test]
    fn agent_inputs_append_each_environments_state_to_its_agents_rows() {
        // E = 2 environments of N = 2 agents, D = 3 observations, G = 2.
        let x: Vec<f32> = (0..12).map(|v| v as f32).collect();
        let g = [10.0, 11.0, 20.0, 21.0];
        let rows = agent_inputs(&x, 3, 2, &g, 2);
        assert_eq!(
            rows.as_ref(),
            [
                0.0, 1.0, 2.0, 10.0, 11.0, 3.0, 4.0, 5.0, 10.0, 11.0, 6.0, 7.0, 8.0, 20.0, 21.0,
                9.0, 10.0, 11.0, 20.0, 21.0
            ]
        );
        assert!(matches!(
            agent_inputs(&x, 3, 2, &[], 0),
            std::borrow::Cow::Borrowed(_)
        ));
    }

    #[test]
    fn an_actor_that_reads_the_phase_acts_on_it_and_a_blind_one_does_not() {
        let phased_cfg = TrainConfig {
            critic_phase: true,
            actor_phase: true,
            ..small_cfg()
        };
        let e = Learner::new(2, 8, phased_cfg.clone(), 4)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("train.actor_phase") && e.contains("global_state_dim"),
            "{e}"
        );
        let mut phased = Learner::with_global_state(2, 8, 2, phased_cfg, 4).unwrap();
        assert!(phased.actor_reads_global());
        let l1 = phased.actor_layout.params()[3].clone();
        assert_eq!(l1.1, vec![crate::learn::nets::HIDDEN, 10], "{l1:?}");
        // Two environments with the same observations and different phases.
        let obs: Vec<f32> = (0..16).map(|v| (v as f32 * 0.37).sin()).collect();
        let obs = [obs.clone(), obs].concat();
        let phases = [0.0, 1.0, 1.0, 0.0];
        let (a, _) = phased.act(&obs, &phases, true).unwrap();
        assert_ne!(a[..2], a[2..], "the phase moves the mean action");
        // The mean action is the actor's mean on [o_i, sin, cos], by candle's actor.
        let dev = Device::Cpu;
        let row: Vec<f32> = [&obs[8..16], &phases[..2]].concat();
        let pass = phased
            .actor
            .forward_pass(&Tensor::from_slice(&row, (1, 10), &dev).unwrap())
            .unwrap();
        let want: Vec<f32> = pass.mean.flatten_all().unwrap().to_vec1().unwrap();
        assert!((a[1][0] - want[0]).abs() < 1e-5 && (a[1][1] - want[1]).abs() < 1e-5);
        // A wrong global-state length is refused.
        let e = phased
            .act(&obs, &phases[..2], true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("global-state inputs"), "{e}");
        // The phase-blind actor ignores the global state (its critic reads it).
        let mut blind = Learner::with_global_state(2, 8, 2, small_cfg(), 4).unwrap();
        assert!(!blind.actor_reads_global());
        let (b, _) = blind.act(&obs, &[], true).unwrap();
        assert_eq!(b[..2], b[2..]);
        // Neither loads the other's policy.
        let mut archive = Archive::new();
        blind.save_policy(&mut archive).unwrap();
        let e = phased.load_policy(&archive).unwrap_err().to_string();
        assert!(e.contains("train.actor_phase = false"), "{e}");
        let mut archive = Archive::new();
        phased.save_state(&mut archive).unwrap();
        let e = blind.load_state(&archive).unwrap_err().to_string();
        assert!(e.contains("its actor read 2 global-state inputs"), "{e}");
    }

    #[test]
    fn paper_train_table_holds_the_spec_values() {
        let t = TrainConfig::default();
        assert_eq!((t.rollout_steps, t.epochs, t.minibatches), (16, 4, 16));
        assert_eq!(
            (t.gamma, t.lambda, t.learning_rate, t.clip),
            (0.95, 0.95, 1e-3, 0.2)
        );
        assert_eq!(
            (t.entropy_coef, t.max_grad_norm, t.pcgrad),
            (0.01, 0.5, true)
        );
    }
}

//! MOMAPPO with PCGrad (SPEC section 5): rollouts of T steps x E environments, GAE per
//! objective and agent, the joint PPO ratio, one clipped surrogate per objective, PCGrad over
//! the three actor gradients (a random projection order per minibatch), plus the entropy
//! bonus's gradient; the critic learns from 0.5 x the sum of its three heads' MSE. The actor's
//! and the critic's gradients are clipped separately; Adam for both.
//! The four actor gradients come from one forward and one batched backward pass
//! ([`Actor::backward`]): each surrogate's gradient is d loss_k / d lp (per sample, plain Rust
//! in [`clipped_surrogate_grad`]) times the shared d lp / d output, and the entropy bonus is a
//! second set of output gradients. Tests hold both against candle's autograd of the losses.
//! Samples are joint transitions (one environment at one step); each epoch splits them into
//! `minibatches` random minibatches.

use candle_core::{DType, Device, Tensor, Var};
use candle_nn::{VarBuilder, VarMap};

use super::adam::Adam;
use super::env::MultiAgentEnv;
use super::gae::{Rollout, gae};
use super::nets::{Actor, ActorPass, Critic, gaussian_log_prob};
use super::normalizer::ObsNormalizer;
use super::pcgrad::{average, pcgrad};
use super::ppo::clipped_surrogate_grad;
use super::surgery::{flatten, named_vars, set_values, values};
use super::transition::EpisodeSummary;
use crate::checkpoint::Archive;
use crate::rng::Rng;

/// Hyperparameters: the `[train]` table of the configuration (SPEC section 5).
pub use crate::config::Train as TrainConfig;

/// What one update logs (the `updates.csv` columns it owns).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct UpdateStats {
    /// Mean surrogate loss per objective (progress, energy, smoothness).
    pub loss: [f64; 3],
    pub value_loss: f64,
    pub entropy: f64,
    pub mean_log_std: f64,
    /// Mean cosine between the objective gradients: (p,e), (p,s), (e,s).
    pub cosine: [f64; 3],
    /// Fraction of minibatches in which that pair conflicted.
    pub conflict: [f64; 3],
}

/// One rollout and update.
#[derive(Debug, Clone)]
pub struct Iteration {
    pub stats: UpdateStats,
    /// Episodes that ended during the rollout.
    pub episodes: Vec<EpisodeSummary>,
    /// Environment steps collected (rollout_steps x E).
    pub env_steps: usize,
    /// Wall time inside `env.step` and everything else (acting, GAE, the update) (s).
    pub sim_s: f64,
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

pub struct Learner {
    pub cfg: TrainConfig,
    agents: usize,
    obs_dim: usize,
    map: VarMap,
    actor: Actor,
    critic: Critic,
    actor_vars: Vec<(String, Var)>,
    critic_vars: Vec<(String, Var)>,
    opt_actor: Adam,
    opt_critic: Adam,
    /// Running observation statistics when `normalize_observations` is on.
    normalizer: Option<ObsNormalizer>,
    rng: Rng,
    dev: Device,
    /// A rayon pool of [`learner_threads`] threads (default one) that runs the networks' tensor
    /// work (`act`, `values`, the update). candle splits even these small matrix products over
    /// rayon's threads (gemm), and on two cores the hand-offs cost more than they save. The
    /// global pool stays free for the native fluid step.
    pool: std::sync::Arc<rayon::ThreadPool>,
}

fn adam(vars: &[(String, Var)], lr: f64) -> Adam {
    Adam::new(vars.iter().map(|v| v.1.elem_count()).sum(), lr)
}

/// One Adam step on `vars` with the flat gradient `g`.
fn adam_step(opt: &mut Adam, vars: &[(String, Var)], g: &[f32]) -> candle_core::Result<()> {
    let mut p = values(vars)?;
    opt.step(&mut p, g);
    set_values(vars, &p)
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

fn clip_norm(g: &mut [f32], max: f64) {
    let norm = g.iter().map(|x| (*x as f64).powi(2)).sum::<f64>().sqrt();
    if norm > max {
        let s = (max / norm) as f32;
        g.iter_mut().for_each(|x| *x *= s);
    }
}

/// Threads of the learner's own pool: `FLUXSWARM_LEARNER_THREADS`, default 1. On the 2-core
/// development VM one thread was fastest (candle split even small products, and the
/// hand-offs cost more than they saved; docs/performance.md, "The learner's cost"); many-core machines may gain from
/// more at large batches.
pub fn learner_threads() -> anyhow::Result<usize> {
    match std::env::var("FLUXSWARM_LEARNER_THREADS") {
        Err(_) => Ok(1),
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => anyhow::bail!(
                "FLUXSWARM_LEARNER_THREADS={v}: give a positive number of threads, or unset it for 1"
            ),
        },
    }
}

impl Learner {
    pub fn new(agents: usize, obs_dim: usize, cfg: TrainConfig, seed: u64) -> anyhow::Result<Self> {
        let dev = Device::Cpu;
        let map = VarMap::new();
        let vb = VarBuilder::from_varmap(&map, DType::F32, &dev);
        let actor = Actor::new(vb.pp("actor"), obs_dim, 2)?;
        let critic = Critic::new(vb.pp("critic"), agents, obs_dim)?;
        let mut rng = Rng::new(seed);
        seed_parameters(&map, &mut rng)?;
        let actor_vars = named_vars(&map, "actor");
        let critic_vars = named_vars(&map, "critic");
        let opt_actor = adam(&actor_vars, cfg.learning_rate);
        let opt_critic = adam(&critic_vars, cfg.learning_rate);
        let normalizer = cfg
            .normalize_observations
            .then(|| ObsNormalizer::new(obs_dim));
        Ok(Self {
            cfg,
            agents,
            obs_dim,
            map,
            actor,
            critic,
            actor_vars,
            critic_vars,
            opt_actor,
            opt_critic,
            normalizer,
            rng,
            dev,
            pool: std::sync::Arc::new(
                rayon::ThreadPoolBuilder::new()
                    .num_threads(learner_threads()?)
                    .build()?,
            ),
        })
    }

    /// Observations [rows][D] as the networks see them (normalised when that is on).
    pub fn normalize(&self, obs: &[f32]) -> Vec<f32> {
        match &self.normalizer {
            Some(n) => n.apply(obs),
            None => obs.to_vec(),
        }
    }

    /// Adds the learner's whole state under `learner.`: parameters by name, both optimisers'
    /// moments and step counts, the observation normaliser and the RNG.
    pub fn save_state(&self, archive: &mut Archive) -> anyhow::Result<()> {
        for (name, var) in named_vars(&self.map, "") {
            let data: Vec<f32> = var.as_tensor().flatten_all()?.to_vec1()?;
            archive.put_f32(&format!("learner.param.{name}"), var.dims(), &data);
        }
        for (tag, opt) in [("actor", &self.opt_actor), ("critic", &self.opt_critic)] {
            let len = opt.m.len();
            archive.put_f32(&format!("learner.adam.{tag}.m"), &[len], &opt.m);
            archive.put_f32(&format!("learner.adam.{tag}.v"), &[len], &opt.v);
            archive.put_u64(&format!("learner.adam.{tag}.t"), &[opt.t]);
        }
        if let Some(n) = &self.normalizer {
            archive.put_f64("learner.obs_norm.count", &[1], &[n.count]);
            archive.put_f64("learner.obs_norm.mean", &[n.dim()], &n.mean);
            archive.put_f64("learner.obs_norm.var", &[n.dim()], &n.var);
        }
        archive.put_u64("learner.rng", &[self.rng.0]);
        archive.put_u64("learner.shape", &[self.agents as u64, self.obs_dim as u64]);
        Ok(())
    }

    /// Restores what [`Self::save_state`] wrote; the learner must have the same agents,
    /// observation size and normalisation setting.
    pub fn load_state(&mut self, archive: &Archive) -> anyhow::Result<()> {
        let shape = archive.u64("learner.shape", Some(2))?;
        if shape != [self.agents as u64, self.obs_dim as u64] {
            return Err(archive
                .mismatch(format!(
                    "it was trained with {} agents and {} observations each, this run has {} and {}",
                    shape[0], shape[1], self.agents, self.obs_dim
                ))
                .into());
        }
        let saved_norm = archive.shape("learner.obs_norm.mean").is_some();
        if saved_norm != self.normalizer.is_some() {
            return Err(archive
                .mismatch(format!(
                    "train.normalize_observations was {saved_norm} when it was written, {} now",
                    !saved_norm
                ))
                .into());
        }
        // Read everything before changing anything, so a bad file leaves the learner intact.
        let vars = named_vars(&self.map, "");
        let mut params = Vec::with_capacity(vars.len());
        for (name, var) in &vars {
            params.push(archive.f32(&format!("learner.param.{name}"), Some(var.elem_count()))?);
        }
        let mut opts = Vec::new();
        for (tag, opt) in [("actor", &self.opt_actor), ("critic", &self.opt_critic)] {
            let len = Some(opt.m.len());
            opts.push((
                archive.f32(&format!("learner.adam.{tag}.m"), len)?,
                archive.f32(&format!("learner.adam.{tag}.v"), len)?,
                archive.u64(&format!("learner.adam.{tag}.t"), Some(1))?[0],
            ));
        }
        let normalizer = match &self.normalizer {
            Some(n) => Some(ObsNormalizer {
                count: archive.f64("learner.obs_norm.count", Some(1))?[0],
                mean: archive.f64("learner.obs_norm.mean", Some(n.dim()))?,
                var: archive.f64("learner.obs_norm.var", Some(n.dim()))?,
            }),
            None => None,
        };
        let rng = archive.u64("learner.rng", Some(1))?[0];
        set_values(&vars, &params.concat())?;
        for (opt, (m, v, t)) in [&mut self.opt_actor, &mut self.opt_critic]
            .into_iter()
            .zip(opts)
        {
            (opt.m, opt.v, opt.t) = (m, v, t);
        }
        self.normalizer = normalizer;
        self.rng.0 = rng;
        Ok(())
    }

    pub fn var_map(&self) -> &VarMap {
        &self.map
    }

    /// Sampled (or mean) raw actions [E][N] and joint log-probabilities [E] for network inputs
    /// [E][N][D] (observations passed through [`Self::normalize`]).
    pub fn act(
        &mut self,
        obs: &[f32],
        deterministic: bool,
    ) -> anyhow::Result<(Vec<[f32; 2]>, Vec<f32>)> {
        let pool = self.pool.clone();
        pool.install(|| self.act_serial(obs, deterministic))
    }

    fn act_serial(
        &mut self,
        obs: &[f32],
        deterministic: bool,
    ) -> anyhow::Result<(Vec<[f32; 2]>, Vec<f32>)> {
        let rows = obs.len() / self.obs_dim;
        let x = Tensor::from_slice(obs, (rows, self.obs_dim), &self.dev)?;
        let (mean, log_std) = self.actor.forward(&x)?;
        let m: Vec<f32> = mean.flatten_all()?.to_vec1()?;
        let s: Vec<f32> = log_std.exp()?.flatten_all()?.to_vec1()?;
        let mut actions = Vec::with_capacity(rows);
        for r in 0..rows {
            let mut a = [0.0f32; 2];
            for d in 0..2 {
                let z = if deterministic {
                    0.0
                } else {
                    self.rng.normal() as f32
                };
                a[d] = m[2 * r + d] + s[2 * r + d] * z;
            }
            actions.push(a);
        }
        let a = Tensor::from_slice(&actions.concat(), (rows, 2), &self.dev)?;
        let lp: Vec<f32> = gaussian_log_prob(&a, &mean, &log_std)?
            .reshape((rows / self.agents, self.agents))?
            .sum(1)?
            .to_vec1()?;
        Ok((actions, lp))
    }

    /// Values [B][N][3] of joint states given as network inputs [B][N][D].
    pub fn values(&self, obs: &[f32]) -> anyhow::Result<Vec<f32>> {
        self.pool.install(|| {
            let b = obs.len() / (self.agents * self.obs_dim);
            let x = Tensor::from_slice(obs, (b, self.agents * self.obs_dim), &self.dev)?;
            Ok(self
                .critic
                .forward(&x)?
                .transpose(1, 2)?
                .contiguous()?
                .flatten_all()?
                .to_vec1()?)
        })
    }

    /// Collects one rollout from `env` (continuing from `obs`) and updates the networks.
    pub fn iterate(
        &mut self,
        env: &mut dyn MultiAgentEnv,
        obs: &mut Vec<f32>,
    ) -> anyhow::Result<Iteration> {
        let start = std::time::Instant::now();
        let mut sim_s = 0.0;
        let (t_len, ne, n, d) = (
            self.cfg.rollout_steps as usize,
            env.n_env(),
            self.agents,
            self.obs_dim,
        );
        let per_env = n * 3;
        let mut obs_buf = Vec::with_capacity(t_len * ne * n * d);
        let mut act_buf: Vec<[f32; 2]> = Vec::with_capacity(t_len * ne * n);
        let mut logp_buf = Vec::with_capacity(t_len * ne);
        let mut values = Vec::with_capacity(t_len * ne * per_env);
        let mut next_values = vec![0.0f32; t_len * ne * per_env];
        let mut rewards = Vec::with_capacity(t_len * ne * per_env);
        let (mut term, mut trunc, mut div) = (Vec::new(), Vec::new(), Vec::new());
        let mut episodes: Vec<EpisodeSummary> = Vec::new();
        let mut ended_prev = vec![false; ne];
        for t in 0..t_len {
            if let Some(norm) = &mut self.normalizer {
                norm.update(obs);
            }
            let x = self.normalize(obs);
            let (actions, logp) = self.act(&x, false)?;
            let v = self.values(&x)?;
            if t > 0 {
                // V(s_t) bootstraps step t-1 where that episode went on.
                for e in 0..ne {
                    if !ended_prev[e] {
                        let dst = ((t - 1) * ne + e) * per_env;
                        next_values[dst..dst + per_env]
                            .copy_from_slice(&v[e * per_env..(e + 1) * per_env]);
                    }
                }
            }
            obs_buf.extend_from_slice(&x);
            act_buf.extend_from_slice(&actions);
            logp_buf.extend(logp);
            values.extend_from_slice(&v);
            let t0 = std::time::Instant::now();
            let tr = env.step(&actions)?;
            sim_s += t0.elapsed().as_secs_f64();
            rewards.extend_from_slice(&tr.rewards);
            for (e, ended) in ended_prev.iter_mut().enumerate() {
                *ended = tr.terminated[e] || tr.truncated[e] || tr.diverged[e];
                if tr.truncated[e]
                    && let Some(f) = &tr.final_obs[e]
                {
                    let vf = self.values(&self.normalize(f))?;
                    let dst = (t * ne + e) * per_env;
                    next_values[dst..dst + per_env].copy_from_slice(&vf);
                }
                if let Some(ep) = &tr.episodes[e] {
                    episodes.push(ep.clone());
                }
            }
            term.extend_from_slice(&tr.terminated);
            trunc.extend_from_slice(&tr.truncated);
            div.extend_from_slice(&tr.diverged);
            *obs = tr.obs;
        }
        let v_last = self.values(&self.normalize(obs))?;
        for e in 0..ne {
            if !ended_prev[e] {
                let dst = ((t_len - 1) * ne + e) * per_env;
                next_values[dst..dst + per_env]
                    .copy_from_slice(&v_last[e * per_env..(e + 1) * per_env]);
            }
        }
        let (mut adv, returns) = gae(
            &Rollout {
                steps: t_len,
                envs: ne,
                agents: n,
                objectives: 3,
                rewards: &rewards,
                values: &values,
                next_values: &next_values,
                terminated: &term,
                truncated: &trunc,
                diverged: &div,
            },
            self.cfg.gamma as f32,
            self.cfg.lambda as f32,
        );
        if self.cfg.normalize_advantages {
            for k in 0..3 {
                let xs: Vec<f32> = adv.iter().skip(k).step_by(3).copied().collect();
                let m = xs.iter().sum::<f32>() / xs.len() as f32;
                let sd = (xs.iter().map(|x| (x - m).powi(2)).sum::<f32>() / xs.len() as f32).sqrt();
                adv.iter_mut()
                    .skip(k)
                    .step_by(3)
                    .for_each(|x| *x = (*x - m) / (sd + 1e-8));
            }
        }
        let pool = self.pool.clone();
        let stats = pool
            .install(|| self.update(&obs_buf, &act_buf, &logp_buf, &adv, &returns, t_len * ne))?;
        Ok(Iteration {
            stats,
            episodes,
            env_steps: t_len * ne,
            sim_s,
            learn_s: start.elapsed().as_secs_f64() - sim_s,
        })
    }

    /// The three objectives' actor gradients and the entropy bonus's, flattened in
    /// `actor_vars` order, from one forward pass and one batched backward pass, given each
    /// objective's d loss / d (joint log-probability) `d_lp` [3][B]. Also the mean entropy
    /// and mean log σ. Rows are agents, `b` samples of `n` agents each; `actions` [B N][2].
    fn actor_gradients(
        &self,
        pass: &ActorPass,
        actions: &[f32],
        d_lp: &[Vec<f32>],
        b: usize,
        n: usize,
    ) -> anyhow::Result<ActorGradients> {
        let rows = b * n;
        let mean: Vec<f32> = pass.mean.flatten_all()?.to_vec1()?;
        let log_std: Vec<f32> = pass.log_std.flatten_all()?.to_vec1()?;
        // Two sets of row gradients. Set 0, per row and action dimension: d log N / d mean =
        // z / σ and d log N / d log σ = z^2 - 1, weighted by each objective's d loss / d lp of
        // the row's sample. Set 1, the entropy bonus -c mean_rows sum_dims (log σ + const):
        // -c / rows on every d / d log σ, weight 1 for the bonus and 0 for the objectives.
        let k = d_lp.len() + 1;
        let mut d_mean = vec![0.0f32; 2 * rows * 2];
        let mut d_log_std = vec![0.0f32; 2 * rows * 2];
        for i in 0..rows * 2 {
            let inv_sigma = (-log_std[i]).exp();
            let z = (actions[i] - mean[i]) * inv_sigma;
            d_mean[i] = z * inv_sigma;
            d_log_std[i] = z * z - 1.0;
            d_log_std[rows * 2 + i] = -(self.cfg.entropy_coef / rows as f64) as f32;
        }
        let mut weights = vec![0.0f32; k * 2 * b];
        for (o, w) in d_lp.iter().enumerate() {
            weights[o * 2 * b..o * 2 * b + b].copy_from_slice(w);
        }
        weights[(k - 1) * 2 * b + b..].fill(1.0);
        let shape = (2, rows, 2);
        let grads = self.actor.backward(
            pass,
            &Tensor::from_vec(d_mean, shape, &self.dev)?,
            &Tensor::from_vec(d_log_std, shape, &self.dev)?,
            &Tensor::from_vec(weights, (k, 2, b), &self.dev)?,
        )?;
        let mut flat = vec![Vec::new(); k];
        for ((name, _), (suffix, g)) in self.actor_vars.iter().zip(&grads) {
            assert_eq!(
                name.strip_prefix("actor."),
                Some(*suffix),
                "actor parameter order"
            );
            let g: Vec<f32> = g.flatten_all()?.to_vec1()?;
            let per = g.len() / k;
            for (o, f) in flat.iter_mut().enumerate() {
                f.extend_from_slice(&g[o * per..(o + 1) * per]);
            }
        }
        let entropy_bonus = flat.pop().expect("k >= 1");
        let mean_log_std = log_std.iter().map(|&x| x as f64).sum::<f64>() / log_std.len() as f64;
        let entropy = 2.0 * (0.5 + 0.5 * (2.0 * std::f64::consts::PI).ln() + mean_log_std);
        Ok(ActorGradients {
            objectives: flat,
            entropy_bonus,
            entropy,
            mean_log_std,
        })
    }

    fn update(
        &mut self,
        obs: &[f32],
        actions: &[[f32; 2]],
        logp_old: &[f32],
        adv: &[f32],
        returns: &[f32],
        samples: usize,
    ) -> anyhow::Result<UpdateStats> {
        let (n, d) = (self.agents, self.obs_dim);
        let mb = (samples / self.cfg.minibatches.max(1) as usize).max(1);
        let mut stats = UpdateStats::default();
        let mut count = 0.0;
        for _ in 0..self.cfg.epochs {
            let perm = self.rng.permutation(samples);
            for chunk in perm.chunks(mb) {
                let b = chunk.len();
                let gather = |src: &[f32], width: usize| -> Vec<f32> {
                    chunk
                        .iter()
                        .flat_map(|&s| src[s * width..(s + 1) * width].iter().copied())
                        .collect()
                };
                let o = Tensor::from_slice(&gather(obs, n * d), (b * n, d), &self.dev)?;
                let a_flat: Vec<f32> = chunk
                    .iter()
                    .flat_map(|&s| actions[s * n..(s + 1) * n].concat())
                    .collect();
                let a = Tensor::from_slice(&a_flat, (b * n, 2), &self.dev)?;
                let ret_t = Tensor::from_slice(&gather(returns, n * 3), (b, n, 3), &self.dev)?;

                let pass = self.actor.forward_pass(&o)?;
                let lp_new: Vec<f32> = gaussian_log_prob(&a, &pass.mean, &pass.log_std)?
                    .reshape((b, n))?
                    .sum(1)?
                    .to_vec1()?;
                let (lp_old, adv_b) = (gather(logp_old, 1), gather(adv, n * 3));
                let mut d_lp = Vec::with_capacity(3);
                for k in 0..3 {
                    let adv_k: Vec<f32> = adv_b.iter().skip(k).step_by(3).copied().collect();
                    let (loss, g) =
                        clipped_surrogate_grad(&lp_new, &lp_old, &adv_k, self.cfg.clip as f32);
                    stats.loss[k] += loss;
                    d_lp.push(g);
                }
                let grads = self.actor_gradients(&pass, &a_flat, &d_lp, b, n)?;
                let surgery = if self.cfg.pcgrad {
                    let order: Vec<Vec<usize>> = (0..3)
                        .map(|i| {
                            self.rng
                                .permutation(3)
                                .into_iter()
                                .filter(|&j| j != i)
                                .collect()
                        })
                        .collect();
                    pcgrad(&grads.objectives, &order)
                } else {
                    average(&grads.objectives)
                };
                let mut g: Vec<f32> = surgery
                    .combined
                    .iter()
                    .zip(&grads.entropy_bonus)
                    .map(|(a, b)| a + b)
                    .collect();
                clip_norm(&mut g, self.cfg.max_grad_norm);
                adam_step(&mut self.opt_actor, &self.actor_vars, &g)?;

                let x = o.reshape((b, n * d))?;
                let v = self.critic.forward(&x)?.transpose(1, 2)?;
                let value_loss = (v - &ret_t)?.sqr()?.mean_all()?.affine(1.5, 0.0)?; // 0.5 x 3 heads
                let mut gc = flatten(&value_loss.backward()?, &self.critic_vars)?;
                clip_norm(&mut gc, self.cfg.max_grad_norm);
                adam_step(&mut self.opt_critic, &self.critic_vars, &gc)?;

                stats.value_loss += value_loss.to_scalar::<f32>()? as f64;
                stats.entropy += grads.entropy;
                stats.mean_log_std += grads.mean_log_std;
                for p in 0..3 {
                    stats.cosine[p] += surgery.cosines[p] as f64;
                    stats.conflict[p] += surgery.conflicts[p] as u32 as f64;
                }
                count += 1.0;
            }
        }
        for x in stats
            .loss
            .iter_mut()
            .chain(stats.cosine.iter_mut())
            .chain(stats.conflict.iter_mut())
            .chain([
                &mut stats.value_loss,
                &mut stats.entropy,
                &mut stats.mean_log_std,
            ])
        {
            *x /= count;
        }
        Ok(stats)
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
            .actor_gradients(&pass, &actions, &d_lp, b, n)
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

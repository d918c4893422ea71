//! The PPO update: the four actor gradients from one batched backward pass, PCGrad (or the
//! average) over the three objectives, the entropy bonus, gradient clipping and Adam steps for
//! actor and critic, per minibatch and epoch, all on the flat parameter vectors with the
//! hand-written networks ([`mlp`]); candle's variables are refreshed once at the end.

use super::*;

impl Learner {
    /// [`Self::actor_grads`] for a candle forward pass (the tests' reference networks).
    #[cfg(test)]
    pub(super) fn actor_gradients(
        &self,
        pass: &ActorPass,
        actions: &[f32],
        d_lp: &[Vec<f32>],
        noise: &[f32],
        b: usize,
        n: usize,
    ) -> Result<ActorGradients, LearnError> {
        Ok(self.actor_grads(&pass.to_acts()?, actions, d_lp, noise, b, n))
    }

    /// The three objectives' actor gradients and the entropy bonus's, flattened in
    /// `actor_vars` order, from one forward pass `acts` and one batched backward pass, given
    /// each objective's d loss / d (joint log-probability) `d_lp` [3][B]. Also the mean entropy
    /// and mean log σ. Rows are agents, `b` samples of `n` agents each; `actions` [B N][2];
    /// `noise` [B N][2] the tanh policy's entropy draws ([`squash::entropy_noise`]).
    pub(super) fn actor_grads(
        &self,
        acts: &ActorActs,
        actions: &[f32],
        d_lp: &[Vec<f32>],
        noise: &[f32],
        b: usize,
        n: usize,
    ) -> ActorGradients {
        let rows = b * n;
        let (mean, log_std) = (&acts.mean, &acts.log_std);
        // Two sets of row gradients. Set 0, per row and action dimension: d log N / d mean =
        // z / σ and d log N / d log σ = z^2 - 1, weighted by each objective's d loss / d lp of
        // the row's sample (the tanh policy's term depends on the sample only). Set 1, the
        // entropy bonus -c mean_rows sum_dims (log σ + const + tanh term): -c / rows times
        // (1 + the term's d / d log σ) on d / d log σ and times its d / d mean on d / d mean
        // (`squash`; zero for the Gaussian), weight 1 for the bonus and 0 for the objectives.
        let k = d_lp.len() + 1;
        let mut d_mean = vec![0.0f32; 2 * rows * 2];
        let mut d_log_std = vec![0.0f32; 2 * rows * 2];
        let bonus = -(self.cfg.entropy_coef / rows as f64) as f32;
        let mut squash_entropy = 0.0f64;
        let squashed = self.cfg.action_distribution != ActionDistribution::Gaussian;
        let terms = squash::entropy_terms(self.cfg.action_distribution, mean, log_std, noise);
        for (i, (term, d_term_mean, d_term_log_std)) in terms.enumerate() {
            let inv_sigma = (-log_std[i]).exp();
            let z = (actions[i] - mean[i]) * inv_sigma;
            d_mean[i] = z * inv_sigma;
            d_log_std[i] = z * z - 1.0;
            if squashed {
                d_mean[rows * 2 + i] = bonus * d_term_mean;
            }
            d_log_std[rows * 2 + i] = bonus * (1.0 + d_term_log_std);
            squash_entropy += term as f64;
        }
        let mut weights = vec![0.0f32; k * 2 * b];
        for (o, w) in d_lp.iter().enumerate() {
            weights[o * 2 * b..o * 2 * b + b].copy_from_slice(w);
        }
        weights[(k - 1) * 2 * b + b..].fill(1.0);
        let mut flat = mlp::actor::backward(
            &self.actor_layout,
            &self.actor_p,
            acts,
            &d_mean,
            &d_log_std,
            mlp::Weights {
                w: &weights,
                losses: k,
                sets: 2,
                samples: b,
            },
        );
        let entropy_bonus = flat.pop().expect("k >= 1");
        let mean_log_std = log_std.iter().map(|&x| x as f64).sum::<f64>() / log_std.len() as f64;
        let entropy = 2.0 * (0.5 + 0.5 * (2.0 * std::f64::consts::PI).ln() + mean_log_std)
            + squash_entropy / rows as f64;
        ActorGradients {
            objectives: flat,
            entropy_bonus,
            entropy,
            mean_log_std,
        }
    }

    /// One update from a rollout of `samples` joint transitions: network inputs `obs`
    /// `[S][N][D]`, global states `global` `[S][G]` (empty when G = 0), raw actions `[S][N]`,
    /// old joint log-probabilities `[S]`, advantages and returns `[S][N][3]`.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn update(
        &mut self,
        obs: &[f32],
        global: &[f32],
        actions: &[[f32; 2]],
        logp_old: &[f32],
        adv: &[f32],
        returns: &[f32],
        samples: usize,
    ) -> Result<UpdateStats, LearnError> {
        let (n, d) = (self.agents, self.obs_dim);
        let mb = (samples / self.cfg.minibatches.max(1) as usize).max(1);
        let mut stats = UpdateStats::default();
        let mut count = 0.0;
        let mut g_actor = vec![0.0f32; self.actor_p.len()];
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
                let x = gather(obs, n * d);
                let a_flat: Vec<f32> = chunk
                    .iter()
                    .flat_map(|&s| actions[s * n..(s + 1) * n].concat())
                    .collect();
                let global_b = gather(global, self.global_dim);
                let xa = agent_inputs(&x, d, n, &global_b, self.actor_global);
                let acts = mlp::actor::forward(&self.actor_layout, &self.actor_p, &xa, b * n);
                let mut lp_new = mlp::actor::joint_log_prob(&a_flat, &acts.mean, &acts.log_std, n);
                // The tanh term depends on the raw sample only: it cancels in the ratio.
                squash::correct_log_prob(self.cfg.action_distribution, &a_flat, n, &mut lp_new);
                let (lp_old, adv_b) = (gather(logp_old, 1), gather(adv, n * 3));
                let mut d_lp = Vec::with_capacity(3);
                for k in 0..3 {
                    let adv_k: Vec<f32> = adv_b.iter().skip(k).step_by(3).copied().collect();
                    let (loss, g) =
                        clipped_surrogate_grad(&lp_new, &lp_old, &adv_k, self.cfg.clip as f32);
                    stats.loss[k] += loss;
                    d_lp.push(g);
                }
                let noise =
                    squash::entropy_noise(self.cfg.action_distribution, b * n, &mut self.rng);
                let grads = self.actor_grads(&acts, &a_flat, &d_lp, &noise, b, n);
                // PCGrad's random projection orders (none for the plain average).
                let order: Vec<Vec<usize>> = if self.cfg.pcgrad {
                    (0..3)
                        .map(|i| {
                            self.rng
                                .permutation(3)
                                .into_iter()
                                .filter(|&j| j != i)
                                .collect()
                        })
                        .collect()
                } else {
                    vec![Vec::new(); 3]
                };
                let views: Vec<&[f32]> = grads.objectives.iter().map(|g| g.as_slice()).collect();
                let mut surgery = plan(&views, &order);
                surgery.weight = mix_weights(&self.cfg, surgery.weight);
                // The combined gradient plus the entropy bonus's and its squared norm in one
                // pass; Adam scales it as it reads it where the norm is clipped.
                let norm_sq = combine(
                    &mut g_actor,
                    &views,
                    &surgery.weight,
                    Some(&grads.entropy_bonus),
                );
                let scale = clip_scale(norm_sq, self.cfg.max_grad_norm);
                self.opt_actor
                    .step_scaled(&mut self.actor_p, &g_actor, scale);

                // The joint states are the same rows, [b, n d], then their global states [b, g].
                let g = self.global_dim;
                let state = joint_states(&x, n * d, &global_b, g);
                let c = mlp::critic::forward(&self.critic_layout, &self.critic_p, &state, b);
                let (value_loss, gc) = mlp::critic::value_loss_grad(
                    &self.critic_layout,
                    &self.critic_p,
                    &c,
                    &gather(returns, n * 3),
                );
                let scale = clip_scale(dot(&gc, &gc), self.cfg.max_grad_norm);
                self.opt_critic.step_scaled(&mut self.critic_p, &gc, scale);

                stats.value_loss += value_loss;
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
        self.sync_vars()?;
        Ok(stats)
    }
}

/// The weight of each objective's gradient in the actor's step: PCGrad's plan, or without
/// PCGrad `train.objective_weights` normalised to sum 1 (equal weights: 1/3 each, the plain
/// average the plan already holds, to the bit).
fn mix_weights(cfg: &TrainConfig, planned: Vec<f64>) -> Vec<f64> {
    if cfg.pcgrad {
        return planned;
    }
    let w = cfg.objective_weights;
    let total: f64 = w.iter().sum();
    w.iter().map(|x| x / total).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tanh_policys_entropy_bonus_equals_autograd_of_its_estimate() {
        use crate::learn::nets::gaussian_entropy;
        let (b, n) = (4, 3);
        let cfg = TrainConfig {
            action_distribution: ActionDistribution::Tanh,
            ..TrainConfig::default()
        };
        let learner = Learner::new(n, 8, cfg, 5).unwrap();
        let mut rng = Rng::new(21);
        let mut noise = |len: usize, s: f64| -> Vec<f32> {
            (0..len).map(|_| (s * rng.normal()) as f32).collect()
        };
        let (obs, actions) = (noise(b * n * 8, 1.0), noise(b * n * 2, 1.5));
        let noise = noise(b * n * 2, 1.0);
        let dev = Device::Cpu;
        let o = Tensor::from_slice(&obs, (b * n, 8), &dev).unwrap();
        let pass = learner.actor.forward_pass(&o).unwrap();
        let d_lp = vec![vec![0.0f32; b]; 3];
        let got = learner
            .actor_gradients(&pass, &actions, &d_lp, &noise, b, n)
            .unwrap();
        // The reference: u = mean + σ ε for the draws ε, H = H(N) + sum_dims log(1 - tanh² u),
        // averaged over rows, times -entropy_coef, by autograd.
        let sigma = pass.log_std.exp().unwrap();
        let eps = Tensor::from_slice(&noise, (b * n, 2), &dev).unwrap();
        let u = (&pass.mean + (&sigma * &eps).unwrap()).unwrap();
        let term = u
            .tanh()
            .unwrap()
            .sqr()
            .unwrap()
            .affine(-1.0, 1.0)
            .unwrap()
            .log()
            .unwrap();
        let h = (gaussian_entropy(&pass.log_std).unwrap() + term.sum(1).unwrap())
            .unwrap()
            .mean_all()
            .unwrap();
        let want = flatten(
            &h.affine(-0.01, 0.0).unwrap().backward().unwrap(),
            &learner.actor_vars,
        )
        .unwrap();
        let scale = want.iter().fold(0f32, |m, x| m.max(x.abs()));
        assert!(scale > 0.0);
        for (x, y) in got.entropy_bonus.iter().zip(&want) {
            assert!((x - y).abs() <= 1e-5 * scale, "{x} vs {y}");
        }
        assert!((got.entropy - h.to_scalar::<f32>().unwrap() as f64).abs() < 1e-5);
        // The estimate is below the Gaussian's entropy: the squashing only removes spread.
        let gauss = 2.0 * (0.5 + 0.5 * (2.0 * std::f64::consts::PI).ln() + got.mean_log_std);
        assert!(got.entropy < gauss);
    }

    #[test]
    fn objective_weights_mix_the_gradients_only_without_pcgrad() {
        let planned = vec![0.5, 0.3, 0.2];
        let cfg = TrainConfig {
            pcgrad: true,
            ..TrainConfig::default()
        };
        assert_eq!(mix_weights(&cfg, planned.clone()), planned);
        let mut cfg = TrainConfig {
            pcgrad: false,
            ..TrainConfig::default()
        };
        // Equal weights: the plan of the plain average (no projections), bit for bit.
        let views: Vec<&[f32]> = vec![&[1.0, 2.0], &[-3.0, 1.0], &[0.5, 0.5]];
        let average = plan(&views, &vec![Vec::new(); 3]).weight;
        assert_eq!(mix_weights(&cfg, average.clone()), average);
        cfg.objective_weights = [9.0, 1.0, 1.0];
        assert_eq!(
            mix_weights(&cfg, average.clone()),
            [9.0 / 11.0, 1.0 / 11.0, 1.0 / 11.0]
        );
        cfg.objective_weights = [1.0, 0.0, 0.0];
        assert_eq!(mix_weights(&cfg, average), [1.0, 0.0, 0.0]);
    }
}

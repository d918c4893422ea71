//! Acting (sampled or mean actions and their joint log-probabilities), the critic's values, and
//! one iteration: a rollout of T steps x E environments, GAE per objective and agent, then the
//! update.

use super::*;

impl Learner {
    /// Sampled (or mean) raw actions `[E][N]` and joint log-probabilities `[E]` for network inputs
    /// `[E][N][D]` (observations passed through [`Self::normalize`]) and the environments'
    /// global states `[E][G]` (read only with `train.actor_phase`; pass `&[]` otherwise, see
    /// [`Self::actor_reads_global`]). The environment receives [`Self::applied`] of the raw
    /// actions; the log-probabilities are those of the applied actions (with the tanh policy's
    /// change-of-variables term).
    pub fn act(
        &mut self,
        obs: &[f32],
        global: &[f32],
        deterministic: bool,
    ) -> Result<(Vec<[f32; 2]>, Vec<f32>), LearnError> {
        let pool = self.pool.clone();
        pool.install(|| self.act_serial(obs, global, deterministic))
    }

    /// Whether [`Self::act`] reads the global state (`train.actor_phase`).
    pub fn actor_reads_global(&self) -> bool {
        self.actor_global > 0
    }

    pub(super) fn act_serial(
        &mut self,
        obs: &[f32],
        global: &[f32],
        deterministic: bool,
    ) -> Result<(Vec<[f32; 2]>, Vec<f32>), LearnError> {
        let rows = obs.len() / self.obs_dim;
        if self.actor_global > 0 {
            self.check_global(global, rows / self.agents)?;
        }
        let x = agent_inputs(obs, self.obs_dim, self.agents, global, self.actor_global);
        let acts = mlp::actor::forward(&self.actor_layout, &self.actor_p, &x, rows);
        let (m, log_std) = (&acts.mean, &acts.log_std);
        let s: Vec<f32> = log_std.iter().map(|x| x.exp()).collect();
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
        let raw = actions.concat();
        let mut lp = mlp::actor::joint_log_prob(&raw, m, log_std, self.agents);
        squash::correct_log_prob(self.cfg.action_distribution, &raw, self.agents, &mut lp);
        Ok((actions, lp))
    }

    /// The actions the environment receives for raw actions `[E][N]` from [`Self::act`]: the
    /// same for the Gaussian policy, tanh of each component for `action_distribution = "tanh"`.
    pub fn applied(&self, raw: &[[f32; 2]]) -> Vec<[f32; 2]> {
        squash::applied(self.cfg.action_distribution, raw)
    }

    /// Values `[B][N][3]` of joint states given as network inputs `[B][N][D]` and global states
    /// `[B][G]` (empty when the critic reads none).
    pub fn values(&self, obs: &[f32], global: &[f32]) -> Result<Vec<f32>, LearnError> {
        self.pool.install(|| {
            let (n, b) = (self.agents, obs.len() / (self.agents * self.obs_dim));
            let x = joint_states(obs, n * self.obs_dim, global, self.global_dim);
            let c = mlp::critic::forward(&self.critic_layout, &self.critic_p, &x, b);
            // [B, 3, N] -> [B, N, 3].
            let mut v = vec![0.0f32; c.values.len()];
            for (at, x) in c.values.iter().enumerate() {
                let (s, k, i) = (at / (3 * n), at / n % 3, at % n);
                v[(s * n + i) * 3 + k] = *x;
            }
            Ok(v)
        })
    }

    /// The global state `[E][G]` of `env` now, checked against the critic's G (nothing is
    /// asked of the environment when G = 0).
    fn global_state_of(&self, env: &dyn MultiAgentEnv) -> Result<Vec<f32>, LearnError> {
        if self.global_dim == 0 {
            return Ok(Vec::new());
        }
        let state = env.global_state();
        self.check_global(&state, env.n_env())?;
        Ok(state)
    }

    /// `state` holds G values for each of `rows` rows.
    fn check_global(&self, state: &[f32], rows: usize) -> Result<(), LearnError> {
        if state.len() != rows * self.global_dim {
            return Err(LearnError::GlobalState {
                want: self.global_dim,
                have: state.len() / rows.max(1),
            });
        }
        Ok(())
    }

    /// Collects one rollout from `env` (continuing from `obs`) and updates the networks.
    pub fn iterate(
        &mut self,
        env: &mut dyn MultiAgentEnv,
        obs: &mut Vec<f32>,
    ) -> Result<Iteration, LearnError> {
        let start = std::time::Instant::now();
        let mut sim_s = 0.0;
        let (t_len, ne, n, d) = (
            self.cfg.rollout_steps as usize,
            env.n_env(),
            self.agents,
            self.obs_dim,
        );
        let per_env = n * 3;
        if self.global_dim > 0 && env.global_state_dim() != self.global_dim {
            return Err(LearnError::GlobalState {
                want: self.global_dim,
                have: env.global_state_dim(),
            });
        }
        let mut global_buf = Vec::with_capacity(t_len * ne * self.global_dim);
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
            let global = self.global_state_of(env)?;
            let (actions, logp) = self.act(&x, &global, false)?;
            let v = self.values(&x, &global)?;
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
            global_buf.extend_from_slice(&global);
            act_buf.extend_from_slice(&actions);
            logp_buf.extend(logp);
            values.extend_from_slice(&v);
            let t0 = std::time::Instant::now();
            let tr = env.step(&self.applied(&actions)).map_err(LearnError::Env)?;
            sim_s += t0.elapsed().as_secs_f64();
            rewards.extend_from_slice(&tr.rewards);
            for (e, ended) in ended_prev.iter_mut().enumerate() {
                *ended = tr.terminated[e] || tr.truncated[e] || tr.diverged[e];
                if tr.truncated[e]
                    && let Some(f) = &tr.final_obs[e]
                {
                    let fg = match self.global_dim {
                        0 => Vec::new(),
                        _ => tr.final_global_state[e].clone().unwrap_or_default(),
                    };
                    self.check_global(&fg, 1)?;
                    let vf = self.values(&self.normalize(f), &fg)?;
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
        let v_last = self.values(&self.normalize(obs), &self.global_state_of(env)?)?;
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
        let stats = pool.install(|| {
            self.update(
                &obs_buf,
                &global_buf,
                &act_buf,
                &logp_buf,
                &adv,
                &returns,
                t_len * ne,
            )
        })?;
        Ok(Iteration {
            stats,
            episodes,
            env_steps: t_len * ne,
            sim_s,
            learn_s: start.elapsed().as_secs_f64() - sim_s,
        })
    }
}

//! Test-only code shared by the library's unit tests, the integration tests and the
//! benchmarks (feature `testing`, which the crate's dev-dependency on itself turns on; not in
//! the release binary): [`PointMasses`], a toy multi-agent environment with a known optimum for
//! the learner.

use crate::checkpoint::Archive;
use crate::env::reward;
use crate::learn::env::{EnvError, EpisodeSummary, MultiAgentEnv, Outcome, Transition};
use crate::rng::Rng;

/// N point masses per environment on a plane, starting at random around (3, 0), that should
/// head for the origin. Force F = a / max(1, |a|) (unit bound); v' = 0.8 v + 0.1 F;
/// x' = x + 0.1 v' (at most about 2 units in an episode, so the target is never reached and
/// "push straight at it, at full force, steadily" is optimal for all three objectives at once).
/// Rewards as the swarm's, with "upstream" meaning towards the origin:
/// progress = 10 * (|x_prev| - |x|) - 0.01, energy = F . dr / |dr|, smoothness = cos(a', a).
/// Episodes are truncated after 40 steps and never terminate. Observations:
/// (x / 3, y / 3, vx, vy, 0, 0, 0, 0).
pub struct PointMasses {
    envs: usize,
    agents: usize,
    rng: Rng,
    pos: Vec<[f64; 2]>,
    vel: Vec<[f64; 2]>,
    prev: Vec<Option<[f64; 2]>>,
    steps: Vec<u32>,
    sums: Vec<[f64; 3]>,
}

impl PointMasses {
    /// Steps after which every episode is truncated.
    pub const MAX_STEPS: u32 = 40;

    /// `envs` environments of `agents` point masses each, started from `seed`.
    pub fn new(envs: usize, agents: usize, seed: u64) -> Self {
        Self {
            envs,
            agents,
            rng: Rng::new(seed),
            pos: vec![[0.0; 2]; envs * agents],
            vel: vec![[0.0; 2]; envs * agents],
            prev: vec![None; envs * agents],
            steps: vec![0; envs],
            sums: vec![[0.0; 3]; envs],
        }
    }

    fn reset_env(&mut self, e: usize) {
        for i in 0..self.agents {
            let k = e * self.agents + i;
            self.pos[k] = [3.0 + self.rng.range(-0.5, 0.5), self.rng.range(-0.5, 0.5)];
            self.vel[k] = [0.0, 0.0];
            self.prev[k] = None;
        }
        self.steps[e] = 0;
        self.sums[e] = [0.0; 3];
    }

    fn observe(&self, e: usize) -> Vec<f32> {
        (0..self.agents)
            .flat_map(|i| {
                let k = e * self.agents + i;
                let (p, v) = (self.pos[k], self.vel[k]);
                let s = 1.0 / 3.0;
                [
                    (p[0] * s) as f32,
                    (p[1] * s) as f32,
                    v[0] as f32,
                    v[1] as f32,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ]
            })
            .collect()
    }
}

impl MultiAgentEnv for PointMasses {
    fn n_env(&self) -> usize {
        self.envs
    }
    fn n_agents(&self) -> usize {
        self.agents
    }
    fn obs_dim(&self) -> usize {
        8
    }

    fn reset(&mut self) -> Result<Vec<f32>, EnvError> {
        (0..self.envs).for_each(|e| self.reset_env(e));
        Ok((0..self.envs).flat_map(|e| self.observe(e)).collect())
    }

    fn step(&mut self, actions: &[[f32; 2]]) -> Result<Transition, EnvError> {
        let (ne, n) = (self.envs, self.agents);
        let mut t = Transition::empty(ne, n);
        for e in 0..ne {
            let mut mean = [0.0f64; 3];
            for i in 0..n {
                let k = e * n + i;
                let a = [actions[k][0] as f64, actions[k][1] as f64];
                let s = 1.0 / a[0].hypot(a[1]).max(1.0);
                let f = [s * a[0], s * a[1]];
                let old = self.pos[k];
                for (d, fd) in f.iter().enumerate() {
                    self.vel[k][d] = 0.8 * self.vel[k][d] + 0.1 * fd;
                    self.pos[k][d] += 0.1 * self.vel[k][d];
                }
                let now = self.pos[k];
                let dr = [now[0] - old[0], now[1] - old[1]];
                let r = [
                    10.0 * (old[0].hypot(old[1]) - now[0].hypot(now[1])) - 0.01,
                    reward::energy(f, dr, 1.0),
                    reward::smoothness(self.prev[k], a),
                ];
                self.prev[k] = Some(a);
                for q in 0..3 {
                    t.rewards[k * 3 + q] = r[q] as f32;
                    mean[q] += r[q] / n as f64;
                }
            }
            self.steps[e] += 1;
            for (sum, m) in self.sums[e].iter_mut().zip(mean) {
                *sum += m;
            }
            let timeout = self.steps[e] >= Self::MAX_STEPS;
            t.truncated[e] = timeout;
            if timeout {
                let steps = self.steps[e] as f64;
                let s = self.sums[e];
                let x: f64 = (0..n).map(|i| self.pos[e * n + i][0]).sum::<f64>() / n as f64;
                t.episodes[e] = Some(EpisodeSummary {
                    env: e,
                    episode: 0,
                    steps: self.steps[e],
                    outcome: Outcome::Timeout,
                    progress: s[0],
                    energy: s[1] / steps,
                    smoothness: s[2] / steps,
                    progress_mean: s[0] / steps,
                    energy_sum: s[1],
                    smoothness_sum: s[2],
                    scalar_return: s[0] + s[1] + s[2],
                    final_x_com_mm: x,
                });
                t.final_obs[e] = Some(self.observe(e));
                self.reset_env(e);
            }
            t.obs.extend(self.observe(e));
        }
        Ok(t)
    }

    fn save_state(&self, archive: &mut Archive) -> Result<(), EnvError> {
        let k = self.envs * self.agents;
        archive.put_u64("env.rng", &[self.rng.0]);
        archive.put_f64("env.pos", &[k, 2], &self.pos.concat());
        archive.put_f64("env.vel", &[k, 2], &self.vel.concat());
        let prev: Vec<f64> = self
            .prev
            .iter()
            .flat_map(|p| p.unwrap_or([f64::NAN; 2]))
            .collect();
        archive.put_f64("env.prev", &[k, 2], &prev);
        let steps: Vec<u64> = self.steps.iter().map(|s| *s as u64).collect();
        archive.put_u64("env.steps", &steps);
        archive.put_f64("env.sums", &[self.envs, 3], &self.sums.concat());
        Ok(())
    }

    fn load_state(&mut self, archive: &Archive) -> Result<(), EnvError> {
        let k = self.envs * self.agents;
        let pairs = |v: Vec<f64>| -> Vec<[f64; 2]> { v.chunks(2).map(|c| [c[0], c[1]]).collect() };
        self.pos = pairs(archive.f64("env.pos", Some(2 * k))?);
        self.vel = pairs(archive.f64("env.vel", Some(2 * k))?);
        self.prev = pairs(archive.f64("env.prev", Some(2 * k))?)
            .into_iter()
            .map(|p| Some(p).filter(|p| !p[0].is_nan()))
            .collect();
        self.steps = archive
            .u64("env.steps", Some(self.envs))?
            .iter()
            .map(|s| *s as u32)
            .collect();
        self.sums = archive
            .f64("env.sums", Some(3 * self.envs))?
            .chunks(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        self.rng.0 = archive.u64("env.rng", Some(1))?[0];
        Ok(())
    }
}

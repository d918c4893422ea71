//! The batched swarm environment of SPEC section 3: E channels with N members each, advanced
//! one control step per `step(actions [E][N][2])`, returning observations `[E][N][8]`, rewards
//! `[E][N][3]` (progress, energy, smoothness), separate terminated/truncated flags, the final
//! observation of every episode that ended (environments auto-reset independently) and the
//! finished episodes' metrics. One read-back per control step (health + members + forces).
//!
//! Observation of member i: ((x - x_mid) / half, (y - H/2) / (H/2), v / U_peak, p_k / 1 kPa)
//! with x_mid, half the centre and half-width of the analysis region (50 mm, 30 mm in the
//! paper), U_peak the waveform's peak |U| (0.4 m/s) and p_k the four pressure samples.

mod checkpoint;
pub mod policy;
pub mod reward;

pub use crate::learn::env::{EpisodeSummary, Outcome, Transition};

use crate::config::{EnergyReward, Resolved};
use crate::gpu::params::{GpuMember, GpuMemberDiag};
use crate::learn::EnvError;
use crate::rng::Rng;
use crate::sim::{FlowBatch, SimError};

/// Values per observation, per reward.
pub const OBS_DIM: usize = 8;
/// Length of an environment's global state ([`SwarmEnv::phase_features`]): the inlet phase as
/// (sin 2 pi phi, cos 2 pi phi), read by the critic with `train.critic_phase` and by the actors
/// with `train.actor_phase`.
pub const GLOBAL_DIM: usize = 2;
/// Reward objectives per agent: progress, energy, smoothness.
pub const N_OBJECTIVES: usize = 3;
/// Pressure scale of the observation (Pa).
pub const PRESSURE_SCALE_PA: f64 = 1000.0;

/// What `SwarmEnv::step` returns: the [`Transition`] (also reachable through `Deref`) plus the
/// swarm's state for logging.
#[derive(Debug, Clone)]
pub struct StepOutput {
    /// The batched transition: observations, rewards, end flags, final observations, episode metrics.
    pub transition: Transition,
    /// Members and their forces at the end of this step, before any reset, `[E][N]`.
    pub members: Vec<GpuMember>,
    /// Forces and pressure samples of each member over this step, `[E][N]`.
    pub forces: Vec<GpuMemberDiag>,
    /// Episode index and step within it (after this step) of each environment, before reset.
    pub episode: Vec<u64>,
    /// Step count within the episode after this step, per environment `[E]`, before reset.
    pub episode_step: Vec<u32>,
}

impl std::ops::Deref for StepOutput {
    type Target = Transition;

    fn deref(&self) -> &Transition {
        &self.transition
    }
}

#[derive(Debug, Clone)]
struct Episode {
    index: u64,
    steps: u32,
    /// Member centres at the previous control step (m).
    positions: Vec<[f64; 2]>,
    previous_action: Vec<Option<[f64; 2]>>,
    progress_sum: f64,
    energy_sum: f64,
    smoothness_sum: f64,
}

/// E swarm environments on one batch (either backend).
pub struct SwarmEnv {
    batch: Box<dyn FlowBatch>,
    resolved: Resolved,
    n_env: usize,
    n: usize,
    rng: Rng,
    episodes: Vec<Episode>,
}

impl SwarmEnv {
    /// The environments of `batch` (made for `resolved`), seeded with `seed`.
    pub fn new(
        batch: Box<dyn FlowBatch>,
        resolved: &Resolved,
        seed: u64,
    ) -> Result<Self, SimError> {
        let n = batch.n_members();
        let n_env = batch.n_env();
        Ok(Self {
            batch,
            resolved: resolved.clone(),
            n_env,
            n,
            rng: Rng::new(seed),
            episodes: Vec::new(),
        })
    }

    /// Number of environments E.
    pub fn n_env(&self) -> usize {
        self.n_env
    }

    /// Number of members (agents) N per environment.
    pub fn n_agents(&self) -> usize {
        self.n
    }

    /// The configuration the environments run.
    pub fn resolved(&self) -> &Resolved {
        &self.resolved
    }

    /// The underlying flow batch.
    pub fn batch(&self) -> &dyn FlowBatch {
        self.batch.as_ref()
    }

    /// The batch, for tests and tools that need to alter the fluid state.
    pub fn batch_mut(&mut self) -> &mut dyn FlowBatch {
        self.batch.as_mut()
    }

    /// Control steps taken so far in the current episode of environment `e` (0 before the
    /// first step or after a reset).
    pub fn episode_step(&self, e: usize) -> u32 {
        self.episodes.get(e).map_or(0, |ep| ep.steps)
    }

    /// The inlet phase of environment e now as (sin 2 pi phi, cos 2 pi phi), phi = (t mod T) / T
    /// with t its waveform time and T the period: the global state a centralised critic may
    /// see (`train.critic_phase`); continuous across the period's wrap.
    pub fn phase_features(&self, e: usize) -> [f32; 2] {
        let period = self.batch.waveform().period_s();
        let angle =
            std::f64::consts::TAU * self.batch.waveform_time_s(e).rem_euclid(period) / period;
        [angle.sin() as f32, angle.cos() as f32]
    }

    /// Restarts the generator of start phases and jitter from `seed` (the next reset draws
    /// from it), as a new environment made with that seed would.
    pub fn reseed(&mut self, seed: u64) {
        self.rng = Rng::new(seed);
    }

    /// Resets every environment; returns the observations `[E][N][8]`.
    pub fn reset(&mut self) -> Result<Vec<f32>, SimError> {
        self.episodes.clear();
        let mut obs = Vec::with_capacity(self.n_env * self.n * OBS_DIM);
        for e in 0..self.n_env {
            obs.extend(self.reset_env(e, 0)?);
        }
        Ok(obs)
    }

    /// Starts episode `index` in environment e: optional random phase and position jitter.
    fn reset_env(&mut self, e: usize, index: u64) -> Result<Vec<f32>, SimError> {
        let c = &self.resolved.config;
        let phase = if c.inlet.random_phase {
            self.rng.range(0.0, c.inlet.period_s)
        } else {
            0.0
        };
        self.batch.reset_env_with_phase(e, phase)?;
        let jitter = c.env.position_jitter_m;
        let r = c.swarm.radius_m;
        let (length, height) = (c.domain.length_m, c.domain.height_m);
        let mut members: Vec<GpuMember> = Vec::with_capacity(self.n);
        for (k, p) in c.swarm.initial_positions(height).iter().enumerate() {
            let (mut x, mut y) = (p[0], p[1]);
            if jitter > 0.0 {
                x = (x + self.rng.range(-jitter, jitter)).clamp(r, length - r);
                y = (y + self.rng.range(-jitter, jitter)).clamp(r, height - r);
            }
            members.push(GpuMember {
                pos: [x as f32, y as f32],
                vel: [0.0; 2],
                pinned: c.swarm.pinned.contains(&(k as u32)) as u32 as f32,
                pad: [0.0; 3],
            });
        }
        self.batch.set_members(e, &members)?;
        let episode = Episode {
            index,
            steps: 0,
            positions: members
                .iter()
                .map(|m| [m.pos[0] as f64, m.pos[1] as f64])
                .collect(),
            previous_action: vec![None; self.n],
            progress_sum: 0.0,
            energy_sum: 0.0,
            smoothness_sum: 0.0,
        };
        if e < self.episodes.len() {
            self.episodes[e] = episode;
        } else {
            self.episodes.push(episode);
        }
        // The initial pressure is Poiseuille's linear profile: sample it analytically.
        let u0 = self.batch.waveform().at(phase);
        let grad = 8.0 * c.fluid.viscosity_pa_s * u0 / (height * height);
        let rs = r + 2.0 * c.dx();
        let p_at = |x: f64| {
            let xc = x.clamp(0.5 * c.dx(), length - 0.5 * c.dx());
            (grad * (length - xc)) as f32
        };
        Ok(members
            .iter()
            .flat_map(|m| {
                let x = m.pos[0] as f64;
                let p = [p_at(x + rs), p_at(x), p_at(x - rs), p_at(x)];
                self.observe(*m, p)
            })
            .collect())
    }

    /// The scaled 8-vector of one member.
    fn observe(&self, m: GpuMember, p: [f32; 4]) -> [f32; OBS_DIM] {
        let c = &self.resolved.config;
        let mid = 0.5 * (c.domain.success_x_m + c.domain.failure_x_m);
        let half = 0.5 * (c.domain.failure_x_m - c.domain.success_x_m);
        let h2 = 0.5 * c.domain.height_m;
        let v = self.resolved.waveform.peak_abs().max(1e-12);
        let ps = PRESSURE_SCALE_PA;
        [
            ((m.pos[0] as f64 - mid) / half) as f32,
            ((m.pos[1] as f64 - h2) / h2) as f32,
            (m.vel[0] as f64 / v) as f32,
            (m.vel[1] as f64 / v) as f32,
            (p[0] as f64 / ps) as f32,
            (p[1] as f64 / ps) as f32,
            (p[2] as f64 / ps) as f32,
            (p[3] as f64 / ps) as f32,
        ]
    }

    /// Advances every environment by one control step with raw actions `[E][N][2]`.
    pub fn step(&mut self, actions: &[[f32; 2]]) -> Result<StepOutput, SimError> {
        assert_eq!(actions.len(), self.n_env * self.n, "one action per agent");
        assert_eq!(self.episodes.len(), self.n_env, "reset before step");
        self.batch.set_all_actions(actions)?;
        let health = self.batch.step()?;
        // One copy of the read-back: resets below overwrite the batch's cached members.
        let members = self.batch.members().to_vec();
        let forces = self.batch.member_forces().to_vec();
        let c = &self.resolved.config;
        let (xs, xf) = (c.domain.success_x_m, c.domain.failure_x_m);
        let (f_max, max_steps) = (c.swarm.max_thrust_n, c.env.max_steps);
        let energy_reward = c.env.energy_reward;
        let n = self.n;
        let mut out = StepOutput {
            transition: Transition::empty(self.n_env, n),
            members: Vec::new(),
            forces: Vec::new(),
            episode: vec![0; self.n_env],
            episode_step: vec![0; self.n_env],
        };
        out.transition.obs.reserve(self.n_env * n * OBS_DIM);
        for e in 0..self.n_env {
            let ms = &members[e * n..(e + 1) * n];
            let fs = &forces[e * n..(e + 1) * n];
            let now: Vec<[f64; 2]> = ms
                .iter()
                .map(|m| [m.pos[0] as f64, m.pos[1] as f64])
                .collect();
            let finite = now.iter().all(|p| p[0].is_finite() && p[1].is_finite());
            let diverged = health[e].diverged() || !finite;
            let ep = &mut self.episodes[e];
            ep.steps += 1;
            out.episode[e] = ep.index;
            out.episode_step[e] = ep.steps;
            let mut mean = [0.0f64; 3];
            if !diverged {
                for i in 0..n {
                    let a = [actions[e * n + i][0] as f64, actions[e * n + i][1] as f64];
                    let scale = f_max / a[0].hypot(a[1]).max(1.0);
                    let force = [scale * a[0], scale * a[1]];
                    let dr = [
                        now[i][0] - ep.positions[i][0],
                        now[i][1] - ep.positions[i][1],
                    ];
                    let r = [
                        reward::progress(ep.positions[i][0], now[i][0], xs, xf),
                        match energy_reward {
                            EnergyReward::Paper => reward::energy(force, dr, f_max),
                            EnergyReward::Upstream => reward::energy_upstream(force, dr, f_max),
                        },
                        reward::smoothness(ep.previous_action[i], a),
                    ];
                    for k in 0..3 {
                        out.transition.rewards[(e * n + i) * 3 + k] = r[k] as f32;
                        mean[k] += r[k] / n as f64;
                    }
                    ep.previous_action[i] = Some(a);
                }
                ep.progress_sum += mean[0];
                ep.energy_sum += mean[1];
                ep.smoothness_sum += mean[2];
                ep.positions = now.clone();
            }
            let x_com = now.iter().map(|p| p[0]).sum::<f64>() / n.max(1) as f64;
            let success = x_com < xs;
            let failure = now.iter().any(|p| p[0] > xf);
            let outcome = if diverged {
                Some(Outcome::Diverged)
            } else if success {
                Some(Outcome::Success)
            } else if failure {
                Some(Outcome::Failure)
            } else if ep.steps >= max_steps {
                Some(Outcome::Timeout)
            } else {
                None
            };
            out.transition.diverged[e] = diverged;
            out.transition.terminated[e] =
                matches!(outcome, Some(Outcome::Success | Outcome::Failure));
            out.transition.truncated[e] = outcome == Some(Outcome::Timeout);
            let obs_e: Vec<f32> = ms
                .iter()
                .zip(fs)
                .flat_map(|(m, d)| self.observe(*m, d.p))
                .collect();
            match outcome {
                None => out.transition.obs.extend(obs_e),
                Some(outcome) => {
                    let ep = &self.episodes[e];
                    let steps = ep.steps as f64;
                    out.transition.episodes[e] = Some(EpisodeSummary {
                        env: e,
                        episode: ep.index,
                        steps: ep.steps,
                        outcome,
                        progress: ep.progress_sum,
                        energy: ep.energy_sum / steps,
                        smoothness: ep.smoothness_sum / steps,
                        progress_mean: ep.progress_sum / steps,
                        energy_sum: ep.energy_sum,
                        smoothness_sum: ep.smoothness_sum,
                        scalar_return: ep.progress_sum + ep.energy_sum + ep.smoothness_sum,
                        final_x_com_mm: x_com * 1e3,
                    });
                    out.transition.final_obs[e] = Some(obs_e);
                    out.transition.final_global_state[e] = Some(self.phase_features(e).to_vec());
                    let next = ep.index + 1;
                    out.transition.obs.extend(self.reset_env(e, next)?);
                }
            }
        }
        out.members = members;
        out.forces = forces;
        Ok(out)
    }
}

impl crate::learn::env::MultiAgentEnv for SwarmEnv {
    fn n_env(&self) -> usize {
        self.n_env
    }
    fn n_agents(&self) -> usize {
        self.n
    }
    fn obs_dim(&self) -> usize {
        OBS_DIM
    }
    fn reset(&mut self) -> Result<Vec<f32>, EnvError> {
        Ok(SwarmEnv::reset(self)?)
    }
    fn step(&mut self, actions: &[[f32; 2]]) -> Result<Transition, EnvError> {
        Ok(SwarmEnv::step(self, actions)?.transition)
    }

    fn save_state(&self, archive: &mut crate::checkpoint::Archive) -> Result<(), EnvError> {
        Ok(SwarmEnv::save_state(self, archive, "env")?)
    }

    fn load_state(&mut self, archive: &crate::checkpoint::Archive) -> Result<(), EnvError> {
        Ok(SwarmEnv::load_state(self, archive, "env")?)
    }

    fn global_state_dim(&self) -> usize {
        GLOBAL_DIM
    }
    fn global_state(&self) -> Vec<f32> {
        (0..self.n_env)
            .flat_map(|e| self.phase_features(e))
            .collect()
    }
}

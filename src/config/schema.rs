//! The configuration's keys: serde structs mirroring the TOML sections (`deny_unknown_fields`),
//! SI units, each key named with its unit.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

/// The whole run configuration, one field per TOML section.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// `[domain]`: channel size, grid and analysis region.
    pub domain: Domain,
    /// `[fluid]`: fluid properties.
    pub fluid: Fluid,
    /// `[time]`: control step and fluid substeps.
    pub time: Time,
    /// `[inlet]`: the periodic inlet centreline-velocity waveform.
    pub inlet: Inlet,
    /// `[swarm]`: the members and their placement.
    pub swarm: Swarm,
    /// `[env]`: episode settings.
    pub env: EnvConfig,
    /// `[train]`: learner hyperparameters.
    pub train: Train,
    /// `[solver]`: numerical schemes and where the control step runs.
    pub solver: Solver,
}

/// Learner hyperparameters (SPEC section 5); `Default` is the embedded paper configuration's.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Train {
    /// Control steps per environment per update.
    pub rollout_steps: u32,
    /// Passes over each rollout per update.
    pub epochs: u32,
    /// Minibatches per epoch, at any number of environments.
    pub minibatches: u32,
    /// Discount factor, in [0, 1].
    pub gamma: f64,
    /// GAE lambda, in [0, 1].
    pub lambda: f64,
    /// Adam learning rate of actor and critic.
    pub learning_rate: f64,
    /// PPO clip range eps of the probability ratio.
    pub clip: f64,
    /// Weight of the entropy bonus (non-negative).
    pub entropy_coef: f64,
    /// Largest gradient norm; actor and critic are clipped separately.
    pub max_grad_norm: f64,
    /// PCGrad surgery of the three actor gradients; false averages them (the ablation).
    pub pcgrad: bool,
    /// Normalise advantages per objective, per rollout.
    pub normalize_advantages: bool,
    /// Running mean/std normalisation of the networks' inputs (saved with checkpoints).
    pub normalize_observations: bool,
    /// Weights of the progress, energy and smoothness actor gradients in their sum when
    /// `pcgrad` is false (normalised to sum 1; the default, equal weights, is the paper's
    /// averaged-gradient ablation): [1, 0, 0] is progress-only PPO, [9, 1, 1] a fixed
    /// scalarisation. PCGrad averages its projected gradients equally, so with `pcgrad` the
    /// weights must be equal.
    #[serde(default = "equal_weights")]
    pub objective_weights: [f64; 3],
    /// The policy's action distribution: `gaussian` (the paper's: the raw Gaussian sample is
    /// the action, and the environment clips its norm at 1) or `tanh` (each component of the
    /// sample squashed by tanh, with the change-of-variables log-probability and an entropy
    /// estimate that falls as the mean saturates; `learn::squash`).
    #[serde(default)]
    pub action_distribution: ActionDistribution,
    /// Give the centralised critic the environment's global state beyond the joint
    /// observations: for the swarm, the inlet phase as (sin 2 pi phi, cos 2 pi phi). The actors
    /// never see it, so the policy acts on the paper's observations alone.
    #[serde(default)]
    pub critic_phase: bool,
    /// Give the actors the inlet phase too, after each member's observation (the policy reads
    /// `[8 + 2]` inputs): a policy that knows the phase, privileged like the `scripted`
    /// controller and to be compared with it on equal information. Needs `critic_phase`, so
    /// that the critic sees at least what the actors see.
    #[serde(default)]
    pub actor_phase: bool,
}

/// The policy's action distribution (`train.action_distribution`).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ActionDistribution {
    /// The raw Gaussian sample is the action (SPEC section 5).
    #[default]
    Gaussian,
    /// tanh of each component of the Gaussian sample.
    Tanh,
}

fn equal_weights() -> [f64; 3] {
    [1.0, 1.0, 1.0]
}

/// Episode settings of the environment (SPEC section 3).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EnvConfig {
    /// Control steps after which an episode is truncated.
    pub max_steps: u32,
    /// Half-width of the uniform jitter added to each member's start, in x and y (m).
    pub position_jitter_m: f64,
    /// The energy reward: `paper` (F . dr / (F_max |dr|), SPEC section 3) or `upstream`, which
    /// counts only the work towards upstream motion, F_x min(dr_x, 0) / (F_max |dr|), so
    /// pushing with the flow earns nothing.
    #[serde(default)]
    pub energy_reward: EnergyReward,
}

/// The energy reward's form (`env.energy_reward`).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum EnergyReward {
    /// The paper's energy reward, F . dr / (F_max |dr|).
    #[default]
    Paper,
    /// Only the work towards upstream motion, F_x min(dr_x, 0) / (F_max |dr|).
    Upstream,
}

/// `[domain]`: the channel, its grid and the analysis region.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    /// Channel length L along x (m).
    pub length_m: f64,
    /// Channel height H along y (m).
    pub height_m: f64,
    /// Cells along x (dx = L / nx), at least 4.
    pub nx: u32,
    /// Cells across the height (dy = H / ny), 2 to 256.
    pub ny: u32,
    /// Success line x_s (m): the episode succeeds once the swarm's centre of mass has x < x_s.
    pub success_x_m: f64,
    /// Failure line x_f (m): the episode fails once any member has x > x_f.
    pub failure_x_m: f64,
}

/// `[fluid]`: properties of the fluid.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    /// Fluid density rho (kg/m^3).
    pub density_kg_m3: f64,
    /// Dynamic viscosity mu (Pa s).
    pub viscosity_pa_s: f64,
}

/// `[time]`: time stepping.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Time {
    /// Length of one control step (s).
    pub control_dt_s: f64,
    /// Fluid substeps per control step (dt_sub = control_dt_s / substeps).
    pub substeps: u32,
}

/// `[inlet]`: the periodic, piecewise-linear inlet centreline velocity U(t).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Inlet {
    /// Period of the waveform (s); control points' times lie in [0, period_s].
    pub period_s: f64,
    /// Control points [t (s), U (m/s)], strictly increasing in time.
    #[serde(default)]
    pub points: Vec<[f64; 2]>,
    /// CSV file of control points (header `t_s,u_m_per_s`); replaces `points` when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub csv: Option<PathBuf>,
    /// Start each episode at a random phase of the waveform instead of t = 0.
    #[serde(default)]
    pub random_phase: bool,
    /// Multiplies every waveform velocity (points or CSV), so a scenario can scale the flow
    /// without restating it; the observation's velocity scale (the waveform's peak) follows.
    #[serde(default = "unit_scale")]
    pub scale: f64,
}

fn unit_scale() -> f64 {
    1.0
}

/// Advection scheme of the fluid step.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Advection {
    /// First-order semi-Lagrangian (the paper's scheme).
    SemiLagrangian,
    /// Second-order MacCormack with the Selle et al. (2008) extrema clamp.
    Maccormack,
}

impl Default for Train {
    fn default() -> Self {
        Config::paper().train
    }
}

/// How the members are placed at reset.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Layout {
    /// `grid_rows` rows of count / grid_rows members, `grid_spacing_m` apart, centred at
    /// (`grid_centre_x_m`, H / 2).
    Grid,
    /// One `positions_m` entry per member.
    Explicit,
}

/// `[swarm]`: the micro-robots and their placement at reset.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Swarm {
    /// Members per environment N (0: no swarm; at most [`MAX_MEMBERS`]).
    pub count: u32,
    /// Sphere radius r (m), seen in 2D as a disc.
    pub radius_m: f64,
    /// Member density rho_s (kg/m^3); mass is 4/3 pi r^3 rho_s.
    pub density_kg_m3: f64,
    /// Largest propulsion force F_max (N): |F_prop| <= F_max.
    pub max_thrust_n: f64,
    /// How members are placed at reset.
    pub layout: Layout,
    /// Rows of the `grid` layout; `count` must be a multiple of it.
    pub grid_rows: u32,
    /// Centre-to-centre spacing of the `grid` layout, in x and y (m).
    pub grid_spacing_m: f64,
    /// x of the `grid` layout's centre (m); it is centred on mid-height in y.
    pub grid_centre_x_m: f64,
    /// Member centres [x, y] (m), one per member, for the `explicit` layout.
    #[serde(default)]
    pub positions_m: Vec<[f64; 2]>,
    /// Indices of members held fixed (their forces are still computed).
    #[serde(default)]
    pub pinned: Vec<u32>,
    /// Schiller-Naumann drag on top of the resolved pressure force.
    pub drag: bool,
}

/// Most members per environment (one workgroup of 64 threads moves a swarm).
pub const MAX_MEMBERS: u32 = 64;

impl Swarm {
    /// Initial member centres (m), in member order.
    pub fn initial_positions(&self, height_m: f64) -> Vec<[f64; 2]> {
        match self.layout {
            Layout::Explicit => self.positions_m.clone(),
            Layout::Grid => {
                let rows = self.grid_rows.max(1) as usize;
                let cols = self.count as usize / rows;
                let s = self.grid_spacing_m;
                (0..rows)
                    .flat_map(|r| (0..cols).map(move |c| (r, c)))
                    .map(|(r, c)| {
                        [
                            self.grid_centre_x_m + s * (c as f64 - (cols as f64 - 1.0) / 2.0),
                            height_m / 2.0 + s * (r as f64 - (rows as f64 - 1.0) / 2.0),
                        ]
                    })
                    .collect()
            }
        }
    }

    /// Mass of one member: the 3D sphere, 4/3 pi r^3 rho_s (kg).
    pub fn mass_kg(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.radius_m.powi(3) * self.density_kg_m3
    }
}

/// Order of the semi-Lagrangian backtrace (departure point of a trajectory).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Backtrace {
    /// One Euler step with the velocity at the arrival point (the paper's scheme).
    Euler,
    /// Midpoint rule: a second velocity sample half-way back.
    Rk2,
}

/// `[solver]`: numerical schemes and the backend of the control step.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Solver {
    /// Advection scheme.
    pub advection: Advection,
    /// Order of the semi-Lagrangian backtrace.
    pub backtrace: Backtrace,
    /// Where the control step runs (default: the adapter).
    #[serde(default)]
    pub backend: Backend,
    /// How the kernels solve each y-mode's tridiagonal system along x (default: auto).
    #[serde(default)]
    pub pressure_sweep: PressureSweep,
}

/// The kernel for the tridiagonal solve of each y-mode along x (both exact, same factors).
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PressureSweep {
    /// `scan` on a GPU, `sequential` on a software adapter.
    #[default]
    Auto,
    /// `pressure_solve.wgsl`: one thread per (environment, mode) runs the Thomas sweeps, 2 nx
    /// dependent steps. Fastest on lavapipe, where threads are few and barriers dear.
    Sequential,
    /// `pressure_scan.wgsl`: one workgroup of 256 threads per (environment, mode) runs each
    /// sweep as a parallel scan of affine maps, at most 4 ceil(nx / 256) dependent steps per
    /// thread plus 2 x 8 barrier steps. For GPUs, where a dependent step costs a memory latency.
    Scan,
}

impl PressureSweep {
    /// Whether the batch uses the scan kernel on an adapter that is (or is not) software.
    pub fn uses_scan(self, software_adapter: bool) -> bool {
        match self {
            Self::Auto => !software_adapter,
            Self::Sequential => false,
            Self::Scan => true,
        }
    }
}

/// Where the fluid and swarm control step runs.
#[derive(Debug, Clone, Copy, Default, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// The WGSL kernels on a real GPU (after a start-up self-check against the CPU step),
    /// the CPU backend otherwise (SPEC section 8).
    #[default]
    Auto,
    /// The WGSL kernels on the wgpu adapter, whatever it is (a GPU, or lavapipe on the CPU).
    Adapter,
    /// `sim::cpu`: the control step in plain Rust on the CPU cores (rayon, one environment
    /// per task); needs no adapter.
    Native,
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Auto => "auto",
            Self::Adapter => "adapter",
            Self::Native => "native",
        })
    }
}

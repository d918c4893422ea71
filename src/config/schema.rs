//! The configuration's keys: serde structs mirroring the TOML sections (`deny_unknown_fields`),
//! SI units, each key named with its unit.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Config {
    pub domain: Domain,
    pub fluid: Fluid,
    pub time: Time,
    pub inlet: Inlet,
    pub swarm: Swarm,
    pub env: EnvConfig,
    pub train: Train,
    pub solver: Solver,
}

/// Learner hyperparameters (SPEC section 5); `Default` is the embedded paper configuration's.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Train {
    pub rollout_steps: u32,
    pub epochs: u32,
    pub minibatches: u32,
    pub gamma: f64,
    pub lambda: f64,
    pub learning_rate: f64,
    pub clip: f64,
    pub entropy_coef: f64,
    pub max_grad_norm: f64,
    pub pcgrad: bool,
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
    #[default]
    Paper,
    Upstream,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Domain {
    pub length_m: f64,
    pub height_m: f64,
    pub nx: u32,
    pub ny: u32,
    pub success_x_m: f64,
    pub failure_x_m: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Fluid {
    pub density_kg_m3: f64,
    pub viscosity_pa_s: f64,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Time {
    pub control_dt_s: f64,
    pub substeps: u32,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Inlet {
    pub period_s: f64,
    #[serde(default)]
    pub points: Vec<[f64; 2]>,
    /// CSV file of control points (header `t_s,u_m_per_s`); replaces `points` when given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub csv: Option<PathBuf>,
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

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Swarm {
    pub count: u32,
    pub radius_m: f64,
    pub density_kg_m3: f64,
    pub max_thrust_n: f64,
    pub layout: Layout,
    pub grid_rows: u32,
    pub grid_spacing_m: f64,
    pub grid_centre_x_m: f64,
    #[serde(default)]
    pub positions_m: Vec<[f64; 2]>,
    #[serde(default)]
    pub pinned: Vec<u32>,
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

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Solver {
    pub advection: Advection,
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

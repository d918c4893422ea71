//! `fluxswarm-gpu eval --checkpoint PATH`: runs a trained policy (sampled, or its mean action
//! with `--deterministic`) in the configuration saved with it (or a changed scenario around it,
//! `--set` of `config::TRANSFER_KEYS`) and writes the same files as
//! `rollout` (episodes.csv, starts.csv, swarm.csv, trajectories.csv, config.toml, frames).

use std::path::PathBuf;

use clap::Args;
use fluxswarm_gpu::gpu::AdapterChoice;
use fluxswarm_gpu::output::run_dir;

use super::common::ConfigArgs;
use super::rollout::{self, RolloutArgs};

#[derive(Debug, Args)]
pub struct EvalArgs {
    /// A checkpoint file, or a `train` run directory (its newest checkpoint).
    #[arg(long, value_name = "PATH")]
    pub checkpoint: PathBuf,
    /// Finished episodes to collect, over all environments (a quota per environment, as
    /// `rollout`).
    #[arg(long, default_value_t = 8)]
    pub episodes: u64,
    /// Act with the policy's mean action instead of sampling.
    #[arg(long)]
    pub deterministic: bool,
    #[arg(long, default_value_t = 4)]
    pub envs: usize,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory (default runs/eval-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write a frame of environment 0 every K control steps (0: none).
    #[arg(long, default_value_t = 0, value_name = "K")]
    pub frames_every: u64,
    /// Also write `animation.gif` of the frames (needs --frames-every).
    #[arg(long)]
    pub gif: bool,
    /// Animate only environment 0's episode K (0: its first; default all).
    #[arg(long, value_name = "K", requires = "gif")]
    pub gif_episode: Option<u64>,
    /// Animate only the control steps [START, END) of each animated episode.
    #[arg(long, value_name = "START:END", requires = "gif", value_parser = rollout::parse_gif_steps)]
    pub gif_steps: Option<(u64, u64)>,
    /// Write only episodes.csv, starts.csv and config.toml (no swarm.csv, trajectories.csv).
    #[arg(long)]
    pub no_traces: bool,
    /// Also write gap.csv: the flow past the swarm at every step (as `rollout --gap`).
    #[arg(long, conflicts_with = "no_traces")]
    pub gap: bool,
    #[arg(long, value_enum, default_value_t = AdapterChoice::Auto)]
    pub adapter: AdapterChoice,
    /// How the step runs: `--set solver.backend=auto|adapter|native` (or
    /// `solver.pressure_sweep=...`) over the checkpoint's configuration; or, to test how the
    /// policy transfers, the scenario around it: inlet.scale, swarm.max_thrust_n, domain.nx,
    /// domain.ny, time.substeps or swarm.drag. Nothing else.
    #[arg(long = "set", value_name = "SECTION.KEY=VALUE")]
    pub sets: Vec<String>,
}

pub fn run(args: EvalArgs) -> anyhow::Result<()> {
    rollout::run(RolloutArgs {
        common: ConfigArgs {
            config: None,
            sets: args.sets,
            adapter: args.adapter,
        },
        policy: args.checkpoint.to_string_lossy().into_owned(),
        deterministic: args.deterministic,
        envs: args.envs,
        episodes: args.episodes,
        seed: args.seed,
        out: Some(args.out.unwrap_or_else(|| run_dir::default_dir("eval"))),
        frames_every: args.frames_every,
        gif: args.gif,
        gif_episode: args.gif_episode,
        gif_steps: args.gif_steps,
        no_traces: args.no_traces,
        gap: args.gap,
    })
}

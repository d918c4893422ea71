//! `fluxswarm-gpu rollout` (and `eval`): runs a baseline or a trained policy in E environments
//! until K episodes have finished (over all environments) and writes `episodes.csv`,
//! `swarm.csv`, `trajectories.csv` (SPEC section 7), `starts.csv` (the start phase of every
//! episode), `config.toml` and frames of environment 0
//! (`frames/env0_ep<episode:04>_s<step:06>.png`). A trained policy brings its configuration
//! from its checkpoint, so it runs in the physics it was trained in; `--set` may change the
//! scenario around it (`config::TRANSFER_KEYS`: flow scale, thrust, resolution) to test how
//! it transfers, and `config.toml` records the changed scenario.
//! The loop and the files are the library's ([`fluxswarm_gpu::rollout`]): this command parses
//! the flags, writes `config.toml` with its header, and shows progress.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::env::SwarmEnv;
use fluxswarm_gpu::env::policy::Controller;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::rollout::files::{FileOptions, RolloutFiles};
use fluxswarm_gpu::rollout::{self, Policy, RolloutError};

use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct RolloutArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// upstream, wall, wall-angle:DEG, heading:DEG (one direction for every member, DEG from
    /// upstream towards the upper wall), zero, random, scripted (privileged: reads the inlet
    /// phase; scripted:CALM_DEG:STORM_DEG:START_S:END_S sets its parameters;
    /// scripted-heading:CALM_DEG:STORM_DEG:START_S:END_S switches between two headings), or a trained
    /// checkpoint: a `.safetensors` file or a `train` run directory (its newest checkpoint).
    /// A trained policy runs in its saved configuration; `--set` may change inlet.scale,
    /// swarm.max_thrust_n, domain.nx, domain.ny, time.substeps and swarm.drag around it (a
    /// transfer test) and solver.backend or solver.pressure_sweep.
    #[arg(long)]
    pub policy: String,
    /// With a trained policy: act with the mean action instead of sampling.
    #[arg(long)]
    pub deterministic: bool,
    #[arg(long, default_value_t = 1)]
    pub envs: usize,
    /// Finished episodes to collect, over all environments: a quota of K/E per environment
    /// (the remainder to the first ones), so long episodes count as often as short ones.
    #[arg(long, default_value_t = 1)]
    pub episodes: u64,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output directory (default runs/rollout-<YYYYmmdd-HHMMSS>).
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
    #[arg(long, value_name = "START:END", requires = "gif", value_parser = parse_gif_steps)]
    pub gif_steps: Option<(u64, u64)>,
    /// Write only episodes.csv, starts.csv and config.toml (no swarm.csv, trajectories.csv):
    /// for sweeps of many episodes.
    #[arg(long)]
    pub no_traces: bool,
    /// Also write gap.csv: the flow past the swarm at every step (its x extent, the peak fluid
    /// u_x there and the blocked fraction of its columns; a field read-back per step).
    #[arg(long, conflicts_with = "no_traces")]
    pub gap: bool,
}

/// `--gif-steps START:END`.
pub fn parse_gif_steps(text: &str) -> Result<(u64, u64), String> {
    fluxswarm_gpu::output::gif::Window::parse_steps(text)
}

pub fn run(args: RolloutArgs) -> anyhow::Result<()> {
    let (resolved, mut policy) = match args.policy.parse::<Controller>() {
        Ok(c) => {
            if args.deterministic {
                bail!(
                    "--deterministic applies to trained policies; {} has no noise to remove",
                    c.name()
                );
            }
            (args.common.load()?, Policy::controller(c, args.seed))
        }
        Err(e) => {
            let path = std::path::Path::new(&args.policy);
            if !path.exists() {
                return Err(RolloutError::UnknownPolicy(e.to_string()).into());
            }
            if args.common.config.is_some() {
                bail!(
                    "a trained policy runs in the configuration it was trained with (saved in its checkpoint): drop --config"
                );
            }
            let (policy, mut resolved) = Policy::load_trained(path, args.seed, args.deterministic)?;
            super::common::apply_policy_sets(&mut resolved, &args.common.sets)?;
            (resolved, policy)
        }
    };
    if resolved.config.swarm.count == 0 {
        bail!("rollout needs a swarm: swarm.count is 0");
    }
    if args.gif && args.frames_every == 0 {
        bail!("--gif animates the frames: give --frames-every K with K > 0");
    }
    if args.envs == 0 || args.episodes == 0 {
        bail!("--envs and --episodes must be positive");
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| run_dir::default_dir("rollout"));
    let out = run_dir::prepare(
        &out,
        if args.frames_every > 0 {
            &["frames"]
        } else {
            &[]
        },
    )?;
    let opened = args.common.open_batch(&resolved, args.envs)?;
    // The header names the policy and protocol (`report` labels baselines with it); the rest
    // loads back with --config.
    let header = format!(
        "# fluxswarm-gpu {} rollout: policy {}{}{}, seed {}, {} environments, {} episodes, adapter {}\n",
        env!("CARGO_PKG_VERSION"),
        args.policy,
        if args.deterministic {
            " (mean action)"
        } else {
            ""
        },
        policy.privileged_note(),
        args.seed,
        args.envs,
        args.episodes,
        super::common::runs_on(&opened)
    );
    std::fs::write(out.join("config.toml"), header + &resolved.config.to_toml())
        .context("writing config.toml")?;
    let mut env = SwarmEnv::new(opened.batch, &resolved, args.seed)?;
    let mut files = RolloutFiles::create(
        &out,
        FileOptions {
            traces: !args.no_traces,
            gap: args.gap,
            frames_every: args.frames_every,
        },
    )?;
    let stop = super::signals::Stop::install("stopping after this step, keeping what was written");
    let mut bar = super::progress::Progress::new("rollout", "episodes", args.episodes, 0);
    let mut last = String::new();
    let start = std::time::Instant::now();
    let stats = rollout::run(
        &mut env,
        &mut policy,
        args.episodes,
        &mut files,
        &|| stop.requested(),
        &mut |p| {
            if let Some(s) = p.last {
                last = format!(
                    "; last: env {} {} after {} steps, progress {:.2}",
                    s.env, s.outcome, s.steps, s.progress
                );
            }
            bar.set(p.finished, format!("{} env steps{last}", p.env_steps));
        },
    )?;
    bar.finish();
    files.flush()?;
    let finished = stats.episodes.len() as u64;
    let wall = start.elapsed().as_secs_f64();
    log::info!(
        "{finished} episodes, {} environment steps in {wall:.1} s ({:.2} env steps/s)",
        stats.env_steps,
        stats.env_steps as f64 / wall
    );
    if let Some(signal) = stop.signal().filter(|_| finished < args.episodes) {
        let what = format!("{finished} of {} episodes written", args.episodes);
        return Err(super::signals::Stopped::new(signal, &what, &out).into());
    }
    if args.gif {
        let window = fluxswarm_gpu::output::gif::Window {
            episode: args.gif_episode,
            steps: args.gif_steps,
        };
        super::common::write_gif(&out, "env0_", window)?;
    }
    println!("{}", out.display());
    Ok(())
}

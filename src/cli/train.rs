//! `fluxswarm-gpu train`: MOMAPPO with PCGrad on the swarm environment. Writes `config.toml`
//! (the resolved configuration, headed by the seed, batch, adapter and version as comments, so
//! it loads back with `--config`), `episodes.csv` and `updates.csv` (SPEC section 7), with a
//! progress bar of global steps, steps/s, ETA, success rate and the latest episode metrics.
//! Not yet: checkpoints, `--resume`, TensorBoard event files, Ctrl-C handling (issue 4).

use std::collections::VecDeque;
use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::env::{GpuSwarmEnv, OBS_DIM, Outcome, SwarmEnv};
use fluxswarm_gpu::learn::env::MultiAgentEnv;
use fluxswarm_gpu::learn::mappo::{Learner, TrainConfig};
use fluxswarm_gpu::output::episodes::EpisodesCsv;
use fluxswarm_gpu::output::run_dir;
use indicatif::{ProgressBar, ProgressStyle};

use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct TrainArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// Environments trained on together.
    #[arg(long, default_value_t = 4)]
    pub envs: usize,
    /// Global environment steps (environments x control steps each); the paper's is 4 x 27,000.
    #[arg(long, default_value_t = 108_000)]
    pub steps: u64,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Average the three actor gradients instead of PCGrad (the paper's ablation).
    #[arg(long)]
    pub no_pcgrad: bool,
    /// Output directory (default runs/train-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
}

pub fn run(mut args: TrainArgs) -> anyhow::Result<()> {
    if args.no_pcgrad {
        args.common.sets.push("train.pcgrad=false".into());
    }
    let resolved = args.common.load()?;
    if resolved.config.swarm.count == 0 {
        bail!("train needs a swarm: swarm.count is 0");
    }
    if args.envs == 0 || args.steps == 0 {
        bail!("--envs and --steps must be positive");
    }
    let out = run_dir::prepare(
        &args
            .out
            .clone()
            .unwrap_or_else(|| run_dir::default_dir("train")),
        &[],
    )?;
    let ctx = args.common.open_gpu()?;
    let header = format!(
        "# fluxswarm-gpu {} train: seed {}, {} environments, {} global steps, adapter {}\n",
        env!("CARGO_PKG_VERSION"),
        args.seed,
        args.envs,
        args.steps,
        ctx.describe()
    );
    std::fs::write(out.join("config.toml"), header + &resolved.config.to_toml())
        .context("writing config.toml")?;

    let swarm = SwarmEnv::new(&ctx, &resolved, args.envs, args.seed)?;
    let mut env = GpuSwarmEnv {
        env: swarm,
        ctx: &ctx,
    };
    let cfg: TrainConfig = resolved.config.train.clone();
    let mut learner = Learner::new(env.n_agents(), OBS_DIM, cfg, args.seed)?;
    let mut obs = env.reset()?;

    let create = |name: &str| -> anyhow::Result<std::io::BufWriter<std::fs::File>> {
        let f =
            std::fs::File::create(out.join(name)).with_context(|| format!("creating {name}"))?;
        Ok(std::io::BufWriter::new(f))
    };
    let mut episodes_csv = EpisodesCsv::create(&out, true).context("creating episodes.csv")?;
    let mut updates_csv = create("updates.csv")?;
    writeln!(
        updates_csv,
        "update,global_step,loss_progress,loss_energy,loss_smoothness,value_loss,entropy,mean_log_std,cos_pe,cos_ps,cos_es,conflict_pe,conflict_ps,conflict_es,sim_s,learn_s"
    )?;

    let bar = ProgressBar::new(args.steps);
    bar.set_style(
        ProgressStyle::with_template("{bar:30} {pos}/{len} steps  {per_sec}  eta {eta}  {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut recent: VecDeque<(bool, [f64; 3])> = VecDeque::new();
    let (mut global, mut update) = (0u64, 0u64);
    let (mut sim_total, mut learn_total) = (0.0, 0.0);
    while global < args.steps {
        let it = learner.iterate(&mut env, &mut obs)?;
        global += it.env_steps as u64;
        update += 1;
        sim_total += it.sim_s;
        learn_total += it.learn_s;
        for s in &it.episodes {
            episodes_csv.write(global, s)?;
            recent.push_back((
                s.outcome == Outcome::Success,
                [s.progress, s.energy, s.smoothness],
            ));
            if recent.len() > 100 {
                recent.pop_front();
            }
        }
        let st = &it.stats;
        writeln!(
            updates_csv,
            "{update},{global},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            st.loss[0],
            st.loss[1],
            st.loss[2],
            st.value_loss,
            st.entropy,
            st.mean_log_std,
            st.cosine[0],
            st.cosine[1],
            st.cosine[2],
            st.conflict[0],
            st.conflict[1],
            st.conflict[2],
            it.sim_s,
            it.learn_s
        )?;
        updates_csv.flush()?;
        if !recent.is_empty() {
            let n = recent.len() as f64;
            let success = recent.iter().filter(|r| r.0).count() as f64 / n;
            let m = recent.iter().fold([0.0; 3], |a, r| {
                [a[0] + r.1[0] / n, a[1] + r.1[1] / n, a[2] + r.1[2] / n]
            });
            bar.set_message(format!(
                "success {:.0}%  progress {:.1} energy {:.2} smoothness {:.2}",
                100.0 * success,
                m[0],
                m[1],
                m[2]
            ));
        }
        bar.set_position(global.min(args.steps));
    }
    bar.finish();
    log::info!(
        "{update} updates, {global} global steps: simulation {sim_total:.1} s, learner {learn_total:.1} s ({:.0} % of the time)",
        100.0 * learn_total / (sim_total + learn_total).max(1e-9)
    );
    println!("{}", out.display());
    Ok(())
}

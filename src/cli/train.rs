//! `fluxswarm-gpu train`: MOMAPPO with PCGrad on the swarm environment. A run directory holds
//! `config.toml` (the resolved configuration, headed by the seed, batch, adapter and version as
//! comments, so it loads back with `--config`), `episodes.csv` and `updates.csv` (SPEC section
//! 7), a TensorBoard event file of the same scalars, and `checkpoints/update-NNNNNNN.safetensors`
//! (every K updates, at the end and on a signal; the newest three are kept), with
//! `policy.safetensors` (the newest checkpoint's actor, normaliser and configuration: a few
//! hundred KB to share or commit) rewritten beside them, and kept as
//! `policies/update-NNNNNNN.safetensors` at every checkpoint whose update is a multiple of
//! `--policy-every` (250; never pruned: a run's learning curve can be evaluated afterwards).
//! A checkpoint holds
//! the learner, the environments and the run's counters, including how many bytes of each log
//! belong to it, so `--resume DIR` cuts the logs back to that point and continues exactly as
//! the uninterrupted run would have (same adapter).
//!
//! SIGINT (Ctrl-C), SIGTERM and SIGHUP (`signals`) finish the update in hand, write a
//! checkpoint, print the `--resume` command and exit with 130, 143 or 129; progress goes to
//! stderr (`progress`: a bar on a terminal, plain lines elsewhere).

use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::checkpoint::{self, Archive, CheckpointError};
use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::env::{OBS_DIM, Outcome, SwarmEnv};
use fluxswarm_gpu::learn::env::MultiAgentEnv;
use fluxswarm_gpu::learn::mappo::{Learner, TrainConfig};
use fluxswarm_gpu::output::run_dir;

use super::common::ConfigArgs;
use super::progress::Progress as Bar;
use super::signals::{self, Stop};
use super::train_logs::{Logs, create_logs, log_update, reopen_logs};

#[derive(Debug, Args)]
pub struct TrainArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// Environments trained on together [default: 4].
    #[arg(long)]
    pub envs: Option<usize>,
    /// Global environment steps (environments x control steps each); the paper's is 4 x 27,000
    /// [default: 108000]. With --resume: the new total (default: the run's own). 0 writes only
    /// the untrained policy's checkpoint (update 0), e.g. for before/after comparisons.
    #[arg(long)]
    pub steps: Option<u64>,
    /// Seed of the networks, the environments and the sampling [default: 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Average the three actor gradients instead of PCGrad (the paper's ablation).
    #[arg(long)]
    pub no_pcgrad: bool,
    /// Output directory (default runs/train-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Continue the run in DIR from its newest checkpoint (its configuration, seed and
    /// environments; only --steps and --adapter may be given with it).
    #[arg(long, value_name = "DIR")]
    pub resume: Option<PathBuf>,
    /// Write a checkpoint every K updates (and always at the end and on Ctrl-C, SIGTERM or
    /// SIGHUP).
    #[arg(long, default_value_t = 25, value_name = "K")]
    pub checkpoint_every: u64,
    /// Also keep the policy of every checkpoint whose update is a multiple of K in
    /// `policies/update-NNNNNNN.safetensors` (never pruned; 0: none), so that the run's learning
    /// curve can be evaluated afterwards with `eval --checkpoint FILE`.
    #[arg(long, default_value_t = 250, value_name = "K")]
    pub policy_every: u64,
}

pub use fluxswarm_gpu::checkpoint::POLICY_FILE;

/// Checkpoints kept in `checkpoints/` (older ones are deleted after a newer one is written).
const KEEP: usize = 3;

/// What fixes a run: its directory, configuration, seed, batch and budget.
struct Plan {
    out: PathBuf,
    resolved: Resolved,
    seed: u64,
    envs: usize,
    steps: u64,
    /// `--policy-every`.
    policy_every: u64,
}

/// The counters a checkpoint carries besides the learner and the environments.
#[derive(Default)]
struct Progress {
    update: u64,
    global: u64,
    sim_s: f64,
    learn_s: f64,
}

pub fn run(mut args: TrainArgs) -> anyhow::Result<()> {
    if args.checkpoint_every == 0 {
        bail!("--checkpoint-every must be at least 1 (checkpoints are also written at the end)");
    }
    let resumed = match &args.resume {
        Some(dir) => Some(open_checkpoint(dir, &args)?),
        None => None,
    };
    let plan = match &resumed {
        Some((dir, archive)) => resume_plan(dir, archive, &args)?,
        None => fresh_plan(&mut args)?,
    };
    let opened = args.common.open_batch(&plan.resolved, plan.envs)?;
    let runs_on = super::common::runs_on(&opened);
    let mut env = SwarmEnv::new(opened.batch, &plan.resolved, plan.seed)?;
    let cfg: TrainConfig = plan.resolved.config.train.clone();
    // train.critic_phase: the critic also reads the environment's global state (the inlet phase).
    let global_dim = match cfg.critic_phase {
        true => MultiAgentEnv::global_state_dim(&env),
        false => 0,
    };
    let mut learner =
        Learner::with_global_state(env.n_agents(), OBS_DIM, global_dim, cfg, plan.seed)?;
    let mut obs = env.reset()?;
    let ck_dir = plan.out.join("checkpoints");
    let (mut progress, mut logs) = match &resumed {
        Some((_, archive)) => {
            learner.load_state(archive)?;
            env.load_state(archive, "env")?;
            obs = archive.f32("train.obs", Some(obs.len()))?;
            let p = Progress {
                update: archive.meta_parse("update")?,
                global: archive.meta_parse("global_step")?,
                sim_s: archive.meta_parse("sim_s")?,
                learn_s: archive.meta_parse("learn_s")?,
            };
            log::info!(
                "resuming {} at update {}, {} of {} global steps",
                plan.out.display(),
                p.update,
                p.global,
                plan.steps
            );
            (p, reopen_logs(&plan.out, archive)?)
        }
        None => {
            let header = format!(
                "# fluxswarm-gpu {} train: seed {}, {} environments, {} global steps, adapter {}\n",
                env!("CARGO_PKG_VERSION"),
                plan.seed,
                plan.envs,
                plan.steps,
                runs_on
            );
            std::fs::write(
                plan.out.join("config.toml"),
                header + &plan.resolved.config.to_toml(),
            )
            .context("writing config.toml")?;
            (Progress::default(), create_logs(&plan.out)?)
        }
    };

    let stop = Stop::install("finishing this update, then writing a checkpoint");
    let mut bar = Bar::new("train", "steps", plan.steps, progress.global);
    let mut recent: VecDeque<(bool, [f64; 3])> = VecDeque::new();
    let mut saved_at = progress.update;
    while progress.global < plan.steps && !stop.requested() {
        let it = learner.iterate(&mut env, &mut obs)?;
        progress.global += it.env_steps as u64;
        progress.update += 1;
        progress.sim_s += it.sim_s;
        progress.learn_s += it.learn_s;
        log_update(&mut logs, progress.update, progress.global, &it)?;
        for s in &it.episodes {
            recent.push_back((
                s.outcome == Outcome::Success,
                [s.progress, s.energy, s.smoothness],
            ));
            if recent.len() > 100 {
                recent.pop_front();
            }
        }
        let mut msg = format!("update {}", progress.update);
        if !recent.is_empty() {
            let n = recent.len() as f64;
            let success = recent.iter().filter(|r| r.0).count() as f64 / n;
            let m = recent.iter().fold([0.0; 3], |a, r| {
                [a[0] + r.1[0] / n, a[1] + r.1[1] / n, a[2] + r.1[2] / n]
            });
            msg += &format!(
                "  success {:.0}%  progress {:.1} energy {:.2} smoothness {:.2}",
                100.0 * success,
                m[0],
                m[1],
                m[2]
            );
        }
        bar.set(progress.global, msg);
        if progress.update.is_multiple_of(args.checkpoint_every) {
            save(&ck_dir, &plan, &progress, &mut logs, &learner, &env, &obs)?;
            saved_at = progress.update;
        }
    }
    bar.finish();
    if saved_at != progress.update || resumed.is_none() && progress.update == 0 {
        save(&ck_dir, &plan, &progress, &mut logs, &learner, &env, &obs)?;
    }
    log::info!(
        "{} updates, {} global steps: simulation {:.1} s, learner {:.1} s ({:.0} % of the time)",
        progress.update,
        progress.global,
        progress.sim_s,
        progress.learn_s,
        100.0 * progress.learn_s / (progress.sim_s + progress.learn_s).max(1e-9)
    );
    // A signal during the last update stops nothing: the run is complete.
    if let Some(signal) = stop.signal().filter(|_| progress.global < plan.steps) {
        return Err(signals::Stopped::new(
            signal,
            &format!(
                "checkpoint of update {} written; continue with `fluxswarm-gpu train --resume {}`",
                progress.update,
                plan.out.display()
            ),
            &plan.out,
        )
        .into());
    }
    println!("{}", plan.out.display());
    Ok(())
}

/// The configuration a fresh run of `args` trains in: `--config`, `--set` and `--no-pcgrad`.
pub fn fresh_config(args: &TrainArgs) -> anyhow::Result<Resolved> {
    let mut common = args.common.clone();
    if args.no_pcgrad {
        common.sets.push("train.pcgrad=false".into());
    }
    common.load()
}

fn fresh_plan(args: &mut TrainArgs) -> anyhow::Result<Plan> {
    let resolved = fresh_config(args)?;
    if resolved.config.swarm.count == 0 {
        bail!("train needs a swarm: swarm.count is 0");
    }
    let (envs, steps) = (args.envs.unwrap_or(4), args.steps.unwrap_or(108_000));
    if envs == 0 {
        bail!("--envs must be positive");
    }
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| run_dir::default_dir("train"));
    if out.join("updates.csv").exists() || !checkpoint::list(&out.join("checkpoints")).is_empty() {
        bail!(
            "{} already holds a training run: continue it with --resume {0} or choose another --out",
            out.display()
        );
    }
    Ok(Plan {
        out: run_dir::prepare(&out, &["checkpoints"])?,
        resolved,
        seed: args.seed.unwrap_or(0),
        envs,
        steps,
        policy_every: args.policy_every,
    })
}

/// The newest readable checkpoint of run `dir`; a damaged newest file falls back to the one
/// before it (with a warning), so a crash while writing loses at most K updates.
fn open_checkpoint(dir: &Path, args: &TrainArgs) -> anyhow::Result<(PathBuf, Archive)> {
    let c = &args.common;
    let mut given = Vec::new();
    let run_key = |s: &String| {
        super::common::RUN_KEYS
            .iter()
            .any(|k| s.trim_start().starts_with(&format!("{k}=")))
    };
    if c.config.is_some() || !c.sets.iter().all(run_key) {
        given.push("--config/--set");
    }
    for (flag, on) in [
        ("--envs", args.envs.is_some()),
        ("--seed", args.seed.is_some()),
        ("--no-pcgrad", args.no_pcgrad),
        ("--out", args.out.is_some()),
    ] {
        if on {
            given.push(flag);
        }
    }
    if !given.is_empty() {
        bail!(
            "--resume continues a run as it was started; {} cannot change it (only --steps, --adapter, --checkpoint-every and --set solver.backend=... / solver.pressure_sweep=... can): drop {}, or start a new run without --resume",
            given.join(", "),
            if given.len() > 1 { "them" } else { "it" }
        );
    }
    let files = checkpoint::list(&dir.join("checkpoints"));
    if files.is_empty() {
        bail!(
            "{} has no checkpoints/update-*.safetensors to resume from: is it a `train` run directory?",
            dir.display()
        );
    }
    let mut last_err = None;
    for f in files {
        match Archive::load(&f) {
            Ok(a) => {
                if a.meta("kind").ok() != Some("train") {
                    return Err(a.mismatch("it is not a train checkpoint").into());
                }
                return Ok((dir.to_path_buf(), a));
            }
            Err(e @ CheckpointError::Corrupt { .. }) => {
                log::warn!("{e}; trying the one before it");
                last_err = Some(e);
            }
            Err(e) => return Err(e.into()),
        }
    }
    Err(last_err.expect("at least one file").into())
}

fn resume_plan(dir: &Path, archive: &Archive, args: &TrainArgs) -> anyhow::Result<Plan> {
    let mut resolved = Config::from_saved(archive.meta("config")?)
        .with_context(|| format!("the configuration saved in {}", archive.path().display()))?;
    check_config_record(dir, &resolved.config)?;
    super::common::apply_run_sets(&mut resolved, &args.common.sets, "a resumed run", &[])?;
    let steps = match args.steps {
        Some(s) => s,
        None => archive.meta_parse("steps")?,
    };
    Ok(Plan {
        out: run_dir::prepare(dir, &["checkpoints"])?,
        resolved,
        seed: archive.meta_parse("seed")?,
        envs: archive.meta_parse("envs")?,
        steps,
        policy_every: args.policy_every,
    })
}

/// `DIR/config.toml` records the run; a resumed run takes the configuration saved in its
/// checkpoint and never reads the file. An edited record would silently not apply (and would
/// then misdescribe the run), so resume refuses it, naming the keys. A missing file is fine.
fn check_config_record(dir: &Path, saved: &Config) -> anyhow::Result<()> {
    let path = dir.join("config.toml");
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(());
    };
    let fix = format!(
        "--resume continues the run with the configuration saved in its checkpoint and does not read {0}: undo the edit to continue it, or start a new run with the change (`fluxswarm-gpu train --config {0} --out NEW_DIR`)",
        path.display()
    );
    let record = Config::from_saved(&text)
        .with_context(|| format!("{} no longer loads; {fix}", path.display()))?;
    let changed = saved.differences(&record.config);
    if !changed.is_empty() {
        let keys: Vec<String> = changed
            .iter()
            .map(|(k, was, now)| format!("{k} = {now} (saved: {was})"))
            .collect();
        bail!(
            "{} was edited after the run started: {}. {fix}",
            path.display(),
            keys.join(", ")
        );
    }
    Ok(())
}

/// Writes `checkpoints/update-NNNNNNN.safetensors` atomically and prunes old ones.
fn save(
    dir: &Path,
    plan: &Plan,
    p: &Progress,
    logs: &mut Logs,
    learner: &Learner,
    env: &SwarmEnv,
    obs: &[f32],
) -> anyhow::Result<()> {
    let mut a = Archive::new();
    learner.save_state(&mut a)?;
    env.save_state(&mut a, "env")?;
    a.put_f32("train.obs", &[obs.len()], obs);
    identify(&mut a, "train", plan, p);
    a.set_meta("envs", plan.envs);
    a.set_meta("steps", plan.steps);
    a.set_meta("sim_s", p.sim_s);
    a.set_meta("learn_s", p.learn_s);
    logs.updates.flush()?;
    a.set_meta("episodes_csv_bytes", logs.episodes.bytes_written()?);
    a.set_meta(
        "updates_csv_bytes",
        logs.updates.get_ref().metadata()?.len(),
    );
    a.set_meta("events_bytes", logs.events.flush()?);
    let events_name = logs
        .events
        .path()
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    a.set_meta("events_file", events_name);
    let path = dir.join(checkpoint::file_name(p.update));
    a.save(&path)?;
    // The policy alone beside it (SPEC section 8), always that of the newest checkpoint.
    let mut policy = Archive::new();
    learner.save_policy(&mut policy)?;
    identify(&mut policy, "policy", plan, p);
    policy.save(&plan.out.join(POLICY_FILE))?;
    if p.update > 0 && plan.policy_every > 0 && p.update.is_multiple_of(plan.policy_every) {
        let snapshots = plan.out.join("policies");
        std::fs::create_dir_all(&snapshots)
            .with_context(|| format!("creating {}", snapshots.display()))?;
        policy.save(&snapshots.join(checkpoint::file_name(p.update)))?;
    }
    log::debug!("checkpoint {}", path.display());
    for old in checkpoint::list(dir).into_iter().skip(KEEP) {
        let _ = std::fs::remove_file(old);
    }
    Ok(())
}

/// The metadata a checkpoint and a policy file share: what it is, the version, the resolved
/// configuration, the seed and where in the run it was written.
fn identify(a: &mut Archive, kind: &str, plan: &Plan, p: &Progress) {
    a.set_meta("kind", kind);
    a.set_meta("version", env!("CARGO_PKG_VERSION"));
    a.set_meta("config", plan.resolved.config.to_toml());
    a.set_meta("seed", plan.seed);
    a.set_meta("update", p.update);
    a.set_meta("global_step", p.global);
}

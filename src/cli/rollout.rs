//! `fluxswarm-gpu rollout` (and `eval`): runs a baseline or a trained policy in E environments
//! until K episodes have finished (over all environments) and writes `episodes.csv`,
//! `swarm.csv`, `trajectories.csv` (SPEC section 7), `starts.csv` (the start phase of every
//! episode), `config.toml` and frames of environment 0
//! (`frames/env0_ep<episode:04>_s<step:06>.png`). A trained policy brings its configuration
//! from its checkpoint, so it runs in the physics it was trained in.
//!
//! K episodes over E environments are collected as a quota per environment (the first
//! ceil(K/E) or floor(K/E) episodes each environment finishes), so that long episodes are not
//! under-counted: taking the first K to finish over all environments would favour short ones.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::checkpoint::{self, Archive};
use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::env::policy::Controller;
use fluxswarm_gpu::env::{OBS_DIM, SwarmEnv, reward};
use fluxswarm_gpu::gpu::params::{GpuMember, GpuMemberDiag};
use fluxswarm_gpu::learn::mappo::Learner;
use fluxswarm_gpu::output::episodes::EpisodesCsv;
use fluxswarm_gpu::output::frame::{self, MemberMark};
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::rng::Rng;

use super::common::ConfigArgs;

type Csv = std::io::BufWriter<std::fs::File>;

#[derive(Debug, Args)]
pub struct RolloutArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// upstream, wall, wall-angle:DEG, zero, random, scripted (privileged: reads the inlet
    /// phase; scripted:CALM_DEG:STORM_DEG:START_S:END_S sets its parameters), or a trained
    /// checkpoint: a `.safetensors` file or a `train` run directory (its newest checkpoint).
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
    /// Write only episodes.csv, starts.csv and config.toml (no swarm.csv, trajectories.csv):
    /// for sweeps of many episodes.
    #[arg(long)]
    pub no_traces: bool,
}

/// What chooses the actions.
enum Policy {
    Controller(Controller, Rng),
    Trained {
        learner: Box<Learner>,
        deterministic: bool,
    },
}

impl Policy {
    fn act_all(&mut self, obs: &[f32], env: &SwarmEnv) -> anyhow::Result<Vec<[f32; 2]>> {
        Ok(match self {
            Policy::Controller(c, rng) => {
                let batch = env.batch();
                let t: Vec<f64> = (0..env.n_env()).map(|e| batch.waveform_time_s(e)).collect();
                c.act_all(obs, &t, batch.waveform().period_s(), rng)
            }
            Policy::Trained {
                learner,
                deterministic,
            } => learner.act(&learner.normalize(obs), *deterministic)?.0,
        })
    }
}

/// The trained policy of a checkpoint or a `policy.safetensors` (a file, or a run directory:
/// its newest checkpoint) and its configuration; `seed` drives the sampled actions.
fn load_trained(path: &std::path::Path, seed: u64) -> anyhow::Result<(Learner, Resolved)> {
    let file = checkpoint::locate(path)?;
    let archive = Archive::load(&file)?;
    let resolved = Config::from_saved(archive.meta("config")?)
        .with_context(|| format!("the configuration saved in {}", file.display()))?;
    let agents = resolved.config.swarm.count as usize;
    let mut learner = Learner::new(agents, OBS_DIM, resolved.config.train.clone(), seed)?;
    learner.load_policy(&archive)?;
    log::info!("policy: {}", file.display());
    Ok((learner, resolved))
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
            let rng = Rng::new(args.seed.wrapping_add(0x9E37));
            (args.common.load()?, Policy::Controller(c, rng))
        }
        Err(e) => {
            let path = std::path::Path::new(&args.policy);
            if !path.exists() {
                bail!("{e}, or the path of a trained checkpoint");
            }
            if args.common.config.is_some() {
                bail!(
                    "a trained policy runs in the configuration it was trained with (saved in its checkpoint): drop --config"
                );
            }
            let (learner, mut resolved) = load_trained(path, args.seed)?;
            super::common::apply_run_sets(&mut resolved, &args.common.sets, "a trained policy")?;
            let policy = Policy::Trained {
                learner: Box::new(learner),
                deterministic: args.deterministic,
            };
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
    let privileged = match &policy {
        Policy::Controller(Controller::Scripted(p), _) => format!(
            " (privileged, reads the inlet phase: {} deg outside and {} deg inside [{} s, {} s) of the period)",
            p.calm_deg, p.storm_deg, p.storm_start_s, p.storm_end_s
        ),
        _ => String::new(),
    };
    let header = format!(
        "# fluxswarm-gpu {} rollout: policy {}{}{privileged}, seed {}, {} environments, {} episodes, adapter {}\n",
        env!("CARGO_PKG_VERSION"),
        args.policy,
        if args.deterministic {
            " (mean action)"
        } else {
            ""
        },
        args.seed,
        args.envs,
        args.episodes,
        super::common::runs_on(&opened)
    );
    std::fs::write(out.join("config.toml"), header + &resolved.config.to_toml())
        .context("writing config.toml")?;
    let mut env = SwarmEnv::new(opened.batch, &resolved, args.seed)?;
    let c = &resolved.config;
    let n = env.n_agents();
    let dt = c.time.control_dt_s;
    let f_max = c.swarm.max_thrust_n;

    let create = |name: &str| -> anyhow::Result<std::io::BufWriter<std::fs::File>> {
        let f =
            std::fs::File::create(out.join(name)).with_context(|| format!("creating {name}"))?;
        Ok(std::io::BufWriter::new(f))
    };
    let mut episodes_csv = EpisodesCsv::create(&out, false).context("creating episodes.csv")?;
    let mut starts_csv = create("starts.csv")?;
    writeln!(
        starts_csv,
        "env,episode,start_phase_s,start_inlet_u_m_s,start_x_com_mm"
    )?;
    let mut traces = if args.no_traces {
        None
    } else {
        let mut swarm_csv = create("swarm.csv")?;
        writeln!(
            swarm_csv,
            "env,episode,step,t_s,inlet_u_m_s,x_com_mm,y_com_mm,sigma_x_mm,sigma_y_mm,r_g_mm"
        )?;
        let mut traj_csv = create("trajectories.csv")?;
        writeln!(
            traj_csv,
            "env,episode,step,member,x_mm,y_mm,vx_mm_s,vy_mm_s,ax,ay,f_prop_x_nN,f_prop_y_nN,f_hydro_x_nN,f_hydro_y_nN,f_drag_x_nN,f_drag_y_nN,f_contact_x_nN,f_contact_y_nN"
        )?;
        Some((swarm_csv, traj_csv))
    };

    let log_state = |traces: &mut Option<(Csv, Csv)>,
                     e: usize,
                     episode: u64,
                     step: u32,
                     inlet: f64,
                     ms: &[GpuMember],
                     fs: &[GpuMemberDiag],
                     actions: &[[f32; 2]]|
     -> std::io::Result<()> {
        let Some((swarm_csv, traj_csv)) = traces else {
            return Ok(());
        };
        let pos: Vec<[f64; 2]> = ms
            .iter()
            .map(|m| [m.pos[0] as f64 * 1e3, m.pos[1] as f64 * 1e3])
            .collect();
        let [xc, yc, sx, sy, rg] = reward::swarm_metrics(&pos);
        writeln!(
            swarm_csv,
            "{e},{episode},{step},{:.4},{inlet:.6},{xc:.5},{yc:.5},{sx:.5},{sy:.5},{rg:.5}",
            step as f64 * dt
        )?;
        for (i, (m, d)) in ms.iter().zip(fs).enumerate() {
            let nn = |v: f32| v as f64 * 1e9;
            writeln!(
                traj_csv,
                "{e},{episode},{step},{i},{:.5},{:.5},{:.4},{:.4},{:.5},{:.5},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3},{:.3}",
                pos[i][0],
                pos[i][1],
                m.vel[0] as f64 * 1e3,
                m.vel[1] as f64 * 1e3,
                actions[i][0],
                actions[i][1],
                nn(d.prop[0]),
                nn(d.prop[1]),
                nn(d.hydro[0]),
                nn(d.hydro[1]),
                nn(d.drag[0]),
                nn(d.drag[1]),
                nn(d.contact[0]),
                nn(d.contact[1]),
            )?;
        }
        Ok(())
    };
    // The state at the start of episode `episode` of environment e: starts.csv, step 0 of the
    // traces and, for environment 0, its first frame.
    let start_episode = |traces: &mut Option<(Csv, Csv)>,
                         starts_csv: &mut Csv,
                         env: &SwarmEnv,
                         e: usize,
                         episode: u64|
     -> anyhow::Result<()> {
        let batch = env.batch();
        let inlet = batch.inlet_u(e);
        let ms = initial_members(env, e);
        let x_com = ms.iter().map(|m| m.pos[0] as f64).sum::<f64>() / ms.len() as f64 * 1e3;
        writeln!(
            starts_csv,
            "{e},{episode},{:.6},{inlet:.6},{x_com:.5}",
            batch.phase_s(e)
        )?;
        log_state(
            traces,
            e,
            episode,
            0,
            inlet,
            &ms,
            &vec![GpuMemberDiag::default(); n],
            &vec![[0.0f32; 2]; n],
        )?;
        if e == 0 && args.frames_every > 0 {
            let zero_forces = vec![GpuMemberDiag::default(); n];
            write_frame(env, &out, episode, 0, &ms, &zero_forces, f_max, &resolved)?;
        }
        Ok(())
    };

    // Each environment's share of the K episodes (module header).
    let quota: Vec<u64> = (0..args.envs as u64)
        .map(|e| args.episodes / args.envs as u64 + u64::from(e < args.episodes % args.envs as u64))
        .collect();
    let mut counted = vec![0u64; args.envs];
    let mut obs = env.reset()?;
    for (e, &q) in quota.iter().enumerate() {
        if q > 0 {
            start_episode(&mut traces, &mut starts_csv, &env, e, 0)?;
        }
    }
    let frame_due =
        |step: u32| args.frames_every > 0 && (step as u64).is_multiple_of(args.frames_every);
    let stop = super::signals::Stop::install("stopping after this step, keeping what was written");
    let mut bar = super::progress::Progress::new("rollout", "episodes", args.episodes, 0);
    let mut last = String::new();
    let mut finished = 0u64;
    let mut steps_total = 0u64;
    let start = std::time::Instant::now();
    while finished < args.episodes && !stop.requested() {
        let actions = policy.act_all(&obs, &env)?;
        // Inlet velocity at the end of this step, taken before any environment resets.
        let inlet_after: Vec<f64> = (0..args.envs)
            .map(|e| env.batch().inlet_u_after(e, dt))
            .collect();
        let step = env.step(&actions)?;
        steps_total += args.envs as u64;
        for e in 0..args.envs {
            if counted[e] == quota[e] {
                continue;
            }
            let (ms, fs) = (
                &step.members[e * n..(e + 1) * n],
                &step.forces[e * n..(e + 1) * n],
            );
            let k = step.episode_step[e];
            log_state(
                &mut traces,
                e,
                step.episode[e],
                k,
                inlet_after[e],
                ms,
                fs,
                &actions[e * n..(e + 1) * n],
            )?;
            if e == 0 && frame_due(k) {
                write_frame(&env, &out, step.episode[e], k, ms, fs, f_max, &resolved)?;
            }
            if let Some(s) = &step.episodes[e] {
                counted[e] += 1;
                finished += 1;
                episodes_csv.write(0, s)?;
                last = format!(
                    "; last: env {e} {} after {} steps, progress {:.2}",
                    s.outcome, s.steps, s.progress
                );
                if counted[e] < quota[e] {
                    start_episode(&mut traces, &mut starts_csv, &env, e, step.episode[e] + 1)?;
                }
            }
        }
        obs = step.transition.obs;
        bar.set(finished, format!("{steps_total} env steps{last}"));
    }
    bar.finish();
    starts_csv.flush()?;
    if let Some((swarm_csv, traj_csv)) = &mut traces {
        swarm_csv.flush()?;
        traj_csv.flush()?;
    }
    let wall = start.elapsed().as_secs_f64();
    log::info!(
        "{finished} episodes, {steps_total} environment steps in {wall:.1} s ({:.2} env steps/s)",
        steps_total as f64 / wall
    );
    if let Some(signal) = stop.signal().filter(|_| finished < args.episodes) {
        let what = format!("{finished} of {} episodes written", args.episodes);
        return Err(super::signals::Stopped::new(signal, &what, &out).into());
    }
    if args.gif {
        super::common::write_gif(&out, "env0_")?;
    }
    println!("{}", out.display());
    Ok(())
}

/// The members of environment e as last placed or read back.
fn initial_members(env: &SwarmEnv, e: usize) -> Vec<GpuMember> {
    let n = env.n_agents();
    env.batch().members()[e * n..(e + 1) * n].to_vec()
}

#[allow(clippy::too_many_arguments)]
fn write_frame(
    env: &SwarmEnv,
    out: &std::path::Path,
    episode: u64,
    step: u32,
    ms: &[GpuMember],
    fs: &[GpuMemberDiag],
    f_max: f64,
    resolved: &fluxswarm_gpu::config::Resolved,
) -> anyhow::Result<()> {
    let d = &resolved.config.domain;
    let fields = env.batch().fields(0)?;
    let marks: Vec<MemberMark> = ms
        .iter()
        .zip(fs)
        .map(|(m, f)| MemberMark::new(m.pos, f.prop, f_max))
        .collect();
    let (v_min, v_max) = frame::velocity_range(resolved.waveform.points());
    let path = out
        .join("frames")
        .join(format!("env0_ep{episode:04}_s{step:06}.png"));
    frame::write(
        &path,
        &frame::FrameSpec {
            ux: &fields.ux_cells(),
            nx: fields.nx,
            ny: fields.ny,
            length_m: d.length_m,
            height_m: d.height_m,
            x_min_m: d.success_x_m,
            x_max_m: d.failure_x_m,
            v_min,
            v_max,
            time_s: step as f64 * resolved.config.time.control_dt_s,
            inlet_u_m_s: resolved
                .waveform
                .at(step as f64 * resolved.config.time.control_dt_s),
            env: 0,
            members: &marks,
            radius_m: resolved.config.swarm.radius_m,
        },
    )
    .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

//! `fluxswarm-gpu rollout` (and `eval`): runs a baseline or a trained policy in E environments
//! until K episodes have finished (over all environments) and writes `episodes.csv`,
//! `swarm.csv`, `trajectories.csv` (SPEC section 7), `config.toml` and frames of environment 0
//! (`frames/env0_ep<episode:04>_s<step:06>.png`). A trained policy brings its configuration
//! from its checkpoint, so it runs in the physics it was trained in.

use std::io::Write;
use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Args;
use fluxswarm_gpu::checkpoint::{self, Archive};
use fluxswarm_gpu::config::{Config, Resolved};
use fluxswarm_gpu::env::policy::Baseline;
use fluxswarm_gpu::env::{OBS_DIM, SwarmEnv, reward};
use fluxswarm_gpu::gpu::params::{GpuMember, GpuMemberDiag};
use fluxswarm_gpu::learn::mappo::Learner;
use fluxswarm_gpu::output::episodes::EpisodesCsv;
use fluxswarm_gpu::output::frame::{self, MemberMark};
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::rng::Rng;
use indicatif::{ProgressBar, ProgressStyle};

use super::common::ConfigArgs;

#[derive(Debug, Args)]
pub struct RolloutArgs {
    #[command(flatten)]
    pub common: ConfigArgs,
    /// upstream, wall, zero, random, or a trained checkpoint: a `.safetensors` file or a
    /// `train` run directory (its newest checkpoint).
    #[arg(long)]
    pub policy: String,
    /// With a trained policy: act with the mean action instead of sampling.
    #[arg(long)]
    pub deterministic: bool,
    #[arg(long, default_value_t = 1)]
    pub envs: usize,
    /// Finished episodes to collect, over all environments.
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
}

/// What chooses the actions.
enum Policy {
    Baseline(Baseline, Rng),
    Trained {
        learner: Box<Learner>,
        deterministic: bool,
    },
}

impl Policy {
    fn act_all(&mut self, obs: &[f32]) -> anyhow::Result<Vec<[f32; 2]>> {
        Ok(match self {
            Policy::Baseline(b, rng) => b.act_all(obs, rng),
            Policy::Trained {
                learner,
                deterministic,
            } => learner.act(&learner.normalize(obs), *deterministic)?.0,
        })
    }
}

/// The trained policy of a checkpoint (a file or a run directory) and its configuration.
fn load_trained(path: &std::path::Path, seed: u64) -> anyhow::Result<(Learner, Resolved)> {
    let file = checkpoint::locate(path)?;
    let archive = Archive::load(&file)?;
    let resolved = Config::from_saved(archive.meta("config")?)
        .with_context(|| format!("the configuration saved in {}", file.display()))?;
    let agents = resolved.config.swarm.count as usize;
    let mut learner = Learner::new(agents, OBS_DIM, resolved.config.train.clone(), seed)?;
    learner.load_state(&archive)?;
    log::info!("policy: {}", file.display());
    Ok((learner, resolved))
}

pub fn run(args: RolloutArgs) -> anyhow::Result<()> {
    let (resolved, mut policy) = match args.policy.parse::<Baseline>() {
        Ok(b) => {
            if args.deterministic {
                bail!(
                    "--deterministic applies to trained policies; {} has no noise to remove",
                    b.name()
                );
            }
            let rng = Rng::new(args.seed.wrapping_add(0x9E37));
            (args.common.load()?, Policy::Baseline(b, rng))
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
    let header = format!(
        "# fluxswarm-gpu {} rollout: policy {}{}, seed {}, {} environments, {} episodes, adapter {}\n",
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

    let log_state = |swarm_csv: &mut dyn Write,
                     traj_csv: &mut dyn Write,
                     e: usize,
                     episode: u64,
                     step: u32,
                     inlet: f64,
                     ms: &[GpuMember],
                     fs: &[GpuMemberDiag],
                     actions: &[[f32; 2]]|
     -> std::io::Result<()> {
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

    let mut obs = env.reset()?;
    let zero_actions = vec![[0.0f32; 2]; n];
    let zero_forces = vec![GpuMemberDiag::default(); n];
    for e in 0..args.envs {
        let ms = initial_members(&env, e);
        log_state(
            &mut swarm_csv,
            &mut traj_csv,
            e,
            0,
            0,
            env.batch().inlet_u(e),
            &ms,
            &zero_forces,
            &zero_actions,
        )?;
    }
    let frame_due =
        |step: u32| args.frames_every > 0 && (step as u64).is_multiple_of(args.frames_every);
    if frame_due(0) {
        write_frame(
            &env,
            &out,
            0,
            0,
            &initial_members(&env, 0),
            &zero_forces,
            f_max,
            &resolved,
        )?;
    }
    let bar = ProgressBar::new(args.episodes);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} episodes  {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut finished = 0u64;
    let mut steps_total = 0u64;
    let start = std::time::Instant::now();
    while finished < args.episodes {
        let actions = policy.act_all(&obs)?;
        // Inlet velocity at the end of this step, taken before any environment resets.
        let inlet_after: Vec<f64> = (0..args.envs)
            .map(|e| env.batch().inlet_u_after(e, dt))
            .collect();
        let step = env.step(&actions)?;
        steps_total += args.envs as u64;
        for e in 0..args.envs {
            let (ms, fs) = (
                &step.members[e * n..(e + 1) * n],
                &step.forces[e * n..(e + 1) * n],
            );
            let k = step.episode_step[e];
            log_state(
                &mut swarm_csv,
                &mut traj_csv,
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
            if let Some(s) = &step.episodes[e]
                && finished < args.episodes
            {
                // Exactly K episodes: others ending in the same step are not counted.
                finished += 1;
                episodes_csv.write(0, s)?;
                bar.inc(1);
                bar.set_message(format!(
                    "last: env {e} {} after {} steps, progress {:.2}",
                    s.outcome, s.steps, s.progress
                ));
                if finished < args.episodes {
                    let ms = initial_members(&env, e);
                    let next = step.episode[e] + 1;
                    log_state(
                        &mut swarm_csv,
                        &mut traj_csv,
                        e,
                        next,
                        0,
                        env.batch().inlet_u(e),
                        &ms,
                        &zero_forces,
                        &zero_actions,
                    )?;
                    if e == 0 && frame_due(0) {
                        write_frame(&env, &out, next, 0, &ms, &zero_forces, f_max, &resolved)?;
                    }
                }
            }
        }
        obs = step.transition.obs;
    }
    bar.finish();
    for w in [&mut swarm_csv, &mut traj_csv] {
        w.flush()?;
    }
    let wall = start.elapsed().as_secs_f64();
    log::info!(
        "{finished} episodes, {steps_total} environment steps in {wall:.1} s ({:.2} env steps/s)",
        steps_total as f64 / wall
    );
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

//! `fluxswarm-gpu sweep SPEC.toml --out DIR`: every run of a sweep (`fluxswarm_gpu::sweep`,
//! SPEC section 8) on a local pool (`--jobs K`), or as a Slurm job array (`--slurm`, with
//! `--submit` to hand it to `sbatch`); `--status` refreshes `sweep.csv` and summarises it,
//! `--dry-run` prints the command lines. Re-running the same command resumes the sweep.
//!
//! `--task I` (hidden) is what the pool and the array run: it runs run I (or runs I x P to
//! I x P + P - 1 with `--pack P`) in this process, records each in its `sweep-task.toml`, and
//! continues a train run that has a checkpoint with `--resume`. A signal stops the run as it
//! stops `train` (a checkpoint, then exit 128 + the signal), and the run is recorded `pending`.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Parser};
use fluxswarm_gpu::checkpoint;
use fluxswarm_gpu::output::run_dir;
use fluxswarm_gpu::sweep::pool::{self, PoolEnd, PoolOptions};
use fluxswarm_gpu::sweep::record::{self, Status, TaskRecord};
use fluxswarm_gpu::sweep::slurm::{self, Shape};
use fluxswarm_gpu::sweep::{Sweep, SweepCommand};

use super::signals::{Signal, Stop, Stopped};

#[derive(Debug, Args)]
pub struct SweepArgs {
    /// The sweep spec (TOML, SPEC section 8). Not needed to resume or inspect a sweep
    /// directory, which keeps its spec in sweep.toml.
    #[arg(value_name = "SPEC.toml")]
    pub spec: Option<PathBuf>,
    /// The sweep directory (default runs/sweep-<YYYYmmdd-HHMMSS>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Runs at once on this machine (default: one per two cores); each gets cores / K threads.
    #[arg(long, value_name = "K")]
    pub jobs: Option<usize>,
    /// Write DIR/sweep.sbatch, a Slurm job array of one task per run, instead of running.
    #[arg(long)]
    pub slurm: bool,
    /// Submit the job array with sbatch (with --slurm).
    #[arg(long, requires = "slurm")]
    pub submit: bool,
    /// Refresh DIR/sweep.csv from the runs' records and print a summary.
    #[arg(long, conflicts_with_all = ["slurm", "dry_run"])]
    pub status: bool,
    /// Print each run's command line; write nothing.
    #[arg(long)]
    pub dry_run: bool,
    /// Slurm: cores per task (default 2, or the spec's [slurm] cpus_per_task).
    #[arg(long, requires = "slurm")]
    pub cpus_per_task: Option<u32>,
    /// Slurm: GPUs per task (--gres=gpu:N).
    #[arg(long, requires = "slurm")]
    pub gpus: Option<u32>,
    /// Slurm: time limit per task, e.g. 04:00:00.
    #[arg(long, requires = "slurm")]
    pub time: Option<String>,
    #[arg(long, requires = "slurm")]
    pub partition: Option<String>,
    #[arg(long, requires = "slurm")]
    pub account: Option<String>,
    /// Slurm: memory per task, e.g. 4G.
    #[arg(long, requires = "slurm")]
    pub mem: Option<String>,
    /// Slurm: the cluster's MaxArraySize (default 1001); larger sweeps pack runs into tasks.
    #[arg(long, requires = "slurm")]
    pub max_array_size: Option<usize>,
    /// Slurm: at most K tasks running at once (--array=...%K).
    #[arg(long, requires = "slurm", value_name = "K")]
    pub max_running: Option<usize>,
    /// Run task I of the sweep in DIR (what the local pool and the Slurm array call).
    #[arg(long, hide = true, value_name = "I", conflicts_with_all = ["slurm", "status", "dry_run"])]
    pub task: Option<usize>,
    /// Runs per task (with --task).
    #[arg(long, hide = true, default_value_t = 1, requires = "task")]
    pub pack: usize,
}

pub fn run(args: SweepArgs) -> anyhow::Result<()> {
    let out = match (&args.out, &args.spec) {
        (Some(o), _) => o.clone(),
        (None, Some(_)) if !args.status && args.task.is_none() => run_dir::default_dir("sweep"),
        (None, _) => bail!("give the sweep directory with --out DIR"),
    };
    if let Some(task) = args.task {
        return run_task(&out, task, args.pack);
    }
    let text = match &args.spec {
        Some(p) => Some(
            std::fs::read_to_string(p)
                .with_context(|| format!("reading the sweep spec {}", p.display()))?,
        ),
        None => None,
    };
    let origin = args.spec.as_ref().map(|p| p.display().to_string());
    let given = text.as_deref().zip(origin.as_deref());
    let write = !args.dry_run && !args.status;
    let sweep = Sweep::open(&out, given, write)?;
    if args.status {
        return status(&sweep);
    }
    check_command_lines(&sweep)?;
    if args.dry_run {
        use std::io::Write;
        let mut stdout = std::io::stdout().lock();
        for run in &sweep.plan.runs {
            let line = sweep.plan.fresh_args(run, &out).join(" ");
            // A closed pipe (`| head`) ends the listing quietly.
            if writeln!(stdout, "fluxswarm-gpu {line}").is_err() {
                break;
            }
        }
        return Ok(());
    }
    if args.slurm {
        return write_slurm(&sweep, &args);
    }
    let exe = std::env::current_exe().context("finding this program to run the tasks")?;
    let stop = Stop::install("passing the signal to the running tasks, which checkpoint and stop");
    let opts = PoolOptions::sized(args.jobs);
    let end = pool::run_local(&sweep, &exe, opts, &|| stop.signal().map(Signal::number))?;
    let records = record::refresh_table(&sweep.plan, &sweep.root)?;
    let [pending, running, done, failed] = record::counts(&records);
    log::info!(
        "{} runs: {done} done, {failed} failed, {pending} pending, {running} running elsewhere; table in {}",
        records.len(),
        sweep.root.join("sweep.csv").display()
    );
    if let (PoolEnd::Stopped(_), Some(signal)) = (&end, stop.signal()) {
        let what = format!(
            "{pending} runs pending; resume with `fluxswarm-gpu sweep --out {}`",
            out.display()
        );
        return Err(Stopped::new(signal, &what, &out).into());
    }
    if failed > 0 {
        print_failures(&sweep, &records);
        bail!(
            "{failed} of {} runs failed (errors above, logs in {}); re-running the sweep retries them",
            records.len(),
            out.join("logs").display()
        );
    }
    println!("{}", out.display());
    Ok(())
}

/// Parses every point's command line (the first seed's) before anything runs, so a typo in a
/// flag or a key fails now, naming the point, rather than in every task.
fn check_command_lines(sweep: &Sweep) -> anyhow::Result<()> {
    let mut seen = std::collections::BTreeSet::new();
    for run in sweep.plan.runs.iter().filter(|r| seen.insert(r.point)) {
        let args = sweep.plan.fresh_args(run, &sweep.root);
        let point = || {
            format!(
                "point {} ({})",
                run.point,
                sweep.plan.overrides(run.point).join(" ")
            )
        };
        let cli = super::Cli::try_parse_from(std::iter::once("fluxswarm-gpu".into()).chain(args))
            .map_err(|e| anyhow::anyhow!("{}: {}", point(), e.render().to_string().trim()))?;
        if let super::Command::Train(t) = &cli.command {
            super::train::fresh_config(t).with_context(point)?;
        }
    }
    Ok(())
}

fn status(sweep: &Sweep) -> anyhow::Result<()> {
    let records = record::refresh_table(&sweep.plan, &sweep.root)?;
    let [pending, running, done, failed] = record::counts(&records);
    println!(
        "{}: {} runs of `{}`: {done} done, {running} running, {pending} pending, {failed} failed",
        sweep.root.display(),
        records.len(),
        sweep.plan.spec.command.name()
    );
    print_failures(sweep, &records);
    for (run, rec) in sweep.plan.runs.iter().zip(&records) {
        if rec.effective_status() == Status::Running {
            let slurm = if rec.slurm_task.is_empty() {
                String::new()
            } else {
                format!(", Slurm task {}", rec.slurm_task)
            };
            println!("  running: {} on {}{slurm}", run.dir, rec.host);
        }
    }
    Ok(())
}

fn print_failures(sweep: &Sweep, records: &[TaskRecord]) {
    for (run, rec) in sweep.plan.runs.iter().zip(records) {
        if rec.effective_status() == Status::Failed {
            eprintln!("  failed: {}: {}", run.dir, rec.error);
        }
    }
}

fn write_slurm(sweep: &Sweep, args: &SweepArgs) -> anyhow::Result<()> {
    let mut opts = sweep.plan.spec.slurm.clone();
    let or = |flag: &Option<String>, spec: &mut Option<String>| {
        if flag.is_some() {
            *spec = flag.clone();
        }
    };
    or(&args.time, &mut opts.time);
    or(&args.partition, &mut opts.partition);
    or(&args.account, &mut opts.account);
    or(&args.mem, &mut opts.mem);
    opts.cpus_per_task = args.cpus_per_task.or(opts.cpus_per_task);
    opts.gpus = args.gpus.or(opts.gpus);
    opts.max_array_size = args.max_array_size.or(opts.max_array_size);
    opts.max_running = args.max_running.or(opts.max_running);
    let root = std::path::absolute(&sweep.root)?;
    let exe = std::env::current_exe().context("finding this program for the job script")?;
    let script = slurm::script(&root, &exe, sweep.plan.runs.len(), &opts)?;
    let path = root.join("sweep.sbatch");
    std::fs::write(&path, script).with_context(|| format!("writing {}", path.display()))?;
    record::refresh_table(&sweep.plan, &sweep.root)?;
    let shape = Shape::new(
        sweep.plan.runs.len(),
        opts.max_array_size.unwrap_or(slurm::DEFAULT_MAX_ARRAY_SIZE),
    );
    log::info!(
        "{}: {} array tasks of {} run(s) each",
        path.display(),
        shape.tasks,
        shape.pack
    );
    if !args.submit {
        println!("{}", path.display());
        eprintln!(
            "submit it with `sbatch {}`; follow it with `fluxswarm-gpu sweep --status --out {}`",
            path.display(),
            sweep.root.display()
        );
        return Ok(());
    }
    let out = std::process::Command::new("sbatch")
        .arg("--parsable")
        .arg(&path)
        .output()
        .context("running sbatch (is Slurm installed here?)")?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let job = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let jobs_file = root.join("slurm-jobs.txt");
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&jobs_file)?;
    use std::io::Write;
    writeln!(f, "{job}")?;
    eprintln!(
        "submitted job array {job}; follow it with `fluxswarm-gpu sweep --status --out {}`",
        sweep.root.display()
    );
    println!("{job}");
    Ok(())
}

/// Runs task `task` of the sweep in `root` (module header).
fn run_task(root: &Path, task: usize, pack: usize) -> anyhow::Result<()> {
    pool::watch_pool();
    let sweep = Sweep::open(root, None, false)?;
    let n = sweep.plan.runs.len();
    let shape = Shape {
        tasks: n.div_ceil(pack.max(1)),
        pack: pack.max(1),
    };
    if task >= shape.tasks {
        return Err(fluxswarm_gpu::sweep::SweepError::NoSuchTask {
            task,
            tasks: shape.tasks,
        }
        .into());
    }
    let mut failures = Vec::new();
    for index in shape.runs_of(task, n) {
        match run_one(&sweep, index) {
            Ok(None) => {}
            Ok(Some(error)) => failures.push(error),
            Err(e) => {
                let _ = record::refresh_table(&sweep.plan, &sweep.root);
                return Err(e);
            }
        }
    }
    record::refresh_table(&sweep.plan, &sweep.root)?;
    if !failures.is_empty() {
        bail!("{}", failures.join("\n"));
    }
    Ok(())
}

/// Runs one run of the sweep in this process; Ok(Some(error)) when it failed (recorded), Err
/// when a signal stopped it (recorded pending) or its record could not be written.
fn run_one(sweep: &Sweep, index: usize) -> anyhow::Result<Option<String>> {
    let run = &sweep.plan.runs[index];
    let dir = sweep.run_dir(run);
    let mut rec = TaskRecord::read(&dir)?;
    match rec.effective_status() {
        Status::Done => {
            eprintln!("== {}: done already", run.dir);
            return Ok(None);
        }
        Status::Running if rec.host == fluxswarm_gpu::sweep::host() => {
            eprintln!(
                "== {}: running already (pid {} on this host); skipped",
                run.dir, rec.pid
            );
            return Ok(None);
        }
        _ => {}
    }
    let newest = checkpoint::list(&dir.join("checkpoints"))
        .into_iter()
        .next();
    let (args, resumed) = match (&newest, sweep.plan.spec.command) {
        (Some(file), SweepCommand::Train) => {
            (sweep.plan.resume_args(run, &sweep.root), update_of(file))
        }
        _ => {
            // Nothing to continue from: start afresh in an empty directory.
            if dir.exists() {
                std::fs::remove_dir_all(&dir)
                    .with_context(|| format!("clearing {} to start it again", dir.display()))?;
            }
            (sweep.plan.fresh_args(run, &sweep.root), None)
        }
    };
    rec.status = Status::Running;
    rec.attempts += 1;
    rec.resumed_from_update = resumed;
    rec.host = fluxswarm_gpu::sweep::host();
    rec.pid = std::process::id();
    rec.threads = rayon::current_num_threads();
    rec.commit = fluxswarm_gpu::sweep::commit().into();
    rec.slurm_task = match (
        std::env::var("SLURM_ARRAY_JOB_ID"),
        std::env::var("SLURM_ARRAY_TASK_ID"),
    ) {
        (Ok(j), Ok(t)) => format!("{j}_{t}"),
        _ => String::new(),
    };
    rec.started = now();
    rec.finished.clear();
    rec.error.clear();
    rec.write(&dir)?;
    let _ = record::refresh_table(&sweep.plan, &sweep.root);
    eprintln!(
        "== {} (attempt {}): fluxswarm-gpu {}",
        run.dir,
        rec.attempts,
        args.join(" ")
    );
    let result =
        super::Cli::try_parse_from(std::iter::once("fluxswarm-gpu".to_string()).chain(args))
            .map_err(|e| anyhow::anyhow!("{}", e.render().to_string().trim()))
            .and_then(super::run);
    rec.backend = backend_of(&dir);
    rec.finished = now();
    let failed = match result {
        Ok(()) => {
            rec.status = Status::Done;
            None
        }
        Err(e) => {
            if let Some(stopped) = e.downcast_ref::<Stopped>() {
                rec.status = Status::Pending;
                rec.error = stopped.to_string();
                rec.write(&dir)?;
                return Err(e);
            }
            rec.status = Status::Failed;
            rec.error = super::error_chain(&e);
            Some(format!("{}: {}", run.dir, rec.error))
        }
    };
    rec.write(&dir)?;
    eprintln!("== {}: {}", run.dir, rec.status.name());
    Ok(failed)
}

fn update_of(file: &Path) -> Option<u64> {
    let name = file.file_name()?.to_str()?;
    name.strip_prefix("update-")?
        .strip_suffix(".safetensors")?
        .parse()
        .ok()
}

fn now() -> String {
    chrono::Local::now()
        .format("%Y-%m-%dT%H:%M:%S%z")
        .to_string()
}

/// What ran the control step, from the header of the run's config.toml: `native` (the CPU
/// backend) or `wgsl (<adapter>)`.
fn backend_of(dir: &Path) -> String {
    let Ok(text) = std::fs::read_to_string(dir.join("config.toml")) else {
        return String::new();
    };
    let head = text.lines().next().unwrap_or("");
    let Some((_, on)) = head.split_once("adapter ") else {
        return String::new();
    };
    let on = on.split(';').next().unwrap_or(on).trim();
    if on.starts_with("CPU backend") {
        "native".into()
    } else {
        format!("wgsl ({})", on.trim_start_matches("WGSL kernels on "))
    }
}

//! The local pool: up to `jobs` tasks at once, each a child process `<exe> sweep --task I --out
//! DIR` with `threads` threads (RAYON_NUM_THREADS), its output appended to `logs/<run>.log`.
//! Children get their own process group, so a terminal's Ctrl-C reaches only the pool, which
//! passes the signal on once to every running task (each then checkpoints and records itself
//! `pending`). A task also watches its parent ([`watch_pool`]): when the pool dies (kill -9)
//! it sends itself one SIGTERM, so no orphan keeps running. (Not PR_SET_PDEATHSIG: that fires
//! again each time a thread of the process that adopts the orphan exits, and a second signal
//! stops a run without its checkpoint.) A task that fails is recorded with its error and the
//! pool goes on.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use super::record::{self, Status, TaskRecord};
use super::{Sweep, SweepError};

/// Set in each task's environment to the pool's pid: the task watches for the pool's death
/// (module header).
pub const POOL_VAR: &str = "FLUXSWARM_SWEEP_POOL";

/// How many tasks run at once and the threads of each.
#[derive(Clone, Copy, Debug)]
pub struct PoolOptions {
    /// Tasks running at once.
    pub jobs: usize,
    /// Threads per task (its RAYON_NUM_THREADS).
    pub threads: usize,
}

impl PoolOptions {
    /// `jobs` tasks (default: one per two cores) sharing this machine's cores evenly.
    pub fn sized(jobs: Option<usize>) -> PoolOptions {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let jobs = jobs.unwrap_or(cores / 2).max(1);
        PoolOptions {
            jobs,
            threads: (cores / jobs).max(1),
        }
    }
}

/// How the pool ended.
#[derive(Debug, PartialEq, Eq)]
pub enum PoolEnd {
    /// Every task ran (some may have failed: see the records).
    Finished,
    /// A signal (its number) stopped the pool; the running tasks were passed it.
    Stopped(i32),
}

struct Active {
    index: usize,
    child: Child,
}

/// Runs every run of the sweep that is not done (nor running elsewhere). `stop` is polled and
/// returns the number of a signal received, if any.
pub fn run_local(
    sweep: &Sweep,
    exe: &Path,
    opts: PoolOptions,
    stop: &dyn Fn() -> Option<i32>,
) -> Result<PoolEnd, SweepError> {
    let records = record::refresh_table(&sweep.plan, &sweep.root)?;
    let mut queue: std::collections::VecDeque<usize> = sweep
        .plan
        .runs
        .iter()
        .zip(&records)
        .filter(|(_, r)| matches!(r.effective_status(), Status::Pending | Status::Failed))
        .map(|(run, _)| run.index)
        .collect();
    let total = queue.len();
    let skipped = sweep.plan.runs.len() - total;
    log::info!(
        "{total} runs to do ({skipped} done or running elsewhere), {} at a time with {} threads each",
        opts.jobs,
        opts.threads
    );
    let mut active: Vec<Active> = Vec::new();
    let mut finished = 0;
    let mut forwarded = None;
    loop {
        if forwarded.is_none()
            && let Some(sig) = stop()
        {
            log::warn!(
                "signal {sig}: passing it to {} running tasks, starting no more",
                active.len()
            );
            for a in &active {
                signal(&a.child, sig);
            }
            forwarded = Some(sig);
        }
        while forwarded.is_none() && active.len() < opts.jobs {
            let Some(index) = queue.pop_front() else {
                break;
            };
            active.push(Active {
                index,
                child: spawn(sweep, exe, index, opts.threads)?,
            });
            log::info!("started {}", sweep.plan.runs[index].dir);
        }
        if active.is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
        let mut changed = false;
        let mut i = 0;
        while i < active.len() {
            let status = active[i]
                .child
                .try_wait()
                .map_err(|e| SweepError::io(exe, e))?;
            let Some(exit) = status else {
                i += 1;
                continue;
            };
            let a = active.swap_remove(i);
            let run = &sweep.plan.runs[a.index];
            let dir = sweep.run_dir(run);
            let mut rec = TaskRecord::read(&dir)?;
            if rec.effective_status() == Status::Pending && !exit.success() && forwarded.is_none() {
                // The task died before it could record why (a crash, kill -9).
                rec.status = Status::Failed;
                rec.error = format!(
                    "the task exited with {exit} without recording a result; see {}",
                    sweep.log_path(run).display()
                );
                rec.write(&dir)?;
            }
            finished += 1;
            let what = match rec.effective_status() {
                Status::Failed => format!("failed: {}", rec.error),
                s => s.name().to_string(),
            };
            log::info!("[{finished}/{total}] {} {what}", run.dir);
            changed = true;
        }
        if changed {
            record::refresh_table(&sweep.plan, &sweep.root)?;
        }
    }
    record::refresh_table(&sweep.plan, &sweep.root)?;
    Ok(match forwarded {
        Some(sig) => PoolEnd::Stopped(sig),
        None => PoolEnd::Finished,
    })
}

fn spawn(sweep: &Sweep, exe: &Path, index: usize, threads: usize) -> Result<Child, SweepError> {
    let log_path = sweep.log_path(&sweep.plan.runs[index]);
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| SweepError::io(&log_path, e))?;
    let err = log.try_clone().map_err(|e| SweepError::io(&log_path, e))?;
    let mut cmd = Command::new(exe);
    cmd.args(["sweep", "--task", &index.to_string(), "--out"])
        .arg(&sweep.root)
        .env("RAYON_NUM_THREADS", threads.to_string())
        .stdin(Stdio::null())
        .stdout(log)
        .stderr(err);
    detach(&mut cmd);
    cmd.spawn().map_err(|e| SweepError::io(exe, e))
}

#[cfg(unix)]
fn detach(cmd: &mut Command) {
    use std::os::unix::process::CommandExt;
    cmd.process_group(0);
    cmd.env(POOL_VAR, std::process::id().to_string());
}

#[cfg(not(unix))]
fn detach(_: &mut Command) {}

#[cfg(unix)]
fn signal(child: &Child, sig: i32) {
    // SAFETY: kill only sends a signal to the child's pid.
    unsafe {
        libc::kill(child.id() as libc::pid_t, sig);
    }
}

#[cfg(not(unix))]
fn signal(_: &Child, _: i32) {}

/// In a task the pool started (its pid in [`POOL_VAR`]): a thread that sends this process one
/// SIGTERM once its parent is no longer the pool, as if the pool had passed on a signal.
pub fn watch_pool() {
    #[cfg(unix)]
    {
        let Some(pool) = std::env::var(POOL_VAR)
            .ok()
            .and_then(|v| v.parse::<libc::pid_t>().ok())
        else {
            return;
        };
        let spawned = std::thread::Builder::new()
            .name("pool-watch".into())
            .spawn(move || {
                // SAFETY: getppid and kill have no memory effects; kill signals this process.
                while unsafe { libc::getppid() } == pool {
                    std::thread::sleep(Duration::from_millis(200));
                }
                log::warn!("the sweep's pool (pid {pool}) is gone: stopping this run cleanly");
                unsafe {
                    libc::kill(libc::getpid(), libc::SIGTERM);
                }
            });
        if let Err(e) = spawned {
            log::warn!("cannot watch the sweep's pool: {e}");
        }
    }
}

//! Sweeps (`fluxswarm-gpu sweep`, SPEC section 8): many runs of one command over a grid of
//! overrides and seeds, on a local process pool or as a Slurm job array. We schedule nothing
//! ourselves beyond the pool: each run is one task that records what happened to it, so any
//! scheduler can run the tasks in any order, twice, or after a requeue.
//!
//! A sweep directory holds `sweep.toml` (the spec it runs; its hash refuses a changed spec),
//! `sweep.csv` (one row per run, refreshed from the runs' records), `runs/<run>/` (each run's
//! own output directory and its `sweep-task.toml` record), `logs/` (each task's output) and,
//! for Slurm, `sweep.sbatch`.
//!
//! `spec` parses the spec, `plan` expands it into runs and their command lines, `record`
//! keeps the records and the table, `pool` runs tasks locally, `slurm` writes the job array.

pub mod plan;
pub mod pool;
pub mod record;
pub mod slurm;
pub mod spec;

use std::path::{Path, PathBuf};

use thiserror::Error;

pub use plan::{Plan, Run};
pub use record::{Status, TaskRecord};
pub use spec::{Spec, SweepCommand};

/// Errors of reading, planning, running and recording a sweep.
#[derive(Debug, Error)]
pub enum SweepError {
    /// The spec does not parse or fails its checks.
    #[error("sweep spec {origin}: {message}")]
    Spec {
        /// Where the spec came from (a file name).
        origin: String,
        /// What is wrong with it.
        message: String,
    },
    /// The spec cannot be expanded into runs.
    #[error("sweep plan: {0}")]
    Plan(String),
    #[error(
        "{dir} was started from a different spec (hash {stored}; {given} now has {now}): \
         resume it with the spec it ran ({dir}/sweep.toml), or start the changed sweep in \
         another --out directory"
    )]
    /// The given spec's hash differs from the one the directory was started from.
    Changed {
        /// The sweep directory.
        dir: String,
        /// Where the given spec came from.
        given: String,
        /// Hash of the spec stored in the directory.
        stored: String,
        /// Hash of the given spec.
        now: String,
    },
    #[error(
        "{0} is not a sweep directory (no sweep.toml): give the spec, e.g. `fluxswarm-gpu sweep SPEC.toml --out {0}`"
    )]
    /// The directory holds no `sweep.toml` and no spec was given.
    NotASweep(String),
    /// A run's task record cannot be read or parsed.
    #[error("sweep record {path}: {message} (delete the file to run that point again)")]
    Record {
        /// The record file.
        path: String,
        /// What is wrong with it.
        message: String,
    },
    /// A file operation failed.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A task index past the number of tasks of the sweep.
    #[error("task {task} is outside this sweep's {tasks} tasks")]
    NoSuchTask {
        /// The task index asked for.
        task: usize,
        /// Number of tasks in the sweep.
        tasks: usize,
    },
    /// The Slurm job array cannot be written.
    #[error("{0}")]
    Slurm(String),
}

impl SweepError {
    /// An [`SweepError::Io`] for `path`.
    pub fn io(path: &Path, source: std::io::Error) -> SweepError {
        SweepError::Io {
            path: path.display().to_string(),
            source,
        }
    }
}

/// The spec file kept in a sweep directory.
pub const SPEC_FILE: &str = "sweep.toml";

/// An opened sweep directory.
#[derive(Debug)]
pub struct Sweep {
    /// The sweep directory.
    pub root: PathBuf,
    /// The runs its spec expands into.
    pub plan: Plan,
}

impl Sweep {
    /// Opens the sweep in `root`, creating it from `given` (the spec's text and where it came
    /// from) when the directory holds none. A given spec must have the same hash as the one
    /// the directory ran; its `[slurm]` options may differ and replace the stored ones. With
    /// `write` false (a dry run) nothing is written.
    pub fn open(
        root: &Path,
        given: Option<(&str, &str)>,
        write: bool,
    ) -> Result<Sweep, SweepError> {
        let stored_path = root.join(SPEC_FILE);
        let stored = match std::fs::read_to_string(&stored_path) {
            Ok(t) => Some(t),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(SweepError::io(&stored_path, e)),
        };
        let spec = match (stored, given) {
            (None, None) => return Err(SweepError::NotASweep(root.display().to_string())),
            (Some(text), None) => Spec::parse(&text, &stored_path.display().to_string())?,
            (stored, Some((text, origin))) => {
                let spec = Spec::parse(text, origin)?;
                if let Some(old) = stored {
                    let old = Spec::parse(&old, &stored_path.display().to_string())?;
                    if old.hash() != spec.hash() {
                        return Err(SweepError::Changed {
                            dir: root.display().to_string(),
                            given: origin.into(),
                            stored: old.hash(),
                            now: spec.hash(),
                        });
                    }
                }
                if write {
                    std::fs::create_dir_all(root.join("logs"))
                        .map_err(|e| SweepError::io(root, e))?;
                    let head = format!(
                        "# fluxswarm-gpu sweep spec (hash {}), from {origin}\n",
                        spec.hash()
                    );
                    write_atomically(&stored_path, (head + text).as_bytes())?;
                }
                spec
            }
        };
        Ok(Sweep {
            root: root.to_path_buf(),
            plan: Plan::new(spec)?,
        })
    }

    /// The directory of `run`.
    pub fn run_dir(&self, run: &Run) -> PathBuf {
        self.root.join(&run.dir)
    }

    /// The log file of `run`'s task when the local pool runs it.
    pub fn log_path(&self, run: &Run) -> PathBuf {
        let name = run.dir.trim_start_matches("runs/");
        self.root.join("logs").join(format!("{name}.log"))
    }
}

/// The commit this binary was built from (build.rs).
pub fn commit() -> &'static str {
    env!("FLUXSWARM_COMMIT")
}

/// This machine's host name.
pub fn host() -> String {
    #[cfg(unix)]
    {
        let mut buf = [0u8; 256];
        // SAFETY: the buffer is writable for its length; gethostname NUL-terminates on success
        // (a truncated name is cut at the buffer's end below).
        if unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0 {
            let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
            return String::from_utf8_lossy(&buf[..end]).into_owned();
        }
    }
    std::env::var("HOSTNAME")
        .or_else(|_| std::env::var("COMPUTERNAME"))
        .unwrap_or_else(|_| "unknown".into())
}

/// Writes `path` through a temporary file in the same directory and a rename, so a reader
/// never sees half a file.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), SweepError> {
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(|e| SweepError::io(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| SweepError::io(path, e))
}

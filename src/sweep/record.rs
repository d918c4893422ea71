//! What each run's task records, in `<run dir>/sweep-task.toml` (written atomically by the
//! process that runs it), and `sweep.csv`, the table made from those records (SPEC section 8):
//! `point,seed,status,dir,overrides`, one column per point key, then `commit,backend,threads,
//! host`. A record that says `running` for a process of this host that no longer exists (a
//! killed sweep, a power cut) reads as `pending`: the next call resumes it.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::SweepError;
use super::plan::Plan;

/// The status of a run (SPEC section 8).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Not started, or stopped before it finished (resumed next time).
    #[default]
    Pending,
    /// A task is running it.
    Running,
    /// Finished successfully.
    Done,
    /// Finished with an error.
    Failed,
}

impl Status {
    /// The status as written in `sweep.csv` and the record.
    pub fn name(self) -> &'static str {
        match self {
            Status::Pending => "pending",
            Status::Running => "running",
            Status::Done => "done",
            Status::Failed => "failed",
        }
    }
}

/// One run's record.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TaskRecord {
    /// The run's status.
    pub status: Status,
    /// Times a task started this run (a requeued or resumed run counts again).
    pub attempts: u32,
    /// The update the last attempt resumed from (train runs with a checkpoint).
    pub resumed_from_update: Option<u64>,
    /// Host name of the machine that ran the last attempt.
    pub host: String,
    /// Process id of the last attempt.
    pub pid: u32,
    /// Rayon threads of the last attempt.
    pub threads: usize,
    /// What ran the control step ("native", or the WGSL adapter's name).
    pub backend: String,
    /// The commit the binary was built from.
    pub commit: String,
    /// `SLURM_ARRAY_JOB_ID_SLURM_ARRAY_TASK_ID` when Slurm ran it.
    pub slurm_task: String,
    /// Local start time of the last attempt (`%Y-%m-%dT%H:%M:%S%z`).
    pub started: String,
    /// Local end time of the last attempt (same format); empty while running.
    pub finished: String,
    /// Why the run failed or stopped.
    pub error: String,
}

/// The record's file in a run directory.
pub const RECORD_FILE: &str = "sweep-task.toml";

impl TaskRecord {
    /// The record of the run in `dir` (a default, pending one when there is none).
    pub fn read(dir: &Path) -> Result<TaskRecord, SweepError> {
        let path = dir.join(RECORD_FILE);
        let text = match std::fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(TaskRecord::default()),
            Err(e) => return Err(SweepError::io(&path, e)),
        };
        toml::from_str(&text).map_err(|e| SweepError::Record {
            path: path.display().to_string(),
            message: e.to_string(),
        })
    }

    /// Writes the record atomically (a temporary file renamed over the old one).
    pub fn write(&self, dir: &Path) -> Result<(), SweepError> {
        std::fs::create_dir_all(dir).map_err(|e| SweepError::io(dir, e))?;
        let text = toml::to_string(self).expect("a record serialises");
        super::write_atomically(&dir.join(RECORD_FILE), text.as_bytes())
    }

    /// The status as it stands: `running` for a process of this host that is gone is
    /// `pending`.
    pub fn effective_status(&self) -> Status {
        if self.status == Status::Running && self.host == super::host() && !alive(self.pid) {
            Status::Pending
        } else {
            self.status
        }
    }
}

#[cfg(unix)]
fn alive(pid: u32) -> bool {
    // SAFETY: signal 0 only checks that the process exists and may be signalled.
    pid != 0 && unsafe { libc::kill(pid as libc::pid_t, 0) } == 0
}

#[cfg(not(unix))]
fn alive(_: u32) -> bool {
    true
}

/// `sweep.csv`'s header for `plan`.
pub fn header(plan: &Plan) -> Vec<String> {
    let mut h: Vec<String> = ["point", "seed", "status", "dir", "overrides"]
        .map(String::from)
        .to_vec();
    h.extend(plan.keys.iter().cloned());
    h.extend(["commit", "backend", "threads", "host"].map(String::from));
    h
}

/// Reads every run's record and rewrites `root/sweep.csv` (atomically); returns the records.
pub fn refresh_table(plan: &Plan, root: &Path) -> Result<Vec<TaskRecord>, SweepError> {
    let records = plan
        .runs
        .iter()
        .map(|r| TaskRecord::read(&root.join(&r.dir)))
        .collect::<Result<Vec<_>, _>>()?;
    let mut w = csv::Writer::from_writer(Vec::new());
    let csv_err = |e: csv::Error| SweepError::io(&root.join("sweep.csv"), e.into());
    w.write_record(header(plan)).map_err(csv_err)?;
    for (run, rec) in plan.runs.iter().zip(&records) {
        let mut row = vec![
            run.point.to_string(),
            run.seed.to_string(),
            rec.effective_status().name().to_string(),
            run.dir.clone(),
            plan.overrides(run.point).join(" "),
        ];
        row.extend(plan.point_values(run.point));
        row.extend([
            rec.commit.clone(),
            rec.backend.clone(),
            if rec.threads > 0 {
                rec.threads.to_string()
            } else {
                String::new()
            },
            rec.host.clone(),
        ]);
        w.write_record(&row).map_err(csv_err)?;
    }
    let bytes = w.into_inner().map_err(|e| csv_err(e.into_error().into()))?;
    super::write_atomically(&root.join("sweep.csv"), &bytes)?;
    Ok(records)
}

/// Counts of each status, in the order pending, running, done, failed.
pub fn counts(records: &[TaskRecord]) -> [usize; 4] {
    let mut c = [0; 4];
    for r in records {
        c[r.effective_status() as usize] += 1;
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_record_round_trips_and_a_dead_runner_reads_as_pending() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(TaskRecord::read(dir.path()).unwrap(), TaskRecord::default());
        let mut r = TaskRecord {
            status: Status::Running,
            attempts: 2,
            resumed_from_update: Some(7),
            host: super::super::host(),
            pid: std::process::id(),
            threads: 2,
            ..TaskRecord::default()
        };
        r.write(dir.path()).unwrap();
        let back = TaskRecord::read(dir.path()).unwrap();
        assert_eq!(back, r);
        assert_eq!(back.effective_status(), Status::Running);
        r.pid = u32::MAX / 2; // no such process
        assert_eq!(r.effective_status(), Status::Pending);
        r.host = "another-node".into();
        assert_eq!(r.effective_status(), Status::Running);
    }

    #[test]
    fn the_table_quotes_overrides_that_hold_commas() {
        let spec = super::super::spec::Spec::parse(
            "command = \"rollout\"\n[grid]\n\"swarm.positions_m\" = [[[0.05, 0.00025]]]\n",
            "s",
        )
        .unwrap();
        let plan = Plan::new(spec).unwrap();
        let dir = tempfile::tempdir().unwrap();
        refresh_table(&plan, dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join("sweep.csv")).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "point,seed,status,dir,overrides,swarm.positions_m,commit,backend,threads,host"
        );
        let row = lines.next().unwrap();
        assert!(
            row.starts_with("0,0,pending,runs/p000_positions_m=--0.05--0.00025--_seed0,\"swarm.positions_m=[[0.05, 0.00025]]\",\"[[0.05, 0.00025]]\",,,,"),
            "{row}"
        );
    }
}

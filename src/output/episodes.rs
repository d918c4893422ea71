//! `episodes.csv` (SPEC section 7), written by `rollout` and `train` (which adds `global_step`
//! first).

use std::io::{BufWriter, Write};
use std::path::Path;

use crate::learn::transition::EpisodeSummary;

const COLUMNS: &str = "env,episode,steps,outcome,progress,energy,smoothness,progress_mean,energy_sum,smoothness_sum,scalar_return,final_x_com_mm";

/// Writer of `episodes.csv`, one row per finished episode.
pub struct EpisodesCsv {
    out: BufWriter<std::fs::File>,
    global_step: bool,
}

impl EpisodesCsv {
    /// Creates `dir/episodes.csv` with its header; `global_step` adds that column first.
    pub fn create(dir: &Path, global_step: bool) -> std::io::Result<Self> {
        let mut out = BufWriter::new(std::fs::File::create(dir.join("episodes.csv"))?);
        if global_step {
            writeln!(out, "global_step,{COLUMNS}")?;
        } else {
            writeln!(out, "{COLUMNS}")?;
        }
        // The header is on disk before any episode: a checkpoint taken before the first
        // episode records its length, and a resume cuts the file back to that length.
        out.flush()?;
        Ok(Self { out, global_step })
    }

    /// Continues `dir/episodes.csv` from its first `len` bytes (a resumed run).
    pub fn resume(dir: &Path, global_step: bool, len: u64) -> std::io::Result<Self> {
        let f = super::run_dir::append_after(&dir.join("episodes.csv"), len)?;
        Ok(Self {
            out: BufWriter::new(f),
            global_step,
        })
    }

    /// Bytes on disk so far (the header and every row are flushed as they are written).
    pub fn bytes_written(&self) -> std::io::Result<u64> {
        Ok(self.out.get_ref().metadata()?.len())
    }

    /// Appends one finished episode (and flushes, so a run's file is readable while it goes).
    pub fn write(&mut self, global_step: u64, s: &EpisodeSummary) -> std::io::Result<()> {
        if self.global_step {
            write!(self.out, "{global_step},")?;
        }
        writeln!(
            self.out,
            "{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4}",
            s.env,
            s.episode,
            s.steps,
            s.outcome,
            s.progress,
            s.energy,
            s.smoothness,
            s.progress_mean,
            s.energy_sum,
            s.smoothness_sum,
            s.scalar_return,
            s.final_x_com_mm
        )?;
        self.out.flush()
    }
}

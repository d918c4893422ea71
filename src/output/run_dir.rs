//! Output directories: `--out DIR` or `runs/<command>-<YYYYmmdd-HHMMSS>/`, checked writable
//! before any simulation starts.

use std::path::{Path, PathBuf};

use thiserror::Error;

/// An output directory that cannot be created or written.
#[derive(Debug, Error)]
#[error(
    "output directory {path} is not writable ({reason}): choose another with --out DIR or fix \
     its permissions"
)]
pub struct OutputDirError {
    /// The directory or file that failed.
    pub path: String,
    /// The I/O error's message.
    pub reason: String,
}

/// The default directory of a command: `runs/<command>-<YYYYmmdd-HHMMSS>`.
pub fn default_dir(command: &str) -> PathBuf {
    let stamp = chrono::Local::now().format("%Y%m%d-%H%M%S");
    PathBuf::from("runs").join(format!("{command}-{stamp}"))
}

/// Creates `dir` (and `subdirs` inside it) and proves it writable with a probe file.
pub fn prepare(dir: &Path, subdirs: &[&str]) -> Result<PathBuf, OutputDirError> {
    let fail = |path: &Path, e: std::io::Error| OutputDirError {
        path: path.display().to_string(),
        reason: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, e))?;
    for sub in subdirs {
        let p = dir.join(sub);
        std::fs::create_dir_all(&p).map_err(|e| fail(&p, e))?;
    }
    let probe = dir.join(".write-probe");
    std::fs::write(&probe, b"ok").map_err(|e| fail(dir, e))?;
    let _ = std::fs::remove_file(&probe);
    Ok(dir.to_path_buf())
}

/// Opens `path` for appending after cutting it to `len` bytes: a resumed run drops what was
/// written after its checkpoint, so nothing is logged twice.
pub fn append_after(path: &Path, len: u64) -> std::io::Result<std::fs::File> {
    let f = std::fs::OpenOptions::new().write(true).open(path)?;
    f.set_len(len)?;
    drop(f);
    std::fs::OpenOptions::new().append(true).open(path)
}

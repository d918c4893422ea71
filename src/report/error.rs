//! The errors of `report`, `report --sweep` and `map`: each names the file or the flag at fault
//! and what to give instead.

use std::path::{Path, PathBuf};

/// An error of the report module.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The inputs given do not make a report (wrong or missing directories or flags).
    #[error("{0}")]
    Usage(String),
    /// A file could not be read.
    #[error("reading {path}: {cause}{hint}")]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
        /// What to check (may be empty).
        hint: String,
    },
    /// A file was read but does not hold what a fluxswarm-gpu run writes.
    #[error("{0}")]
    Invalid(String),
    /// An output could not be written.
    #[error("writing {path}: {cause}{hint}")]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
        /// What to check (may be empty).
        hint: String,
    },
    /// A figure could not be drawn.
    #[error("drawing {path}: {why}")]
    Draw {
        /// The figure's file.
        path: PathBuf,
        /// What the plotting library said.
        why: String,
    },
    /// One of the above, with where it happened.
    #[error("{what}: {inner}")]
    Within {
        /// What was being read or written.
        what: String,
        /// The error itself.
        inner: Box<ReportError>,
    },
}

impl ReportError {
    /// A read error of `path`, with no hint.
    pub fn read(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
        move |cause| ReportError::Read {
            path: path.to_path_buf(),
            cause,
            hint: String::new(),
        }
    }

    /// A write error of `path`.
    pub fn write(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
        move |cause| ReportError::Write {
            path: path.to_path_buf(),
            cause,
            hint: String::new(),
        }
    }
}

/// Adds where an error happened.
pub trait Within<T> {
    /// Wraps the error with `what()` (evaluated only on error).
    fn within(self, what: impl FnOnce() -> String) -> Result<T, ReportError>;
}

impl<T> Within<T> for Result<T, ReportError> {
    fn within(self, what: impl FnOnce() -> String) -> Result<T, ReportError> {
        self.map_err(|inner| ReportError::Within {
            what: what(),
            inner: Box::new(inner),
        })
    }
}

/// Shorthand for the module's results.
pub type Result<T, E = ReportError> = std::result::Result<T, E>;

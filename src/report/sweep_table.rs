//! `sweep.csv` as the reports read it (SPEC section 8): one row per run, point-major, with the
//! columns `point,seed,status,dir,overrides,<grid keys...>,commit,...`. `report --sweep` and
//! `report --frontier` both read it here.

use std::path::{Path, PathBuf};

use super::error::{ReportError, Result};

/// One run's row.
#[derive(Debug, Clone)]
pub struct SweepRow {
    /// The point (variant) index.
    pub point: usize,
    /// The run's seed, as written.
    pub seed: String,
    /// `pending`, `running`, `done`, `failed` or `stopped`.
    pub status: String,
    /// The run's directory, relative to the sweep directory.
    pub dir: String,
    /// The run's overrides, as one string.
    pub overrides: String,
    /// The point's value of each grid key, in `SweepTable::keys` order.
    pub values: Vec<String>,
}

impl SweepRow {
    /// The last component of the run's directory (its name under `runs/`, `eval/`, ...).
    pub fn name(&self) -> String {
        Path::new(&self.dir)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }
}

/// A sweep directory's `sweep.csv`.
#[derive(Debug, Clone)]
pub struct SweepTable {
    /// `root/sweep.csv`.
    pub path: PathBuf,
    /// The grid keys: the columns between `overrides` and `commit`.
    pub keys: Vec<String>,
    /// Every run, in file order.
    pub rows: Vec<SweepRow>,
}

/// Reads `root/sweep.csv`. `hint` ends the error when the file cannot be opened: what the
/// caller expected `root` to be and how to get the file.
pub fn read(root: &Path, hint: &str) -> Result<SweepTable> {
    let path = root.join("sweep.csv");
    let bad = |e: csv::Error| ReportError::Invalid(format!("reading {}: {e}", path.display()));
    let mut reader = csv::Reader::from_path(&path)
        .map_err(|e| ReportError::Usage(format!("reading {}: {e} ({hint})", path.display())))?;
    let header: Vec<String> = reader
        .headers()
        .map_err(bad)?
        .iter()
        .map(String::from)
        .collect();
    let col = |name: &str| {
        header.iter().position(|h| h == name).ok_or_else(|| {
            ReportError::Invalid(format!("{} has no column `{name}`", path.display()))
        })
    };
    let (point_c, seed_c, status_c, dir_c, over_c, commit_c) = (
        col("point")?,
        col("seed")?,
        col("status")?,
        col("dir")?,
        col("overrides")?,
        col("commit")?,
    );
    if commit_c <= over_c {
        return Err(ReportError::Invalid(format!(
            "{}: `commit` comes before `overrides`",
            path.display()
        )));
    }
    let mut rows = Vec::new();
    for row in reader.records() {
        let row = row.map_err(bad)?;
        let point = row[point_c].parse().map_err(|_| {
            ReportError::Invalid(format!(
                "{}: point {:?} is not a number",
                path.display(),
                &row[point_c]
            ))
        })?;
        rows.push(SweepRow {
            point,
            seed: row[seed_c].to_string(),
            status: row[status_c].to_string(),
            dir: row[dir_c].to_string(),
            overrides: row[over_c].to_string(),
            values: (over_c + 1..commit_c).map(|i| row[i].to_string()).collect(),
        });
    }
    Ok(SweepTable {
        keys: header[over_c + 1..commit_c].to_vec(),
        path,
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_rows_keys_and_names() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("sweep.csv"),
            "point,seed,status,dir,overrides,--steps,train.gamma,commit,backend\n\
             0,1,done,runs/p000_a_seed1,--steps=8,8,,abc,native\n\
             1,1,pending,runs/p001_b_seed1,--steps=8 train.gamma=0.99,8,0.99,,\n",
        )
        .unwrap();
        let t = read(dir.path(), "hint").unwrap();
        assert_eq!(t.keys, ["--steps", "train.gamma"]);
        assert_eq!(t.rows.len(), 2);
        assert_eq!(t.rows[1].point, 1);
        assert_eq!(t.rows[1].seed, "1");
        assert_eq!(t.rows[1].status, "pending");
        assert_eq!(t.rows[1].values, ["8", "0.99"]);
        assert_eq!(t.rows[0].name(), "p000_a_seed1");
        assert_eq!(t.rows[1].overrides, "--steps=8 train.gamma=0.99");
    }

    #[test]
    fn missing_file_and_bad_point_are_clear() {
        let dir = tempfile::tempdir().unwrap();
        let e = read(dir.path(), "is it a sweep directory?").unwrap_err();
        assert!(e.to_string().contains("is it a sweep directory?"), "{e}");
        std::fs::write(
            dir.path().join("sweep.csv"),
            "point,seed,status,dir,overrides,commit\nx,1,done,runs/a,,\n",
        )
        .unwrap();
        let e = read(dir.path(), "").unwrap_err();
        assert!(e.to_string().contains("point \"x\" is not a number"), "{e}");
        std::fs::write(dir.path().join("sweep.csv"), "point,seed,dir\n").unwrap();
        let e = read(dir.path(), "").unwrap_err();
        assert!(e.to_string().contains("no column `status`"), "{e}");
    }
}

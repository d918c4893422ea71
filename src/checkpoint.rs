//! Checkpoint archives: named arrays (f32, f64, u64) and string metadata in one safetensors
//! file, with a CRC-32 of all array bytes in the metadata so a damaged file is refused rather
//! than half-loaded. Written atomically: to `NAME.tmp` in the same directory, synced, then
//! renamed over `NAME`, so a crash leaves either the old or the new file, never a torn one.
//! What goes in is up to the owners of the state (`Learner`, `SwarmEnv`, `FlowBatch`, `train`).

use std::collections::{BTreeMap, HashMap};
use std::io::Write;
use std::path::{Path, PathBuf};

use safetensors::tensor::{Dtype, SafeTensors, TensorView};

/// Bumped whenever the set or meaning of the saved arrays changes.
pub const FORMAT: u32 = 1;

/// The trained policy alone (actor, normaliser, configuration) in a run directory, rewritten
/// with every checkpoint; `eval --checkpoint` and `rollout --policy` take it like a checkpoint.
pub const POLICY_FILE: &str = "policy.safetensors";

/// Why a checkpoint could not be written, read or used.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// The file could not be read.
    #[error("cannot read checkpoint {path}: {source}")]
    Read {
        /// Path of the checkpoint file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file (or its temporary file) could not be written, synced or renamed.
    #[error("cannot write checkpoint {path}: {source} (is the output directory writable?)")]
    Write {
        /// Path of the checkpoint file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is not a valid archive: bad safetensors, missing format tag, checksum,
    /// metadata or array, or an array of the wrong type.
    #[error(
        "checkpoint {path} is corrupt ({why}); resume from an earlier file in the same checkpoints/ directory or start a new run"
    )]
    Corrupt {
        /// Path of the checkpoint file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// The file is intact but does not fit this run (format version, array sizes, settings).
    #[error(
        "checkpoint {path} does not fit this run: {why}; use the configuration it was written with (train --resume uses it automatically)"
    )]
    Mismatch {
        /// Path of the checkpoint file.
        path: PathBuf,
        /// What does not fit.
        why: String,
    },
}

#[derive(Debug, Clone)]
struct Entry {
    dtype: Dtype,
    shape: Vec<usize>,
    bytes: Vec<u8>,
}

/// Named arrays and metadata, as saved in or loaded from one checkpoint file.
#[derive(Debug, Clone, Default)]
pub struct Archive {
    entries: BTreeMap<String, Entry>,
    meta: BTreeMap<String, String>,
    /// The file it came from, for error messages.
    path: PathBuf,
}

const CRC_KEY: &str = "crc32";
const FORMAT_KEY: &str = "format";

impl Archive {
    /// An empty archive.
    pub fn new() -> Self {
        Self::default()
    }

    /// The file the archive was loaded from (empty for a new one).
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Stores f32 array `name` of `shape`, replacing one of that name.
    /// Panics if `shape` does not fit `data`.
    pub fn put_f32(&mut self, name: &str, shape: &[usize], data: &[f32]) {
        self.put(name, Dtype::F32, shape, bytemuck::cast_slice(data));
    }

    /// Stores f64 array `name` of `shape`, replacing one of that name.
    /// Panics if `shape` does not fit `data`.
    pub fn put_f64(&mut self, name: &str, shape: &[usize], data: &[f64]) {
        self.put(name, Dtype::F64, shape, bytemuck::cast_slice(data));
    }

    /// Stores u64 array `name`, one-dimensional.
    pub fn put_u64(&mut self, name: &str, data: &[u64]) {
        self.put(name, Dtype::U64, &[data.len()], bytemuck::cast_slice(data));
    }

    fn put(&mut self, name: &str, dtype: Dtype, shape: &[usize], bytes: &[u8]) {
        assert_eq!(
            shape.iter().product::<usize>() * dtype.bitsize() / 8,
            bytes.len(),
            "{name}: shape {shape:?} does not match the data"
        );
        self.entries.insert(
            name.to_string(),
            Entry {
                dtype,
                shape: shape.to_vec(),
                bytes: bytes.to_vec(),
            },
        );
    }

    /// Sets metadata `key` to `value` as text.
    pub fn set_meta(&mut self, key: &str, value: impl ToString) {
        self.meta.insert(key.to_string(), value.to_string());
    }

    /// A metadata value; an error naming the key when it is absent.
    pub fn meta(&self, key: &str) -> Result<&str, CheckpointError> {
        self.meta
            .get(key)
            .map(String::as_str)
            .ok_or_else(|| self.corrupt(format!("metadata `{key}` is missing")))
    }

    /// A metadata value parsed as a number (or anything `FromStr`).
    pub fn meta_parse<T: std::str::FromStr>(&self, key: &str) -> Result<T, CheckpointError> {
        let raw = self.meta(key)?;
        raw.parse()
            .map_err(|_| self.corrupt(format!("metadata `{key}` = {raw:?} is not valid")))
    }

    fn entry(
        &self,
        name: &str,
        dtype: Dtype,
        len: Option<usize>,
    ) -> Result<&Entry, CheckpointError> {
        let e = self
            .entries
            .get(name)
            .ok_or_else(|| self.corrupt(format!("array `{name}` is missing")))?;
        if e.dtype != dtype {
            return Err(self.corrupt(format!("array `{name}` is {:?}, not {dtype:?}", e.dtype)));
        }
        let have = e.shape.iter().product::<usize>();
        if let Some(want) = len
            && have != want
        {
            return Err(self.mismatch(format!(
                "array `{name}` holds {have} values where this run needs {want}"
            )));
        }
        Ok(e)
    }

    /// The shape of an array, if present.
    pub fn shape(&self, name: &str) -> Option<&[usize]> {
        self.entries.get(name).map(|e| e.shape.as_slice())
    }

    /// Array `name` as f32, checked to hold `len` values (None: any length).
    pub fn f32(&self, name: &str, len: Option<usize>) -> Result<Vec<f32>, CheckpointError> {
        let e = self.entry(name, Dtype::F32, len)?;
        Ok(bytemuck::pod_collect_to_vec(&e.bytes))
    }

    /// Array `name` as f64, checked to hold `len` values (None: any length).
    pub fn f64(&self, name: &str, len: Option<usize>) -> Result<Vec<f64>, CheckpointError> {
        let e = self.entry(name, Dtype::F64, len)?;
        Ok(bytemuck::pod_collect_to_vec(&e.bytes))
    }

    /// Array `name` as u64, checked to hold `len` values (None: any length).
    pub fn u64(&self, name: &str, len: Option<usize>) -> Result<Vec<u64>, CheckpointError> {
        let e = self.entry(name, Dtype::U64, len)?;
        Ok(bytemuck::pod_collect_to_vec(&e.bytes))
    }

    /// A "this checkpoint does not fit" error naming the file.
    pub fn mismatch(&self, why: impl Into<String>) -> CheckpointError {
        CheckpointError::Mismatch {
            path: self.path.clone(),
            why: why.into(),
        }
    }

    fn corrupt(&self, why: impl Into<String>) -> CheckpointError {
        CheckpointError::Corrupt {
            path: self.path.clone(),
            why: why.into(),
        }
    }

    fn crc(&self) -> u32 {
        let mut h = crc32fast::Hasher::new();
        for (name, e) in &self.entries {
            h.update(name.as_bytes());
            h.update(&e.bytes);
        }
        h.finalize()
    }

    /// Serialises to safetensors bytes (with the format and CRC in the metadata).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut meta: HashMap<String, String> = self.meta.clone().into_iter().collect();
        meta.insert(FORMAT_KEY.into(), FORMAT.to_string());
        meta.insert(CRC_KEY.into(), format!("{:08x}", self.crc()));
        let views: Vec<(String, TensorView<'_>)> = self
            .entries
            .iter()
            .map(|(k, e)| {
                let v = TensorView::new(e.dtype, e.shape.clone(), &e.bytes)
                    .expect("shape checked in put");
                (k.clone(), v)
            })
            .collect();
        safetensors::serialize(views, Some(meta)).expect("valid tensors serialise")
    }

    /// Writes the archive to `path` atomically (temp file, fsync, rename).
    pub fn save(&self, path: &Path) -> Result<(), CheckpointError> {
        let werr = |source| CheckpointError::Write {
            path: path.to_path_buf(),
            source,
        };
        let tmp = path.with_extension("safetensors.tmp");
        {
            let mut f = std::fs::File::create(&tmp).map_err(werr)?;
            f.write_all(&self.to_bytes()).map_err(werr)?;
            f.sync_all().map_err(werr)?;
        }
        std::fs::rename(&tmp, path).map_err(werr)?;
        if let Some(dir) = path.parent()
            && let Ok(d) = std::fs::File::open(dir)
        {
            let _ = d.sync_all();
        }
        Ok(())
    }

    /// Reads and verifies a checkpoint file.
    pub fn load(path: &Path) -> Result<Self, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|source| CheckpointError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Parses and verifies safetensors bytes (format tag and CRC); `path` names them in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, CheckpointError> {
        let corrupt = |why: String| CheckpointError::Corrupt {
            path: path.to_path_buf(),
            why,
        };
        let (_, header) = SafeTensors::read_metadata(bytes)
            .map_err(|e| corrupt(format!("not a safetensors file: {e}")))?;
        let st = SafeTensors::deserialize(bytes)
            .map_err(|e| corrupt(format!("not a safetensors file: {e}")))?;
        let mut archive = Archive {
            path: path.to_path_buf(),
            ..Default::default()
        };
        archive.meta = header
            .metadata()
            .clone()
            .unwrap_or_default()
            .into_iter()
            .collect();
        let format = archive.meta.remove(FORMAT_KEY);
        let crc = archive.meta.remove(CRC_KEY);
        match format.as_deref().map(str::parse::<u32>) {
            Some(Ok(FORMAT)) => {}
            Some(Ok(other)) => {
                return Err(archive.mismatch(format!(
                    "it has format {other}, this program reads format {FORMAT}"
                )));
            }
            _ => return Err(corrupt("no fluxswarm-gpu format tag".into())),
        }
        for (name, view) in st.tensors() {
            archive.entries.insert(
                name,
                Entry {
                    dtype: view.dtype(),
                    shape: view.shape().to_vec(),
                    bytes: view.data().to_vec(),
                },
            );
        }
        let want = crc.ok_or_else(|| corrupt("no checksum".into()))?;
        let have = format!("{:08x}", archive.crc());
        if want != have {
            return Err(corrupt(format!(
                "checksum {have} differs from the stored {want}"
            )));
        }
        Ok(archive)
    }
}

/// The file name of the checkpoint written after `update` updates.
pub fn file_name(update: u64) -> String {
    format!("update-{update:07}.safetensors")
}

/// Checkpoint files (`update-*.safetensors`) in `dir`, newest (highest update) first.
pub fn list(dir: &Path) -> Vec<PathBuf> {
    let mut found: Vec<(u64, PathBuf)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().into_string().ok()?;
            let n = name
                .strip_prefix("update-")?
                .strip_suffix(".safetensors")?
                .parse()
                .ok()?;
            Some((n, e.path()))
        })
        .collect();
    found.sort_by_key(|f| std::cmp::Reverse(f.0));
    found.into_iter().map(|f| f.1).collect()
}

/// `path` if it is a file; for a directory, the newest checkpoint in `path/checkpoints/` (a
/// run directory) or in `path` itself, else its `policy.safetensors` (a run whose checkpoints
/// are gone, e.g. one restored from committed results).
pub fn locate(path: &Path) -> Result<PathBuf, CheckpointError> {
    if path.is_file() {
        return Ok(path.to_path_buf());
    }
    let not_found = |why: &str| CheckpointError::Read {
        path: path.to_path_buf(),
        source: std::io::Error::new(std::io::ErrorKind::NotFound, why.to_string()),
    };
    if !path.is_dir() {
        return Err(not_found("no such file or directory"));
    }
    list(&path.join("checkpoints"))
        .into_iter()
        .chain(list(path))
        .chain(Some(path.join(POLICY_FILE)).filter(|p| p.is_file()))
        .next()
        .ok_or_else(|| {
            not_found("no update-*.safetensors checkpoint in it or its checkpoints/, and no policy.safetensors")
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Archive {
        let mut a = Archive::new();
        a.put_f32("w", &[2, 2], &[1.0, -2.0, 3.5, f32::MIN_POSITIVE]);
        a.put_f64("t", &[1], &[0.1]);
        a.put_u64("rng", &[u64::MAX, 7]);
        a.set_meta("update", 12);
        a
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.safetensors");
        sample().save(&path).unwrap();
        assert!(!path.with_extension("safetensors.tmp").exists());
        let b = Archive::load(&path).unwrap();
        assert_eq!(
            b.f32("w", Some(4)).unwrap(),
            [1.0, -2.0, 3.5, f32::MIN_POSITIVE]
        );
        assert_eq!(b.f64("t", None).unwrap(), [0.1]);
        assert_eq!(b.u64("rng", Some(2)).unwrap(), [u64::MAX, 7]);
        assert_eq!(b.meta_parse::<u64>("update").unwrap(), 12);
    }

    #[test]
    fn damaged_files_are_refused_with_the_path_and_a_way_out() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.safetensors");
        let bytes = sample().to_bytes();
        // A flipped bit in the data: the checksum catches it.
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 1;
        std::fs::write(&path, &flipped).unwrap();
        let e = Archive::load(&path).unwrap_err().to_string();
        assert!(e.contains("corrupt") && e.contains("checksum"), "{e}");
        assert!(
            e.contains("c.safetensors") && e.contains("earlier file"),
            "{e}"
        );
        // A truncated file.
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let e = Archive::load(&path).unwrap_err().to_string();
        assert!(e.contains("corrupt"), "{e}");
        // Not a checkpoint at all.
        std::fs::write(&path, b"hello").unwrap();
        assert!(
            Archive::load(&path)
                .unwrap_err()
                .to_string()
                .contains("corrupt")
        );
        // Missing file.
        let e = Archive::load(&dir.path().join("none"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("cannot read"), "{e}");
    }

    #[test]
    fn the_newest_checkpoint_is_found_in_a_run_directory() {
        let dir = tempfile::tempdir().unwrap();
        let ck = dir.path().join("checkpoints");
        std::fs::create_dir(&ck).unwrap();
        for u in [5, 40, 300] {
            sample().save(&ck.join(file_name(u))).unwrap();
        }
        std::fs::write(ck.join("notes.txt"), "x").unwrap();
        let names: Vec<_> = list(&ck)
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            [
                "update-0000300.safetensors",
                "update-0000040.safetensors",
                "update-0000005.safetensors"
            ]
        );
        assert_eq!(locate(dir.path()).unwrap(), ck.join(file_name(300)));
        assert_eq!(
            locate(&ck.join(file_name(5))).unwrap(),
            ck.join(file_name(5))
        );
        let e = locate(&dir.path().join("nothing")).unwrap_err().to_string();
        assert!(e.contains("no such file"), "{e}");
    }

    #[test]
    fn a_run_directory_without_checkpoints_falls_back_to_its_policy_file() {
        let dir = tempfile::tempdir().unwrap();
        let e = locate(dir.path()).unwrap_err().to_string();
        assert!(e.contains("no policy.safetensors"), "{e}");
        sample().save(&dir.path().join(POLICY_FILE)).unwrap();
        assert_eq!(locate(dir.path()).unwrap(), dir.path().join(POLICY_FILE));
        // A checkpoint, when there is one, is newer than or the same as the policy file.
        let ck = dir.path().join("checkpoints");
        std::fs::create_dir_all(&ck).unwrap();
        sample().save(&ck.join(file_name(7))).unwrap();
        assert_eq!(locate(dir.path()).unwrap(), ck.join(file_name(7)));
    }

    #[test]
    fn wrong_sizes_are_a_mismatch_naming_the_array() {
        let a = sample();
        let e = a.f32("w", Some(5)).unwrap_err().to_string();
        assert!(e.contains("does not fit") && e.contains("`w`"), "{e}");
        let e = a.f32("missing", None).unwrap_err().to_string();
        assert!(e.contains("`missing` is missing"), "{e}");
    }
}

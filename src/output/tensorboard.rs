//! TensorBoard event files, written offline with no TensorFlow: `events.out.tfevents.<time>.
//! fluxswarm` holds TFRecords (u64 length, masked CRC-32C of the length, the bytes, masked
//! CRC-32C of the bytes), each an `Event` protobuf {wall_time: 1 double, step: 2 int64,
//! file_version: 3 string | summary: 5 {value: 1 {tag: 1 string, simple_value: 2 float}}},
//! encoded by hand (a dozen bytes of wire format). `tensorboard --logdir RUN_DIR` reads it.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78; the `crc` crate's CRC_32_ISCSI).
pub fn crc32c(data: &[u8]) -> u32 {
    const CASTAGNOLI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
    CASTAGNOLI.checksum(data)
}

/// TFRecord's masked CRC.
pub fn masked_crc(data: &[u8]) -> u32 {
    let c = crc32c(data);
    (c.rotate_right(15)).wrapping_add(0xA282_EAD8)
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push((v as u8) | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

fn bytes_field(out: &mut Vec<u8>, field: u32, data: &[u8]) {
    varint(out, ((field << 3) | 2) as u64);
    varint(out, data.len() as u64);
    out.extend_from_slice(data);
}

/// The protobuf bytes of one Event with scalar values, or the file-version header event.
pub fn encode_event(wall_time: f64, step: i64, scalars: &[(&str, f32)], version: bool) -> Vec<u8> {
    let mut ev = Vec::new();
    ev.push(0x09); // field 1, fixed64
    ev.extend_from_slice(&wall_time.to_le_bytes());
    ev.push(0x10); // field 2, varint
    varint(&mut ev, step as u64);
    if version {
        bytes_field(&mut ev, 3, b"brain.Event:2");
    } else {
        let mut summary = Vec::new();
        for (tag, value) in scalars {
            let mut v = Vec::new();
            bytes_field(&mut v, 1, tag.as_bytes());
            v.push(0x15); // field 2, fixed32
            v.extend_from_slice(&value.to_le_bytes());
            bytes_field(&mut summary, 1, &v);
        }
        bytes_field(&mut ev, 5, &summary);
    }
    ev
}

/// One TFRecord around `data`.
pub fn record(data: &[u8]) -> Vec<u8> {
    let len = (data.len() as u64).to_le_bytes();
    let mut out = Vec::with_capacity(data.len() + 16);
    out.extend_from_slice(&len);
    out.extend_from_slice(&masked_crc(&len).to_le_bytes());
    out.extend_from_slice(data);
    out.extend_from_slice(&masked_crc(data).to_le_bytes());
    out
}

/// An open event file.
pub struct EventWriter {
    path: PathBuf,
    file: BufWriter<File>,
}

impl EventWriter {
    /// Creates a new event file in `dir`.
    pub fn create(dir: &Path) -> std::io::Result<Self> {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        let path = dir.join(format!("events.out.tfevents.{}.fluxswarm", now.as_secs()));
        let mut w = Self {
            file: BufWriter::new(File::create(&path)?),
            path,
        };
        w.file
            .write_all(&record(&encode_event(now.as_secs_f64(), 0, &[], true)))?;
        w.file.flush()?;
        Ok(w)
    }

    /// Reopens `path` for appending after cutting it to `len` bytes (a resumed run drops what
    /// was logged after its checkpoint).
    pub fn resume(path: &Path, len: u64) -> std::io::Result<Self> {
        let f = super::run_dir::append_after(path, len)?;
        Ok(Self {
            path: path.to_path_buf(),
            file: BufWriter::new(f),
        })
    }

    /// Path of the event file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Logs scalars at `step` (TensorBoard's x axis).
    pub fn scalars(&mut self, step: u64, values: &[(&str, f32)]) -> std::io::Result<()> {
        let wall = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default()
            .as_secs_f64();
        self.file
            .write_all(&record(&encode_event(wall, step as i64, values, false)))
    }

    /// Flushes and returns the file's length.
    pub fn flush(&mut self) -> std::io::Result<u64> {
        self.file.flush()?;
        Ok(self.file.get_ref().metadata()?.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32c_matches_the_standard_check_value() {
        // The CRC-32C check value of "123456789" (RFC 3720, iSCSI).
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), 0);
    }

    #[test]
    fn scalar_event_has_the_expected_wire_bytes() {
        let ev = encode_event(1.0, 300, &[("a", 0.5)], false);
        let mut want = vec![0x09];
        want.extend_from_slice(&1.0f64.to_le_bytes());
        want.extend_from_slice(&[0x10, 0xAC, 0x02]); // 300 as a varint
        // summary (field 5) { value (field 1) { tag "a", simple_value 0.5 } }
        want.extend_from_slice(&[0x2A, 10, 0x0A, 8, 0x0A, 1, b'a', 0x15]);
        want.extend_from_slice(&0.5f32.to_le_bytes());
        assert_eq!(ev, want);
    }

    #[test]
    fn records_frame_their_payload_with_checkable_crcs() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = EventWriter::create(dir.path()).unwrap();
        w.scalars(5, &[("x", 1.5), ("y", -2.0)]).unwrap();
        let len = w.flush().unwrap();
        let bytes = std::fs::read(w.path()).unwrap();
        assert_eq!(bytes.len() as u64, len);
        let mut at = 0;
        let mut events = Vec::new();
        while at < bytes.len() {
            let n = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
            let crc_len = u32::from_le_bytes(bytes[at + 8..at + 12].try_into().unwrap());
            assert_eq!(crc_len, masked_crc(&bytes[at..at + 8]));
            let data = &bytes[at + 12..at + 12 + n];
            let crc = u32::from_le_bytes(bytes[at + 12 + n..at + 16 + n].try_into().unwrap());
            assert_eq!(crc, masked_crc(data));
            events.push(data.to_vec());
            at += 16 + n;
        }
        assert_eq!(events.len(), 2);
        assert!(events[0].windows(13).any(|w| w == b"brain.Event:2"));
        assert!(events[1].windows(1).any(|w| w == b"y"));
        // Resuming at the first record's end drops the second.
        let first = 16 + events[0].len() as u64;
        let mut r = EventWriter::resume(w.path(), first).unwrap();
        assert_eq!(r.flush().unwrap(), first);
    }
}

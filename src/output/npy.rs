//! `.npy` output of one field: little-endian f32, shape [ny, nx], row 0 at the bottom wall.

use std::io::{BufWriter, Write};
use std::path::Path;

use npyz::WriterBuilder;

/// Writes `data` (`[ny][nx]`, x fastest) as a `<f4` array of shape `[ny, nx]`.
pub fn write_field(path: &Path, ny: usize, nx: usize, data: &[f32]) -> std::io::Result<()> {
    assert_eq!(data.len(), nx * ny, "field size does not match its shape");
    let file = std::fs::File::create(path)?;
    let mut out = BufWriter::new(file);
    let mut writer = npyz::WriteOptions::<f32>::new()
        .default_dtype()
        .shape(&[ny as u64, nx as u64])
        .writer(&mut out)
        .begin_nd()?;
    writer.extend(data.iter().copied())?;
    writer.finish()?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_with_shape_and_dtype() {
        let dir = std::env::temp_dir().join(format!("fluxswarm-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("f.npy");
        let data: Vec<f32> = (0..6).map(|x| x as f32 * 0.5).collect();
        write_field(&path, 2, 3, &data).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        let npy = npyz::NpyFile::new(&bytes[..]).unwrap();
        assert_eq!(npy.shape(), &[2, 3]);
        assert_eq!(npy.dtype().descr(), "'<f4'");
        assert_eq!(npy.into_vec::<f32>().unwrap(), data);
    }
}

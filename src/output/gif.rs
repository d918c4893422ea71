//! Animated GIFs of a run's frames (`--gif` on simulate, rollout and eval): the PNG frames in
//! name order (step order, as the names carry zero-padded steps), scaled down to at most
//! `max_width` pixels wide for a README, each shown `delay_ms`, looping forever.

use std::path::{Path, PathBuf};

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, imageops};

/// Width of README animations (px).
pub const README_WIDTH: u32 = 640;

/// Errors of writing an animated GIF.
#[derive(Debug, thiserror::Error)]
pub enum GifError {
    /// No matching PNG frames in the directory.
    #[error("no frames to animate in {0}: give --frames-every K (K > 0) with --gif")]
    NoFrames(PathBuf),
    /// A frame could not be read.
    #[error("reading frame {path}: {source}")]
    Frame {
        /// The frame's file.
        path: PathBuf,
        /// The error opening or decoding it.
        source: image::ImageError,
    },
    /// The GIF could not be written.
    #[error("writing {path}: {source}")]
    Write {
        /// The GIF's file.
        path: PathBuf,
        /// The error creating or encoding it.
        source: image::ImageError,
    },
}

/// The PNG files in `dir` whose names start with `prefix`, in name order.
pub fn frames_in(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
            name.is_some_and(|n| n.starts_with(prefix) && n.ends_with(".png"))
        })
        .collect();
    v.sort();
    v
}

/// Writes `frames` as one looping GIF at `out`.
pub fn write(
    frames: &[PathBuf],
    out: &Path,
    max_width: u32,
    delay_ms: u32,
) -> Result<(), GifError> {
    let dir = out.parent().unwrap_or(Path::new(".")).to_path_buf();
    if frames.is_empty() {
        return Err(GifError::NoFrames(dir));
    }
    let werr = |source| GifError::Write {
        path: out.to_path_buf(),
        source,
    };
    let file = std::fs::File::create(out).map_err(|e| werr(image::ImageError::IoError(e)))?;
    let mut enc = GifEncoder::new_with_speed(std::io::BufWriter::new(file), 10);
    enc.set_repeat(Repeat::Infinite).map_err(werr)?;
    for path in frames {
        let img = image::open(path)
            .map_err(|source| GifError::Frame {
                path: path.clone(),
                source,
            })?
            .to_rgba8();
        let img = if img.width() > max_width {
            let h = (img.height() as u64 * max_width as u64 / img.width() as u64).max(1) as u32;
            imageops::resize(&img, max_width, h, imageops::FilterType::Triangle)
        } else {
            img
        };
        let frame = Frame::from_parts(img, 0, 0, Delay::from_numer_denom_ms(delay_ms, 1));
        enc.encode_frame(frame).map_err(werr)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::AnimationDecoder;
    use image::codecs::gif::GifDecoder;

    #[test]
    fn frames_round_trip_in_order_and_scaled() {
        let dir = tempfile::tempdir().unwrap();
        // Three 800 x 100 frames, each one flat colour, written out of order.
        for (k, shade) in [(2u32, 200u8), (0, 0), (1, 100)] {
            let img = image::RgbImage::from_pixel(800, 100, image::Rgb([shade, shade, shade]));
            img.save(dir.path().join(format!("env0_s{k:06}.png")))
                .unwrap();
        }
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        let frames = frames_in(dir.path(), "env0_");
        assert_eq!(frames.len(), 3);
        let out = dir.path().join("animation.gif");
        write(&frames, &out, 400, 80).unwrap();
        let dec =
            GifDecoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap())).unwrap();
        let decoded: Vec<_> = dec.into_frames().collect::<Result<_, _>>().unwrap();
        assert_eq!(decoded.len(), 3);
        for (k, f) in decoded.iter().enumerate() {
            let buf = f.buffer();
            assert_eq!((buf.width(), buf.height()), (400, 50));
            let shade = buf.get_pixel(200, 25)[0] as i32;
            assert!((shade - 100 * k as i32).abs() <= 8, "frame {k}: {shade}");
            assert_eq!(f.delay().numer_denom_ms(), (80, 1));
        }
        let e = write(&[], &out, 400, 80).unwrap_err().to_string();
        assert!(e.contains("--frames-every"), "{e}");
    }
}

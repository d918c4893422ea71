//! Animated GIFs of a run's frames (`--gif` on simulate, rollout and eval): the PNG frames in
//! name order (step order, as the names carry zero-padded steps), scaled down to at most
//! `max_width` pixels wide for a README, each shown `delay_ms`, looping forever. A [`Window`]
//! keeps the frames of one episode and a range of its control steps (rollout and eval name
//! their frames `env<e>_ep<episode:04>_s<step:06>.png`).

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

/// Which rollout frames go into a GIF: those of episode `episode` (all when `None`) whose
/// control step lies in `steps` = [start, end) (all when `None`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Window {
    /// The episode of environment 0 (0 is its first).
    pub episode: Option<u64>,
    /// Control steps [start, end) within each episode.
    pub steps: Option<(u64, u64)>,
}

impl Window {
    /// Parses `START:END` (control steps, END above START) for [`Window::steps`].
    pub fn parse_steps(text: &str) -> Result<(u64, u64), String> {
        let bad = || format!("--gif-steps {text}: give START:END, control steps with END > START");
        let (a, b) = text.split_once(':').ok_or_else(bad)?;
        let (a, b) = (
            a.trim().parse::<u64>().map_err(|_| bad())?,
            b.trim().parse::<u64>().map_err(|_| bad())?,
        );
        if b <= a {
            return Err(bad());
        }
        Ok((a, b))
    }

    /// Whether the frame file `path` (named `..._ep<episode>_s<step>.png`) lies in the window;
    /// a name without episode and step lies in it only when the window is everything.
    pub fn holds(&self, path: &Path) -> bool {
        if *self == Window::default() {
            return true;
        }
        let Some((episode, step)) = episode_and_step(path) else {
            return false;
        };
        self.episode.is_none_or(|e| e == episode)
            && self.steps.is_none_or(|(a, b)| (a..b).contains(&step))
    }
}

/// The episode and control step in a frame's name `..._ep<episode>_s<step>.png`.
fn episode_and_step(path: &Path) -> Option<(u64, u64)> {
    let stem = path.file_stem()?.to_str()?;
    let (head, step) = stem.rsplit_once("_s")?;
    let (_, episode) = head.rsplit_once("_ep")?;
    Some((episode.parse().ok()?, step.parse().ok()?))
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

    #[test]
    fn a_window_keeps_one_episodes_steps() {
        let name = |ep: u64, s: u64| PathBuf::from(format!("f/env0_ep{ep:04}_s{s:06}.png"));
        let w = Window {
            episode: Some(1),
            steps: Some((10, 30)),
        };
        let kept: Vec<bool> = [(1, 10), (1, 29), (1, 30), (1, 9), (0, 20), (11, 20)]
            .iter()
            .map(|&(ep, s)| w.holds(&name(ep, s)))
            .collect();
        assert_eq!(kept, [true, true, false, false, false, false]);
        let steps_only = Window {
            episode: None,
            steps: Some((0, 20)),
        };
        assert!(steps_only.holds(&name(0, 10)) && steps_only.holds(&name(7, 0)));
        assert!(!steps_only.holds(&name(7, 20)));
        // simulate's frames (env0_s000010.png) have no episode: only the whole window holds them.
        assert!(Window::default().holds(Path::new("env0_s000010.png")));
        assert!(!steps_only.holds(Path::new("env0_s000010.png")));
        assert_eq!(Window::parse_steps("200:600"), Ok((200, 600)));
        for bad in ["600:200", "5:5", "200", "a:b", "-1:4"] {
            let e = Window::parse_steps(bad).unwrap_err();
            assert!(e.contains("START:END"), "{bad}: {e}");
        }
    }
}

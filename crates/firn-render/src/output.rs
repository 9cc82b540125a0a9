//! Writing pictures: PNG frames (atomically), an animated GIF preview through
//! the pure-Rust `gif` crate, and an MP4 through ffmpeg when it is installed.

use std::io;
use std::path::{Path, PathBuf};
use std::process::Command;

use firn_io::{IoError, write_atomically};
use image::imageops::FilterType;
use image::{ImageFormat, RgbImage};

/// Longest side of the animated GIF preview, in pixels.
pub const PREVIEW_MAX_SIDE: u32 = 480;

/// Problems writing pictures and animations.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file could not be written or read.
    #[error(transparent)]
    Io(#[from] IoError),
    /// A frame image could not be decoded.
    #[error("cannot read image {}: {reason}", path.display())]
    Decode {
        /// The image file.
        path: PathBuf,
        /// What the decoder said.
        reason: String,
    },
    /// The frames of an animation differ in size.
    #[error("{} is {found:?} pixels but the animation's first frame is {expected:?}", path.display())]
    SizeMismatch {
        /// The odd frame.
        path: PathBuf,
        /// Size of the first frame.
        expected: (u32, u32),
        /// Size of this frame.
        found: (u32, u32),
    },
    /// ffmpeg ran but failed.
    #[error("ffmpeg could not encode {}: {reason}", path.display())]
    Ffmpeg {
        /// The video being written.
        path: PathBuf,
        /// The end of ffmpeg's error output.
        reason: String,
    },
}

/// Writes `image` as a PNG at `path`, atomically.
pub fn write_png(path: &Path, image: &RgbImage) -> Result<(), OutputError> {
    let mut bytes = io::Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, ImageFormat::Png)
        .map_err(|error| IoError::Write {
            path: path.to_path_buf(),
            source: io::Error::other(error.to_string()),
        })?;
    write_atomically(path, |file| file.write_all(bytes.get_ref()))?;
    Ok(())
}

/// Reads a PNG frame back.
pub fn read_png(path: &Path) -> Result<RgbImage, OutputError> {
    let decoded = image::open(path).map_err(|error| OutputError::Decode {
        path: path.to_path_buf(),
        reason: error.to_string(),
    })?;
    Ok(decoded.to_rgb8())
}

/// Writes an animated GIF of `frames` (PNG files, in order) at `fps`, scaled
/// down so its longer side is at most [`PREVIEW_MAX_SIDE`]; loops forever.
pub fn write_gif(path: &Path, frames: &[PathBuf], fps: f64) -> Result<(), OutputError> {
    let mut previews = Vec::with_capacity(frames.len());
    let mut expected = None;
    for frame_path in frames {
        let image = read_png(frame_path)?;
        let size = image.dimensions();
        let first = *expected.get_or_insert(size);
        if first != size {
            return Err(OutputError::SizeMismatch {
                path: frame_path.clone(),
                expected: first,
                found: size,
            });
        }
        previews.push(preview_size(image));
    }
    let encoded = encode_gif(&previews, fps).map_err(|error| gif_error(path, error))?;
    write_atomically(path, |file| file.write_all(&encoded))?;
    Ok(())
}

/// Encodes equally sized frames as a looping GIF, each frame quantised to
/// its own 256-colour palette.
fn encode_gif(previews: &[RgbImage], fps: f64) -> Result<Vec<u8>, gif::EncodingError> {
    let mut encoded = Vec::new();
    let Some(first) = previews.first() else {
        return Ok(encoded);
    };
    let (width, height) = (first.width() as u16, first.height() as u16);
    let delay = (100.0 / fps.max(1e-3)).round().clamp(2.0, 65_535.0) as u16;
    {
        let mut encoder = gif::Encoder::new(&mut encoded, width, height, &[])?;
        encoder.set_repeat(gif::Repeat::Infinite)?;
        for preview in previews {
            let mut frame = gif::Frame::from_rgb_speed(width, height, preview.as_raw(), 10);
            frame.delay = delay;
            encoder.write_frame(&frame)?;
        }
    }
    Ok(encoded)
}

fn gif_error(path: &Path, error: gif::EncodingError) -> OutputError {
    OutputError::Io(IoError::Write {
        path: path.to_path_buf(),
        source: io::Error::other(error.to_string()),
    })
}

/// `image` scaled down to the preview size (unchanged when already small).
fn preview_size(image: RgbImage) -> RgbImage {
    let (width, height) = image.dimensions();
    let longest = width.max(height);
    if longest <= PREVIEW_MAX_SIDE {
        return image;
    }
    let scale = PREVIEW_MAX_SIDE as f32 / longest as f32;
    let (w, h) = (
        ((width as f32 * scale).round() as u32).max(1),
        ((height as f32 * scale).round() as u32).max(1),
    );
    image::imageops::resize(&image, w, h, FilterType::Triangle)
}

/// The ffmpeg executable on PATH, if there is one.
pub fn find_ffmpeg() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|dir| dir.join("ffmpeg"))
        .find(|candidate| candidate.is_file())
}

/// Encodes the PNG sequence `pattern` (an ffmpeg pattern such as
/// `images/points/frame_%05d.png`, numbered from `first`) as an H.264 MP4 at
/// `path`, through a temporary file renamed into place.
pub fn write_mp4(
    ffmpeg: &Path,
    pattern: &Path,
    first: u32,
    fps: f64,
    path: &Path,
) -> Result<(), OutputError> {
    let temporary = path.with_extension("partial.mp4");
    let output = Command::new(ffmpeg)
        .args(["-y", "-loglevel", "error", "-framerate"])
        .arg(format!("{fps}"))
        .args(["-start_number", &first.to_string(), "-i"])
        .arg(pattern)
        .args([
            "-c:v",
            "libx264",
            "-pix_fmt",
            "yuv420p",
            "-vf",
            "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        ])
        .arg(&temporary)
        .output()
        .map_err(|source| IoError::Write {
            path: path.to_path_buf(),
            source,
        })?;
    if !output.status.success() {
        let _ = std::fs::remove_file(&temporary);
        let stderr = String::from_utf8_lossy(&output.stderr);
        let tail: Vec<&str> = stderr.lines().rev().take(3).collect();
        return Err(OutputError::Ffmpeg {
            path: path.to_path_buf(),
            reason: tail.into_iter().rev().collect::<Vec<_>>().join(" / "),
        });
    }
    std::fs::rename(&temporary, path).map_err(|source| IoError::Write {
        path: path.to_path_buf(),
        source,
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trips_and_gif_has_every_frame() {
        let dir = tempfile::tempdir().expect("temp dir");
        let mut frames = Vec::new();
        for index in 0..3u8 {
            let image = RgbImage::from_pixel(20, 10, image::Rgb([index * 80, 10, 200]));
            let path = dir.path().join(format!("frame_{index:05}.png"));
            write_png(&path, &image).expect("png");
            assert_eq!(read_png(&path).expect("read back"), image);
            frames.push(path);
        }
        let gif_path = dir.path().join("preview.gif");
        write_gif(&gif_path, &frames, 24.0).expect("gif");
        let file = std::fs::File::open(&gif_path).expect("open gif");
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options.read_info(file).expect("gif header");
        let mut count = 0;
        while let Some(frame) = decoder.read_next_frame().expect("frame") {
            assert_eq!((frame.width, frame.height), (20, 10));
            assert_eq!(frame.delay, 4);
            count += 1;
        }
        assert_eq!(count, 3);
    }

    #[test]
    fn frames_of_different_sizes_are_refused_by_name() {
        let dir = tempfile::tempdir().expect("temp dir");
        let a = dir.path().join("a.png");
        let b = dir.path().join("b.png");
        write_png(&a, &RgbImage::new(8, 8)).expect("png");
        write_png(&b, &RgbImage::new(9, 8)).expect("png");
        let error =
            write_gif(&dir.path().join("x.gif"), &[a, b.clone()], 10.0).expect_err("sizes differ");
        assert!(error.to_string().contains(&b.display().to_string()));
        assert!(!dir.path().join("x.gif").exists());
    }
}

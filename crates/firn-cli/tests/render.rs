//! Pictures from `firn run` and `firn render`: per-frame PNGs recorded in the
//! manifest, animations, re-rendering from caches, and clear errors for
//! damaged caches.

use std::fs;
use std::path::Path;
use std::process::Command;

mod common;
use common::{firn, manifest, stderr, tiny_ball_scene};

/// The scene every test here runs.
fn tiny_scene() -> String {
    tiny_ball_scene("tiny", "[0.2, 0.2, 0.2]", "")
}

/// Runs the tiny scene into `dir/run` with extra arguments; returns the run directory.
fn run_tiny(dir: &Path, extra: &[&str]) -> std::path::PathBuf {
    let scene = dir.join("tiny.toml");
    fs::write(&scene, tiny_scene()).expect("scene written");
    let out = dir.join("run");
    let mut args = vec![
        "run",
        scene.to_str().expect("utf-8 path"),
        "--out",
        out.to_str().expect("utf-8 path"),
        "--quiet",
    ];
    args.extend_from_slice(extra);
    let output = firn(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    out
}

#[test]
fn a_run_renders_every_frame_and_records_the_images() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &[]);
    let manifest = manifest(&out);
    let frames = manifest["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 4);
    for frame in frames {
        let index = frame["index"].as_u64().expect("index");
        let images = frame["images"].as_array().expect("images");
        let expected = format!("images/points/frame_{index:05}.png");
        assert_eq!(images, &[serde_json::Value::from(expected.clone())]);
        let image = image::open(out.join(&expected)).expect("a PNG");
        assert_eq!((image.width(), image.height()), (96, 64));
    }
    let animations = manifest["animations"].as_array().expect("animations");
    assert!(animations.contains(&"images/points.gif".into()));
    assert!(out.join("images/points.gif").is_file());
}

#[test]
fn no_render_writes_no_pictures() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &["--no-render"]);
    assert!(!out.join("images").exists());
    assert!(
        manifest(&out)["frames"][1]["images"]
            .as_array()
            .expect("images")
            .is_empty()
    );
}

#[test]
fn render_redraws_a_run_in_another_style_and_size() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &["--no-render"]);
    let output = firn(&[
        "render",
        out.to_str().expect("utf-8 path"),
        "--style",
        "points,volume",
        "--size",
        "80x48",
        "--camera",
        "0.2,0.6,1.2@0.2,0.2,0.2",
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let manifest = manifest(&out);
    let images = manifest["frames"][2]["images"].as_array().expect("images");
    assert_eq!(images.len(), 2);
    for name in [
        "images/volume/frame_00002.png",
        "images/points/frame_00002.png",
    ] {
        let image = image::open(out.join(name)).expect("a PNG").to_rgb8();
        assert_eq!(image.dimensions(), (80, 48));
        // The ball sits at the look-at point, in the image centre.
        let centre = image.get_pixel(40, 24).0;
        let corner = image.get_pixel(2, 2).0;
        assert_ne!(centre, corner, "{name} shows the snow in its centre");
    }
}

#[test]
fn a_truncated_cache_is_named_and_nothing_wrong_is_rendered() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &["--no-render"]);
    let damaged = out.join("ply/frame_00002.ply");
    let bytes = fs::read(&damaged).expect("cache");
    fs::write(&damaged, &bytes[..bytes.len() / 2]).expect("truncate");
    let output = firn(&["render", out.to_str().expect("utf-8 path"), "--quiet"]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("frame_00002.ply"), "{message}");
    assert!(message.contains("fix:"), "{message}");
    assert!(!out.join("images/points/frame_00002.png").exists());
    assert!(!out.join("images/points.gif").exists());
}

#[test]
fn a_missing_cache_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &["--no-render"]);
    fs::remove_file(out.join("ply/frame_00001.ply")).expect("remove");
    let output = firn(&["render", out.to_str().expect("utf-8 path"), "--quiet"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("frame_00001.ply"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn render_rejects_a_bad_size_and_a_directory_without_a_run() {
    let dir = tempfile::tempdir().expect("temp dir");
    let output = firn(&["render", dir.path().to_str().expect("utf-8 path")]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("manifest.json"),
        "{}",
        stderr(&output)
    );
    let out = run_tiny(dir.path(), &["--no-render"]);
    let output = firn(&[
        "render",
        out.to_str().expect("utf-8 path"),
        "--size",
        "wide",
    ]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("--size 1920x1080"),
        "{}",
        stderr(&output)
    );
}

#[test]
fn without_ffmpeg_the_run_says_plainly_that_no_mp4_was_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let scene = dir.path().join("tiny.toml");
    fs::write(&scene, tiny_scene()).expect("scene written");
    let empty_path = dir.path().join("no-tools");
    fs::create_dir(&empty_path).expect("dir");
    let output = Command::new(env!("CARGO_BIN_EXE_firn"))
        .args(["run", scene.to_str().expect("utf-8 path"), "--out"])
        .arg(dir.path().join("run"))
        .env("PATH", &empty_path)
        .output()
        .expect("firn runs");
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(
        stderr(&output).contains("ffmpeg is not on PATH"),
        "{}",
        stderr(&output)
    );
    assert!(dir.path().join("run/images/points.gif").is_file());
    assert!(!dir.path().join("run/images/points.mp4").exists());
}

/// Whether ffmpeg is on PATH; CI sets FIRN_REQUIRE_FFMPEG=1 so that a
/// missing ffmpeg fails there instead of skipping the MP4 test.
fn ffmpeg_available() -> bool {
    let found = std::env::var_os("PATH")
        .is_some_and(|path| std::env::split_paths(&path).any(|dir| dir.join("ffmpeg").is_file()));
    if std::env::var_os("FIRN_REQUIRE_FFMPEG").is_some() {
        assert!(
            found,
            "FIRN_REQUIRE_FFMPEG is set but ffmpeg is not on PATH"
        );
    }
    found
}

#[test]
fn with_ffmpeg_the_run_writes_an_mp4_of_every_frame() {
    if !ffmpeg_available() {
        eprintln!("ffmpeg is not on PATH: the MP4 path is not exercised here");
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let out = run_tiny(dir.path(), &[]);
    let video = out.join("images/points.mp4");
    assert!(video.is_file());
    let probe = Command::new("ffprobe")
        .args(["-v", "error", "-count_frames", "-select_streams", "v:0"])
        .args([
            "-show_entries",
            "stream=codec_name,nb_read_frames",
            "-of",
            "csv=p=0",
        ])
        .arg(&video)
        .output()
        .expect("ffprobe runs");
    let described = String::from_utf8_lossy(&probe.stdout).trim().to_string();
    assert_eq!(described, "h264,4");
    let animations = manifest(&out)["animations"].clone();
    assert!(
        animations
            .as_array()
            .expect("list")
            .contains(&"images/points.mp4".into())
    );
}

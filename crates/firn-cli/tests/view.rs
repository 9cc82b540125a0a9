//! `firn view` in a real window: under a virtual X display (Xvfb) with
//! Mesa's software Vulkan adapter, the viewer opens on a scene for a fixed
//! number of frames and writes a screenshot, which must show the particles
//! where the camera puts them and the panel on the left. Without a display
//! it says so and points to `firn run`.
//!
//! These tests need `Xvfb` and a Vulkan adapter (Debian/Ubuntu: `apt install
//! xvfb mesa-vulkan-drivers libvulkan1`). Without them they skip with that
//! message, unless `FIRN_REQUIRE_GPU=1` (as CI sets), which makes them fail.

mod common;

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};

use common::{firn, stderr, text, write_scene};

/// A snowball in the middle of a 1 m box, the camera looking straight at
/// it, so the ball is drawn at the centre of the view.
const BALL: &str = r#"
format = 1
name = "view-ball"

[domain]
min = [0.0, 0.0, 0.0]
max = [1.0, 1.0, 1.0]
cell_size = 0.04

[time]
duration = 0.1
fps = 30

[solver]
transfer = "apic"
gravity = [0.0, 0.0, 0.0]

[materials.snow]
preset = "snow"

[[bodies]]
shape = "sphere"
center = [0.5, 0.5, 0.5]
radius = 0.15
material = "snow"

[camera]
position = [0.5, 0.5, 2.2]
look_at = [0.5, 0.5, 0.5]
fov = 40

[render]
size = [320, 200]
color_by = "density"

[output]
formats = ["ply"]
attributes = ["velocity", "density"]
"#;

/// An X server on a free display for this test, stopped when dropped.
struct VirtualDisplay {
    server: Child,
    name: String,
}

impl VirtualDisplay {
    /// Starts Xvfb on a display number it picks itself (`-displayfd`, so
    /// tests running at once never share one); `None` (after saying why)
    /// when Xvfb is missing, unless FIRN_REQUIRE_GPU=1.
    fn start() -> Option<VirtualDisplay> {
        let spawned = Command::new("Xvfb")
            .args([
                "-displayfd",
                "1",
                "-screen",
                "0",
                "1024x768x24",
                "-nolisten",
                "tcp",
            ])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn();
        let Ok(mut server) = spawned else {
            return skip_or_fail("Xvfb is not installed");
        };
        // Xvfb writes its display number once it accepts connections.
        let mut number = String::new();
        let stdout = server.stdout.take().expect("piped");
        let read = BufReader::new(stdout).read_line(&mut number);
        match (read, number.trim().parse::<u32>()) {
            (Ok(_), Ok(number)) => Some(VirtualDisplay {
                server,
                name: format!(":{number}"),
            }),
            _ => {
                let _ = server.kill();
                skip_or_fail("Xvfb did not start")
            }
        }
    }

    /// Runs `firn` with `args` on this display.
    fn firn(&self, args: &[&str]) -> Output {
        Command::new(env!("CARGO_BIN_EXE_firn"))
            .args(args)
            .env("DISPLAY", &self.name)
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .expect("firn runs")
    }
}

impl Drop for VirtualDisplay {
    fn drop(&mut self) {
        let _ = self.server.kill();
        let _ = self.server.wait();
    }
}

fn skip_or_fail(reason: &str) -> Option<VirtualDisplay> {
    let required = std::env::var("FIRN_REQUIRE_GPU").is_ok_and(|value| value == "1");
    assert!(!required, "FIRN_REQUIRE_GPU=1 but {reason}");
    eprintln!(
        "skipping a viewer test: {reason} (apt install xvfb mesa-vulkan-drivers libvulkan1 to run it)"
    );
    None
}

/// Opens the viewer on `input` for `frames` frames and returns its
/// screenshot (640x400 window).
fn screenshot(display: &VirtualDisplay, input: &Path, extra: &[&str]) -> image::RgbImage {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let mut args = vec![
        "view",
        input.to_str().unwrap(),
        "--size",
        "640x400",
        "--frames",
        "4",
        "--display-fps",
        "60",
        "--screenshot",
        shot.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = display.firn(&args);
    assert!(
        output.status.success(),
        "firn view failed:\n{}\n{}",
        text(&output.stdout),
        stderr(&output)
    );
    let line = text(&output.stdout);
    assert!(line.contains("4 frames"), "{line}");
    image::open(&shot).expect("a PNG screenshot").to_rgb8()
}

/// Mean colour of the `size`-pixel square centred on (`x`, `y`).
fn mean_color(image: &image::RgbImage, x: u32, y: u32, size: u32) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut count = 0.0;
    for py in y - size / 2..y + size / 2 {
        for px in x - size / 2..x + size / 2 {
            let pixel = image.get_pixel(px, py);
            for channel in 0..3 {
                sum[channel] += f32::from(pixel[channel]);
            }
            count += 1.0;
        }
    }
    sum.map(|s| s / count)
}

/// The snowball at the centre of the view beside the 270-pixel panel is
/// bluish snow, unlike the sky in the top-right corner; the panel on the
/// left holds light text on its dark background.
fn assert_ball_and_panel(image: &image::RgbImage) {
    assert_eq!(image.dimensions(), (640, 400));
    let ball = mean_color(image, (270 + 640) / 2, 200, 20);
    let sky = mean_color(image, 620, 20, 20);
    println!("ball {ball:?}, sky {sky:?}");
    assert!(ball[2] > ball[0] + 20.0, "the ball is not bluish: {ball:?}");
    let difference: f32 = (0..3).map(|c| (ball[c] - sky[c]).abs()).sum();
    assert!(
        difference > 60.0,
        "ball {ball:?} looks like the sky {sky:?}"
    );
    let panel: Vec<u8> = (0..400)
        .flat_map(|y| (0..250).map(move |x| (x, y)))
        .map(|(x, y)| image.get_pixel(x, y)[1])
        .collect();
    let bright = panel.iter().filter(|&&g| g > 150).count();
    let dark = panel.iter().filter(|&&g| g < 60).count();
    println!(
        "panel: {bright} bright and {dark} dark pixels of {}",
        panel.len()
    );
    assert!(bright > 500, "no panel text: {bright} bright pixels");
    assert!(
        dark > panel.len() / 2,
        "no panel background: {dark} dark pixels"
    );
}

#[test]
fn the_viewer_shows_a_live_scene_and_its_panel() {
    let Some(display) = VirtualDisplay::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "ball.toml", BALL);
    let image = screenshot(&display, &scene, &["--backend", "cpu"]);
    image.save("/tmp/firn-view-cpu.png").ok();
    assert_ball_and_panel(&image);
}

#[test]
fn the_viewer_opens_on_the_bundled_default_scene() {
    let Some(display) = VirtualDisplay::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("default.png");
    let output = display.firn(&[
        "view",
        "--size",
        "640x400",
        "--frames",
        "3",
        "--display-fps",
        "60",
        "--screenshot",
        shot.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    let image = image::open(&shot).unwrap().to_rgb8();
    image.save("/tmp/firn-view-default.png").ok();
    // The snowball: strongly blue pixels, which neither the grey sky, the
    // ground nor the wall have.
    let snow = image
        .pixels()
        .filter(|p| i32::from(p[2]) > i32::from(p[0]) + 50)
        .count();
    println!("{snow} snow pixels");
    assert!(snow > 800, "only {snow} snow pixels");
}

#[test]
fn the_viewer_draws_a_gpu_simulation_from_its_own_buffers() {
    let Some(display) = VirtualDisplay::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "ball.toml", BALL);
    let image = screenshot(&display, &scene, &["--backend", "gpu"]);
    image.save("/tmp/firn-view-gpu.png").ok();
    assert_ball_and_panel(&image);
}

#[test]
fn the_viewer_plays_back_a_finished_run() {
    let Some(display) = VirtualDisplay::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "ball.toml", BALL);
    let out = dir.path().join("run");
    let run = firn(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-render",
        "--quiet",
        "--backend",
        "cpu",
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let image = screenshot(&display, &out, &[]);
    image.save("/tmp/firn-view-playback.png").ok();
    assert_ball_and_panel(&image);
}

/// `--record` with `--screenshot` writes both: every frame, and the last
/// one again as the screenshot.
#[test]
fn the_viewer_records_every_frame() {
    let Some(display) = VirtualDisplay::start() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "ball.toml", BALL);
    let record = dir.path().join("frames");
    let shot = dir.path().join("last.png");
    let output = display.firn(&[
        "view",
        scene.to_str().unwrap(),
        "--size",
        "320x200",
        "--frames",
        "3",
        "--record",
        record.to_str().unwrap(),
        "--screenshot",
        shot.to_str().unwrap(),
        "--backend",
        "cpu",
    ]);
    assert!(output.status.success(), "{}", stderr(&output));
    for frame in 0..3 {
        let path = record.join(format!("frame-{frame:05}.png"));
        let image = image::open(&path).expect("a recorded frame").to_rgb8();
        assert_eq!(image.dimensions(), (320, 200));
    }
    assert!(!record.join("frame-00003.png").exists());
    let last = image::open(record.join("frame-00002.png"))
        .unwrap()
        .to_rgb8();
    let screenshot = image::open(&shot).expect("the screenshot beside the recording");
    assert_eq!(screenshot.to_rgb8(), last);
}

#[test]
fn without_a_display_the_viewer_says_so_and_points_to_firn_run() {
    let output = Command::new(env!("CARGO_BIN_EXE_firn"))
        .args(["view", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("firn runs");
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    let message = stderr(&output);
    assert!(message.contains("needs a display"), "{message}");
    assert!(message.contains("firn run"), "{message}");
    assert!(!message.contains("panicked"), "{message}");
}

#[test]
fn bad_viewer_options_are_refused_with_a_fix() {
    let output = firn(&["view", "--screenshot", "shot.png"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(stderr(&output).contains("--frames"), "{}", stderr(&output));
    let output = firn(&["view", "--display-fps", "0", "--frames", "1"]);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        stderr(&output).contains("--display-fps"),
        "{}",
        stderr(&output)
    );
}

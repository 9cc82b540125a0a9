//! What the command-line tests share: running the built `firn`, reading its
//! output, and writing scene files.

#![allow(dead_code)] // each test binary uses its own subset

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The `firn` binary under test: this build's, or the one `FIRN_BIN` names
/// (to hold another build to the same tests).
pub fn firn_binary() -> PathBuf {
    std::env::var_os("FIRN_BIN")
        .map_or_else(|| PathBuf::from(env!("CARGO_BIN_EXE_firn")), PathBuf::from)
}

/// Runs the `firn` binary of this build with `args` and waits for it.
pub fn firn(args: &[&str]) -> Output {
    Command::new(firn_binary())
        .args(args)
        .output()
        .expect("firn runs")
}

/// Runs `firn` with `args` and the environment `envs`, and fails the test
/// if it has not finished within `limit` (it is killed then).
pub fn firn_within(args: &[&str], envs: &[(&str, &str)], limit: Duration) -> Output {
    let mut child = Command::new(firn_binary())
        .args(args)
        .envs(envs.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("firn starts");
    let started = Instant::now();
    while child.try_wait().expect("firn can be waited for").is_none() {
        if started.elapsed() > limit {
            child.kill().expect("firn can be stopped");
            child.wait().expect("firn stops");
            panic!("firn {} did not answer within {limit:?}", args.join(" "));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().expect("firn's output")
}

/// Bytes a command printed, as text.
pub fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// What a command printed to standard error.
pub fn stderr(output: &Output) -> String {
    text(&output.stderr)
}

/// Writes a scene file `name` with `contents` into `dir`; returns its path.
pub fn write_scene(dir: &Path, name: &str, contents: &str) -> PathBuf {
    let path = dir.join(name);
    fs::write(&path, contents).expect("scene written");
    path
}

/// The run manifest in `out`, as JSON.
pub fn manifest(out: &Path) -> serde_json::Value {
    let contents = fs::read_to_string(out.join("manifest.json")).expect("manifest");
    serde_json::from_str(&contents).expect("manifest is JSON")
}

/// A small ball of snow (radius 0.08 m) dropped in a 0.4 m box for 0.075 s,
/// pictured at 96x64: scene `name` with the ball at `center` (a TOML array)
/// and `extra` lines added to the body.
pub fn tiny_ball_scene(name: &str, center: &str, extra: &str) -> String {
    format!(
        r#"format = 1
name = "{name}"

[domain]
max = [0.4, 0.4, 0.4]
cell_size = 0.05

[time]
duration = 0.075
fps = 40

[[bodies]]
shape = "sphere"
center = {center}
radius = 0.08
{extra}
[render]
size = [96, 64]
"#
    )
}

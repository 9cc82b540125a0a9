//! What the command-line tests share: running the built `firn`, reading its
//! output, and writing scene files.

#![allow(dead_code)] // each test binary uses its own subset

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs the `firn` binary of this build with `args` and waits for it.
pub fn firn(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_firn"))
        .args(args)
        .output()
        .expect("firn runs")
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

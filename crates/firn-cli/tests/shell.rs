//! `firn` as ordinary shell use meets it: output piped into a reader that
//! has gone (`| head -1`, `grep -q`, a pager quit early), and a launch by
//! mpirun of a build without MPI.

use std::path::Path;
use std::process::{Command, Output, Stdio};

mod common;
use common::{firn, firn_binary, stderr, tiny_ball_scene, write_scene};

/// Runs `firn args` with standard output and standard error both a pipe
/// whose reader is already closed: every write fails with EPIPE, as after
/// `head -1` has its line.
fn firn_into_closed_pipe(args: &[&str], dir: &Path) -> Output {
    let (reader, writer) = std::io::pipe().expect("a pipe");
    drop(reader);
    let errors = writer.try_clone().expect("a second writer");
    Command::new(firn_binary())
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::from(errors))
        .output()
        .expect("firn runs")
}

/// Asserts that `firn args`, its output closed, ends as it would have
/// (exit 0) and not with a panic.
#[track_caller]
fn assert_quiet_end(args: &[&str], dir: &Path) {
    let output = firn_into_closed_pipe(args, dir);
    assert_eq!(
        output.status.code(),
        Some(0),
        "firn {} into a closed pipe: {:?}",
        args.join(" "),
        output.status
    );
}

#[test]
fn every_printing_command_ends_quietly_on_a_closed_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "ball.toml",
        &tiny_ball_scene("ball", "[0.2, 0.2, 0.2]", ""),
    );
    let scene = scene.to_str().unwrap();
    for args in [
        vec!["check", scene],
        vec!["check", scene, "--json"],
        vec!["presets"],
        vec!["info"],
        vec!["run", scene, "--out", "run", "--no-render"],
        vec!["render", "run", "--style", "points", "--size", "32x24"],
        vec![
            "compare", scene, scene, "--times", "0.05", "--size", "32x24", "--out", "cmp",
        ],
        vec![
            "bench",
            "--particles",
            "500",
            "--grid",
            "16",
            "--steps",
            "2",
            "--warmup",
            "1",
            "--backend",
            "cpu",
            "--json",
            "bench.json",
        ],
    ] {
        assert_quiet_end(&args, dir.path());
    }
    // The run went on to the end with its output closed.
    assert!(dir.path().join("run/ply/frame_00002.ply").exists());
}

#[test]
fn a_build_without_mpi_refuses_a_launch_by_mpirun() {
    if cfg!(feature = "mpi") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "ball.toml",
        &tiny_ball_scene("ball", "[0.2, 0.2, 0.2]", ""),
    );
    let out = dir.path().join("out");
    for (variable, launcher) in [
        ("OMPI_COMM_WORLD_SIZE", "Open MPI"),
        ("PMI_SIZE", "MPICH"),
        ("MV2_COMM_WORLD_SIZE", "MVAPICH"),
    ] {
        let output = Command::new(firn_binary())
            .args(["run", scene.to_str().unwrap(), "--out"])
            .arg(&out)
            .env(variable, "2")
            .output()
            .expect("firn runs");
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{launcher}: {message}");
        assert!(
            message.contains(&format!("{variable}=2"))
                && message.contains("--features mpi")
                && message.contains("fix:"),
            "{launcher}: {message}"
        );
        assert!(!out.exists(), "{launcher}: nothing may be written");
    }
    // One process (mpirun -np 1) is an ordinary run.
    let output = Command::new(firn_binary())
        .args(["check", scene.to_str().unwrap()])
        .env("OMPI_COMM_WORLD_SIZE", "1")
        .output()
        .expect("firn runs");
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(firn(&["presets"]).status.success());
}

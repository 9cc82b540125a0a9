//! `mpirun -np N firn run SCENE` (the `mpi` feature): the same PLY frames,
//! byte for byte, for 1 to 4 ranks and one process, both transfer schemes;
//! a run stopped on one rank count resumes on another with the same bytes;
//! a failing rank stops the run with its message; the semi-implicit
//! integrator is refused. Skipped without `mpirun` unless
//! `FIRN_REQUIRE_MPI=1`.

#![cfg(feature = "mpi")]

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{firn, firn_binary};

/// The scene of the MPI tests: two snowballs crossing the slabs both ways
/// and a moving box.
fn crossing_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firn-mpi/tests/crossing.toml")
}

/// Whether `mpirun` is here; fails the test if it must be.
fn have_mpirun() -> bool {
    let found = Command::new("mpirun").arg("--version").output().is_ok();
    if !found && std::env::var_os("FIRN_REQUIRE_MPI").is_some_and(|v| v == "1") {
        panic!("FIRN_REQUIRE_MPI=1 but mpirun is not on PATH (install openmpi-bin)");
    }
    if !found {
        eprintln!("skipped: no mpirun (install openmpi-bin, or set FIRN_REQUIRE_MPI=1 to fail)");
    }
    found
}

/// `mpirun -np ranks firn args…`, oversubscribing the cores, one thread a rank.
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["--oversubscribe", "-np", &ranks.to_string()])
        .arg(firn_binary())
        .args(args)
        .args(["--threads", "1", "--quiet"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun starts")
}

fn assert_success(output: &Output, what: &str) {
    assert!(
        output.status.success(),
        "{what} failed: {}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
}

/// The PLY frames of a run directory, by name.
fn frames(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut frames: Vec<_> = fs::read_dir(run.join("ply"))
        .unwrap()
        .map(|entry| {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, fs::read(&path).unwrap())
        })
        .collect();
    frames.sort();
    frames
}

/// The crossing scene with `transfer`, written into `dir`.
fn scene_with(dir: &Path, transfer: &str) -> PathBuf {
    let text = fs::read_to_string(crossing_scene()).unwrap().replace(
        "transfer = \"pic-flip\"",
        &format!("transfer = \"{transfer}\""),
    );
    let path = dir.join(format!("crossing-{transfer}.toml"));
    fs::write(&path, text).unwrap();
    path
}

#[test]
fn every_rank_count_writes_the_one_process_frames_byte_for_byte() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for transfer in ["pic-flip", "apic"] {
        let scene = scene_with(dir.path(), transfer);
        let scene = scene.to_str().unwrap();
        let alone = dir.path().join(format!("{transfer}-alone"));
        let output = firn(&[
            "run",
            scene,
            "--out",
            alone.to_str().unwrap(),
            "--frames",
            "3",
            "--threads",
            "1",
            "--quiet",
        ]);
        assert_success(&output, "one process");
        let reference = frames(&alone);
        assert_eq!(reference.len(), 4, "frames 0 to 3");
        for ranks in 1..=4 {
            let out = dir.path().join(format!("{transfer}-{ranks}"));
            let output = mpirun(
                ranks,
                &[
                    "run",
                    scene,
                    "--out",
                    out.to_str().unwrap(),
                    "--frames",
                    "3",
                ],
            );
            assert_success(&output, &format!("{ranks} ranks"));
            let split = frames(&out);
            for ((name, whole), (_, parts)) in reference.iter().zip(&split) {
                assert!(
                    whole == parts,
                    "{transfer}: {name} differs with {ranks} ranks"
                );
            }
            assert_eq!(split.len(), reference.len());
        }
    }
}

#[test]
fn a_run_stopped_on_two_ranks_resumes_on_three_with_the_same_bytes() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = crossing_scene();
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    let output = firn(&[
        "run",
        scene,
        "--out",
        alone.to_str().unwrap(),
        "--frames",
        "4",
        "--threads",
        "1",
        "--quiet",
    ]);
    assert_success(&output, "one process");
    let split = dir.path().join("split");
    let out = split.to_str().unwrap();
    assert_success(
        &mpirun(2, &["run", scene, "--out", out, "--frames", "2"]),
        "2 ranks",
    );
    assert_success(
        &mpirun(
            3,
            &["run", scene, "--out", out, "--frames", "4", "--resume"],
        ),
        "resumed on 3 ranks",
    );
    assert!(
        frames(&alone) == frames(&split),
        "the resumed frames differ"
    );
}

#[test]
fn a_rank_that_blows_up_stops_every_rank_with_its_message() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // A fixed step far past the elastic limit: the snow blows up at once.
    let text = fs::read_to_string(crossing_scene())
        .unwrap()
        .replace("step = \"adaptive\"", "step = \"fixed\"")
        .replace("cfl = 0.4\n", "")
        .replace("dt = 2e-3", "dt = 3e-2");
    let scene = dir.path().join("unstable.toml");
    fs::write(&scene, text).unwrap();
    let out = dir.path().join("run");
    let output = mpirun(
        3,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("likely cause"), "{stderr}");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "one rank reports: {stderr}"
    );
}

#[test]
fn the_semi_implicit_integrator_is_refused_on_several_ranks() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let scene = crossing_scene();
    let output = mpirun(
        2,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--integrator",
            "semi-implicit",
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("semi-implicit"), "{stderr}");
    assert!(!out.join("manifest.json").exists(), "nothing is written");
}

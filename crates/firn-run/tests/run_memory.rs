//! A run's peak memory stays within its stated share of its solver's: the
//! caches and checkpoints are written from the solver's own arrays, a
//! chunk at a time, not from copies of them. The peak (VmHWM) is a
//! process's, so each side is measured in a child process of this test
//! binary: one that only steps the scene, and one that records it (every
//! particle format, every attribute, a checkpoint at each frame). Linux
//! only, where /proc tells the peak.

#![cfg(target_os = "linux")]

use std::process::Command;

use firn_core::Scene;
use firn_core::scene::{Attribute, Body, CacheFormat, Transfer};
use firn_run::recording::Observer;
use firn_run::{Budget, Placement, Recording, RunDirectory, Solver};
use glam::Vec3;

/// The environment variable that makes this test the child that measures
/// one side: `solver` or `run`, with the run's folder after a colon.
const CHILD: &str = "FIRN_RUN_MEMORY_CHILD";

/// The share of the solver's peak a run may add (besides what the budget
/// says the writers hold: their buffers, which a scene this small notices).
const STATED_SHARE: f64 = 0.10;

/// Frames recorded after frame 0.
const FRAMES: u32 = 2;

/// A snowball of about 34,000 particles (radius 10 cells), ten substeps a
/// frame, written as PLY, VTK and USD with every attribute.
fn scene() -> Scene {
    let mut scene = Scene::builder("run-memory")
        .unit_box(0.02)
        .duration(f64::from(FRAMES) / 1000.0)
        .fps(1000.0)
        .fixed_dt(1e-4)
        .transfer(Transfer::Apic)
        .body(Body::sphere(Vec3::splat(0.5), 0.2).velocity(Vec3::new(0.0, -1.0, 0.0)))
        .attributes([
            Attribute::Velocity,
            Attribute::PlasticJ,
            Attribute::ElasticJ,
            Attribute::Density,
            Attribute::Mass,
            Attribute::Material,
        ])
        .formats([CacheFormat::Ply, CacheFormat::Vtk, CacheFormat::Usd])
        .checkpoint_every(1)
        .build()
        .expect("the snowball is a valid scene");
    scene.render.enabled = false;
    scene
}

/// Watches nothing.
struct Quiet;

impl Observer for Quiet {}

#[test]
fn a_run_takes_at_most_its_stated_share_more_than_its_solver() {
    if let Ok(side) = std::env::var(CHILD) {
        measure(&side);
        return;
    }
    let folder = tempfile::tempdir().expect("a temporary folder");
    let solver = peak_of("solver".to_string());
    let run = peak_of(format!("run:{}", folder.path().join("run").display()));
    let writers = Budget::of(&scene()).writer_bytes;
    let allowed = (solver as f64 * (1.0 + STATED_SHARE)) as u64 + writers;
    let mib = |bytes: u64| bytes as f64 / (1024.0 * 1024.0);
    println!(
        "peak: solver {:.1} MiB, run {:.1} MiB, allowed {:.1} MiB",
        mib(solver),
        mib(run),
        mib(allowed)
    );
    assert!(
        run <= allowed,
        "the run peaked at {:.1} MiB, its solver at {:.1} MiB: more than {:.0} % and the \
         writers' {:.1} MiB over it",
        mib(run),
        mib(solver),
        STATED_SHARE * 100.0,
        mib(writers)
    );
}

/// Runs this test in a child process that measures `side`, and returns
/// the peak it reports.
fn peak_of(side: String) -> u64 {
    let output = Command::new(std::env::current_exe().expect("the test binary"))
        .args([
            "a_run_takes_at_most_its_stated_share_more_than_its_solver",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD, &side)
        .output()
        .expect("the child runs");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "the {side} child failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
        .lines()
        .find_map(|line| line.split_once("peak_bytes=").map(|(_, bytes)| bytes))
        .and_then(|bytes| bytes.trim().parse().ok())
        .unwrap_or_else(|| panic!("the {side} child reported no peak:\n{stdout}"))
}

/// Steps the scene (`solver`) or records it (`run:FOLDER`), then prints
/// this process's peak resident memory.
fn measure(side: &str) {
    let scene = scene();
    let mut solver = Solver::new(scene.clone(), &Placement::Cpu).expect("the scene starts");
    match side.split_once(':') {
        Some(("run", folder)) => {
            let run = RunDirectory::new(folder);
            run.create(&scene).expect("the run directory is created");
            let mut recording =
                Recording::start(solver, run, None, &mut Quiet).expect("frame 0 is recorded");
            recording
                .run_to(FRAMES, &mut Quiet)
                .expect("the frames are recorded");
        }
        _ => {
            for _ in 0..FRAMES {
                solver.advance_frame().expect("the scene steps");
            }
        }
    }
    println!("peak_bytes={}", peak_bytes());
}

/// VmHWM of /proc/self/status, in bytes.
fn peak_bytes() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let line = status
        .lines()
        .find(|line| line.starts_with("VmHWM:"))
        .expect("a VmHWM line");
    let kib: u64 = line
        .split_whitespace()
        .nth(1)
        .and_then(|kib| kib.parse().ok())
        .expect("VmHWM in kB");
    kib * 1024
}

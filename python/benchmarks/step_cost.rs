//! The Rust side of `step_overhead.py`: firn-run's `Solver` stepping a
//! scene file on the CPU with no Python in between, timed the way the
//! script times `Simulation.step(N)`: after warm-up substeps, on THREADS
//! worker threads, in wall-clock and in CPU time (the process's user and
//! system time from /proc/self/stat, so Linux only; CPU time does not count
//! the time other programs take the cores away on a shared machine).
//!
//! ```text
//! cargo build --release --manifest-path python/Cargo.toml --example step_cost
//! python/target/release/examples/step_cost SCENE.toml SUBSTEPS ROUNDS THREADS
//! ```
//!
//! Prints one line per round: particles, substeps, and wall-clock and CPU
//! milliseconds per substep.

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use firn_core::Scene;
use firn_run::{Placement, Solver};

/// Substeps taken before the first timed round (as the script does).
const WARMUP_SUBSTEPS: u32 = 10;

/// Clock ticks per second of /proc/self/stat's times (USER_HZ, 100 on Linux).
const TICKS_PER_SECOND: f64 = 100.0;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, numbers @ ..] = args.as_slice() else {
        return usage();
    };
    let numbers: Result<Vec<u32>, _> = numbers.iter().map(|number| number.parse()).collect();
    let Ok(&[substeps, rounds, threads]) = numbers.as_deref() else {
        return usage();
    };
    match measure(Path::new(scene), substeps, rounds, threads) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
    }
}

/// Says how to call the program.
fn usage() -> ExitCode {
    eprintln!("usage: step_cost SCENE.toml SUBSTEPS ROUNDS THREADS (whole numbers)");
    ExitCode::from(2)
}

/// Measures the scene at `path` on a pool of `threads` threads.
fn measure(
    path: &Path,
    substeps: u32,
    rounds: u32,
    threads: u32,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads as usize)
        .build()?;
    // All of it on the pool's threads, as the Python module steps.
    pool.install(|| stepping(path, substeps, rounds))
}

/// Steps the scene at `path` `rounds` times `substeps` substeps, printing
/// each round's cost.
fn stepping(
    path: &Path,
    substeps: u32,
    rounds: u32,
) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let scene = Scene::load(path)?;
    let mut solver = Solver::new(scene, &Placement::Cpu)?;
    solver.advance_substeps(WARMUP_SUBSTEPS)?;
    for _ in 0..rounds {
        let (started, cpu_before) = (Instant::now(), cpu_seconds()?);
        solver.advance_substeps(substeps)?;
        let wall = started.elapsed().as_secs_f64();
        let cpu = cpu_seconds()? - cpu_before;
        let per_substep = |seconds: f64| seconds * 1e3 / f64::from(substeps);
        println!(
            "rust: {} particles, {substeps} substeps, {:.3} ms wall, {:.3} ms cpu per substep",
            solver.particle_count(),
            per_substep(wall),
            per_substep(cpu)
        );
    }
    Ok(())
}

/// User and system CPU seconds of this process so far.
fn cpu_seconds() -> Result<f64, Box<dyn std::error::Error + Send + Sync>> {
    let stat = std::fs::read_to_string("/proc/self/stat")?;
    // Fields after the command name, which is in parentheses: utime and
    // stime are the 12th and 13th.
    let after_name = stat.rsplit_once(')').ok_or("no command name")?.1;
    let fields: Vec<&str> = after_name.split_whitespace().collect();
    let ticks = fields[11].parse::<u64>()? + fields[12].parse::<u64>()?;
    Ok(ticks as f64 / TICKS_PER_SECOND)
}

//! The `firn` command: run, check and benchmark snow simulations.

// Every line goes through `console`'s macros, which end quietly on a
// closed pipe.
#![deny(clippy::print_stdout, clippy::print_stderr)]

#[macro_use]
mod console;

mod backend;
mod bench;
mod bench_flow;
mod bench_gpu;
mod bench_mesh_field;
mod bench_render;
mod bench_sweep;
mod charts;
mod check;
mod compare;
mod compare_layout;
mod info;
mod launch;
mod machine;
mod pictures;
mod presets;
#[cfg(feature = "mpi")]
mod ranks;
mod render;
mod run;
mod scene_source;
mod view;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Exit code for bad input: a scene, a path or an argument that must be fixed.
const EXIT_BAD_INPUT: u8 = 2;
/// Exit code for a simulation that went unstable or failed to write.
const EXIT_FAILED: u8 = 1;

/// firn: snow simulation with the Material Point Method.
#[derive(Parser, Debug)]
#[command(name = "firn", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate a scene and write particle caches, a manifest and checkpoints.
    Run(run::RunArgs),
    /// Validate a scene and print what it resolves to.
    Check(check::CheckArgs),
    /// List the material presets and their parameters.
    Presets,
    /// Measure solver speed on a snowball-drop scene.
    Bench(bench::BenchArgs),
    /// Re-render a run's frames from its caches (other styles, camera or size).
    Render(render::RenderArgs),
    /// Picture scene variants side by side at given times (the thesis' figures 14-18).
    Compare(compare::CompareArgs),
    /// Show the CPU, the GPU adapters and which backend `--backend auto` takes.
    Info,
    /// Open a window that runs a scene live (or plays back a run) with an
    /// orbit camera and a parameter panel.
    View(view::ViewArgs),
}

/// A failure, classified for the exit code.
#[derive(Debug)]
pub enum Failure {
    /// The user must fix an input (exit code 2).
    BadInput(String),
    /// The run failed (exit code 1).
    Failed(String),
}

/// The environment variable that turns off Mesa's Vulkan device-select layer.
const NODEVICE_SELECT: &str = "NODEVICE_SELECT";

/// Turns off Mesa's Vulkan device-select layer, unless the user set it.
/// The layer asks the Wayland compositor for the desktop's default GPU and,
/// on a headless machine, prints "error: XDG_RUNTIME_DIR is invalid" at
/// every adapter probe (`--backend auto` probes on every run); firn ranks
/// the adapters itself, so it loses nothing without the layer.
// The Vulkan loader reads the process environment, which only the unsafe `set_var` changes.
#[allow(unsafe_code)]
fn quiet_device_select_layer() {
    if std::env::var_os(NODEVICE_SELECT).is_none() {
        // SAFETY: main calls this first, before any thread exists that could
        // read the environment concurrently.
        unsafe { std::env::set_var(NODEVICE_SELECT, "1") };
    }
}

fn main() -> ExitCode {
    quiet_device_select_layer();
    let cli = Cli::parse();
    let result = launch::refuse_mpirun_without_mpi().and_then(|()| match cli.command {
        Command::Run(args) => run::run(args),
        Command::Check(args) => check::check(args),
        Command::Presets => {
            presets::print_presets();
            Ok(())
        }
        Command::Bench(args) => bench::bench(args),
        Command::Render(args) => render::render(args),
        Command::Compare(args) => compare::compare(args),
        Command::Info => info::info(),
        Command::View(args) => view::view(args),
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::BadInput(message)) => {
            say(&message);
            ExitCode::from(EXIT_BAD_INPUT)
        }
        Err(Failure::Failed(message)) => {
            say(&message);
            ExitCode::from(EXIT_FAILED)
        }
    }
}

/// Prints a failure's message on stderr; an empty one (an MPI rank whose
/// failure another rank reports) prints nothing.
fn say(message: &str) {
    if !message.is_empty() {
        errln!("{message}");
    }
}

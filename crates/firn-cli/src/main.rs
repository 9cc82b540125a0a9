//! The `firn` command: run, check and benchmark snow simulations.

mod bench;
mod bench_flow;
mod bench_render;
mod bench_sweep;
mod charts;
mod check;
mod compare;
mod compare_layout;
mod frames;
mod pictures;
mod presets;
mod render;
mod run;
mod scene_source;
mod solver;

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
}

/// A failure, classified for the exit code.
#[derive(Debug)]
pub enum Failure {
    /// The user must fix an input (exit code 2).
    BadInput(String),
    /// The run failed (exit code 1).
    Failed(String),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run(args) => run::run(args),
        Command::Check(args) => check::check(args),
        Command::Presets => {
            presets::print_presets();
            Ok(())
        }
        Command::Bench(args) => bench::bench(args),
        Command::Render(args) => render::render(args),
        Command::Compare(args) => compare::compare(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::BadInput(message)) => {
            eprintln!("{message}");
            ExitCode::from(EXIT_BAD_INPUT)
        }
        Err(Failure::Failed(message)) => {
            eprintln!("{message}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

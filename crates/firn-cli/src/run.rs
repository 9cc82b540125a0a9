//! `firn run`: simulate a scene frame by frame, writing caches, the manifest
//! and checkpoints, with progress on the terminal (a bar) or in logs (a line
//! per frame).

use std::io::IsTerminal;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::Instant;

use clap::Args;
use firn_core::Scene;
use firn_core::scene::Backend;
use firn_run::error::ResumeError;
use firn_run::recording::{FrameToPicture, Observer, Progress, Stepper};
use firn_run::{Budget, Placement, Recording, RunDirectory, RunError, Solver};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::Failure;
use crate::backend::{backend_values, choose_backend};
use crate::bench::IntegratorChoice;
use crate::pictures::prepare_image_dirs;
use crate::scene_source::load_scene;
use firn_run::pictures::{frame_pictures, write_animations};

/// Arguments of `firn run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Scene file (TOML); without one, the bundled snowball-against-a-wall scene runs.
    pub scene: Option<PathBuf>,
    /// Output directory (default: the scene's [output] directory).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Stop after this frame instead of the scene's last frame.
    #[arg(long)]
    pub frames: Option<u32>,
    /// Worker threads (default: all cores). Results are identical for any count.
    #[arg(long)]
    pub threads: Option<usize>,
    /// Continue an interrupted run from its last checkpoint in the output directory.
    #[arg(long)]
    pub resume: bool,
    /// Print nothing but errors and the final summary line.
    #[arg(long, short)]
    pub quiet: bool,
    /// Write caches only: no pictures and no animation.
    #[arg(long)]
    pub no_render: bool,
    /// Picture size as WIDTHxHEIGHT, instead of the scene's `[render] size`
    /// (e.g. a small preview: --size 320x180).
    #[arg(long)]
    pub size: Option<String>,
    /// Time integrator (default: the scene's [solver] integrator).
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorChoice>,
    /// Compute backend (default: the scene's [compute] backend, else auto:
    /// a hardware GPU when there is one, else the CPU).
    #[arg(long, value_parser = backend_values())]
    pub backend: Option<Backend>,
}

/// Runs the simulation described by `args`.
pub fn run(args: RunArgs) -> Result<(), Failure> {
    // Before anything runs in parallel (loading fills bodies on the global
    // pool), so that the pool gets the asked-for size.
    configure_threads(args.threads)?;
    #[cfg(feature = "mpi")]
    if let Some(mpi) = firn_mpi::mpi_exchange::MpiRun::launched() {
        return crate::ranks::run(&args, &mpi);
    }
    let (scene, scene_file) = scene_for(&args)?;
    let chosen = choose_backend(&scene)?;
    if let (Some(note), false) = (&chosen.note, args.quiet) {
        errln!("{note}");
    }
    let placement = chosen.placement;
    let described = placement.describe();
    record(&args, scene, scene_file, &placement, &described, |_| {
        Ok(None)
    })
}

/// The scene of `args` with the command line's overrides applied, and the
/// file it came from.
pub(crate) fn scene_for(args: &RunArgs) -> Result<(Scene, Option<PathBuf>), Failure> {
    let (mut scene, scene_file) = load_scene(args.scene.as_deref())?;
    if let Some(out) = &args.out {
        scene.output.directory = out.clone();
    }
    if args.no_render {
        scene.render.enabled = false;
    }
    if let Some(size) = &args.size {
        scene.render.size = crate::render::parse_size(size)?;
    }
    if let Some(choice) = args.integrator {
        scene.solver.integrator = choice.applied_to(scene.solver.integrator);
    }
    if let Some(backend) = args.backend {
        scene.compute.backend = backend;
    }
    Ok((scene, scene_file))
}

/// Records `scene` on `placement` (described as `described` in the start
/// line) into its output directory, started or resumed as `args` say;
/// `stepper_for` may give a stepper that advances the recording's solver
/// (the ranks of a split run), made once the recording has started.
pub(crate) fn record(
    args: &RunArgs,
    scene: Scene,
    scene_file: Option<PathBuf>,
    placement: &Placement,
    described: &str,
    stepper_for: impl FnOnce(&Solver) -> Result<Option<Box<dyn Stepper>>, RunError>,
) -> Result<(), Failure> {
    // Before anything is written: a scene past the machine leaves no trace.
    Budget::of(&scene)
        .check_placement(&scene, placement)
        .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
    let run = RunDirectory::new(scene.output.directory.clone());
    run.create(&scene).map_err(|error| {
        Failure::BadInput(format!(
            "error: {error}\n  fix: choose a writable directory with --out DIR or [output] directory"
        ))
    })?;
    if scene.render.enabled {
        prepare_image_dirs(&scene, &run)?;
    }
    let last_frame = scene
        .time
        .frame_count()
        .min(args.frames.unwrap_or(u32::MAX));
    let mut terminal = Terminal {
        directory: run.path().to_path_buf(),
        quiet: args.quiet,
        bar: None,
        log_lines: !args.quiet && !std::io::stderr().is_terminal(),
    };
    let (mut recording, mut stepper) = if args.resume {
        let recording = Recording::resume(scene, run, placement).map_err(resume_failure)?;
        let stepper = stepper_for(recording.solver()).map_err(failed)?;
        (recording, stepper)
    } else {
        let solver = Solver::new(scene, placement)
            .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
        let mut stepper = stepper_for(&solver).map_err(failed)?;
        let recording = Recording::start_with(
            solver,
            run,
            scene_file,
            &mut terminal,
            stepper.as_deref_mut(),
        )
        .map_err(failed)?;
        (recording, stepper)
    };
    if !args.quiet {
        announce(&recording, last_frame, described);
    }
    terminal.bar = Some(progress_bar(last_frame, recording.frame(), args.quiet));
    let started = Instant::now();
    match stepper.as_deref_mut() {
        Some(stepper) => recording.run_to_with(last_frame, &mut terminal, stepper),
        None => recording.run_to(last_frame, &mut terminal),
    }
    .map_err(failed)?;
    terminal.clear_bar();
    warn_unconverged(&recording, args.quiet);
    outln!(
        "{}; caches and manifest in {}",
        summary(
            recording.frame(),
            recording.solver().particle_count(),
            started.elapsed().as_secs_f64(),
            recording.mean_cost(),
        ),
        recording.run_directory().path().display()
    );
    Ok(())
}

/// What a run did: frames, particles, time and, when particles were
/// stepped and some are left, the cost per particle-substep.
fn summary(frames: u32, particles: usize, seconds: f64, cost: Option<f64>) -> String {
    let counted = |count: usize, one: &str| match count {
        1 => format!("1 {one}"),
        count => format!("{count} {one}s"),
    };
    let done = format!(
        "firn: {} of {}",
        counted(frames as usize, "frame"),
        counted(particles, "particle")
    );
    match cost.filter(|_| particles > 0) {
        Some(ns) => format!("{done} in {seconds:.1} s ({ns:.0} ns per particle-substep)"),
        None => format!("{done} in {seconds:.1} s"),
    }
}

/// Sets up rayon's pool.
fn configure_threads(threads: Option<usize>) -> Result<(), Failure> {
    if let Some(count) = threads {
        if count == 0 {
            return Err(Failure::BadInput(
                "error: --threads must be at least 1\n  fix: pass --threads 1 or more, or leave it out to use all cores".into(),
            ));
        }
        rayon::ThreadPoolBuilder::new()
            .num_threads(count)
            .build_global()
            .map_err(|error| {
                Failure::Failed(format!("error: cannot start {count} threads: {error}"))
            })?;
    }
    Ok(())
}

/// A run that failed while it was recorded (exit code 1).
fn failed(error: RunError) -> Failure {
    Failure::Failed(format!("error: {error}"))
}

/// A run that cannot be resumed, with what to do instead (exit code 2).
fn resume_failure(error: ResumeError) -> Failure {
    let fix = match error {
        ResumeError::NoCheckpoint { .. } => {
            "run without --resume to start over, or point --out at the run's directory"
        }
        ResumeError::SceneDiffers { .. } => {
            "resume with the same scene file, or run without --resume to start over"
        }
        ResumeError::Restore(_) | ResumeError::Manifest(_) => "run without --resume to start over",
    };
    Failure::BadInput(format!("error: cannot resume: {error}\n  fix: {fix}"))
}

/// Says on stderr what runs where (`described`): the start line.
fn announce(recording: &Recording, last_frame: u32, described: &str) {
    let solver = recording.solver();
    errln!(
        "firn: {}: {} particles, frames {} to {}, on {}",
        solver.scene().name,
        solver.particle_count(),
        recording.frame() + 1,
        last_frame,
        described
    );
}

/// Says on stderr when semi-implicit solves stopped before converging.
fn warn_unconverged(recording: &Recording, quiet: bool) {
    let unconverged = recording.unconverged_substeps();
    if unconverged > 0 && !quiet {
        errln!(
            "warning: the semi-implicit solve stopped before reaching its tolerance in {unconverged} substeps (see \"solver\" in manifest.json)\n  fix: raise [solver] solver_max_iterations, or lower dt"
        );
    }
}

/// What `firn run` shows and draws while a run is recorded: pictures and
/// animations of the frames, and progress as a bar (on a terminal) or a
/// line per frame (in logs: render farms, CI, nohup).
struct Terminal {
    directory: PathBuf,
    quiet: bool,
    /// The progress bar, once the start line is out.
    bar: Option<ProgressBar>,
    log_lines: bool,
}

impl Terminal {
    /// Takes the progress bar off the terminal.
    fn clear_bar(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl Observer for Terminal {
    fn pictures(&mut self, frame: &FrameToPicture<'_>) -> Result<Vec<String>, String> {
        frame_pictures(frame, &self.directory)
    }

    fn frame_recorded(&mut self, progress: &Progress) -> ControlFlow<()> {
        let status = format!(
            "t = {:.3} s, {:.0} substeps/s",
            progress.time,
            progress.substeps_per_second()
        );
        if self.log_lines {
            errln!(
                "frame {}/{}  {status}  ETA {:.0} s",
                progress.frame,
                progress.last_frame,
                progress.seconds_left()
            );
        }
        if let Some(bar) = &self.bar {
            bar.set_position(u64::from(progress.frame));
            bar.set_message(status);
        }
        ControlFlow::Continue(())
    }

    fn animations(&mut self, scene: &Scene, frames: &[u32]) -> Result<Vec<String>, String> {
        self.clear_bar();
        write_animations(scene, &self.directory, frames, self.quiet)
    }
}

/// A progress bar showing frame, simulated time, substeps/s and ETA.
pub fn progress_bar(last_frame: u32, first_frame: u32, quiet: bool) -> ProgressBar {
    let bar = ProgressBar::with_draw_target(
        Some(last_frame as u64),
        if quiet {
            ProgressDrawTarget::hidden()
        } else {
            ProgressDrawTarget::stderr()
        },
    );
    bar.set_style(
        ProgressStyle::with_template("{bar:30.cyan/blue} frame {pos}/{len}  {msg}  ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_position(first_frame as u64);
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_without_particles_left_gives_no_cost_per_particle() {
        assert_eq!(
            summary(1, 0, 0.31, Some(308_169.0)),
            "firn: 1 frame of 0 particles in 0.3 s"
        );
        assert_eq!(
            summary(3, 1200, 2.0, Some(95.4)),
            "firn: 3 frames of 1200 particles in 2.0 s (95 ns per particle-substep)"
        );
        assert_eq!(
            summary(2, 1, 1.0, None),
            "firn: 2 frames of 1 particle in 1.0 s"
        );
    }
}

//! `firn run`: simulate a scene frame by frame, writing caches, the manifest
//! and checkpoints, with progress on the terminal (a bar) or in logs (a line
//! per frame).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use clap::Args;
use firn_core::Scene;
use firn_io::{
    FrameRecord, Manifest, PvdCollection, RunStatus, SolverFrameStats, ensure_writable_dir,
};
use firn_mpm::SolverStats;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::Failure;
use crate::backend::{BackendChoice, Placement, choose_backend};
use crate::bench::IntegratorChoice;
use crate::frames::{prepare_cache_dirs, same_physics, scene_json};
use crate::pictures::{prepare_image_dirs, render_frame, write_animations};
use crate::scene_source::load_scene;
use crate::solver::{Solver, frame_solver_stats};

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
    #[arg(long, value_enum)]
    pub backend: Option<BackendChoice>,
}

/// File name of the checkpoint inside the output directory.
const CHECKPOINT_FILE: &str = "checkpoint.firnckpt";
pub use firn_io::MANIFEST_FILE;

/// Runs the simulation described by `args`.
pub fn run(args: RunArgs) -> Result<(), Failure> {
    // Before anything runs in parallel (loading fills bodies on the global
    // pool), so that the pool gets the asked-for size.
    let threads = configure_threads(args.threads)?;
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
    if let Some(choice) = args.backend {
        scene.compute.backend = choice.backend();
    }
    let chosen = choose_backend(&scene)?;
    if let (Some(note), false) = (&chosen.note, args.quiet) {
        eprintln!("{note}");
    }
    let placement = chosen.placement;
    let directory = scene.output.directory.clone();
    ensure_writable_dir(&directory)
        .and_then(|()| prepare_cache_dirs(&scene, &directory))
        .map_err(|error| {
        Failure::BadInput(format!(
            "error: {error}\n  fix: choose a writable directory with --out DIR or [output] directory"
        ))
    })?;
    if scene.render.enabled {
        prepare_image_dirs(&scene, &directory)?;
    }
    let last_frame = scene
        .time
        .frame_count()
        .min(args.frames.unwrap_or(u32::MAX));
    let scene_json = scene_json(&scene);
    let mut state = if args.resume {
        RunState::resume(scene, &directory, &scene_json, &placement)?
    } else {
        let started = Started {
            scene_file,
            threads,
            placement: &placement,
        };
        RunState::fresh(scene, started, &directory, scene_json)?
    };
    if !args.quiet {
        state.announce(last_frame, &placement);
    }
    state.run_frames(last_frame, args.quiet)
}

/// Sets up rayon's pool; returns the thread count in use.
fn configure_threads(threads: Option<usize>) -> Result<usize, Failure> {
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
    Ok(rayon::current_num_threads())
}

/// How a fresh run was started, for its manifest.
struct Started<'a> {
    scene_file: Option<PathBuf>,
    threads: usize,
    placement: &'a Placement,
}

/// A run in progress: the simulation, where it writes, and what it wrote.
struct RunState {
    simulation: Solver,
    directory: PathBuf,
    manifest: Manifest,
    pvd: PvdCollection,
    frame: u32,
    scene_json: serde_json::Value,
    /// The solver's running totals when the previous frame was recorded.
    solver_totals: Option<SolverStats>,
}

impl RunState {
    /// Starts a new run and writes frame 0 (the initial state).
    fn fresh(
        scene: Scene,
        started: Started<'_>,
        directory: &Path,
        scene_json: serde_json::Value,
    ) -> Result<RunState, Failure> {
        let cells = scene.domain.cells();
        let simulation = Solver::new(scene, started.placement)
            .map_err(|error| Failure::BadInput(format!("error: {error}")))?;
        let manifest = Manifest {
            firn_version: env!("CARGO_PKG_VERSION").to_string(),
            scene_file: started.scene_file.map(|path| path.display().to_string()),
            scene: scene_json.clone(),
            backend: started.placement.name().into(),
            adapter: started.placement.adapter(),
            threads: started.threads,
            particle_count: simulation.particle_count(),
            grid_cells: cells,
            frames: Vec::new(),
            status: RunStatus::Running,
            animations: Vec::new(),
        };
        let mut state = RunState {
            simulation,
            directory: directory.to_path_buf(),
            manifest,
            pvd: PvdCollection::new(),
            frame: 0,
            scene_json,
            solver_totals: None,
        };
        state.record_frame(0, 0, Duration::ZERO)?;
        Ok(state)
    }

    /// Picks up a run from the checkpoint in `directory`, on either backend.
    fn resume(
        scene: Scene,
        directory: &Path,
        scene_json: &serde_json::Value,
        placement: &Placement,
    ) -> Result<RunState, Failure> {
        let checkpoint_path = directory.join(CHECKPOINT_FILE);
        let manifest_path = directory.join(MANIFEST_FILE);
        if !checkpoint_path.exists() {
            return Err(Failure::BadInput(format!(
                "error: cannot resume: no checkpoint at {}\n  fix: run without --resume to start over, or point --out at the run's directory",
                checkpoint_path.display()
            )));
        }
        let (simulation, restored_frame, restored_scene) =
            Solver::resume(scene, &checkpoint_path, placement).map_err(|message| {
                Failure::BadInput(format!(
                    "error: cannot resume: {message}\n  fix: run without --resume to start over"
                ))
            })?;
        if !same_physics(&restored_scene, scene_json) {
            return Err(Failure::BadInput(format!(
                "error: cannot resume: the scene differs from the one that wrote {}\n  fix: resume with the same scene file, or run without --resume to start over",
                checkpoint_path.display()
            )));
        }
        let mut manifest = Manifest::read(&manifest_path).map_err(|error| {
            Failure::BadInput(format!(
                "error: cannot resume: {error}\n  fix: run without --resume to start over"
            ))
        })?;
        manifest
            .frames
            .retain(|record| record.index <= restored_frame);
        manifest.status = RunStatus::Running;
        manifest.threads = rayon::current_num_threads();
        manifest.backend = placement.name().into();
        manifest.adapter = placement.adapter();
        let mut pvd = PvdCollection::read(&directory.join("particles.pvd")).unwrap_or_default();
        pvd.remove_after(simulation.time() + 1e-12);
        Ok(RunState {
            simulation,
            directory: directory.to_path_buf(),
            manifest,
            pvd,
            frame: restored_frame,
            scene_json: scene_json.clone(),
            solver_totals: None,
        })
    }

    /// Says on stderr what runs where: the start line.
    fn announce(&self, last_frame: u32, placement: &Placement) {
        eprintln!(
            "firn: {}: {} particles, frames {} to {}, on {}",
            self.simulation.scene().name,
            self.simulation.particle_count(),
            self.frame + 1,
            last_frame,
            placement.describe()
        );
    }

    /// Simulates and writes frames up to `last_frame`.
    fn run_frames(&mut self, last_frame: u32, quiet: bool) -> Result<(), Failure> {
        let fps = self.simulation.scene().time.fps;
        let progress = progress_bar(last_frame, self.frame, quiet);
        // Logs (render farms, CI, nohup) get a plain line per frame instead of a bar.
        let log_lines = !quiet && !std::io::stderr().is_terminal();
        let first_frame = self.frame;
        let started = Instant::now();
        let mut substeps_total = 0u64;
        while self.frame < last_frame {
            let frame = self.frame + 1;
            let frame_started = Instant::now();
            let substeps = match self.simulation.advance_to(frame as f64 / fps) {
                Ok(substeps) => substeps,
                Err(error) => {
                    return Err(self.fail(format!(
                        "error: the simulation stopped in frame {frame}: {error}"
                    )));
                }
            };
            self.record_frame(frame, substeps, frame_started.elapsed())?;
            substeps_total += substeps as u64;
            let rate = substeps_total as f64 / started.elapsed().as_secs_f64().max(1e-9);
            let status = format!("t = {:.3} s, {rate:.0} substeps/s", self.simulation.time());
            if log_lines {
                let elapsed = started.elapsed().as_secs_f64();
                let eta = elapsed / (frame - first_frame) as f64 * (last_frame - frame) as f64;
                eprintln!("frame {frame}/{last_frame}  {status}  ETA {eta:.0} s");
            }
            progress.set_position(self.frame as u64);
            progress.set_message(status);
        }
        progress.finish_and_clear();
        self.write_animations(quiet)?;
        self.write_checkpoint()?;
        if last_frame >= self.simulation.scene().time.frame_count() {
            self.manifest.status = RunStatus::Finished;
        }
        self.write_manifest()?;
        self.warn_unconverged(quiet);
        let cost = self.mean_cost();
        println!(
            "firn: {} frames of {} particles in {:.1} s ({cost:.0} ns per particle-substep); caches and manifest in {}",
            self.frame,
            self.simulation.particle_count(),
            started.elapsed().as_secs_f64(),
            self.directory.display()
        );
        Ok(())
    }

    /// Writes the current frame's caches, its manifest record and, when due, a checkpoint.
    fn record_frame(&mut self, index: u32, substeps: u32, wall: Duration) -> Result<(), Failure> {
        let files = self
            .simulation
            .write_frame(index, &self.directory, &mut self.pvd)
            .map_err(|error| self.fail(format!("error: {error}")))?;
        let images = self.render_frame(index)?;
        let particles = self.simulation.particle_count().max(1) as f64;
        let wall_seconds = wall.as_secs_f64();
        let solver = self.frame_solver_stats();
        self.manifest.record_frame(FrameRecord {
            index,
            time: self.simulation.time(),
            substeps,
            wall_seconds,
            ns_per_particle_substep: if substeps > 0 {
                wall_seconds * 1e9 / (particles * substeps as f64)
            } else {
                0.0
            },
            files,
            images,
            solver,
        });
        self.frame = index;
        let every = self.simulation.scene().output.checkpoint_every;
        if every > 0 && index > 0 && index.is_multiple_of(every) {
            self.write_checkpoint()?;
        }
        self.write_manifest()
    }

    /// The solver's work since the previous frame, if it runs a semi-implicit solve.
    fn frame_solver_stats(&mut self) -> Option<SolverFrameStats> {
        let totals = self.simulation.solver_stats()?;
        let stats = frame_solver_stats(self.solver_totals, totals);
        self.solver_totals = Some(totals);
        Some(stats)
    }

    /// Renders the current state in every style of the scene, if rendering is on.
    fn render_frame(&mut self, index: u32) -> Result<Vec<String>, Failure> {
        let scene = self.simulation.scene();
        if !scene.render.enabled {
            return Ok(Vec::new());
        }
        let (directory, time) = (&self.directory, self.simulation.time());
        let rendered = self
            .simulation
            .with_frame_particles(|frame| render_frame(scene, directory, index, time, frame));
        rendered.map_err(|error| self.fail(format!("error: {error}")))
    }

    /// Writes the animations of all frames rendered so far.
    fn write_animations(&mut self, quiet: bool) -> Result<(), Failure> {
        let scene = self.simulation.scene();
        if !scene.render.enabled {
            return Ok(());
        }
        let frames: Vec<u32> = self.manifest.frames.iter().map(|f| f.index).collect();
        self.manifest.animations = write_animations(scene, &self.directory, &frames, quiet)
            .map_err(|error| self.fail(format!("error: {error}")))?;
        Ok(())
    }

    fn write_checkpoint(&mut self) -> Result<(), Failure> {
        let path = self.directory.join(CHECKPOINT_FILE);
        self.simulation
            .write_checkpoint(self.frame, &self.scene_json, &path)
            .map_err(|error| self.fail(format!("error: {error}")))
    }

    fn write_manifest(&mut self) -> Result<(), Failure> {
        let path = self.directory.join(MANIFEST_FILE);
        self.manifest
            .write(&path)
            .map_err(|error| Failure::Failed(format!("error: {error}")))
    }

    /// Records a failure in the manifest (best effort) and classifies it.
    fn fail(&mut self, message: String) -> Failure {
        self.manifest.status = RunStatus::Failed {
            message: message.clone(),
        };
        // The run has already failed; a manifest that cannot be written changes nothing.
        let _ = self.manifest.write(&self.directory.join(MANIFEST_FILE));
        Failure::Failed(message)
    }

    /// Says on stderr when semi-implicit solves stopped before converging.
    fn warn_unconverged(&self, quiet: bool) {
        let unconverged: u64 = self
            .manifest
            .frames
            .iter()
            .filter_map(|record| record.solver)
            .map(|stats| stats.unconverged)
            .sum();
        if unconverged > 0 && !quiet {
            eprintln!(
                "warning: the semi-implicit solve stopped before reaching its tolerance in {unconverged} substeps (see \"solver\" in manifest.json)\n  fix: raise [solver] solver_max_iterations, or lower dt"
            );
        }
    }

    /// Mean cost over the frames of this manifest that took substeps.
    fn mean_cost(&self) -> f64 {
        let (seconds, work) =
            self.manifest
                .frames
                .iter()
                .fold((0.0, 0.0), |(seconds, work), record| {
                    (seconds + record.wall_seconds, work + record.substeps as f64)
                });
        if work > 0.0 {
            seconds * 1e9 / (work * self.manifest.particle_count.max(1) as f64)
        } else {
            0.0
        }
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

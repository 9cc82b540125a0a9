//! [`Recording`]: a run in progress, as `firn run` makes one: a solver
//! stepped frame by frame, each frame written to the run directory (caches,
//! pictures, a manifest record), a checkpoint every `checkpoint_every`
//! frames and at the end, and the manifest kept current so that an
//! interrupted run can be resumed or read.
//!
//! What is shown while it runs and how pictures are made is the front
//! door's: it hands in an [`Observer`], which can also stop the run between
//! two frames.

use std::ops::ControlFlow;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use firn_core::Scene;
use firn_io::{
    BodyPose, ColliderPose, FrameRecord, Manifest, MassBalance, PvdCollection, RunStatus,
    SolverFrameStats,
};
use firn_mesh::TriangleMesh;
use firn_mpm::SolverStats;

use crate::backend::Placement;
use crate::caches;
use crate::checkpoint::{self, same_physics, scene_json};
use crate::error::{ResumeError, RunError};
use crate::run_dir::RunDirectory;
use crate::simulation::{HostParticles, HostState, Solver};

/// A run in progress: its solver, where it writes, and what it wrote.
pub struct Recording {
    solver: Solver,
    run: RunDirectory,
    manifest: Manifest,
    pvd: PvdCollection,
    /// The last frame recorded.
    frame: u32,
    scene_json: serde_json::Value,
    /// The solver's running totals when the previous frame was recorded.
    solver_totals: Option<SolverStats>,
}

/// Who brings a recording's solver to the end of each frame, when the
/// solver does not step itself: the ranks of a run split between processes
/// (firn-mpi), which step their parts and hand the whole state back.
pub trait Stepper {
    /// Brings `solver` to simulated time `until`; returns the substeps taken.
    fn advance_to(&mut self, solver: &mut Solver, until: f64) -> Result<u32, RunError>;

    /// Where the run's work is done, for the manifest, when not where the
    /// recording's solver is (MPI ranks on GPUs: the solver only holds the
    /// state rank 0 gathers). `None`: the solver's placement.
    fn placement(&self) -> Option<Placement> {
        None
    }

    /// Writes frame `index` (at simulated time `time`) as VTK pieces, one
    /// per part of the run, into `run` in place of the recording's one VTK
    /// file; returns each piece's part and path relative to the run
    /// directory. `None`: the stepper writes no pieces.
    fn write_vtk_pieces(
        &mut self,
        index: u32,
        time: f64,
        run: &RunDirectory,
    ) -> Option<Result<Vec<(u32, String)>, RunError>> {
        let _ = (index, time, run);
        None
    }

    /// Writes the checkpoint after frame `frame` of the scene `scene_json`
    /// in pieces of its own, in place of the recording's one checkpoint
    /// file. `None`: the stepper writes none.
    fn write_checkpoint(
        &mut self,
        frame: u32,
        scene_json: &serde_json::Value,
        run: &RunDirectory,
    ) -> Option<Result<(), RunError>> {
        let _ = (frame, scene_json, run);
        None
    }
}

/// What a front door does while a run is recorded. Every method does
/// nothing by default.
pub trait Observer {
    /// Makes the pictures of a frame just written (called only when the
    /// scene's `[render] enabled` is on); returns their paths relative to
    /// the run directory.
    fn pictures(&mut self, frame: &FrameToPicture<'_>) -> Result<Vec<String>, String> {
        let _ = frame;
        Ok(Vec::new())
    }

    /// Hears that a frame was recorded; `Break` stops the run there (see
    /// [`Recording::run_to`]).
    fn frame_recorded(&mut self, progress: &Progress) -> ControlFlow<()> {
        let _ = progress;
        ControlFlow::Continue(())
    }

    /// Makes the animations of the frames `frames` (their indices, in
    /// order, all pictured) once the last is recorded (called only when
    /// the scene's `[render] enabled` is on); returns their paths relative
    /// to the run directory.
    fn animations(&mut self, scene: &Scene, frames: &[u32]) -> Result<Vec<String>, String> {
        let _ = (scene, frames);
        Ok(Vec::new())
    }
}

/// A frame to make pictures of.
pub struct FrameToPicture<'a> {
    /// The scene simulated.
    pub scene: &'a Scene,
    /// The frame's index.
    pub index: u32,
    /// Its simulated time.
    pub time: f64,
    /// Its particles, with the values of the scene's `color_by`.
    pub particles: HostParticles<'a>,
    /// The snow's surface, where the `mesh` cache made it for this frame
    /// (so that the `surface` style need not make it again).
    pub surface: Option<&'a TriangleMesh>,
}

/// How far a run has come, after a frame.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// The frame just recorded.
    pub frame: u32,
    /// The frame this session of the run started after.
    pub first_frame: u32,
    /// The frame the run stops after.
    pub last_frame: u32,
    /// Simulated time reached.
    pub time: f64,
    /// Substeps taken in this session.
    pub substeps: u64,
    /// Wall-clock time of this session.
    pub elapsed: Duration,
}

impl Progress {
    /// Substeps per wall-clock second in this session.
    pub fn substeps_per_second(&self) -> f64 {
        self.substeps as f64 / self.elapsed.as_secs_f64().max(1e-9)
    }

    /// Wall-clock seconds left at this session's pace.
    pub fn seconds_left(&self) -> f64 {
        let done = f64::from(self.frame - self.first_frame);
        self.elapsed.as_secs_f64() / done * f64::from(self.last_frame - self.frame)
    }
}

impl Recording {
    /// Starts a new run of `solver` (at time 0) in `run`, whose folders
    /// exist ([`RunDirectory::create`]), and records frame 0. `scene_file`
    /// is where the scene came from, for the manifest.
    pub fn start(
        solver: Solver,
        run: RunDirectory,
        scene_file: Option<PathBuf>,
        observer: &mut dyn Observer,
    ) -> Result<Recording, RunError> {
        Recording::start_with(solver, run, scene_file, observer, None)
    }

    /// [`Recording::start`] for a solver that `stepper` advances (the ranks
    /// of a split run), which may write frame 0's VTK pieces.
    pub fn start_with(
        solver: Solver,
        run: RunDirectory,
        scene_file: Option<PathBuf>,
        observer: &mut dyn Observer,
        stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<Recording, RunError> {
        let scene = solver.scene();
        let scene_json = scene_json(scene);
        let placement = stepper
            .as_ref()
            .and_then(|stepper| stepper.placement())
            .unwrap_or_else(|| solver.placement());
        let manifest = Manifest {
            firn_version: env!("CARGO_PKG_VERSION").to_string(),
            scene_file: scene_file.map(|path| path.display().to_string()),
            scene: scene_json.clone(),
            backend: placement.name().into(),
            adapter: placement.adapter(),
            threads: rayon::current_num_threads(),
            particle_count: solver.particle_count(),
            grid_cells: scene.domain.cells(),
            frames: Vec::new(),
            status: RunStatus::Running,
            animations: Vec::new(),
        };
        let mut recording = Recording {
            solver,
            run,
            manifest,
            pvd: PvdCollection::new(),
            frame: 0,
            scene_json,
            solver_totals: None,
        };
        recording.record_frame(0, 0, Duration::ZERO, observer, stepper)?;
        Ok(recording)
    }

    /// Picks up the run in `run` from its checkpoint, to continue `scene`
    /// where `placement` says (the checkpoint may come from either backend).
    pub fn resume(
        scene: Scene,
        run: RunDirectory,
        placement: &Placement,
    ) -> Result<Recording, ResumeError> {
        let (saved, checkpoint_path) = checkpoint::read_latest(&run, &scene)?;
        let scene_json = scene_json(&scene);
        let solver = Solver::restore(scene, saved.state, placement)?;
        if !same_physics(&saved.scene_json, &scene_json) {
            return Err(ResumeError::SceneDiffers {
                path: checkpoint_path,
            });
        }
        let mut manifest = Manifest::read(&run.manifest_path()).map_err(ResumeError::Manifest)?;
        manifest.frames.retain(|record| record.index <= saved.frame);
        manifest.status = RunStatus::Running;
        manifest.threads = rayon::current_num_threads();
        manifest.backend = placement.name().into();
        manifest.adapter = placement.adapter();
        let mut pvd = PvdCollection::read(&run.collection_path()).unwrap_or_default();
        pvd.remove_after(solver.time() + 1e-12);
        Ok(Recording {
            solver,
            run,
            manifest,
            pvd,
            frame: saved.frame,
            scene_json,
            solver_totals: None,
        })
    }

    /// The solver.
    pub fn solver(&self) -> &Solver {
        &self.solver
    }

    /// The last frame recorded.
    pub fn frame(&self) -> u32 {
        self.frame
    }

    /// Where the run writes.
    pub fn run_directory(&self) -> &RunDirectory {
        &self.run
    }

    /// Simulates and records the frames after the last one up to
    /// `last_frame`, then the animations and a checkpoint; the run is
    /// finished when `last_frame` is the scene's last. A failure is written
    /// into the manifest before it is returned.
    ///
    /// When the observer stops the run after a frame, that frame is the
    /// last: a checkpoint of it is written, no animations, and the manifest
    /// keeps the status `running`, as a run killed by Ctrl-C leaves it, so
    /// that [`Recording::resume`] continues from there. [`Recording::frame`]
    /// says where it stopped.
    pub fn run_to(&mut self, last_frame: u32, observer: &mut dyn Observer) -> Result<(), RunError> {
        self.run_frames(last_frame, observer, None)
    }

    /// [`Recording::run_to`] with the solver advanced by `stepper` (the
    /// ranks of a split run) rather than by itself. The stepper is lent, not
    /// kept, so that a recording stays `Send` while a stepper need not be
    /// (an MPI communicator is not).
    pub fn run_to_with(
        &mut self,
        last_frame: u32,
        observer: &mut dyn Observer,
        stepper: &mut dyn Stepper,
    ) -> Result<(), RunError> {
        self.run_frames(last_frame, observer, Some(stepper))
    }

    /// [`Recording::run_to`], advanced by `stepper` where there is one.
    fn run_frames(
        &mut self,
        last_frame: u32,
        observer: &mut dyn Observer,
        mut stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<(), RunError> {
        let first_frame = self.frame;
        let started = Instant::now();
        let mut substeps_total = 0u64;
        while self.frame < last_frame {
            let frame = self.frame + 1;
            let frame_started = Instant::now();
            let substeps = self
                .advance_to_frame(frame, stepper.as_deref_mut())
                .map_err(|error| self.fail(error))?;
            self.record_frame(
                frame,
                substeps,
                frame_started.elapsed(),
                observer,
                stepper.as_deref_mut(),
            )?;
            substeps_total += u64::from(substeps);
            let asked = observer.frame_recorded(&Progress {
                frame,
                first_frame,
                last_frame,
                time: self.solver.time(),
                substeps: substeps_total,
                elapsed: started.elapsed(),
            });
            if asked.is_break() {
                return self.write_checkpoint(stepper);
            }
        }
        self.write_animations(observer)?;
        self.write_checkpoint(stepper)?;
        if last_frame >= self.solver.scene().time.frame_count() {
            self.manifest.status = RunStatus::Finished;
        }
        self.write_manifest()
    }

    /// Substeps over the whole run whose semi-implicit solve stopped before
    /// reaching its tolerance.
    pub fn unconverged_substeps(&self) -> u64 {
        self.manifest
            .frames
            .iter()
            .filter_map(|record| record.solver)
            .map(|stats| stats.unconverged)
            .sum()
    }

    /// Mean wall-clock nanoseconds per particle-substep over the frames
    /// recorded that took substeps, each frame's particle-substeps counted
    /// with its own particle count (a flow's emitters fill it over time);
    /// `None` when no frame stepped a particle.
    pub fn mean_cost(&self) -> Option<f64> {
        let (seconds, work) = self
            .manifest
            .frames
            .iter()
            .filter(|record| record.ns_per_particle_substep > 0.0)
            .fold((0.0, 0.0), |(seconds, work), record| {
                let particle_substeps = record.wall_seconds * 1e9 / record.ns_per_particle_substep;
                (seconds + record.wall_seconds, work + particle_substeps)
            });
        (work > 0.0).then(|| seconds * 1e9 / work)
    }

    /// Advances the solver to the end of `frame` and brings its particles
    /// to the host; returns the substeps taken.
    fn advance_to_frame(
        &mut self,
        frame: u32,
        stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<u32, RunError> {
        let fps = self.solver.scene().time.fps;
        let stopped = |error| RunError::Stopped {
            frame,
            source: Box::new(error),
        };
        let until = frame as f64 / fps;
        let substeps = match stepper {
            Some(stepper) => stepper.advance_to(&mut self.solver, until),
            None => self.solver.advance_to(until),
        }
        .map_err(stopped)?;
        self.solver.host().map_err(stopped)?;
        Ok(substeps)
    }

    /// Writes the current state as frame `index`: its caches, pictures and
    /// manifest record and, when due, a checkpoint.
    fn record_frame(
        &mut self,
        index: u32,
        substeps: u32,
        wall: Duration,
        observer: &mut dyn Observer,
        mut stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<(), RunError> {
        let (files, images) = self
            .write_frame_files(index, observer, stepper.as_deref_mut())
            .map_err(|error| self.fail(error))?;
        let particles = self.solver.particle_count().max(1) as f64;
        let wall_seconds = wall.as_secs_f64();
        let solver = self.frame_solver_stats();
        let mass = self.mass_balance().map_err(|error| self.fail(error))?;
        let rigid_bodies = self.body_poses().map_err(|error| self.fail(error))?;
        self.manifest.record_frame(FrameRecord {
            index,
            time: self.solver.time(),
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
            mass,
            colliders: collider_poses(self.solver.scene(), self.solver.time()),
            rigid_bodies,
        });
        self.frame = index;
        let every = self.solver.scene().output.checkpoint_every;
        if every > 0 && index > 0 && index.is_multiple_of(every) {
            self.write_checkpoint(stepper)?;
        }
        self.write_manifest()
    }

    /// Writes frame `index`'s caches and has its pictures made; returns
    /// both lists of files.
    fn write_frame_files(
        &mut self,
        index: u32,
        observer: &mut dyn Observer,
        stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<(Vec<String>, Vec<String>), RunError> {
        let time = self.solver.time();
        let pieces = stepper
            .and_then(|stepper| stepper.write_vtk_pieces(index, time, &self.run))
            .transpose()?;
        let host = self.solver.host()?;
        let written =
            caches::write_frame_with_pieces(host, index, &self.run, &mut self.pvd, pieces)?;
        let scene = host.scene();
        if !scene.render.enabled {
            return Ok((written.files, Vec::new()));
        }
        let frame = FrameToPicture {
            scene,
            index,
            time: host.time(),
            particles: host.particles(scene.render.color_by),
            surface: written.surface.as_ref(),
        };
        let images = observer.pictures(&frame).map_err(RunError::Pictures)?;
        Ok((written.files, images))
    }

    /// Where the snow's mass is now, for a scene with spindrift.
    fn mass_balance(&mut self) -> Result<Option<MassBalance>, RunError> {
        let HostState::Snow(simulation) = self.solver.host()? else {
            return Ok(None);
        };
        let spindrift = simulation.scene().spindrift().is_some();
        if !spindrift {
            return Ok(None);
        }
        let snow = simulation.particles();
        let drift = simulation.drift();
        let escaped = simulation.escaped();
        let snow_mass = snow.mass.iter().fold(0.0, |sum, &m| sum + f64::from(m));
        let drift_mass = drift.total_mass();
        Ok(Some(MassBalance {
            snow: snow_mass,
            drift: drift_mass,
            escaped: escaped.mass,
            total: snow_mass + drift_mass + escaped.mass,
            snow_particles: snow.len() as u64,
            drift_particles: drift.len() as u64,
            escaped_particles: escaped.count,
        }))
    }

    /// The pose of each of the scene's rigid bodies now.
    fn body_poses(&mut self) -> Result<Vec<BodyPose>, RunError> {
        Ok(self.solver.host()?.body_poses())
    }

    /// The solver's work since the previous frame, if it runs a
    /// semi-implicit solve.
    fn frame_solver_stats(&mut self) -> Option<SolverFrameStats> {
        let totals = self.solver.solver_stats()?;
        let stats = frame_solver_stats(self.solver_totals, totals);
        self.solver_totals = Some(totals);
        Some(stats)
    }

    /// Has the animations of all frames recorded made, if pictures are.
    fn write_animations(&mut self, observer: &mut dyn Observer) -> Result<(), RunError> {
        let scene = self.solver.scene();
        if !scene.render.enabled {
            return Ok(());
        }
        let frames: Vec<u32> = self.manifest.frames.iter().map(|f| f.index).collect();
        let animations = observer
            .animations(scene, &frames)
            .map_err(|error| self.fail(RunError::Pictures(error)))?;
        self.manifest.animations = animations;
        Ok(())
    }

    /// Writes a checkpoint of the last frame recorded (in the stepper's
    /// pieces, where it writes them).
    fn write_checkpoint(
        &mut self,
        stepper: Option<&mut (dyn Stepper + '_)>,
    ) -> Result<(), RunError> {
        let pieces = stepper
            .and_then(|stepper| stepper.write_checkpoint(self.frame, &self.scene_json, &self.run));
        if let Some(written) = pieces {
            return written.map_err(|error| self.fail(error));
        }
        let path = self.run.checkpoint_path();
        self.solver
            .write_checkpoint(self.frame, &self.scene_json, &path)
            .map_err(|error| self.fail(error))
    }

    /// Writes the manifest as it is now.
    fn write_manifest(&self) -> Result<(), RunError> {
        Ok(self.manifest.write(&self.run.manifest_path())?)
    }

    /// Records `error` in the manifest (best effort: the run has failed
    /// already) and returns it.
    fn fail(&mut self, error: RunError) -> RunError {
        self.manifest.status = RunStatus::Failed {
            message: format!("error: {error}"),
        };
        // A manifest that cannot be written changes nothing about the failure.
        let _ = self.write_manifest();
        error
    }
}

/// The solver's work between two readings of its running totals.
fn frame_solver_stats(before: Option<SolverStats>, after: SolverStats) -> SolverFrameStats {
    let before = before.unwrap_or_default();
    let solves = after.steps - before.steps;
    let iterations = after.total_iterations - before.total_iterations;
    SolverFrameStats {
        solves,
        iterations,
        mean_iterations: if solves > 0 {
            iterations as f64 / solves as f64
        } else {
            0.0
        },
        final_residual: after.last_residual,
        unconverged: after.unconverged_steps - before.unconverged_steps,
    }
}

/// The pose of each of `scene`'s colliders at `time`, for the manifest and
/// the USD stage.
pub fn collider_poses(scene: &Scene, time: f64) -> Vec<ColliderPose> {
    scene
        .colliders
        .iter()
        .map(|collider| {
            let pose = collider.pose_at(time);
            ColliderPose {
                position: pose.position.to_array(),
                rotation: pose.rotation.to_array(),
            }
        })
        .collect()
}

//! The simulation behind a run: snow on the MPM solver, or particles in a
//! curl-noise flow, on the CPU or the GPU. `firn run` drives each through
//! this one interface: step to a time, write a frame's caches, render it,
//! checkpoint it.
//!
//! A GPU simulation keeps a CPU mirror, rebuilt from the GPU's particles
//! after each frame's advance, and writes, renders and checkpoints from it
//! with the CPU code; a checkpoint therefore resumes on either backend.

use std::path::Path;
use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{ColorBy, SceneKind};
use firn_flow::{FlowSimulation, FlowSnapshot};
use firn_gpu::{GpuContext, GpuError, GpuFlow, GpuSnow};
use firn_io::{Attribute, Checkpoint, FrameData, IoError, PvdCollection, SolverFrameStats};
use firn_mpm::{Simulation, Snapshot, SolverStats};
use firn_render::scene_view::FrameParticles;
use firn_render::trails::Trails;
use glam::Vec3;

use crate::backend::Placement;
use crate::frames::{read_checkpoint, write_caches, write_checkpoint, write_frame};

/// A running simulation of either kind.
pub enum Solver {
    /// Snow on the CPU MPM solver.
    Snow(Box<Simulation>),
    /// Particles carried by a curl-noise flow.
    Flow(Box<FlowSimulation>),
    /// Snow on the GPU.
    GpuSnow(Box<GpuSnowRun>),
    /// A curl-noise flow on the GPU.
    GpuFlow(Box<GpuFlowRun>),
}

/// Snow on the GPU and the CPU mirror of its last frame.
pub struct GpuSnowRun {
    gpu: GpuSnow,
    mirror: Simulation,
}

impl GpuSnowRun {
    /// Moves `mirror`'s state to the GPU.
    fn start(context: Arc<GpuContext>, mirror: Simulation) -> Result<GpuSnowRun, GpuError> {
        let gpu = GpuSnow::from_snapshot(context, mirror.scene().clone(), mirror.snapshot())?;
        Ok(GpuSnowRun { gpu, mirror })
    }

    /// Advances the GPU to `until` and refreshes the mirror from it.
    fn advance_to(&mut self, until: f64) -> Result<u32, GpuError> {
        let substeps = self.gpu.advance_to(until)?;
        self.mirror = Simulation::from_snapshot(self.gpu.scene().clone(), self.gpu.snapshot()?)?;
        Ok(substeps)
    }
}

/// A curl-noise flow on the GPU and the CPU mirror of its last frame.
pub struct GpuFlowRun {
    gpu: GpuFlow,
    mirror: FlowSimulation,
}

impl GpuFlowRun {
    /// Moves `mirror`'s state to the GPU.
    fn start(context: Arc<GpuContext>, mirror: FlowSimulation) -> Result<GpuFlowRun, GpuError> {
        let gpu = GpuFlow::from_snapshot(context, mirror.scene().clone(), mirror.snapshot())?;
        Ok(GpuFlowRun { gpu, mirror })
    }

    /// Advances the GPU to `until` and refreshes the mirror from it.
    fn advance_to(&mut self, until: f64) -> Result<u32, GpuError> {
        let substeps = self.gpu.advance_to(until)?;
        self.mirror =
            FlowSimulation::from_snapshot(self.gpu.scene().clone(), self.gpu.snapshot()?)?;
        Ok(substeps)
    }
}

/// A solver's state as the CPU code reads it, whatever computes it.
enum View<'a> {
    Snow(&'a Simulation),
    Flow(&'a FlowSimulation),
}

/// A frame's trails, flattened oldest first for the renderer.
pub struct FlatTrails {
    points: Vec<Vec3>,
    capacity: usize,
    lengths: Vec<u32>,
}

impl FlatTrails {
    /// The renderer's view of these trails.
    pub fn view(&self) -> Trails<'_> {
        Trails {
            points: &self.points,
            capacity: self.capacity,
            lengths: &self.lengths,
        }
    }
}

impl Solver {
    /// Starts the scene's simulation at time 0 where `placement` says.
    pub fn new(scene: Scene, placement: &Placement) -> Result<Solver, String> {
        match scene.kind {
            SceneKind::Snow => {
                let simulation = Simulation::new(scene).map_err(|error| error.to_string())?;
                Solver::snow(simulation, placement)
            }
            SceneKind::Flow(_) => {
                let flow = FlowSimulation::new(scene).map_err(|error| error.to_string())?;
                Solver::flow(flow, placement)
            }
        }
    }

    /// A flow continuing from `flow`'s state where `placement` says.
    fn flow(flow: FlowSimulation, placement: &Placement) -> Result<Solver, String> {
        match placement {
            Placement::Cpu => Ok(Solver::Flow(Box::new(flow))),
            Placement::Gpu(context) => GpuFlowRun::start(Arc::clone(context), flow)
                .map(|run| Solver::GpuFlow(Box::new(run)))
                .map_err(|error| error.to_string()),
        }
    }

    /// Snow continuing from `simulation`'s state where `placement` says.
    fn snow(simulation: Simulation, placement: &Placement) -> Result<Solver, String> {
        match placement {
            Placement::Cpu => Ok(Solver::Snow(Box::new(simulation))),
            Placement::Gpu(context) => GpuSnowRun::start(Arc::clone(context), simulation)
                .map(|run| Solver::GpuSnow(Box::new(run)))
                .map_err(|error| error.to_string()),
        }
    }

    /// The state the CPU code writes and renders from.
    fn view(&self) -> View<'_> {
        match self {
            Solver::Snow(simulation) => View::Snow(simulation),
            Solver::GpuSnow(run) => View::Snow(&run.mirror),
            Solver::Flow(flow) => View::Flow(flow),
            Solver::GpuFlow(run) => View::Flow(&run.mirror),
        }
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        match self.view() {
            View::Snow(simulation) => simulation.scene(),
            View::Flow(flow) => flow.scene(),
        }
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        match self.view() {
            View::Snow(simulation) => simulation.time(),
            View::Flow(flow) => flow.time(),
        }
    }

    /// Current number of particles.
    pub fn particle_count(&self) -> usize {
        match self.view() {
            View::Snow(simulation) => simulation.particles().len(),
            View::Flow(flow) => flow.len(),
        }
    }

    /// The semi-implicit solver's running totals (snow with that integrator
    /// on the CPU only).
    pub fn solver_stats(&self) -> Option<SolverStats> {
        match self {
            Solver::Snow(simulation) => simulation.solver_stats(),
            Solver::Flow(_) | Solver::GpuSnow(_) | Solver::GpuFlow(_) => None,
        }
    }

    /// Advances to simulated time `until`; returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, String> {
        match self {
            Solver::Snow(simulation) => simulation
                .advance_to(until)
                .map_err(|error| error.to_string()),
            Solver::Flow(flow) => Ok(flow.advance_to(until)),
            Solver::GpuSnow(run) => run.advance_to(until).map_err(|error| error.to_string()),
            Solver::GpuFlow(run) => run.advance_to(until).map_err(|error| error.to_string()),
        }
    }

    /// Writes frame `index`'s caches; returns their paths relative to `directory`.
    pub fn write_frame(
        &self,
        index: u32,
        directory: &Path,
        pvd: &mut PvdCollection,
    ) -> Result<Vec<String>, IoError> {
        match self.view() {
            View::Snow(simulation) => write_frame(simulation, index, directory, pvd),
            View::Flow(flow) => {
                let frame = FrameData::new(index, flow.time(), flow.positions())
                    .with_attribute(Attribute::vector("velocity", flow.velocities()))
                    .with_attribute(Attribute::scalar("age", flow.ages()));
                write_caches(flow.scene(), &frame, directory, pvd)
            }
        }
    }

    /// Calls `draw` with this frame's particles as the renderer needs them.
    pub fn with_frame_particles<T>(&self, draw: impl FnOnce(FrameParticles<'_>) -> T) -> T {
        match self.view() {
            View::Snow(simulation) => {
                let particles = simulation.particles();
                let values = simulation.color_values(simulation.scene().render.color_by);
                draw(FrameParticles {
                    positions: &particles.position,
                    masses: Some(&particles.mass),
                    values: values.as_deref(),
                    trails: None,
                })
            }
            View::Flow(flow) => {
                let trails = flat_trails(flow);
                // Only speed is a ramp quantity of a flow; others need no values.
                let speeds = (flow.scene().render.color_by == ColorBy::Speed).then(|| {
                    flow.velocities()
                        .iter()
                        .map(|v| v.length())
                        .collect::<Vec<f32>>()
                });
                draw(FrameParticles {
                    positions: flow.positions(),
                    masses: None,
                    values: speeds.as_deref(),
                    trails: trails.as_ref().map(FlatTrails::view),
                })
            }
        }
    }

    /// Writes a checkpoint taken after frame `frame`.
    pub fn write_checkpoint(
        &self,
        frame: u32,
        scene_json: &serde_json::Value,
        path: &Path,
    ) -> Result<(), IoError> {
        match self.view() {
            View::Snow(simulation) => write_checkpoint(simulation, frame, scene_json, path),
            View::Flow(flow) => write_flow_checkpoint(flow, frame, scene_json, path),
        }
    }

    /// Restores the simulation of `scene` from a checkpoint (written on
    /// either backend) to run where `placement` says; returns it, the frame
    /// the checkpoint follows, and the scene it was written for.
    pub fn resume(
        scene: Scene,
        path: &Path,
        placement: &Placement,
    ) -> Result<(Solver, u32, serde_json::Value), String> {
        match scene.kind {
            SceneKind::Snow => {
                let restored = read_checkpoint(path)?;
                let simulation = restore_snow(scene, restored.snapshot)?;
                Ok((
                    Solver::snow(simulation, placement)?,
                    restored.frame,
                    restored.scene_json,
                ))
            }
            SceneKind::Flow(_) => {
                let (snapshot, frame, scene_json) = read_flow_checkpoint(path)?;
                let flow = FlowSimulation::from_snapshot(scene, snapshot)
                    .map_err(|error| error.to_string())?;
                Ok((Solver::flow(flow, placement)?, frame, scene_json))
            }
        }
    }
}

/// The CPU solver of `scene` at a checkpoint's state.
fn restore_snow(scene: Scene, snapshot: Snapshot) -> Result<Simulation, String> {
    Simulation::from_snapshot(scene, snapshot).map_err(|error| error.to_string())
}

/// The solver's work between two readings of its running totals.
pub fn frame_solver_stats(before: Option<SolverStats>, after: SolverStats) -> SolverFrameStats {
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

/// The flow's trails (if it keeps them), oldest position first.
fn flat_trails(flow: &FlowSimulation) -> Option<FlatTrails> {
    let trails = flow.trails()?;
    let (points, lengths) = trails.oldest_first();
    Some(FlatTrails {
        points,
        capacity: trails.capacity(),
        lengths,
    })
}

/// Writes a flow checkpoint: the snapshot's arrays and its counters.
fn write_flow_checkpoint(
    flow: &FlowSimulation,
    frame: u32,
    scene_json: &serde_json::Value,
    path: &Path,
) -> Result<(), IoError> {
    let snapshot = flow.snapshot();
    let mut checkpoint = Checkpoint::new(serde_json::json!({
        "kind": "flow",
        "frame": frame,
        "substeps": snapshot.substeps,
        "trail_capacity": snapshot.trail_capacity,
        "trail_head": snapshot.trail_head,
        "scene": scene_json,
    }));
    checkpoint.push_array("births", &snapshot.births);
    checkpoint.push_array("positions", &snapshot.positions);
    checkpoint.push_array("velocities", &snapshot.velocities);
    checkpoint.push_array("ages", &snapshot.ages);
    checkpoint.push_array("lifetimes", &snapshot.lifetimes);
    checkpoint.push_array("generations", &snapshot.generations);
    checkpoint.push_array("emitters", &snapshot.emitters);
    checkpoint.push_array("trail_points", &snapshot.trail_points);
    checkpoint.push_array("trail_lengths", &snapshot.trail_lengths);
    checkpoint.push_array("trail_generations", &snapshot.trail_generations);
    checkpoint.write(path)
}

/// Reads a checkpoint written by [`write_flow_checkpoint`].
fn read_flow_checkpoint(path: &Path) -> Result<(FlowSnapshot, u32, serde_json::Value), String> {
    let checkpoint = Checkpoint::read(path).map_err(|error| error.to_string())?;
    let meta = &checkpoint.meta;
    let field = |name: &str| {
        meta.get(name)
            .and_then(serde_json::Value::as_u64)
            .ok_or_else(|| format!("checkpoint {} lacks `{name}`", path.display()))
    };
    let array_error = |error: IoError| error.to_string();
    let snapshot = FlowSnapshot {
        substeps: field("substeps")?,
        births: checkpoint.array("births").map_err(array_error)?,
        positions: checkpoint.array("positions").map_err(array_error)?,
        velocities: checkpoint.array("velocities").map_err(array_error)?,
        ages: checkpoint.array("ages").map_err(array_error)?,
        lifetimes: checkpoint.array("lifetimes").map_err(array_error)?,
        generations: checkpoint.array("generations").map_err(array_error)?,
        emitters: checkpoint.array("emitters").map_err(array_error)?,
        trail_capacity: field("trail_capacity")? as u32,
        trail_head: field("trail_head")? as u32,
        trail_points: checkpoint.array("trail_points").map_err(array_error)?,
        trail_lengths: checkpoint.array("trail_lengths").map_err(array_error)?,
        trail_generations: checkpoint.array("trail_generations").map_err(array_error)?,
    };
    let scene_json = meta.get("scene").cloned().unwrap_or_default();
    Ok((snapshot, field("frame")? as u32, scene_json))
}

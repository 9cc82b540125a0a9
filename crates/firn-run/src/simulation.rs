//! [`Solver`]: a scene simulated on the CPU or the GPU, snow or flow,
//! behind one interface: step it, read its particles, change its
//! parameters while it runs, take its state and start again from one.
//!
//! What computes it is an engine (`engine/`, one file per backend and
//! kind), behind a trait: the solver's methods hand each call to it.
//! Every backend starts from the scene's initial snapshot
//! ([`SolverState::initial`]). A GPU simulation keeps its particles on the
//! device; they come to the host only when asked for ([`Solver::host`]),
//! read back into a snapshot that serves until the next step or parameter
//! change. Writers, renderers and checkpoints read both backends alike,
//! through the views of [`HostState`], and a state taken on one backend
//! continues on the other.
//!
//! [`SolverOptions`] choose how a backend computes where it offers a
//! choice (the CPU's instruction set, the GPU's scatter); every choice
//! gives the same results. For measuring speed, [`Solver::advance_substeps`]
//! steps a number of substeps regardless of frames, [`Solver::wait`] lets a
//! clock see the GPU's work finished, and [`Solver::phase_times`] and
//! [`Solver::memory_bytes`] tell where the time and the memory go.

use std::path::Path;

use firn_core::Scene;
use firn_core::math::lanes::Simd;
use firn_core::scene::{ColorBy, FlowSettings, Material, RigidBody, SceneKind, Wind};
use firn_flow::{FlowSimulation, FlowSnapshot, FlowView};
use firn_gpu::draw::ParticleArrays;
use firn_gpu::snow::Scatter;
use firn_gpu::snow::stage_times::StageTimes;
use firn_io::BodyPose;
use firn_mpm::{PhaseTimes, Simulation, Snapshot, SnowView, SolverStats};
use firn_rigid::BodyState;
use glam::Vec3;

use crate::backend::Placement;
use crate::budget::Budget;
use crate::checkpoint;
use crate::engine::{Engine, OnGpu};
use crate::error::RunError;

/// A running simulation of a scene, snow or flow, on the CPU or the GPU.
pub struct Solver {
    engine: Box<dyn Engine>,
}

/// How a solver computes, where its backend offers a choice; `None` keeps
/// the backend's own. Every choice gives the same results, bit for bit:
/// they differ only in speed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SolverOptions {
    /// The instruction set of the CPU solvers' batched particle updates
    /// (by default AVX2 for snow and the widest the CPU has for a flow,
    /// where the CPU has them). Snow runs one the CPU lacks as portable
    /// code, a flow keeps its own; the GPU ignores it.
    pub simd: Option<Simd>,
    /// How GPU snow's scatter adds into the grid (by default binned, where
    /// the adapter allows it); other backends ignore it.
    pub gpu_scatter: Option<Scatter>,
}

/// The complete state of a solver, as the CPU solvers hold it: what a
/// checkpoint stores, and what any backend continues from bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub enum SolverState {
    /// A snow simulation's state.
    Snow(Snapshot),
    /// A flow's state.
    Flow(FlowSnapshot),
}

/// A solver's state in host memory, as the CPU code reads it whatever
/// backend computed it: borrowed from a CPU simulation, or from the
/// snapshot read back from the GPU.
#[derive(Clone, Copy)]
pub enum HostState<'a> {
    /// Snow.
    Snow(SnowView<'a>),
    /// A curl-noise flow.
    Flow(FlowView<'a>),
}

/// A frame's particles on the host, as pictures need them.
pub struct HostParticles<'a> {
    /// Positions.
    pub positions: &'a [Vec3],
    /// Masses (snow only).
    pub masses: Option<&'a [f32]>,
    /// Values of the colour quantity, one per particle, if it is a ramp
    /// quantity the simulation has.
    pub values: Option<Vec<f32>>,
    /// The flow's trails, if it keeps them.
    pub trails: Option<TrailRings>,
    /// Snow's drift particles, with spindrift (`[wind.spindrift]`).
    pub drift: Option<&'a [Vec3]>,
    /// Where snow's rigid bodies are, in scene order (none for a flow).
    pub rigid_bodies: Vec<BodyPose>,
}

/// A flow's trails, flattened: per particle a ring of `capacity` recent
/// positions, oldest first.
pub struct TrailRings {
    /// The rings, particle-major, `capacity` positions each.
    pub points: Vec<Vec3>,
    /// Positions per ring.
    pub capacity: usize,
    /// Valid positions per ring.
    pub lengths: Vec<u32>,
}

impl SolverState {
    /// The state of `scene` at time 0, where every backend starts
    /// ([`Snapshot::initial`], [`FlowSnapshot::initial`]).
    pub fn initial(scene: &Scene) -> Result<SolverState, RunError> {
        Ok(match scene.kind {
            SceneKind::Snow => SolverState::Snow(Snapshot::initial(scene)?),
            SceneKind::Flow(_) => SolverState::Flow(FlowSnapshot::initial(scene)?),
        })
    }

    /// This state of a simulation of `scene`, borrowed.
    pub fn view<'a>(&'a self, scene: &'a Scene) -> Result<HostState<'a>, RunError> {
        Ok(match self {
            SolverState::Snow(snapshot) => HostState::Snow(snapshot.view(scene)),
            SolverState::Flow(snapshot) => HostState::Flow(snapshot.view(scene)?),
        })
    }
}

impl Solver {
    /// Starts `scene` at time 0 where `placement` says, once its
    /// [`Budget`] fits the machine (checked before a particle is sampled).
    pub fn new(scene: Scene, placement: &Placement) -> Result<Solver, RunError> {
        Budget::of(&scene).check_placement(&scene, placement)?;
        let initial = SolverState::initial(&scene)?;
        Solver::restore(scene, initial, placement)
    }

    /// Continues `scene` from `state` (taken on either backend) where
    /// `placement` says: on the CPU, a simulation made of it; on the GPU,
    /// the state moved to the device, where it stays the host copy until
    /// the first step.
    pub fn restore(
        scene: Scene,
        state: SolverState,
        placement: &Placement,
    ) -> Result<Solver, RunError> {
        let engine: Box<dyn Engine> = match (state, placement) {
            (SolverState::Snow(snapshot), Placement::Cpu) => {
                Box::new(Simulation::from_snapshot(scene, snapshot)?)
            }
            (SolverState::Flow(snapshot), Placement::Cpu) => {
                Box::new(FlowSimulation::from_snapshot(scene, snapshot)?)
            }
            (SolverState::Snow(snapshot), Placement::Gpu(context)) => {
                Box::new(OnGpu::snow(context, scene, snapshot)?)
            }
            (SolverState::Flow(snapshot), Placement::Gpu(context)) => {
                Box::new(OnGpu::flow(context, scene, snapshot)?)
            }
        };
        Ok(Solver { engine })
    }

    /// This solver with `options` applied (see [`SolverOptions`]).
    pub fn with_options(mut self, options: SolverOptions) -> Solver {
        self.engine.apply(options);
        self
    }

    /// The options in effect: the instruction set on the CPU, the scatter
    /// of snow on the GPU, `None` where they do not apply.
    pub fn options(&self) -> SolverOptions {
        self.engine.options()
    }

    /// Where the simulation runs.
    pub fn placement(&self) -> Placement {
        self.engine.placement()
    }

    /// Whether the simulation runs on the GPU.
    pub fn on_gpu(&self) -> bool {
        matches!(self.placement(), Placement::Gpu(_))
    }

    /// The scene as it runs now (with any parameters changed while it runs).
    pub fn scene(&self) -> &Scene {
        self.engine.scene()
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.engine.time()
    }

    /// Substeps taken since time 0.
    pub fn steps(&self) -> u64 {
        self.engine.steps()
    }

    /// The last whole frame of the scene's frame rate reached.
    pub fn frame(&self) -> u32 {
        (self.time() * self.scene().time.fps + FRAME_TOLERANCE).floor() as u32
    }

    /// Current number of particles: of snow, without the drift in the air
    /// (spindrift). The GPU keeps snow and drift in one buffer, so there it
    /// is the snow of the host copy while that is current (from
    /// [`Solver::host`] to the next step, as when a frame was written),
    /// else every particle in the buffer.
    pub fn particle_count(&self) -> usize {
        self.engine.particle_count()
    }

    /// The semi-implicit solver's running totals (snow with that integrator,
    /// on either backend).
    pub fn solver_stats(&self) -> Option<SolverStats> {
        self.engine.solver_stats()
    }

    /// Advances to simulated time `until`; returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        self.engine.advance_to(until)
    }

    /// Takes `count` substeps of the scene's Δt wherever they end, frames
    /// and times aside; returns the substeps taken.
    ///
    /// The CPU takes exactly `count`. The GPU steps to a time, here `count`
    /// times the scene's longest substep ahead (its fixed Δt, the adaptive
    /// bound, or a flow's substep): a flow takes exactly `count`, snow may
    /// take one more (a short last one) or, with adaptive steps, more.
    pub fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        self.engine.advance_substeps(count)
    }

    /// Returns once the GPU has finished the work submitted so far (at once
    /// on the CPU), so that a clock read next has timed all of it.
    pub fn wait(&self) -> Result<(), RunError> {
        self.engine.wait()
    }

    /// Wall-clock seconds spent in each phase of the substeps since the
    /// start or [`Solver::reset_phase_times`] (snow on the CPU only).
    pub fn phase_times(&self) -> Option<PhaseTimes> {
        self.engine.phase_times()
    }

    /// Runs up to `substeps` more substeps timing each stage on the GPU
    /// (snow on a GPU with timestamp queries; `None` elsewhere).
    pub fn stage_times(&mut self, substeps: u32) -> Result<Option<StageTimes>, RunError> {
        self.engine.stage_times(substeps)
    }

    /// Starts the phase profile afresh, e.g. after untimed warm-up substeps
    /// (nothing to do where there is none).
    pub fn reset_phase_times(&mut self) {
        self.engine.reset_phase_times();
    }

    /// Bytes the simulation holds where it computes: on the CPU its
    /// particles, grid and working buffers, on the GPU its device buffers
    /// (not the host copy).
    pub fn memory_bytes(&self) -> u64 {
        self.engine.memory_bytes()
    }

    /// Advances to the end of the next frame; returns the substeps taken.
    pub fn advance_frame(&mut self) -> Result<u32, RunError> {
        let next = f64::from(self.frame() + 1) / self.scene().time.fps;
        self.advance_to(next)
    }

    /// Replaces the snow materials; they take effect at the next substep.
    /// Refused, with nothing changed, for a flow, or materials that differ
    /// from the running ones in number, names, order or density.
    pub fn set_materials(&mut self, materials: &[Material]) -> Result<(), RunError> {
        self.engine.set_materials(materials)
    }

    /// Replaces the wind over the snow (`[wind]`); it takes effect at the
    /// next substep. Refused, with nothing changed, for a flow, or a wind the
    /// scene loader refuses.
    pub fn set_wind(&mut self, wind: &Wind) -> Result<(), RunError> {
        self.engine.set_wind(wind)
    }

    /// Throws `body` into the running snow from the next substep on (the
    /// viewer's throw). Refused, with nothing changed, on the GPU, for a
    /// flow, or for a body the scene loader refuses.
    pub fn add_rigid_body(&mut self, body: RigidBody) -> Result<(), RunError> {
        self.engine.add_rigid_body(body)
    }

    /// Replaces the flow's field parameters; they take effect at the next
    /// substep. Refused, with nothing changed, for snow, or settings that
    /// change the emitters or substeps.
    pub fn set_flow(&mut self, settings: &FlowSettings) -> Result<(), RunError> {
        self.engine.set_flow(settings)
    }

    /// The state in host memory, read back from the GPU if it is not there
    /// yet.
    pub fn host(&mut self) -> Result<HostState<'_>, RunError> {
        self.engine.host()
    }

    /// The flow, where it runs on the CPU: stepped in place by a split run's
    /// rank 0 (firn-mpi), which moves its part and puts the other ranks'
    /// parts into it. `None` for snow or on the GPU.
    pub fn cpu_flow_mut(&mut self) -> Option<&mut FlowSimulation> {
        self.engine.cpu_flow_mut()
    }

    /// The particles with the values of `color_by`, if they are in host
    /// memory now: always on the CPU, and on the GPU until the first step
    /// after they were last read back (see [`Solver::host`]).
    pub fn host_particles(&self, color_by: ColorBy) -> Option<HostParticles<'_>> {
        Some(self.engine.current_host()?.particles(color_by))
    }

    /// The particles of a GPU simulation in its own buffers, for a renderer
    /// on the same device (`None` on the CPU).
    pub fn device_particles(&self) -> Option<ParticleArrays<'_>> {
        self.engine.device_particles()
    }

    /// The rigid bodies' poses of snow on the GPU, which rapier steps on
    /// the host, with no read-back, for a renderer that draws the device's
    /// particles (`None` on the CPU, where the host state has them).
    pub fn device_body_poses(&self) -> Option<Vec<BodyPose>> {
        self.engine.device_body_poses()
    }

    /// Writes the complete state to `path` as the checkpoint taken after
    /// `frame` of the scene `scene_json`, atomically: the file
    /// [`checkpoint::write`] writes of [`Solver::state`], streamed from the
    /// solver's own arrays without a copy of them (on the GPU from a read
    /// back, unless the host copy is current).
    pub fn write_checkpoint(
        &self,
        frame: u32,
        scene_json: &serde_json::Value,
        path: &Path,
    ) -> Result<(), RunError> {
        match self.engine.current_host() {
            Some(host) => checkpoint::write(host, frame, scene_json, path)?,
            None => {
                let state = self.engine.state()?;
                checkpoint::write(state.view(self.scene())?, frame, scene_json, path)?;
            }
        }
        Ok(())
    }

    /// The complete state, to continue from later on either backend
    /// ([`Solver::restore`]); read back from the GPU unless the host copy
    /// is current.
    pub fn state(&self) -> Result<SolverState, RunError> {
        self.engine.state()
    }
}

/// How far below a whole frame the time may fall and still count as having
/// reached it (flows step in substeps of 1/(fps·n) seconds).
const FRAME_TOLERANCE: f64 = 1e-6;

impl<'a> HostState<'a> {
    /// The scene simulated.
    pub fn scene(self) -> &'a Scene {
        match self {
            HostState::Snow(snow) => snow.scene(),
            HostState::Flow(flow) => flow.scene(),
        }
    }

    /// Simulated time in seconds.
    pub fn time(self) -> f64 {
        match self {
            HostState::Snow(snow) => snow.time(),
            HostState::Flow(flow) => flow.time(),
        }
    }

    /// The particles with the values of `color_by`: snow has every ramp
    /// quantity, a flow only its speed.
    pub fn particles(self, color_by: ColorBy) -> HostParticles<'a> {
        match self {
            HostState::Snow(snow) => HostParticles {
                positions: &snow.particles().position,
                masses: Some(&snow.particles().mass),
                values: snow.color_values(color_by),
                trails: None,
                drift: snow
                    .scene()
                    .spindrift()
                    .map(|_| snow.drift().position.as_slice()),
                rigid_bodies: body_poses(snow),
            },
            HostState::Flow(flow) => HostParticles {
                positions: flow.positions(),
                masses: None,
                values: (color_by == ColorBy::Speed)
                    .then(|| flow.velocities().iter().map(|v| v.length()).collect()),
                trails: flow.trails().map(|trails| {
                    let (points, lengths) = trails.oldest_first();
                    TrailRings {
                        points,
                        capacity: trails.capacity(),
                        lengths,
                    }
                }),
                drift: None,
                rigid_bodies: Vec::new(),
            },
        }
    }

    /// The pose and motion of each of the scene's rigid bodies, in scene
    /// order (none for a flow).
    pub fn body_poses(self) -> Vec<BodyPose> {
        match self {
            HostState::Snow(snow) => body_poses(snow),
            HostState::Flow(_) => Vec::new(),
        }
    }
}

/// The pose and motion of each of the rigid bodies of `snow`, in scene
/// order, as the manifest records them and pictures draw them.
pub fn body_poses(snow: SnowView<'_>) -> Vec<BodyPose> {
    poses(&snow.rigid_bodies())
}

/// The pose and motion of bodies in the states `states`, as
/// [`body_poses`] gives them.
pub(crate) fn poses(states: &[BodyState]) -> Vec<BodyPose> {
    states
        .iter()
        .map(|body| BodyPose {
            position: body.position.to_array(),
            rotation: body.rotation.to_array(),
            velocity: body.velocity.to_array(),
            angular_velocity: body.angular_velocity.to_array(),
        })
        .collect()
}

//! [`Solver`]: a scene simulated on the CPU or the GPU, snow or flow,
//! behind one interface: step it, read its particles, change its
//! parameters while it runs, take its state and start again from one.
//!
//! A GPU simulation keeps its particles on the device; they come to the
//! host only when asked for ([`Solver::host`]), and that copy serves until
//! the next step or parameter change. Its state is the CPU solver's, so
//! writers, renderers and checkpoints read both backends alike, and a state
//! taken on one backend continues on the other.
//!
//! [`SolverOptions`] choose how a backend computes where it offers a
//! choice (the CPU's instruction set, the GPU's scatter); every choice
//! gives the same results. For measuring speed, [`Solver::advance_substeps`]
//! steps a number of substeps regardless of frames, [`Solver::wait`] lets a
//! clock see the GPU's work finished, and [`Solver::phase_times`] and
//! [`Solver::memory_bytes`] tell where the time and the memory go.

use std::path::Path;
use std::sync::Arc;

use firn_core::Scene;
use firn_core::math::lanes::Simd;
use firn_core::scene::{ColorBy, FlowSettings, Material, SceneKind, TimeStep, Wind};
use firn_flow::{FlowSimulation, FlowSnapshot};
use firn_gpu::draw::ParticleArrays;
use firn_gpu::snow::{MemoryEstimate, Scatter};
use firn_gpu::{GpuError, GpuFlow, GpuSnow};
use firn_mpm::{PhaseTimes, Simulation, Snapshot, SolverStats};
use glam::Vec3;

use crate::backend::Placement;
use crate::budget::Budget;
use crate::checkpoint::{self, FlowView, SnowView, StateView};
use crate::error::RunError;

/// A running simulation of a scene, snow or flow, on the CPU or the GPU.
pub struct Solver {
    engine: Engine,
}

/// What computes the simulation.
enum Engine {
    /// Snow on the CPU MPM solver.
    CpuSnow(Box<Simulation>),
    /// A curl-noise flow on the CPU.
    CpuFlow(Box<FlowSimulation>),
    /// Snow on the GPU.
    GpuSnow(Box<OnGpu<GpuSnow, Simulation>>),
    /// A curl-noise flow on the GPU.
    GpuFlow(Box<OnGpu<GpuFlow, FlowSimulation>>),
}

/// A simulation on the GPU, its substeps so far, and the CPU solver's copy
/// of its state while that copy is current.
struct OnGpu<Device, Host> {
    device: Device,
    steps: u64,
    host: Option<Host>,
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
/// backend computed it.
#[derive(Clone, Copy)]
pub enum HostState<'a> {
    /// Snow.
    Snow(&'a Simulation),
    /// A curl-noise flow.
    Flow(&'a FlowSimulation),
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

impl Solver {
    /// Starts `scene` at time 0 where `placement` says, once its
    /// [`Budget`] fits the machine (checked before a particle is sampled).
    pub fn new(scene: Scene, placement: &Placement) -> Result<Solver, RunError> {
        Budget::of(&scene).check_placement(&scene, placement)?;
        let state = match scene.kind {
            SceneKind::Snow => HostSimulation::Snow(Box::new(Simulation::new(scene)?)),
            SceneKind::Flow(_) => HostSimulation::Flow(Box::new(FlowSimulation::new(scene)?)),
        };
        Solver::place(state, placement)
    }

    /// Continues `scene` from `state` (taken on either backend) where
    /// `placement` says.
    pub fn restore(
        scene: Scene,
        state: SolverState,
        placement: &Placement,
    ) -> Result<Solver, RunError> {
        let state = match state {
            SolverState::Snow(snapshot) => {
                HostSimulation::Snow(Box::new(Simulation::from_snapshot(scene, snapshot)?))
            }
            SolverState::Flow(snapshot) => {
                HostSimulation::Flow(Box::new(FlowSimulation::from_snapshot(scene, snapshot)?))
            }
        };
        Solver::place(state, placement)
    }

    /// Runs `state` where `placement` says: as it is on the CPU, or moved
    /// to the GPU, where it stays the host copy until the first step.
    fn place(state: HostSimulation, placement: &Placement) -> Result<Solver, RunError> {
        let engine = match (state, placement) {
            (HostSimulation::Snow(simulation), Placement::Cpu) => Engine::CpuSnow(simulation),
            (HostSimulation::Flow(flow), Placement::Cpu) => Engine::CpuFlow(flow),
            (HostSimulation::Snow(simulation), Placement::Gpu(context)) => {
                let scene = simulation.scene().clone();
                let device =
                    GpuSnow::from_snapshot(Arc::clone(context), scene, &simulation.snapshot())?;
                Engine::GpuSnow(Box::new(OnGpu {
                    device,
                    steps: simulation.steps(),
                    host: Some(*simulation),
                }))
            }
            (HostSimulation::Flow(flow), Placement::Gpu(context)) => {
                let scene = flow.scene().clone();
                let device = GpuFlow::from_snapshot(Arc::clone(context), scene, &flow.snapshot())?;
                Engine::GpuFlow(Box::new(OnGpu {
                    device,
                    steps: flow.substeps(),
                    host: Some(*flow),
                }))
            }
        };
        Ok(Solver { engine })
    }

    /// This solver with `options` applied (see [`SolverOptions`]).
    pub fn with_options(mut self, options: SolverOptions) -> Solver {
        match &mut self.engine {
            Engine::CpuSnow(simulation) => {
                if let Some(simd) = options.simd {
                    simulation.set_simd(simd);
                }
            }
            Engine::CpuFlow(flow) => {
                if let Some(simd) = options.simd {
                    flow.set_simd(simd);
                }
            }
            Engine::GpuSnow(run) => {
                if let Some(scatter) = options.gpu_scatter {
                    run.device.set_scatter(scatter);
                }
            }
            Engine::GpuFlow(_) => {}
        }
        self
    }

    /// The options in effect: the instruction set on the CPU, the scatter
    /// of snow on the GPU, `None` where they do not apply.
    pub fn options(&self) -> SolverOptions {
        let (simd, gpu_scatter) = match &self.engine {
            Engine::CpuSnow(simulation) => (Some(simulation.simd()), None),
            Engine::CpuFlow(flow) => (Some(flow.simd()), None),
            Engine::GpuSnow(run) => (None, Some(run.device.scatter())),
            Engine::GpuFlow(_) => (None, None),
        };
        SolverOptions { simd, gpu_scatter }
    }

    /// Where the simulation runs.
    pub fn placement(&self) -> Placement {
        match &self.engine {
            Engine::CpuSnow(_) | Engine::CpuFlow(_) => Placement::Cpu,
            Engine::GpuSnow(run) => Placement::Gpu(Arc::clone(run.device.context())),
            Engine::GpuFlow(run) => Placement::Gpu(Arc::clone(run.device.context())),
        }
    }

    /// Whether the simulation runs on the GPU.
    pub fn on_gpu(&self) -> bool {
        matches!(self.engine, Engine::GpuSnow(_) | Engine::GpuFlow(_))
    }

    /// The scene as it runs now (with any parameters changed while it runs).
    pub fn scene(&self) -> &Scene {
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.scene(),
            Engine::CpuFlow(flow) => flow.scene(),
            Engine::GpuSnow(run) => run.device.scene(),
            Engine::GpuFlow(run) => run.device.scene(),
        }
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.time(),
            Engine::CpuFlow(flow) => flow.time(),
            Engine::GpuSnow(run) => run.device.time(),
            Engine::GpuFlow(run) => run.device.time(),
        }
    }

    /// Substeps taken since time 0.
    pub fn steps(&self) -> u64 {
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.steps(),
            Engine::CpuFlow(flow) => flow.substeps(),
            Engine::GpuSnow(run) => run.steps,
            Engine::GpuFlow(run) => run.steps,
        }
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
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.particles().len(),
            Engine::CpuFlow(flow) => flow.len(),
            Engine::GpuSnow(run) => match &run.host {
                Some(simulation) => simulation.particles().len(),
                None => run.device.particle_arrays().count as usize,
            },
            Engine::GpuFlow(run) => run.device.len(),
        }
    }

    /// The semi-implicit solver's running totals (snow with that integrator,
    /// on either backend).
    pub fn solver_stats(&self) -> Option<SolverStats> {
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.solver_stats(),
            Engine::GpuSnow(run) => run.device.solver_stats(),
            Engine::CpuFlow(_) | Engine::GpuFlow(_) => None,
        }
    }

    /// Advances to simulated time `until`; returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        let taken = match &mut self.engine {
            Engine::CpuSnow(simulation) => simulation.advance_to(until)?,
            Engine::CpuFlow(flow) => flow.advance_to(until),
            Engine::GpuSnow(run) => run.advance(|device| device.advance_to(until))?,
            Engine::GpuFlow(run) => run.advance(|device| device.advance_to(until))?,
        };
        Ok(taken)
    }

    /// Takes `count` substeps of the scene's Δt wherever they end, frames
    /// and times aside; returns the substeps taken.
    ///
    /// The CPU takes exactly `count`. The GPU steps to a time, here `count`
    /// times the scene's longest substep ahead (its fixed Δt, the adaptive
    /// bound, or a flow's substep): a flow takes exactly `count`, snow may
    /// take one more (a short last one) or, with adaptive steps, more.
    pub fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        let ahead = |scene: &Scene, time: f64| time + f64::from(count) * longest_substep(scene);
        match &mut self.engine {
            Engine::CpuSnow(simulation) => {
                for _ in 0..count {
                    simulation.step(f64::INFINITY)?;
                }
            }
            Engine::CpuFlow(flow) => {
                for _ in 0..count {
                    flow.step();
                }
            }
            Engine::GpuSnow(run) => {
                let until = ahead(run.device.scene(), run.device.time());
                return Ok(run.advance(|device| device.advance_to(until))?);
            }
            Engine::GpuFlow(run) => {
                let until = ahead(run.device.scene(), run.device.time());
                return Ok(run.advance(|device| device.advance_to(until))?);
            }
        }
        Ok(count)
    }

    /// Returns once the GPU has finished the work submitted so far (at once
    /// on the CPU), so that a clock read next has timed all of it.
    pub fn wait(&self) -> Result<(), RunError> {
        match &self.engine {
            Engine::CpuSnow(_) | Engine::CpuFlow(_) => {}
            Engine::GpuSnow(run) => run.device.context().wait()?,
            Engine::GpuFlow(run) => run.device.context().wait()?,
        }
        Ok(())
    }

    /// Wall-clock seconds spent in each phase of the substeps since the
    /// start or [`Solver::reset_phase_times`] (snow on the CPU only).
    pub fn phase_times(&self) -> Option<PhaseTimes> {
        match &self.engine {
            Engine::CpuSnow(simulation) => Some(simulation.phase_times()),
            Engine::CpuFlow(_) | Engine::GpuSnow(_) | Engine::GpuFlow(_) => None,
        }
    }

    /// Starts the phase profile afresh, e.g. after untimed warm-up substeps
    /// (nothing to do where there is none).
    pub fn reset_phase_times(&mut self) {
        if let Engine::CpuSnow(simulation) = &mut self.engine {
            simulation.reset_phase_times();
        }
    }

    /// Bytes the simulation holds where it computes: on the CPU its
    /// particles, grid and working buffers, on the GPU its device buffers
    /// (not the host copy).
    pub fn memory_bytes(&self) -> u64 {
        match &self.engine {
            Engine::CpuSnow(simulation) => simulation.memory_bytes() as u64,
            Engine::CpuFlow(flow) => flow.memory_bytes() as u64,
            Engine::GpuSnow(run) => {
                let particles = run.device.particle_arrays().count;
                MemoryEstimate::of(run.device.scene(), u64::from(particles)).total_bytes()
            }
            Engine::GpuFlow(run) => run.device.memory_bytes(),
        }
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
        match &mut self.engine {
            Engine::CpuSnow(simulation) => simulation.set_materials(materials)?,
            Engine::GpuSnow(run) => {
                run.device.set_materials(materials)?;
                run.host = None;
            }
            Engine::CpuFlow(_) | Engine::GpuFlow(_) => {
                return Err(RunError::Unsupported("a flow scene has no snow materials"));
            }
        }
        Ok(())
    }

    /// Replaces the wind over the snow (`[wind]`); it takes effect at the
    /// next substep. Refused, with nothing changed, for a flow, or a wind the
    /// scene loader refuses.
    pub fn set_wind(&mut self, wind: &Wind) -> Result<(), RunError> {
        match &mut self.engine {
            Engine::CpuSnow(simulation) => simulation.set_wind(wind)?,
            Engine::GpuSnow(run) => {
                run.device.set_wind(wind)?;
                run.host = None;
            }
            Engine::CpuFlow(_) | Engine::GpuFlow(_) => {
                return Err(RunError::Unsupported(
                    "a flow scene has no wind over snow; change its [flow] instead",
                ));
            }
        }
        Ok(())
    }

    /// Replaces the flow's field parameters; they take effect at the next
    /// substep. Refused, with nothing changed, for snow, or settings that
    /// change the emitters or substeps.
    pub fn set_flow(&mut self, settings: &FlowSettings) -> Result<(), RunError> {
        match &mut self.engine {
            Engine::CpuFlow(flow) => flow.set_settings(settings.clone())?,
            Engine::GpuFlow(run) => {
                run.device.set_settings(settings.clone())?;
                run.host = None;
            }
            Engine::CpuSnow(_) | Engine::GpuSnow(_) => {
                return Err(RunError::Unsupported("a snow scene has no flow parameters"));
            }
        }
        Ok(())
    }

    /// The state in host memory, read back from the GPU if it is not there
    /// yet.
    pub fn host(&mut self) -> Result<HostState<'_>, RunError> {
        match &mut self.engine {
            Engine::CpuSnow(simulation) => Ok(HostState::Snow(simulation)),
            Engine::CpuFlow(flow) => Ok(HostState::Flow(flow)),
            Engine::GpuSnow(run) => {
                let simulation = run.host(|device| {
                    let scene = device.scene().clone();
                    Ok(Simulation::from_snapshot(scene, device.snapshot()?)?)
                })?;
                Ok(HostState::Snow(simulation))
            }
            Engine::GpuFlow(run) => {
                let flow = run.host(|device| {
                    let scene = device.scene().clone();
                    Ok(FlowSimulation::from_snapshot(scene, device.snapshot()?)?)
                })?;
                Ok(HostState::Flow(flow))
            }
        }
    }

    /// The flow, where it runs on the CPU: stepped in place by a split run's
    /// rank 0 (firn-mpi), which moves its part and puts the other ranks'
    /// parts into it. `None` for snow or on the GPU.
    pub fn cpu_flow_mut(&mut self) -> Option<&mut FlowSimulation> {
        match &mut self.engine {
            Engine::CpuFlow(flow) => Some(flow),
            _ => None,
        }
    }

    /// The particles with the values of `color_by`, if they are in host
    /// memory now: always on the CPU, and on the GPU until the first step
    /// after they were last read back (see [`Solver::host`]).
    pub fn host_particles(&self, color_by: ColorBy) -> Option<HostParticles<'_>> {
        let host = match &self.engine {
            Engine::CpuSnow(simulation) => HostState::Snow(simulation),
            Engine::CpuFlow(flow) => HostState::Flow(flow),
            Engine::GpuSnow(run) => HostState::Snow(run.host.as_ref()?),
            Engine::GpuFlow(run) => HostState::Flow(run.host.as_ref()?),
        };
        Some(host.particles(color_by))
    }

    /// The particles of a GPU simulation in its own buffers, for a renderer
    /// on the same device (`None` on the CPU).
    pub fn device_particles(&self) -> Option<ParticleArrays<'_>> {
        match &self.engine {
            Engine::GpuSnow(run) => Some(run.device.particle_arrays()),
            Engine::GpuFlow(run) => Some(run.device.particle_arrays()),
            Engine::CpuSnow(_) | Engine::CpuFlow(_) => None,
        }
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
        let write = |state: StateView<'_>| checkpoint::write_view(state, frame, scene_json, path);
        match &self.engine {
            Engine::CpuSnow(simulation) => {
                write(StateView::Snow(SnowView::of_simulation(simulation)))
            }
            Engine::CpuFlow(flow) => write(StateView::Flow(FlowView::of_simulation(flow))),
            Engine::GpuSnow(run) => match &run.host {
                Some(simulation) => write(StateView::Snow(SnowView::of_simulation(simulation))),
                None => write(StateView::Snow(SnowView::of_snapshot(
                    &run.device.snapshot()?,
                ))),
            },
            Engine::GpuFlow(run) => match &run.host {
                Some(flow) => write(StateView::Flow(FlowView::of_simulation(flow))),
                None => write(StateView::Flow(FlowView::of_snapshot(
                    &run.device.snapshot()?,
                ))),
            },
        }?;
        Ok(())
    }

    /// The complete state, to continue from later on either backend
    /// ([`Solver::restore`]); read back from the GPU unless the host copy
    /// is current.
    pub fn state(&self) -> Result<SolverState, RunError> {
        Ok(match &self.engine {
            Engine::CpuSnow(simulation) => SolverState::Snow(simulation.snapshot()),
            Engine::CpuFlow(flow) => SolverState::Flow(flow.snapshot()),
            Engine::GpuSnow(run) => SolverState::Snow(match &run.host {
                Some(simulation) => simulation.snapshot(),
                None => run.device.snapshot()?,
            }),
            Engine::GpuFlow(run) => SolverState::Flow(match &run.host {
                Some(flow) => flow.snapshot(),
                None => run.device.snapshot()?,
            }),
        })
    }
}

/// How far below a whole frame the time may fall and still count as having
/// reached it (flows step in substeps of 1/(fps·n) seconds).
const FRAME_TOLERANCE: f64 = 1e-6;

/// The longest substep of `scene`, in seconds: snow's fixed Δt or its
/// adaptive bound, a flow's 1/(fps·substeps).
fn longest_substep(scene: &Scene) -> f64 {
    match (&scene.kind, &scene.time.step) {
        (SceneKind::Flow(settings), _) => 1.0 / (scene.time.fps * f64::from(settings.substeps)),
        (SceneKind::Snow, TimeStep::Fixed { dt }) => f64::from(*dt),
        (SceneKind::Snow, TimeStep::Adaptive { max_dt, .. }) => f64::from(*max_dt),
    }
}

/// A simulation on the CPU, before it is placed.
enum HostSimulation {
    Snow(Box<Simulation>),
    Flow(Box<FlowSimulation>),
}

impl<Device, Host> OnGpu<Device, Host> {
    /// Steps the device by `advance` and counts the substeps it took; the
    /// host copy is no longer current.
    fn advance(
        &mut self,
        advance: impl FnOnce(&mut Device) -> Result<u32, GpuError>,
    ) -> Result<u32, GpuError> {
        self.host = None;
        let taken = advance(&mut self.device)?;
        self.steps += u64::from(taken);
        Ok(taken)
    }

    /// The host copy, read back from the device by `download` unless it is
    /// current.
    fn host(
        &mut self,
        download: impl FnOnce(&Device) -> Result<Host, RunError>,
    ) -> Result<&Host, RunError> {
        let host = match self.host.take() {
            Some(host) => host,
            None => download(&self.device)?,
        };
        Ok(self.host.insert(host))
    }
}

impl<'a> HostState<'a> {
    /// The scene simulated.
    pub fn scene(self) -> &'a Scene {
        match self {
            HostState::Snow(simulation) => simulation.scene(),
            HostState::Flow(flow) => flow.scene(),
        }
    }

    /// Simulated time in seconds.
    pub fn time(self) -> f64 {
        match self {
            HostState::Snow(simulation) => simulation.time(),
            HostState::Flow(flow) => flow.time(),
        }
    }

    /// The particles with the values of `color_by`: snow has every ramp
    /// quantity, a flow only its speed.
    pub fn particles(self, color_by: ColorBy) -> HostParticles<'a> {
        match self {
            HostState::Snow(simulation) => {
                let particles = simulation.particles();
                HostParticles {
                    positions: &particles.position,
                    masses: Some(&particles.mass),
                    values: simulation.view().color_values(color_by),
                    trails: None,
                    drift: simulation
                        .scene()
                        .wind
                        .as_ref()
                        .and_then(|wind| wind.spindrift.as_ref())
                        .map(|_| simulation.drift().position.as_slice()),
                }
            }
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
            },
        }
    }
}

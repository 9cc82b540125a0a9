//! What computes a [`Solver`](crate::Solver): an [`Engine`], one per
//! backend and kind of scene, each in its file: snow on the CPU
//! (`cpu_snow.rs`, a `firn_mpm::Simulation`), a flow on the CPU
//! (`cpu_flow.rs`, a `firn_flow::FlowSimulation`), and both on the GPU
//! (`gpu_snow.rs` and `gpu_flow.rs`, an [`OnGpu`] device simulation with
//! the snapshot last read back as its host copy). Where an engine has
//! nothing to do, the trait's default does it.

mod cpu_flow;
mod cpu_snow;
mod gpu_flow;
mod gpu_snow;

use firn_core::Scene;
use firn_core::scene::{FlowSettings, Material, RigidBody, SceneKind, TimeStep, Wind};
use firn_flow::FlowSimulation;
use firn_gpu::draw::ParticleArrays;
use firn_gpu::snow::stage_times::StageTimes;
use firn_io::BodyPose;
use firn_mpm::{PhaseTimes, SolverStats};

use crate::backend::Placement;
use crate::error::RunError;
use crate::simulation::{HostState, SolverOptions, SolverState};

/// A simulation on one backend, behind the [`Solver`](crate::Solver)'s
/// methods of the same names (whose comments say what each does). `Send`
/// and `Sync`, as the solver is: front doors step it on other threads, and
/// Python shares it.
pub(crate) trait Engine: Send + Sync {
    /// The scene as it runs now.
    fn scene(&self) -> &Scene;

    /// Simulated time in seconds.
    fn time(&self) -> f64;

    /// Substeps taken since time 0.
    fn steps(&self) -> u64;

    /// Current number of snow or flow particles.
    fn particle_count(&self) -> usize;

    /// Where the simulation runs.
    fn placement(&self) -> Placement {
        Placement::Cpu
    }

    /// The options in effect.
    fn options(&self) -> SolverOptions;

    /// Applies the `options` this engine takes.
    fn apply(&mut self, options: SolverOptions);

    /// Advances to simulated time `until`; returns the substeps taken.
    fn advance_to(&mut self, until: f64) -> Result<u32, RunError>;

    /// Takes `count` substeps, or on the GPU steps to the time they reach
    /// at the longest substep; returns the substeps taken.
    fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError>;

    /// Bytes the simulation holds where it computes.
    fn memory_bytes(&self) -> u64;

    /// The state in host memory, read back from the device if need be.
    fn host(&mut self) -> Result<HostState<'_>, RunError>;

    /// The state in host memory, if it is there now.
    fn current_host(&self) -> Option<HostState<'_>>;

    /// The complete state, read back unless the host copy is current.
    fn state(&self) -> Result<SolverState, RunError>;

    /// The semi-implicit solver's running totals (snow only).
    fn solver_stats(&self) -> Option<SolverStats> {
        None
    }

    /// Returns once the device has finished the work submitted so far.
    fn wait(&self) -> Result<(), RunError> {
        Ok(())
    }

    /// Wall-clock seconds per phase (snow on the CPU only).
    fn phase_times(&self) -> Option<PhaseTimes> {
        None
    }

    /// Starts the phase profile afresh, where there is one.
    fn reset_phase_times(&mut self) {}

    /// Runs up to `substeps` more substeps timing the GPU's stages (snow on
    /// a GPU with timestamps only; `None` elsewhere).
    fn stage_times(&mut self, substeps: u32) -> Result<Option<StageTimes>, RunError> {
        let _ = substeps;
        Ok(None)
    }

    /// Replaces the snow materials (snow only).
    fn set_materials(&mut self, _materials: &[Material]) -> Result<(), RunError> {
        Err(RunError::Unsupported("a flow scene has no snow materials"))
    }

    /// Replaces the wind over the snow (snow only).
    fn set_wind(&mut self, _wind: &Wind) -> Result<(), RunError> {
        Err(RunError::Unsupported(
            "a flow scene has no wind over snow; change its [flow] instead",
        ))
    }

    /// Throws a rigid body into the running snow (snow on the CPU only).
    fn add_rigid_body(&mut self, _body: RigidBody) -> Result<(), RunError> {
        Err(RunError::Unsupported(
            "a rigid body is thrown into running snow on the CPU backend only (and not into a \
             flow scene)",
        ))
    }

    /// Replaces the flow's field parameters (flows only).
    fn set_flow(&mut self, _settings: &FlowSettings) -> Result<(), RunError> {
        Err(RunError::Unsupported("a snow scene has no flow parameters"))
    }

    /// The flow, where it runs on the CPU.
    fn cpu_flow_mut(&mut self) -> Option<&mut FlowSimulation> {
        None
    }

    /// The particles in the device's own buffers (GPU only).
    fn device_particles(&self) -> Option<ParticleArrays<'_>> {
        None
    }

    /// The rigid bodies' poses beside the device's particles (snow on the
    /// GPU only).
    fn device_body_poses(&self) -> Option<Vec<BodyPose>> {
        None
    }
}

/// A simulation on the GPU, its substeps so far, and the snapshot last
/// read back from it while that is current (its host copy).
pub(crate) struct OnGpu<Device, Snapshot> {
    device: Device,
    steps: u64,
    host: Option<Snapshot>,
}

impl<Device, Snapshot> OnGpu<Device, Snapshot> {
    /// Steps the device by `advance` and counts the substeps it took; the
    /// host copy is no longer current.
    fn advance(
        &mut self,
        advance: impl FnOnce(&mut Device) -> Result<u32, firn_gpu::GpuError>,
    ) -> Result<u32, RunError> {
        self.host = None;
        let taken = advance(&mut self.device)?;
        self.steps += u64::from(taken);
        Ok(taken)
    }
}

/// The time `count` of `scene`'s longest substeps after `time`: snow's
/// fixed Δt or its adaptive bound, a flow's 1/(fps·substeps).
fn substeps_ahead(scene: &Scene, time: f64, count: u32) -> f64 {
    let longest = match (&scene.kind, &scene.time.step) {
        (SceneKind::Flow(settings), _) => 1.0 / (scene.time.fps * f64::from(settings.substeps)),
        (SceneKind::Snow, TimeStep::Fixed { dt }) => f64::from(*dt),
        (SceneKind::Snow, TimeStep::Adaptive { max_dt, .. }) => f64::from(*max_dt),
    };
    time + f64::from(count) * longest
}

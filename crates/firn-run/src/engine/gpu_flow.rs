//! A curl-noise flow on the GPU: a [`GpuFlow`] and its host copy, the
//! [`FlowSnapshot`] last read back (or the one it started from).

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::FlowSettings;
use firn_flow::FlowSnapshot;
use firn_gpu::draw::ParticleArrays;
use firn_gpu::{GpuContext, GpuFlow};

use super::{Engine, OnGpu, substeps_ahead};
use crate::backend::Placement;
use crate::error::RunError;
use crate::simulation::{HostState, SolverOptions, SolverState};

impl OnGpu<GpuFlow, FlowSnapshot> {
    /// The flow of `scene` continued from `snapshot` on `context`'s device;
    /// the snapshot is the host copy until the first step.
    pub(crate) fn flow(
        context: &Arc<GpuContext>,
        scene: Scene,
        mut snapshot: FlowSnapshot,
    ) -> Result<Self, RunError> {
        let device = GpuFlow::from_snapshot(Arc::clone(context), scene, &snapshot)?;
        // As the CPU holds it, and the device reads back: a ring for every particle.
        snapshot.cover_trails();
        Ok(OnGpu {
            device,
            steps: snapshot.substeps,
            host: Some(snapshot),
        })
    }
}

impl Engine for OnGpu<GpuFlow, FlowSnapshot> {
    fn scene(&self) -> &Scene {
        self.device.scene()
    }

    fn time(&self) -> f64 {
        self.device.time()
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    fn particle_count(&self) -> usize {
        self.device.len()
    }

    fn placement(&self) -> Placement {
        Placement::Gpu(Arc::clone(self.device.context()))
    }

    fn options(&self) -> SolverOptions {
        SolverOptions::default()
    }

    fn apply(&mut self, _options: SolverOptions) {}

    fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        self.advance(|device| device.advance_to(until))
    }

    fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        let until = substeps_ahead(self.device.scene(), self.device.time(), count);
        self.advance(|device| device.advance_to(until))
    }

    fn memory_bytes(&self) -> u64 {
        self.device.memory_bytes()
    }

    fn host(&mut self) -> Result<HostState<'_>, RunError> {
        let snapshot = match self.host.take() {
            Some(snapshot) => snapshot,
            None => self.device.snapshot()?,
        };
        let snapshot = self.host.insert(snapshot);
        Ok(HostState::Flow(snapshot.view(self.device.scene())?))
    }

    fn current_host(&self) -> Option<HostState<'_>> {
        let snapshot = self.host.as_ref()?;
        snapshot.view(self.device.scene()).ok().map(HostState::Flow)
    }

    fn state(&self) -> Result<SolverState, RunError> {
        Ok(SolverState::Flow(match &self.host {
            Some(snapshot) => snapshot.clone(),
            None => self.device.snapshot()?,
        }))
    }

    fn wait(&self) -> Result<(), RunError> {
        Ok(self.device.context().wait()?)
    }

    fn set_flow(&mut self, settings: &FlowSettings) -> Result<(), RunError> {
        self.device.set_settings(settings.clone())?;
        self.host = None;
        Ok(())
    }

    fn device_particles(&self) -> Option<ParticleArrays<'_>> {
        Some(self.device.particle_arrays())
    }
}

//! Snow on the GPU: a [`GpuSnow`] and its host copy, the [`Snapshot`] last
//! read back (or the one it started from).

use std::sync::Arc;

use firn_core::Scene;
use firn_core::scene::{Material, Wind};
use firn_gpu::draw::ParticleArrays;
use firn_gpu::snow::MemoryEstimate;
use firn_gpu::snow::stage_times::StageTimes;
use firn_gpu::{GpuContext, GpuSnow};
use firn_io::BodyPose;
use firn_mpm::coupling::RigidBodies;
use firn_mpm::{Snapshot, SolverStats};

use super::{Engine, OnGpu, substeps_ahead};
use crate::backend::Placement;
use crate::error::RunError;
use crate::simulation::{HostState, SolverOptions, SolverState, poses};

impl OnGpu<GpuSnow, Snapshot> {
    /// Snow of `scene` continued from `snapshot` on `context`'s device;
    /// the snapshot is the host copy until the first step.
    pub(crate) fn snow(
        context: &Arc<GpuContext>,
        scene: Scene,
        snapshot: Snapshot,
    ) -> Result<Self, RunError> {
        let device = GpuSnow::from_snapshot(Arc::clone(context), scene, &snapshot)?;
        Ok(OnGpu {
            device,
            steps: snapshot.steps,
            host: Some(snapshot),
        })
    }
}

impl Engine for OnGpu<GpuSnow, Snapshot> {
    fn scene(&self) -> &Scene {
        self.device.scene()
    }

    fn time(&self) -> f64 {
        self.device.time()
    }

    fn steps(&self) -> u64 {
        self.steps
    }

    /// The snow of the host copy while it is current; else every particle
    /// in the buffer, where snow and drift are one.
    fn particle_count(&self) -> usize {
        match &self.host {
            Some(snapshot) => snapshot.particles.len(),
            None => self.device.particle_arrays().count as usize,
        }
    }

    fn placement(&self) -> Placement {
        Placement::Gpu(Arc::clone(self.device.context()))
    }

    fn options(&self) -> SolverOptions {
        SolverOptions {
            simd: None,
            gpu_scatter: Some(self.device.scatter()),
        }
    }

    fn apply(&mut self, options: SolverOptions) {
        if let Some(scatter) = options.gpu_scatter {
            self.device.set_scatter(scatter);
        }
    }

    fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        self.advance(|device| device.advance_to(until))
    }

    fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        let until = substeps_ahead(self.device.scene(), self.device.time(), count);
        self.advance(|device| device.advance_to(until))
    }

    fn stage_times(&mut self, substeps: u32) -> Result<Option<StageTimes>, RunError> {
        let until = substeps_ahead(self.device.scene(), self.device.time(), substeps);
        self.host = None;
        let times = self.device.stage_times(until, substeps)?;
        self.steps += u64::from(times.map_or(0, |times| times.substeps));
        Ok(times)
    }

    fn memory_bytes(&self) -> u64 {
        let particles = self.device.particle_arrays().count;
        MemoryEstimate::of(self.device.scene(), u64::from(particles)).total_bytes()
    }

    fn host(&mut self) -> Result<HostState<'_>, RunError> {
        let snapshot = match self.host.take() {
            Some(snapshot) => snapshot,
            None => self.device.snapshot()?,
        };
        let snapshot = self.host.insert(snapshot);
        Ok(HostState::Snow(snapshot.view(self.device.scene())))
    }

    fn current_host(&self) -> Option<HostState<'_>> {
        let snapshot = self.host.as_ref()?;
        Some(HostState::Snow(snapshot.view(self.device.scene())))
    }

    fn state(&self) -> Result<SolverState, RunError> {
        Ok(SolverState::Snow(match &self.host {
            Some(snapshot) => snapshot.clone(),
            None => self.device.snapshot()?,
        }))
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        self.device.solver_stats()
    }

    fn wait(&self) -> Result<(), RunError> {
        Ok(self.device.context().wait()?)
    }

    fn set_materials(&mut self, materials: &[Material]) -> Result<(), RunError> {
        self.device.set_materials(materials)?;
        self.host = None;
        Ok(())
    }

    fn set_wind(&mut self, wind: &Wind) -> Result<(), RunError> {
        self.device.set_wind(wind)?;
        self.host = None;
        Ok(())
    }

    fn device_particles(&self) -> Option<ParticleArrays<'_>> {
        Some(self.device.particle_arrays())
    }

    fn device_body_poses(&self) -> Option<Vec<BodyPose>> {
        let states = self
            .device
            .rigid_bodies()
            .map(RigidBodies::states)
            .unwrap_or_default();
        Some(poses(&states))
    }
}

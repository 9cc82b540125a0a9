//! Snow on the CPU: a [`Simulation`] is its own engine.

use firn_core::Scene;
use firn_core::scene::{Material, RigidBody, Wind};
use firn_mpm::{PhaseTimes, Simulation, SolverStats};

use super::Engine;
use crate::error::RunError;
use crate::simulation::{HostState, SolverOptions, SolverState};

impl Engine for Simulation {
    fn scene(&self) -> &Scene {
        Simulation::scene(self)
    }

    fn time(&self) -> f64 {
        Simulation::time(self)
    }

    fn steps(&self) -> u64 {
        Simulation::steps(self)
    }

    fn particle_count(&self) -> usize {
        self.particles().len()
    }

    fn options(&self) -> SolverOptions {
        SolverOptions {
            simd: Some(self.simd()),
            gpu_scatter: None,
        }
    }

    fn apply(&mut self, options: SolverOptions) {
        if let Some(simd) = options.simd {
            self.set_simd(simd);
        }
    }

    fn advance_to(&mut self, until: f64) -> Result<u32, RunError> {
        Ok(Simulation::advance_to(self, until)?)
    }

    fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        for _ in 0..count {
            self.step(f64::INFINITY)?;
        }
        Ok(count)
    }

    fn memory_bytes(&self) -> u64 {
        Simulation::memory_bytes(self) as u64
    }

    fn host(&mut self) -> Result<HostState<'_>, RunError> {
        Ok(HostState::Snow(self.view()))
    }

    fn current_host(&self) -> Option<HostState<'_>> {
        Some(HostState::Snow(self.view()))
    }

    fn state(&self) -> Result<SolverState, RunError> {
        Ok(SolverState::Snow(self.snapshot()))
    }

    fn solver_stats(&self) -> Option<SolverStats> {
        Simulation::solver_stats(self)
    }

    fn phase_times(&self) -> Option<PhaseTimes> {
        Some(Simulation::phase_times(self))
    }

    fn reset_phase_times(&mut self) {
        Simulation::reset_phase_times(self);
    }

    fn set_materials(&mut self, materials: &[Material]) -> Result<(), RunError> {
        Ok(Simulation::set_materials(self, materials)?)
    }

    fn set_wind(&mut self, wind: &Wind) -> Result<(), RunError> {
        Ok(Simulation::set_wind(self, wind)?)
    }

    fn add_rigid_body(&mut self, body: RigidBody) -> Result<(), RunError> {
        Ok(Simulation::add_rigid_body(self, body)?)
    }
}

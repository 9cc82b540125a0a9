//! A curl-noise flow on the CPU: a [`FlowSimulation`] is its own engine.

use firn_core::Scene;
use firn_core::scene::FlowSettings;
use firn_flow::FlowSimulation;

use super::Engine;
use crate::error::RunError;
use crate::simulation::{HostState, SolverOptions, SolverState};

impl Engine for FlowSimulation {
    fn scene(&self) -> &Scene {
        FlowSimulation::scene(self)
    }

    fn time(&self) -> f64 {
        FlowSimulation::time(self)
    }

    fn steps(&self) -> u64 {
        self.substeps()
    }

    fn particle_count(&self) -> usize {
        self.len()
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
        Ok(FlowSimulation::advance_to(self, until))
    }

    fn advance_substeps(&mut self, count: u32) -> Result<u32, RunError> {
        for _ in 0..count {
            self.step();
        }
        Ok(count)
    }

    fn memory_bytes(&self) -> u64 {
        FlowSimulation::memory_bytes(self) as u64
    }

    fn host(&mut self) -> Result<HostState<'_>, RunError> {
        Ok(HostState::Flow(self.view()))
    }

    fn current_host(&self) -> Option<HostState<'_>> {
        Some(HostState::Flow(self.view()))
    }

    fn state(&self) -> Result<SolverState, RunError> {
        Ok(SolverState::Flow(self.snapshot()))
    }

    fn set_flow(&mut self, settings: &FlowSettings) -> Result<(), RunError> {
        Ok(self.set_settings(settings.clone())?)
    }

    fn cpu_flow_mut(&mut self) -> Option<&mut FlowSimulation> {
        Some(self)
    }
}

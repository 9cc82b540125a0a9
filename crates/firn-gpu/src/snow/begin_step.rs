//! The start of every substep, before thesis §3.4 step 1
//! (`shaders/snow/begin_step.wgsl`): the substep's Δt and the stop
//! conditions, as `firn_mpm::Simulation::next_dt` and `advance_to`.
//! Δt = CFL h / (max |v_p| + max c_p), capped, or the fixed Δt, from the
//! maxima the last gather reduced, clipped to the frame's end; the frame
//! stops when it is done or a particle was in trouble. One invocation.
//!
//! The GPU runs the thesis' explicit scheme: step 6, the semi-implicit solve
//! of Stomakhin et al. 2013 (eq. 9, `firn_mpm::implicit`), has no GPU stage
//! ([`crate::GpuSnow::check_supported`] refuses it).

use super::substep::StepProgram;

/// The `begin_step` pipeline.
pub struct BeginStep {
    pipeline: wgpu::ComputePipeline,
}

impl BeginStep {
    /// The pipeline of `begin_step`.
    pub fn new(program: &StepProgram) -> BeginStep {
        BeginStep {
            pipeline: program.pipeline("begin_step"),
        }
    }

    /// Records the one invocation.
    pub fn record(&self, pass: &mut wgpu::ComputePass) {
        pass.set_pipeline(&self.pipeline);
        pass.dispatch_workgroups(1, 1, 1);
    }
}

//! The start of every substep, before thesis §3.4 step 1
//! (`shaders/snow/begin_step.wgsl`): the substep's Δt and the stop
//! conditions, as `firn_mpm::Simulation::next_dt` and `advance_to`.
//! Δt = CFL h / (max |v_p| + max c_p), capped, or the fixed Δt, from the
//! maxima the last gather reduced, clipped to the frame's end; the frame
//! stops when it is done or a particle was in trouble. One invocation.

use super::program::{Kernel, StepProgram};

/// The `begin_step` kernel.
pub struct BeginStep {
    kernel: Kernel,
}

impl BeginStep {
    /// The kernel `begin_step`.
    pub fn new(program: &StepProgram) -> BeginStep {
        BeginStep {
            kernel: program.kernel("begin_step"),
        }
    }

    /// Records the one invocation.
    pub fn record(&self, pass: &mut wgpu::ComputePass) {
        self.kernel.dispatch(pass, (1, 1, 1));
    }
}

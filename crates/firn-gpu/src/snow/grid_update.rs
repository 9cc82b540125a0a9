//! The grid update (thesis §3.4 steps 4 and 5;
//! `shaders/snow/grid_update.wgsl`), the GPU's counterpart of
//! `firn_mpm::grid_update`: grid velocities from the scattered momentum,
//! v_i = p_i / m_i, the forces and gravity, v_i* = v_i + Δt (f_i / m_i + g)
//! (for APIC the force impulse is already inside the momentum), and the
//! grid-based collisions with the colliders placed at the substep's end
//! (Quellcode 12). One invocation per node; v_i and v_i* replace the
//! momentum sums in the word planes for the gather.

use super::substep::StepProgram;

/// The `update_grid` pipeline.
pub struct GridUpdate {
    pipeline: wgpu::ComputePipeline,
}

impl GridUpdate {
    /// The pipeline of `update_grid` (both transfer schemes).
    pub fn new(program: &StepProgram) -> GridUpdate {
        GridUpdate {
            pipeline: program.pipeline("update_grid"),
        }
    }

    /// Records the update, one invocation per node.
    pub fn record(&self, pass: &mut wgpu::ComputePass, (x, y, z): (u32, u32, u32)) {
        pass.set_pipeline(&self.pipeline);
        pass.dispatch_workgroups(x, y, z);
    }
}

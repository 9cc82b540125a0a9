//! The grid update (thesis §3.4 steps 4 and 5;
//! `shaders/snow/grid_update.wgsl`), the GPU's counterpart of
//! `firn_mpm::grid_update`: grid velocities from the scattered momentum,
//! v_i = p_i / m_i, the forces and gravity, v_i* = v_i + Δt (f_i / m_i + g)
//! (for APIC the force impulse is already inside the momentum), and the
//! wind's drag in scenes with a `[wind]` (`shaders/snow/wind.wgsl`), and the
//! grid-based collisions with the colliders placed at the substep's end
//! (Quellcode 12), which the semi-implicit integrator leaves to its solve
//! ([`super::implicit`]), then in scenes with rigid bodies their push,
//! summed for them ([`super::coupling`]). One invocation per node, one workgroup per
//! allocated block of the grid; v_i and v_i* replace the momentum sums in
//! the word planes for the gather.

use super::program::{Kernel, StepProgram};

/// The grid update's kernels: without wind and with the wind's drag
/// (`update_grid_in_wind`), each with the grid collisions or, for the
/// semi-implicit solve that applies them itself, without
/// (`update_grid_free*`), or with the colliders and the rigid bodies
/// (`update_grid_coupled*`); a run records the one its scene needs.
pub struct GridUpdate {
    calm: Kernel,
    in_wind: Kernel,
    /// Whether the scene has a wind.
    windy: bool,
}

impl GridUpdate {
    /// The kernels of both entry points (both transfer schemes), with the
    /// grid collisions unless `implicit` and the rigid bodies when
    /// `coupled` (never both: the scene format refuses rigid bodies with
    /// the semi-implicit integrator), recording the one with the wind's
    /// drag when `windy`.
    pub fn new(program: &StepProgram, windy: bool, implicit: bool, coupled: bool) -> GridUpdate {
        let (calm, in_wind) = match (implicit, coupled) {
            (true, _) => ("update_grid_free", "update_grid_free_in_wind"),
            (false, true) => ("update_grid_coupled", "update_grid_coupled_in_wind"),
            (false, false) => ("update_grid", "update_grid_in_wind"),
        };
        GridUpdate {
            calm: program.kernel(calm),
            in_wind: program.kernel(in_wind),
            windy,
        }
    }

    /// Records the wind's drag from now on when `windy`.
    pub fn set_windy(&mut self, windy: bool) {
        self.windy = windy;
    }

    /// Records the update, one workgroup per allocated block, as many as
    /// the block table's `indirect` arguments say.
    pub fn record(&self, pass: &mut wgpu::ComputePass, indirect: &wgpu::Buffer) {
        let kernel = if self.windy {
            &self.in_wind
        } else {
            &self.calm
        };
        kernel.dispatch_indirect(pass, indirect, 0);
    }
}

//! The semi-implicit solve (Stomakhin et al. 2013 eq. 9, step 6;
//! `shaders/snow/implicit.wgsl`), the GPU's counterpart of
//! `firn_mpm::implicit`: (M + β Δt² H) v^{n+1} = M v* by preconditioned
//! conjugate residuals from v*, on the free components of the nodes in
//! contact, with the same stopping rule and iteration limit.
//!
//! Per substep, after the grid update has left v* without collisions:
//!
//! 1. [`ImplicitSolve::record_start`]: the particles' stress differentials
//!    (`linearize`), v* through the colliders with the components they fix
//!    (`solve_load`), the product with H at v* and the initial residual, the
//!    first search direction;
//! 2. [`ImplicitSolve::record_iterations`], a few iterations at a time: the
//!    host reads `SolveState` back between them ([`SolveHeader`]) and stops
//!    once the solve has; kernels recorded past the end return at once;
//! 3. [`ImplicitSolve::record_store`]: the iterate through the colliders
//!    into v^{n+1}.
//!
//! A product with H scatters into 64-bit fixed-point sums and every dot
//! product is summed in a fixed order (a tree per workgroup, then the
//! partials in order by one workgroup), so the solve is deterministic.

use super::program::{Kernel, StepProgram, compute_pass};
use crate::buffers::read_back;
use crate::context::GpuContext;
use crate::error::GpuError;

use super::layout::SolveHeader;

/// Iterations recorded between two reads of the solve's state.
pub const ITERATIONS_PER_READ: u32 = 8;

/// Bytes of `SolveState` each substep's solve resets: its flags, counters
/// and the active-node count.
const RESET_BYTES: u64 = 32;

/// The solve's kernels.
pub struct ImplicitSolve {
    linearize: Kernel,
    load: Kernel,
    begin: Kernel,
    hessian_of_x: Kernel,
    initial_residual: Kernel,
    start: Kernel,
    hessian_of_z: Kernel,
    finish_product: Kernel,
    curvature: Kernel,
    next_direction: Kernel,
    step_length: Kernel,
    advance: Kernel,
    residual: Kernel,
    store: Kernel,
}

/// The workgroup counts of a dispatch over the particles and over the nodes.
#[derive(Clone, Copy, Debug)]
pub struct SolveGroups<'a> {
    /// One invocation per particle.
    pub particles: (u32, u32, u32),
    /// One workgroup per allocated block of the grid: the indirect
    /// arguments the block table wrote (`blocks.rs`).
    pub nodes: &'a wgpu::Buffer,
}

impl ImplicitSolve {
    /// Every kernel of the solve.
    pub fn new(program: &StepProgram) -> ImplicitSolve {
        ImplicitSolve {
            linearize: program.kernel("linearize"),
            load: program.kernel("solve_load"),
            begin: program.kernel("solve_begin"),
            hessian_of_x: program.kernel("hessian_of_x"),
            initial_residual: program.kernel("solve_initial_residual"),
            start: program.kernel("solve_start"),
            hessian_of_z: program.kernel("hessian_of_z"),
            finish_product: program.kernel("solve_finish_product"),
            curvature: program.kernel("solve_curvature"),
            next_direction: program.kernel("solve_next_direction"),
            step_length: program.kernel("solve_step_length"),
            advance: program.kernel("solve_advance"),
            residual: program.kernel("solve_residual"),
            store: program.kernel("solve_store"),
        }
    }

    /// Records the solve up to its first search direction and step length,
    /// after the grid update; `state` is the `SolveState` buffer.
    pub fn record_start(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        state: &wgpu::Buffer,
        groups: SolveGroups<'_>,
    ) {
        encoder.clear_buffer(state, 0, Some(RESET_BYTES));
        let mut pass = compute_pass(encoder, "semi-implicit solve");
        self.linearize.dispatch(&mut pass, groups.particles);
        self.load.dispatch_indirect(&mut pass, groups.nodes, 0);
        self.begin.dispatch(&mut pass, (1, 1, 1));
        self.hessian_of_x.dispatch(&mut pass, groups.particles);
        self.initial_residual
            .dispatch_indirect(&mut pass, groups.nodes, 0);
        self.start.dispatch(&mut pass, (1, 1, 1));
        self.record_direction(&mut pass, groups);
    }

    /// The product S z, then the next direction and its step length.
    fn record_direction(&self, pass: &mut wgpu::ComputePass, groups: SolveGroups<'_>) {
        self.hessian_of_z.dispatch(pass, groups.particles);
        self.finish_product.dispatch_indirect(pass, groups.nodes, 0);
        self.curvature.dispatch(pass, (1, 1, 1));
        self.next_direction.dispatch_indirect(pass, groups.nodes, 0);
        self.step_length.dispatch(pass, (1, 1, 1));
    }

    /// Records `count` iterations: the step along the direction, the
    /// residual and the stopping test, then the next direction.
    pub fn record_iterations(
        &self,
        pass: &mut wgpu::ComputePass,
        count: u32,
        groups: SolveGroups<'_>,
    ) {
        for _ in 0..count {
            self.advance.dispatch_indirect(pass, groups.nodes, 0);
            self.residual.dispatch(pass, (1, 1, 1));
            self.record_direction(pass, groups);
        }
    }

    /// Records the final velocities: the iterate through the colliders.
    pub fn record_store(&self, pass: &mut wgpu::ComputePass, nodes: &wgpu::Buffer) {
        self.store.dispatch_indirect(pass, nodes, 0);
    }
}

/// Reads the head of `SolveState`: whether the solve still runs, and how it
/// went.
pub fn read_header(context: &GpuContext, state: &wgpu::Buffer) -> Result<SolveHeader, GpuError> {
    let header = read_back::<SolveHeader>(context, &[(state, 1)])?;
    Ok(header[0].first().copied().unwrap_or_default())
}

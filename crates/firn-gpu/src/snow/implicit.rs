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

use super::substep::{StepProgram, compute_pass};
use crate::buffers::read_back;
use crate::context::GpuContext;
use crate::error::GpuError;

use super::layout::SolveHeader;

/// Iterations recorded between two reads of the solve's state.
pub const ITERATIONS_PER_READ: u32 = 8;

/// Bytes of `SolveState` each substep's solve resets: its flags, counters
/// and the active-node count.
const RESET_BYTES: u64 = 32;

/// The solve's pipelines.
pub struct ImplicitSolve {
    linearize: wgpu::ComputePipeline,
    load: wgpu::ComputePipeline,
    begin: wgpu::ComputePipeline,
    hessian_of_x: wgpu::ComputePipeline,
    initial_residual: wgpu::ComputePipeline,
    start: wgpu::ComputePipeline,
    hessian_of_z: wgpu::ComputePipeline,
    finish_product: wgpu::ComputePipeline,
    curvature: wgpu::ComputePipeline,
    next_direction: wgpu::ComputePipeline,
    step_length: wgpu::ComputePipeline,
    advance: wgpu::ComputePipeline,
    residual: wgpu::ComputePipeline,
    store: wgpu::ComputePipeline,
}

/// The workgroup counts of a dispatch over the particles and over the nodes.
#[derive(Clone, Copy, Debug)]
pub struct SolveGroups {
    /// One invocation per particle.
    pub particles: (u32, u32, u32),
    /// One invocation per node.
    pub nodes: (u32, u32, u32),
}

fn dispatch(
    pass: &mut wgpu::ComputePass,
    pipeline: &wgpu::ComputePipeline,
    (x, y, z): (u32, u32, u32),
) {
    pass.set_pipeline(pipeline);
    pass.dispatch_workgroups(x, y, z);
}

impl ImplicitSolve {
    /// The pipelines of every kernel of the solve.
    pub fn new(program: &StepProgram) -> ImplicitSolve {
        ImplicitSolve {
            linearize: program.pipeline("linearize"),
            load: program.pipeline("solve_load"),
            begin: program.pipeline("solve_begin"),
            hessian_of_x: program.pipeline("hessian_of_x"),
            initial_residual: program.pipeline("solve_initial_residual"),
            start: program.pipeline("solve_start"),
            hessian_of_z: program.pipeline("hessian_of_z"),
            finish_product: program.pipeline("solve_finish_product"),
            curvature: program.pipeline("solve_curvature"),
            next_direction: program.pipeline("solve_next_direction"),
            step_length: program.pipeline("solve_step_length"),
            advance: program.pipeline("solve_advance"),
            residual: program.pipeline("solve_residual"),
            store: program.pipeline("solve_store"),
        }
    }

    /// Records the solve up to its first search direction and step length,
    /// after the grid update; `state` is the `SolveState` buffer.
    pub fn record_start(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        state: &wgpu::Buffer,
        groups: SolveGroups,
    ) {
        encoder.clear_buffer(state, 0, Some(RESET_BYTES));
        let mut pass = compute_pass(encoder, "semi-implicit solve", bind_group);
        dispatch(&mut pass, &self.linearize, groups.particles);
        dispatch(&mut pass, &self.load, groups.nodes);
        dispatch(&mut pass, &self.begin, (1, 1, 1));
        dispatch(&mut pass, &self.hessian_of_x, groups.particles);
        dispatch(&mut pass, &self.initial_residual, groups.nodes);
        dispatch(&mut pass, &self.start, (1, 1, 1));
        self.record_direction(&mut pass, groups);
    }

    /// The product S z, then the next direction and its step length.
    fn record_direction(&self, pass: &mut wgpu::ComputePass, groups: SolveGroups) {
        dispatch(pass, &self.hessian_of_z, groups.particles);
        dispatch(pass, &self.finish_product, groups.nodes);
        dispatch(pass, &self.curvature, (1, 1, 1));
        dispatch(pass, &self.next_direction, groups.nodes);
        dispatch(pass, &self.step_length, (1, 1, 1));
    }

    /// Records `count` iterations: the step along the direction, the
    /// residual and the stopping test, then the next direction.
    pub fn record_iterations(&self, pass: &mut wgpu::ComputePass, count: u32, groups: SolveGroups) {
        for _ in 0..count {
            dispatch(pass, &self.advance, groups.nodes);
            dispatch(pass, &self.residual, (1, 1, 1));
            self.record_direction(pass, groups);
        }
    }

    /// Records the final velocities: the iterate through the colliders.
    pub fn record_store(&self, pass: &mut wgpu::ComputePass, node_groups: (u32, u32, u32)) {
        dispatch(pass, &self.store, node_groups);
    }
}

/// Reads the head of `SolveState`: whether the solve still runs, and how it
/// went.
pub fn read_header(context: &GpuContext, state: &wgpu::Buffer) -> Result<SolveHeader, GpuError> {
    let header = read_back::<SolveHeader>(context, &[(state, 1)])?;
    Ok(header[0].first().copied().unwrap_or_default())
}

//! The flow substep's kernels (`shaders/flow/step.wgsl`): their pipelines
//! and the recording of their dispatches, one submission per substep:
//!
//! 1. `advance`: RK2 or RK4 through the field, the fading birth velocity,
//!    aging, rebirth of particles that expired or left the domain, and
//!    pushing particles out of spheres;
//! 2. `settle_newborns`: the particles `rate` emitters add in the substep
//!    (uploaded by the host) pushed out of spheres, with their velocity;
//! 3. `record_trails`, at a frame's end: every position into its trail ring.
//!
//! They see the field as group 0, the particles as group 1 and the trails
//! as group 2 ([`super::bindings`]).

use super::layout::SubstepParams;
use crate::context::GpuContext;
use crate::dispatch::dispatch_items;
use crate::shaders::FLOW_STEP;

/// The compute pipelines of a substep.
pub(crate) struct StepKernels {
    advance: wgpu::ComputePipeline,
    settle_newborns: wgpu::ComputePipeline,
    record_trails: wgpu::ComputePipeline,
}

/// The bind groups a substep's kernels see.
pub(crate) struct StepGroups<'a> {
    /// Group 0: the field.
    pub field: &'a wgpu::BindGroup,
    /// Group 1: the particles.
    pub particles: &'a wgpu::BindGroup,
    /// Group 2: the trails, when this substep records them.
    pub trails: Option<&'a wgpu::BindGroup>,
}

impl StepKernels {
    /// The kernels of [`FLOW_STEP`] with the field, particle and trail
    /// bind group layouts (groups 0, 1 and 2).
    pub(crate) fn new(
        context: &GpuContext,
        field: &wgpu::BindGroupLayout,
        particles: &wgpu::BindGroupLayout,
        trails: &wgpu::BindGroupLayout,
    ) -> StepKernels {
        let [advance, settle_newborns, record_trails] = FLOW_STEP.compute_pipelines(
            &context.device,
            [
                ("advance", &[field, particles]),
                ("settle_newborns", &[field, particles]),
                ("record_trails", &[field, particles, trails]),
            ],
        );
        StepKernels {
            advance,
            settle_newborns,
            record_trails,
        }
    }

    /// Records one substep of `params`: the advance, the newborns settled,
    /// and the trails recorded where `groups` has them.
    pub(crate) fn record(
        &self,
        context: &GpuContext,
        pass: &mut wgpu::ComputePass,
        groups: &StepGroups,
        params: &SubstepParams,
    ) {
        let limit = context.limits.max_compute_workgroups_per_dimension;
        let step = [groups.field, groups.particles];
        dispatch_items(pass, &self.advance, &step, params.count, limit);
        let newborns = params.newborn_end - params.newborn_first;
        dispatch_items(pass, &self.settle_newborns, &step, newborns, limit);
        if let Some(trails) = groups.trails {
            let all = [groups.field, groups.particles, trails];
            let end = params.newborn_end;
            dispatch_items(pass, &self.record_trails, &all, end, limit);
        }
    }

    /// Records `settle_newborns` over the first `count` particles: each
    /// pushed out of the spheres, with its velocity in the field.
    pub(crate) fn record_settle(
        &self,
        context: &GpuContext,
        pass: &mut wgpu::ComputePass,
        groups: &StepGroups,
        count: u32,
    ) {
        let limit = context.limits.max_compute_workgroups_per_dimension;
        let step = [groups.field, groups.particles];
        dispatch_items(pass, &self.settle_newborns, &step, count, limit);
    }
}

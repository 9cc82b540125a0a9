//! The snow step's program and its kernels: each kernel is a pipeline whose
//! layout holds only the buffers its entry point uses, with a bind group of
//! those buffers.
//!
//! The step binds 42 buffers in all ([`StepBindings`]), more than some
//! adapters let one shader stage see: Metal offers 29 buffer slots per
//! stage for storage and uniform buffers together. No single kernel uses
//! more than [`MIN_STORAGE_BUFFERS`](crate::context::MIN_STORAGE_BUFFERS)
//! storage buffers, so giving each its own layout, from naga's analysis of
//! the program ([`Reflection`]), fits every adapter firn accepts.

use super::bindings::StepBindings;
use crate::shaders::{Reflection, SNOW_STEP, compute_pipeline};

/// The step program compiled once, which bindings each entry point uses,
/// and the buffers to bind: the stages make their kernels from it.
pub struct StepProgram<'a> {
    device: &'a wgpu::Device,
    module: wgpu::ShaderModule,
    reflection: Reflection,
    buffers: StepBindings<'a>,
    deforming: bool,
}

impl<'a> StepProgram<'a> {
    /// Compiles the snow step on `device`, to bind `buffers`; its kernels
    /// run deforming colliders only when `deforming` (the WGSL override
    /// `DEFORMING` in `common/deforming.wgsl`).
    pub fn new(
        device: &'a wgpu::Device,
        buffers: StepBindings<'a>,
        deforming: bool,
    ) -> StepProgram<'a> {
        StepProgram {
            device,
            module: SNOW_STEP.module(device),
            reflection: SNOW_STEP.reflect(),
            buffers,
            deforming,
        }
    }

    /// The kernel of entry point `entry`: its pipeline and bind group.
    pub fn kernel(&self, entry: &str) -> Kernel {
        let table = StepBindings::TABLE;
        let numbers = self.reflection.bindings(entry, table.group);
        let group_layout = table.layout_of(self.device, &numbers);
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry),
                bind_group_layouts: &[Some(&group_layout)],
                immediate_size: 0,
            });
        Kernel {
            pipeline: compute_pipeline(
                self.device,
                &self.module,
                &layout,
                entry,
                &[("DEFORMING", f64::from(u8::from(self.deforming)))],
            ),
            bind_group: self
                .buffers
                .bind_group_of(self.device, &group_layout, &numbers),
        }
    }
}

/// One entry point of the step, ready to dispatch.
pub struct Kernel {
    pipeline: wgpu::ComputePipeline,
    bind_group: wgpu::BindGroup,
}

impl Kernel {
    /// Records `x × y × z` workgroups of the kernel.
    pub fn dispatch(&self, pass: &mut wgpu::ComputePass, (x, y, z): (u32, u32, u32)) {
        self.bind(pass);
        pass.dispatch_workgroups(x, y, z);
    }

    /// Records the kernel with the workgroup counts in `indirect` at
    /// `offset`.
    pub fn dispatch_indirect(
        &self,
        pass: &mut wgpu::ComputePass,
        indirect: &wgpu::Buffer,
        offset: u64,
    ) {
        self.bind(pass);
        pass.dispatch_workgroups_indirect(indirect, offset);
    }

    fn bind(&self, pass: &mut wgpu::ComputePass) {
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
    }
}

/// A compute pass of the step (each kernel sets its own bind group).
pub fn compute_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
) -> wgpu::ComputePass<'e> {
    encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    })
}

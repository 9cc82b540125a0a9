//! Bind group layouts, compute pipelines and dispatches of the flow
//! programs. The groups follow `shaders/flow/*.wgsl`: 0 the field (constants,
//! obstacles, emitters, substep), 1 the particles (or the probe's arrays),
//! 2 the trails.

use crate::context::GpuContext;
use crate::dispatch::workgroups;
use crate::shaders::Program;

/// A storage buffer binding, visible to compute shaders.
fn storage(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A uniform buffer binding, visible to compute shaders.
fn uniform(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn layout(
    context: &GpuContext,
    label: &str,
    entries: &[wgpu::BindGroupLayoutEntry],
) -> wgpu::BindGroupLayout {
    context
        .device
        .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(label),
            entries,
        })
}

/// Group 0: constants, obstacles, emitters, substep parameters.
pub(crate) fn field_layout(context: &GpuContext) -> wgpu::BindGroupLayout {
    let entries = [uniform(0), storage(1, true), storage(2, true), uniform(3)];
    layout(context, "flow field", &entries)
}

/// Group 1 of the step: positions, velocities, ages, lifetimes,
/// generations (read-write) and emitters (read-only).
pub(crate) fn particle_layout(context: &GpuContext) -> wgpu::BindGroupLayout {
    let mut entries: Vec<_> = (0..5).map(|binding| storage(binding, false)).collect();
    entries.push(storage(5, true));
    layout(context, "flow particles", &entries)
}

/// Group 2 of the step: trail points, lengths and recorded generations.
pub(crate) fn trail_layout(context: &GpuContext) -> wgpu::BindGroupLayout {
    let entries: Vec<_> = (0..3).map(|binding| storage(binding, false)).collect();
    layout(context, "flow trails", &entries)
}

/// Group 1 of the probes: input (read-only) and output.
pub(crate) fn probe_layout(context: &GpuContext) -> wgpu::BindGroupLayout {
    layout(
        context,
        "flow probe",
        &[storage(0, true), storage(1, false)],
    )
}

/// The compute pipelines of `program`'s entry points, each with its bind
/// group layouts (group 0 first).
pub(crate) fn pipelines<const N: usize>(
    context: &GpuContext,
    program: &Program,
    kernels: [(&str, &[&wgpu::BindGroupLayout]); N],
) -> [wgpu::ComputePipeline; N] {
    let module = program.module(&context.device);
    kernels.map(|(entry_point, groups)| {
        let bind_group_layouts: Vec<_> = groups.iter().map(|group| Some(*group)).collect();
        let layout = context
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(entry_point),
                bind_group_layouts: &bind_group_layouts,
                immediate_size: 0,
            });
        context
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: Some(&layout),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
    })
}

/// Records a dispatch of `pipeline` over `items` invocations (none when
/// `items` is 0).
pub(crate) fn dispatch(
    context: &GpuContext,
    pass: &mut wgpu::ComputePass,
    pipeline: &wgpu::ComputePipeline,
    groups: &[&wgpu::BindGroup],
    items: u32,
) {
    if items == 0 {
        return;
    }
    pass.set_pipeline(pipeline);
    for (index, group) in groups.iter().enumerate() {
        pass.set_bind_group(index as u32, *group, &[]);
    }
    let (x, y, z) = workgroups(items, context.limits.max_compute_workgroups_per_dimension);
    pass.dispatch_workgroups(x, y, z);
}

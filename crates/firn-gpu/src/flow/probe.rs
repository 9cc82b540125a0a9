//! Single functions of the flow's WGSL library run on arrays of inputs
//! ([`shaders::FLOW_PARITY`](crate::shaders::FLOW_PARITY)), so tests can
//! compare them with `firn_flow` one by one: the noise and its gradient, the
//! field velocity, and births.

use std::sync::Arc;

use firn_core::Scene;
use glam::Vec3;

use super::bindings::{FieldBindings, ProbeBindings};
use super::buffers::FieldBuffers;
use super::layout::{NoiseDomains, SubstepParams};
use crate::buffers::{read_back, storage_buffer, zeroed_storage_buffer};
use crate::context::GpuContext;
use crate::dispatch::dispatch_items;
use crate::error::GpuError;
use crate::shaders::FLOW_PARITY;

/// The flow's field and emitters of one scene on the GPU, evaluated at
/// given points (for parity tests against `firn_flow`).
pub struct FlowProbe {
    context: Arc<GpuContext>,
    domains: NoiseDomains,
    field: FieldBuffers,
    probe_layout: wgpu::BindGroupLayout,
    noise: wgpu::ComputePipeline,
    velocity: wgpu::ComputePipeline,
    birth: wgpu::ComputePipeline,
}

impl FlowProbe {
    /// The field and emitters of a flow scene.
    pub fn new(context: Arc<GpuContext>, scene: &Scene) -> Result<FlowProbe, GpuError> {
        let settings = super::flow_settings(scene)?;
        let field_layout = FieldBindings::TABLE.layout(&context.device);
        let probe_layout = ProbeBindings::TABLE.layout(&context.device);
        let groups: &[&wgpu::BindGroupLayout] = &[&field_layout, &probe_layout];
        let [noise, velocity, birth] = FLOW_PARITY.compute_pipelines(
            &context.device,
            [
                ("probe_noise", groups),
                ("probe_velocity", groups),
                ("probe_birth", groups),
            ],
        );
        Ok(FlowProbe {
            domains: NoiseDomains::new(settings),
            field: FieldBuffers::new(&context, scene, settings, &field_layout),
            context,
            probe_layout,
            noise,
            velocity,
            birth,
        })
    }

    /// Simplex noise n(p) and its gradient ∇n(p) at each point (the
    /// counterpart of `firn_flow::noise::noise`).
    pub fn noise(&self, points: &[Vec3]) -> Result<Vec<(f32, Vec3)>, GpuError> {
        let output = self.run(&self.noise, bytemuck::cast_slice(points), points.len(), 4)?;
        Ok(output
            .chunks_exact(4)
            .map(|sample| (sample[0], Vec3::new(sample[1], sample[2], sample[3])))
            .collect())
    }

    /// The field velocity at each point at time `t` (the counterpart of
    /// `firn_flow::FlowField::velocity`).
    pub fn velocities(&self, points: &[Vec3], t: f64) -> Result<Vec<Vec3>, GpuError> {
        let params = SubstepParams::new(&self.domains, t, t, 0);
        self.field.write_substep(&self.context, &params);
        let output = self.run(
            &self.velocity,
            bytemuck::cast_slice(points),
            points.len(),
            3,
        )?;
        Ok(bytemuck::cast_slice::<f32, Vec3>(&output).to_vec())
    }

    /// The birth position and lifetime (+∞ without one) of each request
    /// `[emitter, particle id, generation]` (the counterparts of
    /// `firn_flow::emitters::birth_position` and `lifetime`).
    pub fn births(&self, requests: &[[u32; 3]]) -> Result<Vec<(Vec3, f32)>, GpuError> {
        let output = self.run(
            &self.birth,
            bytemuck::cast_slice(requests),
            requests.len(),
            4,
        )?;
        Ok(output
            .chunks_exact(4)
            .map(|birth| (Vec3::new(birth[0], birth[1], birth[2]), birth[3]))
            .collect())
    }

    /// Runs `pipeline` over `items` inputs of three words each, reading
    /// back `per_item` numbers each.
    fn run(
        &self,
        pipeline: &wgpu::ComputePipeline,
        input: &[u32],
        items: usize,
        per_item: usize,
    ) -> Result<Vec<f32>, GpuError> {
        let context = &self.context;
        let input = storage_buffer(context, "flow probe input", input);
        let output_bytes = (items * per_item * size_of::<f32>()) as u64;
        let output = zeroed_storage_buffer(context, "flow probe output", output_bytes);
        let group = ProbeBindings {
            probe_input: &input,
            probe_output: &output,
        }
        .bind_group(&context.device, &self.probe_layout);
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("flow probe"),
            });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("flow probe"),
                timestamp_writes: None,
            });
            let groups = [&self.field.group, &group];
            let limit = context.limits.max_compute_workgroups_per_dimension;
            dispatch_items(&mut pass, pipeline, &groups, items as u32, limit);
        }
        context.queue.submit([encoder.finish()]);
        let mut outputs = read_back::<f32>(context, &[(&output, items * per_item)])?;
        Ok(outputs.remove(0))
    }
}

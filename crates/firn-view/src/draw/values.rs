//! Colour values of a GPU simulation's particles, computed on the device
//! from the simulation's own buffers (`values.wgsl`): speed |v|, density
//! m / (V⁰ det F_E J_P) and plastic J_P, one `f32` per particle in the
//! renderer's value buffer.

use bytemuck::{Pod, Zeroable};
use firn_core::scene::ColorBy;
use firn_gpu::draw::{ParticleArrays, SnowArrays, StridedArray};

use super::gpu::{GrowingBuffer, uniform_buffer};

const SHADER: &str = include_str!("../../shaders/values.wgsl");

/// Invocations per workgroup (`WORKGROUP_SIZE` in `values.wgsl`).
const WORKGROUP_SIZE: u32 = 64;
/// Most workgroups along one dispatch dimension (WebGPU's limit).
const MAX_GROUPS_PER_DIMENSION: u32 = 65_535;

/// Where each quantity lies (`Arrays` in `values.wgsl`): (stride, offset).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct ArraysUniform {
    count: u32,
    _pad: u32,
    velocity: [u32; 2],
    mass: [u32; 2],
    volume0: [u32; 2],
    elastic: [u32; 2],
    plastic_j: [u32; 2],
}

fn stride_offset(array: &StridedArray<'_>) -> [u32; 2] {
    [array.stride, array.offset]
}

/// The three kernels and their layout uniform.
pub(super) struct ValueKernels {
    speed: wgpu::ComputePipeline,
    density: wgpu::ComputePipeline,
    plastic_j: wgpu::ComputePipeline,
    arrays: wgpu::Buffer,
}

impl ValueKernels {
    /// Compiles the kernels.
    pub(super) fn new(device: &wgpu::Device) -> ValueKernels {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("firn-view values"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let pipeline = |entry_point: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry_point),
                layout: None,
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            })
        };
        ValueKernels {
            speed: pipeline("speed"),
            density: pipeline("density"),
            plastic_j: pipeline("plastic_volume_change"),
            arrays: uniform_buffer(device, "firn-view value arrays", &ArraysUniform::zeroed()),
        }
    }

    /// Records the computation of `color_by`'s value for each of
    /// `particles` into `values`. False, recording nothing, when
    /// `color_by` is not a ramp quantity or needs snow state the source
    /// lacks.
    pub(super) fn record(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        color_by: ColorBy,
        particles: &ParticleArrays<'_>,
        values: &mut GrowingBuffer,
    ) -> bool {
        let Some((pipeline, inputs)) = self.kernel(color_by, particles) else {
            return false;
        };
        values.reserve(device, u64::from(particles.count) * size_of::<f32>() as u64);
        queue.write_buffer(
            &self.arrays,
            0,
            bytemuck::bytes_of(&arrays_uniform(particles)),
        );
        let mut entries = vec![
            wgpu::BindGroupEntry {
                binding: 0,
                resource: self.arrays.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: values.buffer().as_entire_binding(),
            },
        ];
        entries.extend(
            inputs
                .into_iter()
                .map(|(binding, buffer)| wgpu::BindGroupEntry {
                    binding,
                    resource: buffer.as_entire_binding(),
                }),
        );
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("firn-view values"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("firn-view values"),
            timestamp_writes: None,
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        let [x, y] = workgroup_grid(particles.count);
        pass.dispatch_workgroups(x, y, 1);
        true
    }

    /// The kernel for `color_by` and the buffers it reads, by binding.
    fn kernel<'a>(
        &self,
        color_by: ColorBy,
        particles: &ParticleArrays<'a>,
    ) -> Option<(&wgpu::ComputePipeline, Vec<(u32, &'a wgpu::Buffer)>)> {
        let snow = particles.snow;
        match color_by {
            ColorBy::Speed => Some((&self.speed, vec![(2, particles.velocities.buffer)])),
            ColorBy::Density => snow.map(|snow| (&self.density, density_inputs(&snow))),
            ColorBy::PlasticJ => {
                snow.map(|snow| (&self.plastic_j, vec![(6, snow.plastic_j.buffer)]))
            }
            ColorBy::Position | ColorBy::Uniform => None,
        }
    }
}

fn density_inputs<'a>(snow: &SnowArrays<'a>) -> Vec<(u32, &'a wgpu::Buffer)> {
    vec![
        (3, snow.mass.buffer),
        (4, snow.volume0.buffer),
        (5, snow.elastic.buffer),
        (6, snow.plastic_j.buffer),
    ]
}

fn arrays_uniform(particles: &ParticleArrays<'_>) -> ArraysUniform {
    let snow = particles.snow.as_ref();
    let of = |pick: fn(&SnowArrays<'_>) -> [u32; 2]| snow.map_or([0, 0], pick);
    ArraysUniform {
        count: particles.count,
        _pad: 0,
        velocity: stride_offset(&particles.velocities),
        mass: of(|snow| stride_offset(&snow.mass)),
        volume0: of(|snow| stride_offset(&snow.volume0)),
        elastic: of(|snow| stride_offset(&snow.elastic)),
        plastic_j: of(|snow| stride_offset(&snow.plastic_j)),
    }
}

/// Workgroups along x and y that cover `count` particles.
fn workgroup_grid(count: u32) -> [u32; 2] {
    let groups = count.div_ceil(WORKGROUP_SIZE).max(1);
    let x = groups.min(MAX_GROUPS_PER_DIMENSION);
    [x, groups.div_ceil(x)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workgroup_grid_covers_every_particle() {
        for count in [1, 64, 65, 4_194_240, 10_000_000] {
            let [x, y] = workgroup_grid(count);
            assert!(x <= MAX_GROUPS_PER_DIMENSION && y <= MAX_GROUPS_PER_DIMENSION);
            assert!(u64::from(x) * u64::from(y) * u64::from(WORKGROUP_SIZE) >= u64::from(count));
        }
    }
}

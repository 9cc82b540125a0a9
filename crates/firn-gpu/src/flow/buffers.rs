//! The flow's GPU buffers: the field (group 0), the particles (group 1)
//! and the trails (group 2), each sized once for the run's largest particle
//! count so nothing is reallocated mid-run.

use firn_core::Scene;
use firn_core::scene::FlowSettings;
use firn_flow::FlowParticles;
use glam::Vec3;

use super::bindings::{FieldBindings, ParticleBindings, TrailBindings};
use super::layout::{self, FieldConstants, SubstepParams};
use crate::buffers::{read_back, storage_buffer, uniform_buffer, zeroed_storage_buffer};
use crate::context::GpuContext;
use crate::error::GpuError;

/// Fails when a buffer of `bytes` would pass the adapter's limits.
pub(crate) fn check_fits(context: &GpuContext, what: &str, bytes: u64) -> Result<(), GpuError> {
    let limit = context
        .limits
        .max_storage_buffer_binding_size
        .min(context.limits.max_buffer_size);
    if bytes <= limit {
        return Ok(());
    }
    Err(GpuError::TooLarge {
        what: what.into(),
        needed: bytes,
        limit,
        adapter: context.adapter.name.clone(),
        fix: "lower the emitters' counts, rates or lifetimes, or the render's trail_length, \
              or run with --backend cpu"
            .into(),
    })
}

/// Group 0: what every flow kernel reads.
pub(crate) struct FieldBuffers {
    constants: wgpu::Buffer,
    obstacles: wgpu::Buffer,
    emitters: wgpu::Buffer,
    substep: wgpu::Buffer,
    /// The bind group of the four buffers.
    pub group: wgpu::BindGroup,
}

impl FieldBuffers {
    /// The constants, obstacles and emitters of `scene`, and room for one
    /// substep's parameters.
    pub(crate) fn new(
        context: &GpuContext,
        scene: &Scene,
        settings: &FlowSettings,
        group_layout: &wgpu::BindGroupLayout,
    ) -> FieldBuffers {
        let constants = FieldConstants::new(scene, settings);
        let substep = bytemuck::Zeroable::zeroed();
        let constants = uniform_buffer(context, "flow constants", &constants);
        let obstacles = storage_buffer(context, "flow obstacles", &layout::obstacles(settings));
        let emitters = storage_buffer(context, "flow emitters", &layout::emitters(settings));
        let substep = uniform_buffer::<SubstepParams>(context, "flow substep", &substep);
        let group = FieldBindings {
            field_constants: &constants,
            obstacles: &obstacles,
            emitters: &emitters,
            substep: &substep,
        }
        .bind_group(&context.device, group_layout);
        FieldBuffers {
            constants,
            obstacles,
            emitters,
            substep,
            group,
        }
    }

    /// Sets the parameters the next submission's kernels read.
    pub(crate) fn write_substep(&self, context: &GpuContext, params: &SubstepParams) {
        context
            .queue
            .write_buffer(&self.substep, 0, bytemuck::bytes_of(params));
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> u64 {
        [
            &self.constants,
            &self.obstacles,
            &self.emitters,
            &self.substep,
        ]
        .iter()
        .map(|buffer| buffer.size())
        .sum()
    }
}

/// Group 1: the particle arrays, with room for `capacity` particles.
pub(crate) struct ParticleBuffers {
    /// x, y, z per particle.
    pub positions: wgpu::Buffer,
    /// x, y, z per particle.
    pub velocities: wgpu::Buffer,
    ages: wgpu::Buffer,
    lifetimes: wgpu::Buffer,
    generations: wgpu::Buffer,
    emitters: wgpu::Buffer,
    /// The bind group of the six arrays.
    pub group: wgpu::BindGroup,
}

impl ParticleBuffers {
    /// Room for `capacity` particles, the first of them `particles`.
    pub(crate) fn new(
        context: &GpuContext,
        group_layout: &wgpu::BindGroupLayout,
        capacity: u32,
        particles: &FlowParticles,
    ) -> Result<ParticleBuffers, GpuError> {
        let capacity = u64::from(capacity);
        check_fits(context, "the particle positions", capacity * 12)?;
        let vectors = |label| zeroed_storage_buffer(context, label, capacity * 12);
        let words = |label| zeroed_storage_buffer(context, label, capacity * 4);
        let positions = vectors("flow positions");
        let velocities = vectors("flow velocities");
        let ages = words("flow ages");
        let lifetimes = words("flow lifetimes");
        let generations = words("flow generations");
        let emitters = words("flow emitter of particle");
        let group = ParticleBindings {
            positions: &positions,
            velocities: &velocities,
            ages: &ages,
            lifetimes: &lifetimes,
            generations: &generations,
            emitter_of: &emitters,
        }
        .bind_group(&context.device, group_layout);
        let buffers = ParticleBuffers {
            positions,
            velocities,
            ages,
            lifetimes,
            generations,
            emitters,
            group,
        };
        buffers.write(context, 0, particles);
        Ok(buffers)
    }

    /// Writes `particles` into slots `first..` (before the next submission).
    pub(crate) fn write(&self, context: &GpuContext, first: u32, particles: &FlowParticles) {
        if particles.is_empty() {
            return;
        }
        let first = u64::from(first);
        let write = |buffer: &wgpu::Buffer, stride: u64, bytes: &[u8]| {
            context.queue.write_buffer(buffer, first * stride, bytes);
        };
        write(
            &self.positions,
            12,
            bytemuck::cast_slice(&particles.positions),
        );
        write(
            &self.velocities,
            12,
            bytemuck::cast_slice(&particles.velocities),
        );
        write(&self.ages, 4, bytemuck::cast_slice(&particles.ages));
        write(
            &self.lifetimes,
            4,
            bytemuck::cast_slice(&particles.lifetimes),
        );
        write(
            &self.generations,
            4,
            bytemuck::cast_slice(&particles.generations),
        );
        write(&self.emitters, 4, bytemuck::cast_slice(&particles.emitters));
    }

    /// The first `count` particles, read back.
    pub(crate) fn read(
        &self,
        context: &GpuContext,
        count: usize,
    ) -> Result<FlowParticles, GpuError> {
        let words = read_back::<u32>(
            context,
            &[
                (&self.positions, 3 * count),
                (&self.velocities, 3 * count),
                (&self.ages, count),
                (&self.lifetimes, count),
                (&self.generations, count),
                (&self.emitters, count),
            ],
        )?;
        let [
            positions,
            velocities,
            ages,
            lifetimes,
            generations,
            emitters,
        ] = <[Vec<u32>; 6]>::try_from(words).expect("six arrays were read");
        Ok(FlowParticles {
            positions: bytemuck::cast_slice::<u32, Vec3>(&positions).to_vec(),
            velocities: bytemuck::cast_slice::<u32, Vec3>(&velocities).to_vec(),
            ages: bytemuck::cast_slice::<u32, f32>(&ages).to_vec(),
            lifetimes: bytemuck::cast_slice::<u32, f32>(&lifetimes).to_vec(),
            generations,
            emitters,
        })
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> u64 {
        [
            &self.positions,
            &self.velocities,
            &self.ages,
            &self.lifetimes,
            &self.generations,
            &self.emitters,
        ]
        .iter()
        .map(|buffer| buffer.size())
        .sum()
    }
}

/// The raw trail state of `firn_flow::Trails`, as a snapshot holds it.
pub(crate) struct TrailState {
    /// Positions kept per trail.
    pub capacity: u32,
    /// Ring slot of the newest position.
    pub head: u32,
    /// Rings, particle-major.
    pub points: Vec<Vec3>,
    /// Valid positions per trail.
    pub lengths: Vec<u32>,
    /// Generation of each particle when its trail last recorded.
    pub generations: Vec<u32>,
}

/// Group 2: every particle's trail ring, with room for `capacity` particles.
pub(crate) struct TrailBuffers {
    /// Rings, particle-major, x, y, z per point.
    pub points: wgpu::Buffer,
    /// Valid points per ring.
    pub lengths: wgpu::Buffer,
    generations: wgpu::Buffer,
    /// The bind group of the three arrays.
    pub group: wgpu::BindGroup,
    /// Positions kept per trail.
    pub capacity: u32,
    /// Ring slot of the newest position.
    pub head: u32,
    /// Particles with a ring (those alive at the last recording).
    pub count: u32,
}

impl TrailBuffers {
    /// Rings for `particles` particles, the first of them from `state`; the
    /// others have never recorded (generation `u32::MAX`, length 0).
    pub(crate) fn new(
        context: &GpuContext,
        group_layout: &wgpu::BindGroupLayout,
        particles: u32,
        state: &TrailState,
    ) -> Result<TrailBuffers, GpuError> {
        let ring = state.capacity as usize;
        let particles = particles as usize;
        check_fits(context, "the trail rings", (particles * ring * 12) as u64)?;
        let mut points = state.points.clone();
        points.resize(particles * ring, Vec3::ZERO);
        let mut lengths = state.lengths.clone();
        lengths.resize(particles, 0);
        let mut generations = state.generations.clone();
        generations.resize(particles, u32::MAX);
        let points = storage_buffer(context, "flow trail points", &points);
        let lengths = storage_buffer(context, "flow trail lengths", &lengths);
        let generations = storage_buffer(context, "flow trail generations", &generations);
        let group = TrailBindings {
            trail_points: &points,
            trail_lengths: &lengths,
            trail_generations: &generations,
        }
        .bind_group(&context.device, group_layout);
        Ok(TrailBuffers {
            points,
            lengths,
            generations,
            group,
            capacity: state.capacity,
            head: state.head,
            count: state.lengths.len() as u32,
        })
    }

    /// The rings of the particles that have one, read back.
    pub(crate) fn read(&self, context: &GpuContext) -> Result<TrailState, GpuError> {
        let count = self.count as usize;
        let ring = self.capacity as usize;
        let words = read_back::<u32>(
            context,
            &[
                (&self.points, 3 * ring * count),
                (&self.lengths, count),
                (&self.generations, count),
            ],
        )?;
        let [points, lengths, generations] =
            <[Vec<u32>; 3]>::try_from(words).expect("three arrays were read");
        Ok(TrailState {
            capacity: self.capacity,
            head: self.head,
            points: bytemuck::cast_slice::<u32, Vec3>(&points).to_vec(),
            lengths,
            generations,
        })
    }

    /// Bytes held.
    pub(crate) fn bytes(&self) -> u64 {
        self.points.size() + self.lengths.size() + self.generations.size()
    }
}

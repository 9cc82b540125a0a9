//! The snow substep's buffers, bind group and compute pipelines, and the
//! recording of batches of substeps.

use bytemuck::Zeroable;
use firn_core::scene::Transfer;
use firn_mpm::Particles;

use super::bindings::StepBindings;
use super::layout::{GpuMat3, GpuPlastic, Params, StepState};
use crate::buffers::{read_back, storage_buffer, zeroed_storage_buffer};
use crate::context::GpuContext;
use crate::dispatch::workgroups;
use crate::error::GpuError;
use crate::shaders::{SNOW_STEP, compute_pipeline};

/// Per-particle arrays on the GPU.
pub struct ParticleBuffers {
    pub position_mass: wgpu::Buffer,
    pub velocity_volume: wgpu::Buffer,
    pub elastic: wgpu::Buffer,
    pub affine: wgpu::Buffer,
    pub stress: wgpu::Buffer,
    pub plastic: wgpu::Buffer,
}

impl ParticleBuffers {
    /// Uploads the particles.
    pub fn upload(context: &GpuContext, particles: &Particles) -> ParticleBuffers {
        let n = particles.len();
        let matrices =
            |list: &[glam::Mat3]| list.iter().map(|&m| GpuMat3::from(m)).collect::<Vec<_>>();
        let position_mass: Vec<[f32; 4]> = (0..n)
            .map(|p| particles.position[p].extend(particles.mass[p]).into())
            .collect();
        let velocity_volume: Vec<[f32; 4]> = (0..n)
            .map(|p| particles.velocity[p].extend(particles.volume0[p]).into())
            .collect();
        let plastic: Vec<GpuPlastic> = (0..n)
            .map(|p| GpuPlastic {
                plastic_j: particles.plastic_j[p],
                material: u32::from(particles.material[p]),
            })
            .collect();
        ParticleBuffers {
            position_mass: storage_buffer(context, "position and mass", &position_mass),
            velocity_volume: storage_buffer(context, "velocity and volume", &velocity_volume),
            elastic: storage_buffer(context, "elastic gradient", &matrices(&particles.elastic)),
            affine: storage_buffer(
                context,
                "affine velocity",
                &matrices(&particles.velocity_gradient),
            ),
            stress: storage_buffer(context, "stress", &matrices(&particles.stress)),
            plastic: storage_buffer(context, "plastic state", &plastic),
        }
    }
}

/// The grid's word planes, in the order of the quantities
/// (`QUANTITY_*` in `shaders/snow/fixed_point.wgsl`: mass, momentum x, y,
/// z, force impulse x, y, z), low word before high word. APIC binds
/// 16-byte stand-ins for the force planes it never touches.
pub struct GridBuffers {
    planes: [wgpu::Buffer; 14],
    used: usize,
    nodes: u64,
}

impl GridBuffers {
    /// Zeroed planes for `nodes` nodes.
    pub fn new(context: &GpuContext, nodes: u64, transfer: Transfer) -> GridBuffers {
        let used = match transfer {
            Transfer::Apic => 8,
            Transfer::PicFlip => 14,
        };
        let planes = std::array::from_fn(|plane| {
            let bytes = if plane < used { nodes * 4 } else { 16 };
            zeroed_storage_buffer(context, "grid word plane", bytes)
        });
        GridBuffers {
            planes,
            used,
            nodes,
        }
    }

    /// The planes the substeps clear.
    pub fn planes(&self) -> &[wgpu::Buffer] {
        &self.planes[..self.used]
    }
}

/// The counting sort's buffers and the binned
/// scatter's indirect dispatch arguments.
pub struct BinningBuffers {
    bins: wgpu::Buffer,
    particle_bins: wgpu::Buffer,
    work: wgpu::Buffer,
    indirect: wgpu::Buffer,
}

impl BinningBuffers {
    /// Buffers for `particles` particles on a grid of `nodes` nodes.
    pub fn new(context: &GpuContext, particles: u64, nodes: u64) -> BinningBuffers {
        let blocks = nodes / 64;
        let items = particles.div_ceil(64) + particles.min(blocks);
        BinningBuffers {
            bins: zeroed_storage_buffer(context, "bins", blocks * 8),
            particle_bins: zeroed_storage_buffer(context, "particle bins", particles * 12),
            work: zeroed_storage_buffer(context, "binned scatter work", (4 + 2 * items) * 4),
            indirect: context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("binned scatter dispatch"),
                size: 16,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }
}

/// How the scatter adds particle contributions into the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scatter {
    /// Every particle adds into the grid's sums with global atomics.
    Atomic,
    /// Particles are sorted by block each substep and each workgroup sums
    /// one block's chunk of particles in workgroup memory first.
    Binned,
}

/// Workgroup memory the binned scatter needs: the 7³ nodes' sums of seven
/// quantities in two words, and its header.
const BINNED_WORKGROUP_BYTES: u32 = 4802 * 4 + 16;

/// The counting sort and the binned scatter.
struct BinnedPipelines {
    count: wgpu::ComputePipeline,
    offsets: wgpu::ComputePipeline,
    sort: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
}

/// Pipelines and the bind group of one run.
pub struct StepPipelines {
    params: wgpu::Buffer,
    state: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    begin: wgpu::ComputePipeline,
    scatter: wgpu::ComputePipeline,
    binned: Option<BinnedPipelines>,
    binning: BinningBuffers,
    mode: Scatter,
    update: wgpu::ComputePipeline,
    gather: wgpu::ComputePipeline,
    particle_groups: (u32, u32, u32),
    node_groups: (u32, u32, u32),
}

impl StepPipelines {
    /// Builds the pipelines of `transfer` and binds every buffer.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        context: &GpuContext,
        transfer: Transfer,
        params: &Params,
        state: &StepState,
        materials: &wgpu::Buffer,
        [colliders, keys, distances]: [&wgpu::Buffer; 3],
        particles: &ParticleBuffers,
        grid: &GridBuffers,
        binning: BinningBuffers,
    ) -> StepPipelines {
        let device = &context.device;
        let params_buffer = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("snow params"),
                contents: bytemuck::bytes_of(params),
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            },
        );
        let state_buffer = storage_buffer(context, "snow step state", std::slice::from_ref(state));
        let layout = StepBindings::TABLE.layout(device);
        let [
            mass_lo,
            mass_hi,
            px_lo,
            px_hi,
            py_lo,
            py_hi,
            pz_lo,
            pz_hi,
            fx_lo,
            fx_hi,
            fy_lo,
            fy_hi,
            fz_lo,
            fz_hi,
        ] = grid.planes.each_ref();
        let bind_group = StepBindings {
            params: &params_buffer,
            state: &state_buffer,
            materials,
            colliders,
            collider_keys: keys,
            collider_distances: distances,
            position_mass: &particles.position_mass,
            velocity_volume: &particles.velocity_volume,
            elastic: &particles.elastic,
            affine: &particles.affine,
            stress: &particles.stress,
            plastic: &particles.plastic,
            mass_lo,
            mass_hi,
            px_lo,
            px_hi,
            py_lo,
            py_hi,
            pz_lo,
            pz_hi,
            fx_lo,
            fx_hi,
            fy_lo,
            fy_hi,
            fz_lo,
            fz_hi,
            bins: &binning.bins,
            particle_bins: &binning.particle_bins,
            work: &binning.work,
        }
        .bind_group(device, &layout);
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("snow step"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = SNOW_STEP.module(device);
        let pipeline = |entry: &str| compute_pipeline(device, &module, &pipeline_layout, entry);
        let (scatter, binned_scatter, gather) = match transfer {
            Transfer::Apic => ("scatter_apic", "scatter_binned_apic", "gather_apic"),
            Transfer::PicFlip => (
                "scatter_pic_flip",
                "scatter_binned_pic_flip",
                "gather_pic_flip",
            ),
        };
        let binned = (context.limits.max_compute_workgroup_storage_size >= BINNED_WORKGROUP_BYTES)
            .then(|| BinnedPipelines {
                count: pipeline("bin_count"),
                offsets: pipeline("bin_offsets"),
                sort: pipeline("bin_sort"),
                scatter: pipeline(binned_scatter),
            });
        let limit = context.limits.max_compute_workgroups_per_dimension;
        StepPipelines {
            begin: pipeline("begin_step"),
            scatter: pipeline(scatter),
            mode: if binned.is_some() {
                Scatter::Binned
            } else {
                Scatter::Atomic
            },
            binned,
            binning,
            update: pipeline("update_grid"),
            gather: pipeline(gather),
            particle_groups: workgroups(params.dims[3], limit),
            node_groups: workgroups(grid.nodes as u32, limit),
            params: params_buffer,
            state: state_buffer,
            bind_group,
        }
    }

    /// The scatter in use: binned where the adapter's workgroup memory
    /// allows, else atomic.
    pub fn scatter_mode(&self) -> Scatter {
        self.mode
    }

    /// Chooses the scatter; binned falls back to atomic where the adapter
    /// lacks the workgroup memory. Returns the scatter now in use.
    pub fn set_scatter_mode(&mut self, mode: Scatter) -> Scatter {
        self.mode = if self.binned.is_some() {
            mode
        } else {
            Scatter::Atomic
        };
        self.mode
    }

    /// Writes a frame's parameters and starting state.
    pub fn write_frame(&self, context: &GpuContext, params: &Params, state: &StepState) {
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(params));
        // Only the first four words: the maxima and trouble flags stay as
        // the last gather left them.
        let head = [
            state.dt.to_bits(),
            state.elapsed.to_bits(),
            state.running,
            state.steps,
        ];
        context
            .queue
            .write_buffer(&self.state, 0, bytemuck::cast_slice(&head));
    }

    /// Sets the largest squared wave speed the next substep's Δt starts from
    /// (after the materials changed); the rest of the state stays.
    pub fn write_max_wave_speed(&self, context: &GpuContext, wave_speed_squared: f32) {
        let offset = std::mem::offset_of!(StepState, max_wave_bits) as u64;
        let bits = wave_speed_squared.to_bits();
        context
            .queue
            .write_buffer(&self.state, offset, bytemuck::bytes_of(&bits));
    }

    /// Records and runs `substeps` substeps (those after the frame's end do
    /// nothing), then reads the state back.
    pub fn run_batch(
        &self,
        context: &GpuContext,
        substeps: u32,
        planes: &[wgpu::Buffer],
    ) -> Result<StepState, GpuError> {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("snow substeps"),
            });
        for _ in 0..substeps {
            self.dispatch(&mut encoder, &[(&self.begin, (1, 1, 1))]);
            for plane in planes {
                encoder.clear_buffer(plane, 0, None);
            }
            match (&self.binned, self.mode) {
                (Some(binned), Scatter::Binned) => self.scatter_binned(&mut encoder, binned),
                _ => self.dispatch(&mut encoder, &[(&self.scatter, self.particle_groups)]),
            }
            self.dispatch(
                &mut encoder,
                &[
                    (&self.update, self.node_groups),
                    (&self.gather, self.particle_groups),
                ],
            );
        }
        context.queue.submit([encoder.finish()]);
        let state = read_back::<StepState>(context, &[(&self.state, 1)])?;
        Ok(state[0].first().copied().unwrap_or_else(StepState::zeroed))
    }

    /// Sorts the particles by block, then scatters one block's chunk per
    /// workgroup, as many workgroups as the sort found chunks.
    fn scatter_binned(&self, encoder: &mut wgpu::CommandEncoder, binned: &BinnedPipelines) {
        encoder.clear_buffer(&self.binning.bins, 0, None);
        self.dispatch(
            encoder,
            &[
                (&binned.count, self.particle_groups),
                (&binned.offsets, (1, 1, 1)),
                (&binned.sort, self.particle_groups),
            ],
        );
        encoder.copy_buffer_to_buffer(&self.binning.work, 0, &self.binning.indirect, 0, 12);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("binned scatter"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.set_pipeline(&binned.scatter);
        pass.dispatch_workgroups_indirect(&self.binning.indirect, 0);
    }

    fn dispatch(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        kernels: &[(&wgpu::ComputePipeline, (u32, u32, u32))],
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("snow substep"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        for (pipeline, (x, y, z)) in kernels {
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(*x, *y, *z);
        }
    }
}

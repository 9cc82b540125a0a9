//! The counting sort by grid block (`shaders/snow/binning.wgsl`) that the
//! binned scatter runs on, every substep: the GPU's counterpart of
//! `firn_mpm::binning`, which bins the particles by 4³-cell block on the
//! CPU. `bin_count` counts each block's particles and ranks them,
//! `bin_offsets` (one workgroup) turns the counts into first slots and
//! 64-particle work items, and the binned scatter's dispatch size, and
//! `bin_sort` puts each particle in its slot. The bins are the grid's
//! allocated blocks, at their slots (`blocks.rs`, which also zeroes them).
//! The binned scatter itself is in `p2g.rs`.

use super::program::{Kernel, StepProgram, compute_pass};
use crate::buffers::zeroed_storage_buffer;
use crate::context::GpuContext;

/// The counting sort's buffers and the binned scatter's indirect dispatch
/// arguments.
pub struct BinningBuffers {
    /// Per allocated block: its particle count, first slot and index in
    /// the domain.
    pub bins: wgpu::Buffer,
    /// Per particle: its block and rank; per slot: its particle.
    pub particle_bins: wgpu::Buffer,
    /// The binned scatter's dispatch size, item count and work items.
    pub work: wgpu::Buffer,
    /// The dispatch size, copied from `work` for the indirect dispatch.
    pub indirect: wgpu::Buffer,
}

impl BinningBuffers {
    /// Buffers for `particles` particles on a grid with room for `blocks`
    /// blocks.
    pub fn new(context: &GpuContext, particles: u64, blocks: u64) -> BinningBuffers {
        let items = particles.div_ceil(64) + particles.min(blocks);
        BinningBuffers {
            bins: zeroed_storage_buffer(context, "bins", blocks * 12),
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

/// The counting sort's kernels.
pub struct Binning {
    count: Kernel,
    offsets: Kernel,
    sort: Kernel,
}

impl Binning {
    /// The kernels `bin_count`, `bin_offsets` and `bin_sort`.
    pub fn new(program: &StepProgram) -> Binning {
        Binning {
            count: program.kernel("bin_count"),
            offsets: program.kernel("bin_offsets"),
            sort: program.kernel("bin_sort"),
        }
    }

    /// Records the sort: the three kernels (`blocks.rs` zeroed the counts),
    /// and the binned scatter's dispatch size copied to its indirect
    /// arguments.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &BinningBuffers,
        groups: (u32, u32, u32),
    ) {
        {
            let mut pass = compute_pass(encoder, "snow substep");
            self.count.dispatch(&mut pass, groups);
            self.offsets.dispatch(&mut pass, (1, 1, 1));
            self.sort.dispatch(&mut pass, groups);
        }
        encoder.copy_buffer_to_buffer(&buffers.work, 0, &buffers.indirect, 0, 12);
    }
}

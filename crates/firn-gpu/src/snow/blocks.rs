//! The sparse grid's block table (`shaders/snow/blocks.wgsl`), rebuilt at
//! the start of every substep, the GPU's counterpart of the blocks
//! `firn_mpm`'s sparse grid activates: every 4³-node block a snow
//! particle's stencil reaches gets a slot, in block-index order, and owns
//! the 64 nodes of every grid buffer from 64 times its slot on
//! (`shaders/snow/nodes.wgsl`). Grid memory thus follows the snow, not the
//! domain: the table itself takes 4 bytes per block of the domain.
//!
//! `mark_blocks` marks the blocks (the table cleared first), then a prefix
//! sum in block-index order gives them their slots: `count_blocks` per
//! chunk of 1024 blocks, `block_offsets` (one workgroup) over the chunks,
//! which also writes the number of blocks and the node kernels' dispatch
//! size (one workgroup per block), and `assign_blocks`. The grid's
//! capacity in blocks is fixed per run until the snow reaches more blocks:
//! `begin_step` then stops the batch before the substep and the host grows
//! the grid ([`super::GpuSnow`]).

use firn_mpm::grid::{BLOCK_WIDTH, GridLayout};
use glam::{IVec3, Vec3};

use super::program::{Kernel, StepProgram, compute_pass};
use crate::buffers::zeroed_storage_buffer;
use crate::context::GpuContext;

/// Blocks per chunk of the prefix sum (`CHUNK_BLOCKS` in `blocks.wgsl`).
const CHUNK_BLOCKS: u64 = 1024;

/// Words of `block_chunks` before the chunks' counts.
const CHUNK_HEADER: u64 = 4;

/// The block table's buffers, sized by the domain.
pub struct BlockBuffers {
    /// Per block of the domain: its slot, or `NO_SLOT`.
    pub table: wgpu::Buffer,
    /// The node kernels' dispatch size, then per chunk its count and first
    /// slot.
    pub chunks: wgpu::Buffer,
    /// The node kernels' dispatch size, copied from `chunks` for their
    /// indirect dispatch.
    pub indirect: wgpu::Buffer,
    /// Chunks of the prefix sum.
    chunk_count: u32,
}

impl BlockBuffers {
    /// The table for a domain of `domain_blocks` blocks.
    pub fn new(context: &GpuContext, domain_blocks: u64) -> BlockBuffers {
        let chunk_count = domain_blocks.div_ceil(CHUNK_BLOCKS);
        BlockBuffers {
            table: zeroed_storage_buffer(context, "grid block table", domain_blocks * 4),
            chunks: zeroed_storage_buffer(
                context,
                "grid block chunks",
                (CHUNK_HEADER + chunk_count) * 4,
            ),
            indirect: context.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("grid node dispatch"),
                size: 16,
                usage: wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            chunk_count: chunk_count as u32,
        }
    }
}

/// Bytes of the block table and its chunks for `domain_blocks` blocks.
pub fn table_bytes(domain_blocks: u64) -> u64 {
    (domain_blocks + CHUNK_HEADER + domain_blocks.div_ceil(CHUNK_BLOCKS)) * 4
}

/// The block table's kernels.
pub struct Blocks {
    mark: Kernel,
    count: Kernel,
    offsets: Kernel,
    assign: Kernel,
    /// Workgroups of `count_blocks` and `assign_blocks`: one per chunk.
    chunk_groups: (u32, u32, u32),
}

impl Blocks {
    /// The kernels `mark_blocks`, `count_blocks`, `block_offsets` and
    /// `assign_blocks` over `buffers`' chunks.
    pub fn new(program: &StepProgram, buffers: &BlockBuffers, limit: u32) -> Blocks {
        let x = buffers.chunk_count.clamp(1, limit);
        let chunk_groups = (x, buffers.chunk_count.div_ceil(x).max(1), 1);
        Blocks {
            mark: program.kernel("mark_blocks"),
            count: program.kernel("count_blocks"),
            offsets: program.kernel("block_offsets"),
            assign: program.kernel("assign_blocks"),
            chunk_groups,
        }
    }

    /// Records the table's build: cleared, marked by the particles
    /// (`particle_groups`), the prefix sum, and the node kernels' dispatch
    /// size copied to its indirect arguments.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        buffers: &BlockBuffers,
        particle_groups: (u32, u32, u32),
    ) {
        encoder.clear_buffer(&buffers.table, 0, None);
        {
            let mut pass = compute_pass(encoder, "grid blocks");
            self.mark.dispatch(&mut pass, particle_groups);
            self.count.dispatch(&mut pass, self.chunk_groups);
            self.offsets.dispatch(&mut pass, (1, 1, 1));
            self.assign.dispatch(&mut pass, self.chunk_groups);
        }
        encoder.copy_buffer_to_buffer(&buffers.chunks, 0, &buffers.indirect, 0, 12);
    }
}

/// The blocks of `layout` the stencils of particles at `positions` reach,
/// as `mark_blocks` marks them (the cubic stencil for PIC/FLIP when
/// `cubic`, else the quadratic one): what the grid needs for them.
pub fn reached_blocks(layout: &GridLayout, positions: &[Vec3], cubic: bool) -> u64 {
    let top = layout.node_dims().as_ivec3() - IVec3::ONE;
    let mut marked = vec![false; layout.block_count()];
    for &position in positions {
        let x = layout.to_grid(position);
        let (base, reach) = if cubic {
            ((x.floor() - Vec3::ONE).as_ivec3(), 3)
        } else {
            ((x - Vec3::splat(0.5)).floor().as_ivec3(), 2)
        };
        let first = base.clamp(IVec3::ZERO, top) / BLOCK_WIDTH;
        let last = (base + IVec3::splat(reach)).clamp(IVec3::ZERO, top) / BLOCK_WIDTH;
        for i in first.x..=last.x {
            for j in first.y..=last.y {
                for k in first.z..=last.z {
                    marked[layout.block_index(IVec3::new(i, j, k))] = true;
                }
            }
        }
    }
    marked.iter().filter(|&&m| m).count() as u64
}

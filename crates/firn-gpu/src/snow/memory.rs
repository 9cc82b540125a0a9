//! What a snow scene needs on the GPU, known before anything is allocated.

use firn_core::Scene;
use firn_core::scene::{Integrator, Transfer};
use firn_mpm::grid::{BLOCK_WIDTH, GridLayout};
use glam::IVec3;

use super::blocks::table_bytes;
use super::buffers::{LINEARIZED_BYTES, SOLVE_PRODUCTS, SOLVE_VECTORS};
use super::coupling::BYTES_PER_BODY;
use crate::context::{AdapterReport, GpuContext, largest_binding};
use crate::error::GpuError;

/// Bytes per particle: position and mass, velocity and V_p^0 (two `vec4`),
/// F_E, C_p and V_p^0 τ_p (three `mat3x3` of 48 bytes in storage layout),
/// J_P and the material index; then the binning's block, rank and sorted
/// slot (12) and at most one 8-byte work item per particle plus one per 64.
pub const BYTES_PER_PARTICLE: u64 = 16 + 16 + 3 * 48 + 8 + 12 + 9;

/// Bytes per node besides the sums: an allocated block's particle count,
/// first slot and index (12 bytes per 64 nodes), rounded up.
const BINNING_BYTES_PER_NODE: u64 = 1;

/// Grid quantities summed by the scatter: mass and momentum, plus the force
/// for PIC/FLIP or for the semi-implicit solve's products; each is a 64-bit
/// fixed-point sum.
fn grid_quantities(transfer: Transfer, implicit: bool) -> u64 {
    match transfer {
        Transfer::Apic if !implicit => 4,
        Transfer::Apic | Transfer::PicFlip => 7,
    }
}

/// Bytes per node of the semi-implicit solve: its node vectors (one `vec4`
/// each) and a partial sum per 64 nodes, rounded up.
const SOLVE_BYTES_PER_NODE: u64 = (SOLVE_VECTORS + SOLVE_PRODUCTS) * 16 + 1;

/// Blocks of room the grid gets beyond the `blocks` the snow reaches when
/// it is sized: half as many again, at least one, at most the domain's
/// `domain_blocks`.
fn with_headroom(blocks: u64, domain_blocks: u64) -> u64 {
    (blocks + blocks / 2).max(1).min(domain_blocks)
}

/// The blocks the scene's bodies reach before the run: per body, the
/// blocks of its bounding box widened by the stencil's two nodes, summed
/// (bodies that overlap count twice), at most the domain's. The snow's own
/// blocks are at most these while it fills its bodies.
pub fn body_blocks(scene: &Scene, layout: &GridLayout) -> u64 {
    let top = layout.node_dims().as_ivec3() - IVec3::ONE;
    let reached: u64 = scene
        .bodies
        .iter()
        .map(|body| {
            let (min, max) = body.shape.bounds();
            let first = layout.to_grid(min).floor().as_ivec3() - IVec3::splat(2);
            let last = layout.to_grid(max).ceil().as_ivec3() + IVec3::splat(2);
            let first = first.clamp(IVec3::ZERO, top) / BLOCK_WIDTH;
            let last = last.clamp(IVec3::ZERO, top) / BLOCK_WIDTH;
            let blocks = (last - first + IVec3::ONE).as_u64vec3();
            blocks.x * blocks.y * blocks.z
        })
        .sum();
    reached.min(layout.block_count() as u64)
}

/// The GPU memory a snow scene needs: particles, the sparse grid's nodes
/// for its capacity in blocks, the block table over the domain, and the
/// rigid bodies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// Number of particles.
    pub particles: u64,
    /// Grid nodes the run allocates: 64 per block of the grid's capacity.
    pub nodes: u64,
    /// Blocks of 4³ nodes in the domain, padding included: one word each in
    /// the block table.
    pub domain_blocks: u64,
    /// Bytes per particle.
    pub bytes_per_particle: u64,
    /// Bytes per grid node (8 per summed quantity, and the semi-implicit
    /// solve's vectors).
    pub bytes_per_node: u64,
    /// Whether the semi-implicit solve's buffers are counted.
    pub implicit: bool,
    /// Number of rigid bodies: each placed body and its sums
    /// ([`BYTES_PER_BODY`]).
    pub rigid_bodies: u64,
}

impl MemoryEstimate {
    /// The estimate for `particles` particles in `scene`'s domain, with the
    /// blocks its bodies reach ([`body_blocks`]) and half as many again as
    /// the grid's capacity. The run starts with this capacity, or more
    /// where its particles reach more blocks, and grows it when the snow
    /// reaches more than that.
    pub fn of(scene: &Scene, particles: u64) -> MemoryEstimate {
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        MemoryEstimate::for_blocks(scene, particles, body_blocks(scene, &layout))
    }

    /// The estimate for `particles` particles in `scene`'s domain on a
    /// grid with room for `blocks` blocks and half as many again.
    pub fn for_blocks(scene: &Scene, particles: u64, blocks: u64) -> MemoryEstimate {
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        let domain_blocks = layout.block_count() as u64;
        let implicit = matches!(scene.solver.integrator, Integrator::SemiImplicit(_));
        let (solve_per_particle, solve_per_node) = if implicit {
            (LINEARIZED_BYTES, SOLVE_BYTES_PER_NODE)
        } else {
            (0, 0)
        };
        MemoryEstimate {
            particles,
            nodes: with_headroom(blocks, domain_blocks) * 64,
            domain_blocks,
            bytes_per_particle: BYTES_PER_PARTICLE + solve_per_particle,
            bytes_per_node: 8 * grid_quantities(scene.solver.transfer, implicit)
                + BINNING_BYTES_PER_NODE
                + solve_per_node,
            implicit,
            rigid_bodies: scene.rigid_bodies.len() as u64,
        }
    }

    /// The grid's capacity in blocks.
    pub fn grid_blocks(&self) -> u64 {
        self.nodes / 64
    }

    /// The grid's bytes: its nodes and the block table.
    pub fn grid_bytes(&self) -> u64 {
        self.nodes * self.bytes_per_node + table_bytes(self.domain_blocks)
    }

    /// The rigid bodies' bytes: each placed body and its sums.
    pub fn body_bytes(&self) -> u64 {
        self.rigid_bodies * BYTES_PER_BODY
    }

    /// All buffers together, in bytes.
    pub fn total_bytes(&self) -> u64 {
        self.particles * self.bytes_per_particle + self.grid_bytes() + self.body_bytes()
    }

    /// The largest single buffer: one grid quantity's word (4 bytes per
    /// node), the block table (4 bytes per block of the domain) or one
    /// particle matrix array (48 bytes per particle; the work items take at
    /// most 8 bytes and a fraction) or the placed rigid bodies; with the
    /// semi-implicit solve, its larger buffer of node vectors or its stress
    /// differentials.
    pub fn largest_buffer_bytes(&self) -> u64 {
        let explicit = (self.nodes * 4)
            .max(self.domain_blocks * 4)
            .max(self.particles * 48)
            .max(self.body_bytes());
        if self.implicit {
            explicit
                .max(self.nodes * SOLVE_VECTORS * 16)
                .max(self.particles * LINEARIZED_BYTES)
        } else {
            explicit
        }
    }

    /// How many particles fit in `budget` bytes beside this grid and the
    /// rigid bodies.
    pub fn particles_within(&self, budget: u64) -> u64 {
        budget.saturating_sub(self.grid_bytes() + self.body_bytes()) / self.bytes_per_particle
    }
}

impl MemoryEstimate {
    /// Fails before anything is allocated when a buffer of this estimate
    /// would pass `context`'s limits.
    pub fn check_fits(&self, context: &GpuContext) -> Result<(), GpuError> {
        self.check_buffers(&context.adapter.name, largest_binding(&context.limits))
    }

    /// Fails when a buffer of this estimate would pass `adapter`'s limits,
    /// without opening a device (`firn check`).
    pub fn check_fits_adapter(&self, adapter: &AdapterReport) -> Result<(), GpuError> {
        self.check_buffers(&adapter.name, adapter.max_storage_binding)
    }

    /// Fails when a buffer would pass `limit` bytes on the adapter `adapter`.
    fn check_buffers(&self, adapter: &str, limit: u64) -> Result<(), GpuError> {
        let largest = self.largest_buffer_bytes();
        if largest <= limit && self.particles <= u64::from(u32::MAX) {
            return Ok(());
        }
        let (what, fix) = if self.domain_blocks >= self.nodes.max(self.particles * 12) {
            (
                format!(
                    "the block table of the domain's {} blocks",
                    self.domain_blocks
                ),
                "use a larger cell_size or a smaller [domain], or run with --backend cpu",
            )
        } else if self.nodes * 4 >= self.particles * 48 {
            (
                format!("one word plane of the grid's {} nodes", self.nodes),
                "use a larger cell_size or smaller bodies, or run with --backend cpu",
            )
        } else {
            (
                format!("one matrix per particle for {} particles", self.particles),
                "use fewer particles_per_cell or smaller bodies, or run with --backend cpu",
            )
        };
        Err(GpuError::TooLarge {
            what,
            needed: largest,
            limit,
            adapter: adapter.into(),
            fix: fix.into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The thesis' GTX 1070 (8 GB) case: 2^20 particles on a 256³ grid
    /// must fit in 4 GiB with either transfer scheme.
    #[test]
    fn the_thesis_largest_case_fits_in_four_gib() {
        for transfer in ["apic", "pic-flip"] {
            let text = format!(
                "format = 1\n[domain]\nmax = [2.56, 2.56, 2.56]\ncell_size = 0.01\n[time]\nduration = 1.0\n\
                 [solver]\ntransfer = \"{transfer}\"\n[[bodies]]\nshape = \"sphere\"\n\
                 center = [1.28, 1.28, 1.28]\nradius = 0.3\n"
            );
            let scene = Scene::from_toml_str(&text, "thesis-256.toml").unwrap();
            let estimate = MemoryEstimate::of(&scene, 1 << 20);
            assert!(estimate.domain_blocks >= 65u64.pow(3), "{estimate:?}");
            assert!(
                estimate.nodes < estimate.domain_blocks * 64 / 4,
                "{estimate:?}"
            );
            let four_gib = 4u64 << 30;
            assert!(
                estimate.total_bytes() < four_gib,
                "{transfer}: {estimate:?} needs {} bytes",
                estimate.total_bytes()
            );
            assert!(estimate.particles_within(four_gib) > 1 << 20);
        }
    }
}

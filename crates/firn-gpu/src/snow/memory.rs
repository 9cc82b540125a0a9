//! What a snow scene needs on the GPU, known before anything is allocated.

use firn_core::Scene;
use firn_core::scene::{Integrator, Transfer};
use firn_mpm::grid::GridLayout;

use super::buffers::{LINEARIZED_BYTES, SOLVE_PRODUCTS, SOLVE_VECTORS};
use crate::context::{AdapterReport, GpuContext, largest_binding};
use crate::error::GpuError;

/// Bytes per particle: position and mass, velocity and V_p^0 (two `vec4`),
/// F_E, C_p and V_p^0 τ_p (three `mat3x3` of 48 bytes in storage layout),
/// J_P and the material index; then the binning's block, rank and sorted
/// slot (12) and at most one 8-byte work item per particle plus one per 64.
pub const BYTES_PER_PARTICLE: u64 = 16 + 16 + 3 * 48 + 8 + 12 + 9;

/// Bytes per node besides the sums: a block's particle count and first
/// slot (8 bytes per 64 nodes), rounded up.
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

/// The GPU memory a snow scene needs: dense grid plus particles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// Number of particles.
    pub particles: u64,
    /// Grid nodes, padding included.
    pub nodes: u64,
    /// Bytes per particle.
    pub bytes_per_particle: u64,
    /// Bytes per grid node (8 per summed quantity, and the semi-implicit
    /// solve's vectors).
    pub bytes_per_node: u64,
    /// Whether the semi-implicit solve's buffers are counted.
    pub implicit: bool,
}

impl MemoryEstimate {
    /// The estimate for `particles` particles in `scene`'s domain.
    pub fn of(scene: &Scene, particles: u64) -> MemoryEstimate {
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        let dims = layout.node_dims();
        let implicit = matches!(scene.solver.integrator, Integrator::SemiImplicit(_));
        let (solve_per_particle, solve_per_node) = if implicit {
            (LINEARIZED_BYTES, SOLVE_BYTES_PER_NODE)
        } else {
            (0, 0)
        };
        MemoryEstimate {
            particles,
            nodes: u64::from(dims.x) * u64::from(dims.y) * u64::from(dims.z),
            bytes_per_particle: BYTES_PER_PARTICLE + solve_per_particle,
            bytes_per_node: 8 * grid_quantities(scene.solver.transfer, implicit)
                + BINNING_BYTES_PER_NODE
                + solve_per_node,
            implicit,
        }
    }

    /// All buffers together, in bytes.
    pub fn total_bytes(&self) -> u64 {
        self.particles * self.bytes_per_particle + self.nodes * self.bytes_per_node
    }

    /// The largest single buffer: one grid quantity's word (4 bytes per
    /// node) or one particle matrix array (48 bytes per particle; the work
    /// items take at most 8 bytes and a fraction); with the semi-implicit
    /// solve, its larger buffer of node vectors or its stress differentials.
    pub fn largest_buffer_bytes(&self) -> u64 {
        let explicit = (self.nodes * 4).max(self.particles * 48);
        if self.implicit {
            explicit
                .max(self.nodes * SOLVE_VECTORS * 16)
                .max(self.particles * LINEARIZED_BYTES)
        } else {
            explicit
        }
    }

    /// How many particles fit in `budget` bytes beside this grid.
    pub fn particles_within(&self, budget: u64) -> u64 {
        budget.saturating_sub(self.nodes * self.bytes_per_node) / self.bytes_per_particle
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
        let (what, fix) = if self.nodes * 4 >= self.particles * 48 {
            (
                format!("one word plane of the dense {}-node grid", self.nodes),
                "use a larger cell_size or a smaller [domain], or run with --backend cpu (its grid is sparse)",
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
            assert!(estimate.nodes >= 257u64.pow(3), "{estimate:?}");
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

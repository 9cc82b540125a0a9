//! `firn bench --backend gpu`: what the GPU's memory holds for the snowball
//! and `--scene` runs (which step a `firn_run::Solver` on the GPU as the
//! CPU runs do on the CPU): bytes per particle and per grid node, and the
//! most particles that fit a memory budget on the bench's grid and on a
//! 256³ grid (the thesis ran 2^20 particles on 256³ on a 4 GiB GTX 1070).

use firn_core::Scene;
use firn_gpu::snow::MemoryEstimate;
use serde::Serialize;

use crate::bench::snowball_drop;

/// Particles of the thesis' largest GPU run (§6.2): 2^20.
pub const THESIS_PARTICLES: u64 = 1 << 20;
/// Cells per side of the thesis' largest grid.
pub const THESIS_GRID: u32 = 256;
/// Bytes in a GiB.
const GIB: f64 = (1u64 << 30) as f64;
/// Bytes in a MiB.
const MIB: f64 = (1u64 << 20) as f64;

/// What a GPU run needs in GPU memory, and what fits the budget.
#[derive(Debug, Serialize)]
pub struct GpuMemoryRecord {
    /// Bytes each particle takes on the GPU.
    pub bytes_per_particle: u64,
    /// Bytes each grid node takes on the GPU.
    pub bytes_per_grid_node: u64,
    /// Grid nodes this run allocates: 64 per block of the sparse grid's
    /// capacity (the blocks its bodies reach and half as many again).
    pub grid_nodes: u64,
    /// The grid's bytes: its nodes and the block table over the domain.
    pub grid_bytes: u64,
    /// All of this run's GPU buffers, in bytes.
    pub total_bytes: u64,
    /// This run's largest single buffer, in bytes.
    pub largest_buffer_bytes: u64,
    /// The memory budget of the estimates below, GiB (`--memory-budget-gib`).
    pub budget_gib: f64,
    /// The most particles that fit the budget beside this run's grid.
    pub max_particles_on_this_grid: u64,
    /// The most particles that fit the budget beside a 256³ grid.
    pub max_particles_on_256_grid: u64,
    /// Whether 2^20 particles on a 256³ grid fit the budget (the thesis'
    /// GTX 1070 case with 4 GiB).
    pub thesis_2_20_particles_on_256_fit: bool,
    /// What 2^20 particles on a 256³ grid take, in bytes.
    pub thesis_2_20_particles_on_256_bytes: u64,
}

impl GpuMemoryRecord {
    /// The record for `particles` particles of `scene` and a budget in GiB.
    pub fn of(scene: &Scene, particles: u64, budget_gib: f64) -> GpuMemoryRecord {
        let budget = (budget_gib * GIB) as u64;
        let here = MemoryEstimate::of(scene, particles);
        let thesis_scene = snowball_drop(1, THESIS_GRID, scene.solver.transfer);
        let thesis = MemoryEstimate::of(&thesis_scene, THESIS_PARTICLES);
        GpuMemoryRecord {
            bytes_per_particle: here.bytes_per_particle,
            bytes_per_grid_node: here.bytes_per_node,
            grid_nodes: here.nodes,
            grid_bytes: here.grid_bytes(),
            total_bytes: here.total_bytes(),
            largest_buffer_bytes: here.largest_buffer_bytes(),
            budget_gib,
            max_particles_on_this_grid: here.particles_within(budget),
            max_particles_on_256_grid: thesis.particles_within(budget),
            thesis_2_20_particles_on_256_fit: thesis.total_bytes() <= budget,
            thesis_2_20_particles_on_256_bytes: thesis.total_bytes(),
        }
    }

    /// Two indented lines for the bench's output.
    pub fn lines(&self) -> String {
        format!(
            "  gpu memory: {} bytes per particle, {} bytes per grid node ({} nodes), \
             {:.2} MiB in all, largest buffer {:.2} MiB\n  within {} GiB: {} particles \
             on this grid, {} on 256^3; 2^20 particles on 256^3 ({:.0} MiB): {}",
            self.bytes_per_particle,
            self.bytes_per_grid_node,
            self.grid_nodes,
            self.total_bytes as f64 / MIB,
            self.largest_buffer_bytes as f64 / MIB,
            self.budget_gib,
            self.max_particles_on_this_grid,
            self.max_particles_on_256_grid,
            self.thesis_2_20_particles_on_256_bytes as f64 / MIB,
            if self.thesis_2_20_particles_on_256_fit {
                "fit"
            } else {
                "do not fit"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firn_core::scene::Transfer;

    #[test]
    fn the_thesis_case_is_estimated_on_a_256_grid() {
        let scene = snowball_drop(2000, 32, Transfer::Apic);
        let record = GpuMemoryRecord::of(&scene, 2000, 4.0);
        assert_eq!(
            record.total_bytes,
            2000 * record.bytes_per_particle + record.grid_bytes
        );
        assert!(record.grid_bytes > record.grid_nodes * record.bytes_per_grid_node);
        assert!(record.max_particles_on_256_grid < record.max_particles_on_this_grid);
        let fits = record.thesis_2_20_particles_on_256_bytes <= 4 << 30;
        assert_eq!(record.thesis_2_20_particles_on_256_fit, fits);
        let tiny = GpuMemoryRecord::of(&scene, 2000, 0.001);
        assert!(!tiny.thesis_2_20_particles_on_256_fit);
        assert!(
            record.lines().contains("within 4 GiB"),
            "{}",
            record.lines()
        );
    }
}

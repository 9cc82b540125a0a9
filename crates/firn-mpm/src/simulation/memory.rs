//! What a snow run's CPU memory is, and what it will be before anything is
//! allocated (the bound `firn check` and the run's budget hold).

use firn_core::Scene;
use glam::Vec3;

use super::Simulation;
use crate::grid::{BLOCK_NODES, BLOCK_WIDTH, GridLayout, Node};
use crate::particles::{Particles, PermuteBuffers};

impl Simulation {
    /// Bytes allocated for the grid (page table and the blocks near the snow),
    /// the binning buffers and the particles (with the space to reorder them).
    pub fn memory_bytes(&self) -> usize {
        self.grid.memory_bytes()
            + self.bins.memory_bytes()
            + self.permute_buffers.memory_bytes()
            + self.particles.len() * Particles::bytes_per_particle()
    }

    /// The bytes [`Simulation::memory_bytes`] will report at the start for
    /// `scene` filled with `particles` particles, known before anything is
    /// sampled or allocated: the particles with their reorder and binning
    /// space, the grid's and the bins' tables of every block of the box,
    /// and the node blocks around each body's bounding box (a block of
    /// padding on every side). An upper bound at the start; it grows as the
    /// snow spreads over more blocks.
    pub fn estimate_memory_bytes(scene: &Scene, particles: u64) -> u64 {
        const WORD: u64 = std::mem::size_of::<u32>() as u64;
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        let box_blocks = layout.block_count() as u64;
        let near_bodies: u64 = scene
            .bodies
            .iter()
            .map(|body| blocks_around(&layout, body.shape.bounds()))
            .fold(0, u64::saturating_add);
        let active = near_bodies.min(box_blocks);
        // Per block: its nodes, its eight neighbours' slots, its place in
        // the resident list and in the bins' active list.
        let block_bytes = (BLOCK_NODES * std::mem::size_of::<Node>()) as u64 + 10 * WORD;
        // Per particle: its attributes (with the bin order), the reorder
        // space, and the bins' key and sorted slot.
        let particle_bytes = (Particles::bytes_per_particle() + PermuteBuffers::BYTES_PER_PARTICLE)
            as u64
            + 2 * WORD;
        particles
            .saturating_mul(particle_bytes)
            .saturating_add(box_blocks.saturating_mul(2 * WORD))
            .saturating_add(active.saturating_mul(block_bytes))
    }
}

/// Grid blocks covering the box `low .. high` and one block around it.
fn blocks_around(layout: &GridLayout, (low, high): (Vec3, Vec3)) -> u64 {
    let width = f64::from(BLOCK_WIDTH);
    let first = (layout.to_grid(low).as_dvec3() / width).floor() - 1.0;
    let last = (layout.to_grid(high).as_dvec3() / width).ceil() + 1.0;
    let blocks = (last - first).max(glam::DVec3::ONE).element_product();
    if blocks.is_finite() {
        blocks.min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    }
}

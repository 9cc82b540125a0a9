//! Particles binned by grid block, and the block colouring that makes the
//! parallel scatter deterministic without atomics.
//!
//! A particle in cell c (per axis) writes to nodes c−1 … c+2 (cubic) or a
//! subset of them (quadratic). Particles of block b (cells 4b … 4b+3) therefore
//! touch nodes 4b−1 … 4b+5. Two blocks whose coordinates differ by 2 along an
//! axis are 8 nodes apart there and never share a node, so all blocks with the
//! same parity pattern (one of 8 colours) can scatter at once. Colours run in a
//! fixed order and each block adds its particles in a fixed order, so every
//! node sums its contributions in the same order whatever the thread count.

use firn_core::math::bspline::floor;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::grid::{ABSENT, BLOCK_WIDTH, GridLayout};

/// A grid block that holds particles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OccupiedBlock {
    /// Block coordinate.
    pub coord: IVec3,
    /// Range of this block's particles in [`Bins::order`].
    pub start: u32,
    /// End (exclusive) of the range.
    pub end: u32,
}

/// Particles sorted by block, the occupied blocks by colour, and the blocks
/// whose nodes receive mass this step.
///
/// Rebuilding costs time in proportion to the particles and the blocks near
/// them, not to the domain: a per-block table (4 bytes per block of the box)
/// numbers the occupied blocks, and is reset entry by entry afterwards.
#[derive(Clone, Debug, Default)]
pub struct Bins {
    /// Particle indices, stably sorted by block index: a permutation, which
    /// the parallel gather relies on (each particle in exactly one block), so
    /// only [`Bins::rebuild`] writes it.
    order: Vec<u32>,
    /// Occupied blocks in increasing block index.
    occupied: Vec<OccupiedBlock>,
    /// Indices into `occupied`, one list per colour.
    colours: [Vec<u32>; 8],
    /// Linear indices of the blocks that the particles' stencils reach, increasing.
    active_blocks: Vec<u32>,
    /// Block index of each particle.
    keys: Vec<u32>,
    /// Block index → number of the block in `seen`; [`ABSENT`] between rebuilds.
    numbers: Vec<u32>,
    /// Occupied block indices in order of first appearance.
    seen: Vec<u32>,
    /// Particle count, then next free place in `order`, per block of `seen`.
    counts: Vec<u32>,
    /// Numbers of the `seen` blocks sorted by block index.
    sorted: Vec<u32>,
}

impl Bins {
    /// Particle indices, stably sorted by block index (a permutation).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// Occupied blocks in increasing block index.
    pub fn occupied(&self) -> &[OccupiedBlock] {
        &self.occupied
    }

    /// Indices into [`Bins::occupied`], one list per colour: blocks of one
    /// colour never share a grid node.
    pub fn colours(&self) -> &[Vec<u32>; 8] {
        &self.colours
    }

    /// Linear indices of the blocks that the particles' stencils reach, increasing.
    pub fn active_blocks(&self) -> &[u32] {
        &self.active_blocks
    }

    /// Re-bins all particles by their current positions (a stable counting
    /// sort). The block keys are computed in parallel and cut into runs of
    /// equal keys (particles are kept sorted by block, so runs are long);
    /// the counting and placing then go run by run, in particle order, so
    /// the result is the same for any thread count.
    pub fn rebuild(&mut self, grid: &GridLayout, positions: &[Vec3]) {
        self.keys.resize(positions.len(), 0);
        self.keys
            .par_iter_mut()
            .zip(positions.par_iter())
            .with_min_len(4096)
            .for_each(|(key, &position)| *key = block_key(grid, position) as u32);
        let runs: Vec<Vec<Run>> = self.keys.par_chunks(RUN_CHUNK).map(runs_of).collect();
        self.numbers.resize(grid.block_count(), ABSENT);

        self.seen.clear();
        self.counts.clear();
        for run in runs.iter().flatten() {
            let number = &mut self.numbers[run.key as usize];
            if *number == ABSENT {
                *number = self.seen.len() as u32;
                self.seen.push(run.key);
                self.counts.push(0);
            }
            self.counts[*number as usize] += run.length;
        }
        self.collect_occupied(grid);
        self.order.resize(positions.len(), 0);
        let mut first_particle = 0;
        for run in runs.iter().flatten() {
            let next = &mut self.counts[self.numbers[run.key as usize] as usize];
            let places = &mut self.order[*next as usize..(*next + run.length) as usize];
            for (place, p) in places.iter_mut().zip(first_particle..) {
                *place = p;
            }
            *next += run.length;
            first_particle += run.length;
        }
        for &key in &self.seen {
            self.numbers[key as usize] = ABSENT;
        }
        self.collect_colours();
        self.collect_active(grid);
    }

    /// Orders each block's particles by `keys` (one per particle, distinct)
    /// instead of by index: in a part of a split run the array is not in
    /// the whole run's order, but each block must add its particles in that
    /// order, which the keys give. Blocks already in key order (most) are
    /// only checked.
    pub fn order_blocks_by(&mut self, keys: &[u64]) {
        for block in &self.occupied {
            let places = &mut self.order[block.start as usize..block.end as usize];
            if !places.is_sorted_by_key(|&p| keys[p as usize]) {
                places.sort_unstable_by_key(|&p| keys[p as usize]);
            }
        }
    }

    /// Lists the occupied blocks in block order and turns `counts` into the
    /// first place of each block's particles in `order`.
    fn collect_occupied(&mut self, grid: &GridLayout) {
        self.sorted.clear();
        self.sorted.extend(0..self.seen.len() as u32);
        let seen = &self.seen;
        self.sorted
            .sort_unstable_by_key(|&number| seen[number as usize]);
        self.occupied.clear();
        let mut start = 0;
        for &number in &self.sorted {
            let count = self.counts[number as usize];
            self.counts[number as usize] = start;
            self.occupied.push(OccupiedBlock {
                coord: grid.block_coord(self.seen[number as usize] as usize),
                start,
                end: start + count,
            });
            start += count;
        }
    }

    fn collect_colours(&mut self) {
        for list in &mut self.colours {
            list.clear();
        }
        for (i, block) in self.occupied.iter().enumerate() {
            self.colours[colour_of(block.coord)].push(i as u32);
        }
    }

    /// Lists the blocks within one block of an occupied block, marking them
    /// in `numbers` to list each once.
    fn collect_active(&mut self, grid: &GridLayout) {
        self.active_blocks.clear();
        let last = grid.blocks.as_ivec3() - IVec3::ONE;
        for block in &self.occupied {
            let low = (block.coord - IVec3::ONE).max(IVec3::ZERO);
            let high = (block.coord + IVec3::ONE).min(last);
            for x in low.x..=high.x {
                for y in low.y..=high.y {
                    for z in low.z..=high.z {
                        let index = grid.block_index(IVec3::new(x, y, z));
                        if self.numbers[index] == ABSENT {
                            self.numbers[index] = 0;
                            self.active_blocks.push(index as u32);
                        }
                    }
                }
            }
        }
        for &index in &self.active_blocks {
            self.numbers[index as usize] = ABSENT;
        }
        self.active_blocks.sort_unstable();
    }

    /// Bytes held by the binning buffers, except `order`, which
    /// [`crate::Particles::bytes_per_particle`] already counts.
    pub fn memory_bytes(&self) -> usize {
        let lists = [
            &self.active_blocks,
            &self.keys,
            &self.numbers,
            &self.seen,
            &self.counts,
            &self.sorted,
        ];
        let words: usize = lists.iter().map(|list| list.capacity()).sum::<usize>()
            + self.colours.iter().map(Vec::capacity).sum::<usize>();
        words * std::mem::size_of::<u32>()
            + self.occupied.capacity() * std::mem::size_of::<OccupiedBlock>()
    }

    /// Particle indices of an occupied block.
    pub fn particles_of(&self, block: &OccupiedBlock) -> &[u32] {
        &self.order[block.start as usize..block.end as usize]
    }
}

/// Particles per parallel piece when cutting the keys into runs.
const RUN_CHUNK: usize = 4096;

/// Consecutive particles in the same block.
#[derive(Clone, Copy, Debug)]
struct Run {
    key: u32,
    length: u32,
}

/// The runs of equal keys in `keys`, in order.
fn runs_of(keys: &[u32]) -> Vec<Run> {
    let mut runs: Vec<Run> = Vec::new();
    for &key in keys {
        match runs.last_mut() {
            Some(run) if run.key == key => run.length += 1,
            _ => runs.push(Run { key, length: 1 }),
        }
    }
    runs
}

/// log₂ of [`BLOCK_WIDTH`].
const BLOCK_SHIFT: i32 = 2;

/// Linear index of the block holding the cell of `position` (clamped to
/// the grid), the key the particles are sorted by.
pub fn block_key(grid: &GridLayout, position: Vec3) -> usize {
    let (_, cell) = floor(grid.to_grid(position));
    let last = grid.blocks.as_ivec3() - IVec3::ONE;
    // ⌊cell / 4⌋ by an arithmetic shift, negative cells included.
    const { assert!(BLOCK_WIDTH == 1 << BLOCK_SHIFT) };
    grid.block_index((cell >> BLOCK_SHIFT).clamp(IVec3::ZERO, last))
}

/// Colour (0..8) of a block: the parity of its coordinates.
pub fn colour_of(block: IVec3) -> usize {
    ((block.x & 1) | ((block.y & 1) << 1) | ((block.z & 1) << 2)) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_bins(grid: &GridLayout, positions: &[Vec3]) {
        let mut bins = Bins::default();
        bins.rebuild(grid, positions);
        let mut seen = vec![false; positions.len()];
        for block in &bins.occupied {
            let particles = bins.particles_of(block);
            assert!(particles.windows(2).all(|w| w[0] < w[1]), "stable order");
            for &p in particles {
                assert_eq!(
                    block_key(grid, positions[p as usize]),
                    grid.block_index(block.coord)
                );
                seen[p as usize] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
        let coloured: usize = bins.colours.iter().map(Vec::len).sum();
        assert_eq!(coloured, bins.occupied.len());
    }

    fn scattered(count: usize) -> impl Fn(usize) -> Vec3 {
        move |i| {
            let t = (i % count) as f32 * 0.618;
            Vec3::new(t.fract(), (t * 1.7).fract(), (t * 2.3).fract())
        }
    }

    #[test]
    fn bins_sort_stably_and_cover_every_particle() {
        let grid = GridLayout::new(Vec3::ZERO, Vec3::ONE, 0.05);
        let positions: Vec<Vec3> = (0..500).map(scattered(500)).collect();
        check_bins(&grid, &positions);
    }

    /// Runs of particles in one block that cross the pieces the keys are
    /// cut into, and blocks that come back in later pieces.
    #[test]
    fn runs_across_pieces_sort_stably() {
        let grid = GridLayout::new(Vec3::ZERO, Vec3::ONE, 0.05);
        let count = 3 * RUN_CHUNK + 17;
        let positions: Vec<Vec3> = (0..count).map(|i| scattered(40)(i / 333)).collect();
        check_bins(&grid, &positions);
    }
}

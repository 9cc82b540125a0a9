//! The domain decomposition: the grid's blocks in the order of their index
//! (x slowest, then y, then z), cut into one contiguous range per rank
//! ("slab"), balanced by particle count. A cut may fall at any block, so
//! the balance is as fine as one block's particles. The blocks within one
//! block of a slab in every axis lie within [`neighbour_reach`] indices of
//! its ends, so a rank trades block sums (and, unless a particle went
//! further, migrants) with its neighbours in the order only: those of the
//! one block layer each side of a cut (where a cut falls inside a block
//! layer, the slab's faces are a staircase of blocks, and the layer follows
//! it). Recursive bisection would give smaller faces at the price of more
//! neighbours.

use firn_mpm::grid::GridLayout;
use std::ops::Range;

use glam::UVec3;

/// How far, in block indices, the blocks within one block of a block in
/// every axis lie from it, for a grid of `blocks` blocks: a step of one
/// block in x, y and z moves the index by `blocks.y · blocks.z`,
/// `blocks.z` and 1.
pub fn neighbour_reach(blocks: UVec3) -> u32 {
    blocks.y * blocks.z + blocks.z + 1
}

/// Each rank's range of block indices: rank `r` owns the particles whose
/// block index is in `starts[r]..starts[r + 1]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Slabs {
    starts: Vec<u32>,
}

impl Slabs {
    /// Particles per block index, of the particles in `blocks`.
    pub fn block_histogram(blocks: &[u32], layout: &GridLayout) -> Vec<u64> {
        let mut histogram = vec![0u64; layout.blocks.element_product() as usize];
        for &block in blocks {
            histogram[block as usize] += 1;
        }
        histogram
    }

    /// Slabs for `ranks` ranks over the blocks whose particle counts are
    /// `histogram` (one entry per block index): each slab ends at the block
    /// boundary nearest to its equal share of the particles.
    pub fn balanced(histogram: &[u64], ranks: usize) -> Slabs {
        let blocks = histogram.len() as u32;
        let total: u64 = histogram.iter().sum();
        let mut starts = vec![0u32; ranks + 1];
        starts[ranks] = blocks;
        let mut before = 0u64;
        let mut block = 0u32;
        for (rank, start) in starts.iter_mut().enumerate().take(ranks).skip(1) {
            let share = (u128::from(total) * rank as u128 / ranks as u128) as u64;
            // Move the cut past every block that keeps the count before it
            // within the share or brings it nearer.
            while block < blocks {
                let after = before + histogram[block as usize];
                if after <= share || after.abs_diff(share) < before.abs_diff(share) {
                    before = after;
                    block += 1;
                } else {
                    break;
                }
            }
            *start = block;
        }
        Slabs { starts }
    }

    /// How many ranks the slabs are for.
    pub fn ranks(&self) -> usize {
        self.starts.len() - 1
    }

    /// The block indices of `rank`.
    pub fn blocks(&self, rank: usize) -> Range<u32> {
        self.starts[rank]..self.starts[rank + 1]
    }

    /// The rank owning block `block` (blocks past the last belong
    /// to the last rank).
    pub fn owner(&self, block: u32) -> usize {
        let after = self.starts[1..].partition_point(|&start| start <= block);
        after.min(self.ranks() - 1)
    }

    /// The other ranks whose blocks lie within `reach` block indices of
    /// `rank`'s (a symmetric relation; none for an empty slab): the only
    /// ranks it trades block sums with, and migrants with when no particle
    /// went further.
    pub fn neighbours(&self, rank: usize, reach: u32) -> Vec<usize> {
        let own = self.blocks(rank);
        if own.is_empty() {
            return Vec::new();
        }
        (0..self.ranks())
            .filter(|&other| {
                let theirs = self.blocks(other);
                other != rank
                    && !theirs.is_empty()
                    && theirs.start < own.end + reach
                    && own.start < theirs.end + reach
            })
            .collect()
    }

    /// The busiest rank's particles over the mean, for particle counts per
    /// block `histogram` (1 is perfect balance).
    pub fn imbalance(&self, histogram: &[u64]) -> f64 {
        let total: u64 = histogram.iter().sum();
        if total == 0 {
            return 1.0;
        }
        let busiest = (0..self.ranks())
            .map(|rank| {
                let range = self.blocks(rank);
                histogram[range.start as usize..range.end as usize]
                    .iter()
                    .sum::<u64>()
            })
            .max()
            .unwrap_or(0);
        busiest as f64 * self.ranks() as f64 / total as f64
    }

    /// The slab starts and the end, as words.
    pub fn to_words(&self) -> Vec<u32> {
        self.starts.clone()
    }

    /// Slabs from [`Slabs::to_words`].
    pub fn from_words(words: &[u32]) -> Slabs {
        Slabs {
            starts: words.to_vec(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balanced_slabs_split_the_particles_evenly_and_cover_every_block() {
        let histogram = [0, 10, 10, 10, 10, 0, 0, 10];
        let slabs = Slabs::balanced(&histogram, 2);
        assert_eq!(slabs.blocks(0), 0..3);
        assert_eq!(slabs.blocks(1), 3..8);
        assert!((slabs.imbalance(&histogram) - 1.2).abs() < 1e-12);
        let four = Slabs::balanced(&histogram, 4);
        assert_eq!(four.blocks(0).start, 0);
        assert_eq!(four.blocks(3).end, 8);
        assert!((four.imbalance(&histogram) - 1.6).abs() < 1e-12);
        for block in 0..8 {
            let owner = four.owner(block);
            assert!(four.blocks(owner).contains(&block));
        }
    }

    #[test]
    fn the_neighbour_reach_covers_every_neighbouring_block() {
        let blocks = UVec3::new(5, 4, 3);
        let index = |x: u32, y: u32, z: u32| (x * blocks.y + y) * blocks.z + z;
        let reach = neighbour_reach(blocks);
        for (x, y, z) in [(1, 1, 1), (2, 2, 1), (3, 1, 1)] {
            for offset in 0..27u32 {
                let [dx, dy, dz] = [offset % 3, offset / 3 % 3, offset / 9].map(|d| d as i32 - 1);
                let neighbour = index(
                    (x as i32 + dx) as u32,
                    (y as i32 + dy) as u32,
                    (z as i32 + dz) as u32,
                );
                assert!(neighbour.abs_diff(index(x, y, z)) <= reach);
            }
        }
    }

    #[test]
    fn neighbours_are_the_ranks_within_reach_both_ways() {
        let slabs = Slabs::from_words(&[0, 10, 12, 30, 30, 40]);
        assert_eq!(slabs.neighbours(0, 3), [1, 2]);
        assert_eq!(slabs.neighbours(1, 3), [0, 2]);
        assert_eq!(slabs.neighbours(2, 3), [0, 1, 4]);
        assert_eq!(slabs.neighbours(3, 3), Vec::<usize>::new());
        assert_eq!(slabs.neighbours(4, 3), [2]);
        assert_eq!(slabs.neighbours(0, 1), [1]);
    }

    #[test]
    fn a_lone_heavy_block_gets_a_rank_of_its_own() {
        let histogram = [1, 1, 100, 1, 1];
        let slabs = Slabs::balanced(&histogram, 3);
        let heavy = slabs.owner(2);
        assert_eq!(slabs.blocks(heavy), 2..3);
    }
}

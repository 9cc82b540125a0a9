//! The domain decomposition: the grid's block columns along x (the slowest
//! axis of the block index, so a slab of whole columns is one contiguous
//! range of block indices) cut into one slab per rank, balanced by particle
//! count. Slabs of a few columns keep the ghost layers thin (two block
//! columns each side, three with wind) and the exchange with two
//! neighbours; recursive bisection would balance finer at the price of
//! more neighbours.

use std::ops::Range;

/// Each rank's range of block columns along x: rank `r` owns the particles
/// whose block has x in `starts[r]..starts[r + 1]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Slabs {
    starts: Vec<u32>,
}

impl Slabs {
    /// Slabs for `ranks` ranks over the block columns whose particle counts
    /// are `histogram` (one entry per column): each slab ends at the column
    /// boundary nearest to its equal share of the particles.
    pub fn balanced(histogram: &[u64], ranks: usize) -> Slabs {
        let columns = histogram.len() as u32;
        let total: u64 = histogram.iter().sum();
        let mut starts = vec![0u32; ranks + 1];
        starts[ranks] = columns;
        let mut before = 0u64;
        let mut column = 0u32;
        for (rank, start) in starts.iter_mut().enumerate().take(ranks).skip(1) {
            let share = (u128::from(total) * rank as u128 / ranks as u128) as u64;
            // Move the cut past every column that keeps the count before it
            // within the share or brings it nearer.
            while column < columns {
                let after = before + histogram[column as usize];
                if after <= share || after.abs_diff(share) < before.abs_diff(share) {
                    before = after;
                    column += 1;
                } else {
                    break;
                }
            }
            *start = column;
        }
        Slabs { starts }
    }

    /// How many ranks the slabs are for.
    pub fn ranks(&self) -> usize {
        self.starts.len() - 1
    }

    /// The block columns of `rank`.
    pub fn columns(&self, rank: usize) -> Range<u32> {
        self.starts[rank]..self.starts[rank + 1]
    }

    /// The rank owning block column `column` (columns past the last belong
    /// to the last rank).
    pub fn owner(&self, column: u32) -> usize {
        let after = self.starts[1..].partition_point(|&start| start <= column);
        after.min(self.ranks() - 1)
    }

    /// The columns whose particles `rank` needs as ghosts, `width` columns
    /// either side of its slab (none for an empty slab).
    pub fn ghost_columns(&self, rank: usize, width: u32) -> [Range<u32>; 2] {
        let own = self.columns(rank);
        if own.is_empty() {
            return [0..0, 0..0];
        }
        [
            own.start.saturating_sub(width)..own.start,
            own.end..own.end + width,
        ]
    }

    /// The busiest rank's particles over the mean, for particle counts per
    /// column `histogram` (1 is perfect balance).
    pub fn imbalance(&self, histogram: &[u64]) -> f64 {
        let total: u64 = histogram.iter().sum();
        if total == 0 {
            return 1.0;
        }
        let busiest = (0..self.ranks())
            .map(|rank| {
                let range = self.columns(rank);
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
    fn balanced_slabs_split_the_particles_evenly_and_cover_every_column() {
        let histogram = [0, 10, 10, 10, 10, 0, 0, 10];
        let slabs = Slabs::balanced(&histogram, 2);
        assert_eq!(slabs.columns(0), 0..3);
        assert_eq!(slabs.columns(1), 3..8);
        assert!((slabs.imbalance(&histogram) - 1.2).abs() < 1e-12);
        let four = Slabs::balanced(&histogram, 4);
        assert_eq!(four.columns(0).start, 0);
        assert_eq!(four.columns(3).end, 8);
        assert!((four.imbalance(&histogram) - 1.6).abs() < 1e-12);
        for column in 0..8 {
            let owner = four.owner(column);
            assert!(four.columns(owner).contains(&column));
        }
    }

    #[test]
    fn a_lone_heavy_column_gets_a_rank_of_its_own() {
        let histogram = [1, 1, 100, 1, 1];
        let slabs = Slabs::balanced(&histogram, 3);
        let heavy = slabs.owner(2);
        assert_eq!(slabs.columns(heavy), 2..3);
    }
}

//! A rank's side of the scatter's trade of block sums with its neighbours.

use firn_mpm::SumTrade;
use firn_mpm::grid::GridLayout;
use glam::IVec3;

use super::{Phase, RankTraffic};
use crate::exchange::Exchange;
use crate::slabs::{Slabs, neighbour_reach};

/// A rank's side of the scatter's trade of block sums
/// ([`firn_mpm::block_sums`]): a block's sums go to the owners of the
/// blocks around it, which are among the neighbours; the trade goes to and
/// from the neighbours only, timed as [`Phase::Sums`], as is the sum of
/// the rigid bodies' exchanges over all ranks.
pub(super) struct SlabTrade<'a, E: Exchange> {
    pub(super) exchange: &'a E,
    pub(super) slabs: &'a Slabs,
    pub(super) layout: GridLayout,
    /// The ranks within [`neighbour_reach`] ([`Slabs::neighbours`]).
    pub(super) neighbours: Vec<usize>,
    pub(super) traffic: &'a mut RankTraffic,
}

impl<E: Exchange> SumTrade for SlabTrade<'_, E> {
    fn readers(&self, block: u32, readers: &mut Vec<usize>) {
        let me = self.exchange.rank();
        let own = self.slabs.blocks(me);
        let reach = neighbour_reach(self.layout.blocks);
        if own.start + reach <= block && block + reach < own.end {
            return;
        }
        let centre = self.layout.block_coord(block as usize);
        let last = self.layout.blocks.as_ivec3() - IVec3::ONE;
        let low = (centre - IVec3::ONE).max(IVec3::ZERO);
        let high = (centre + IVec3::ONE).min(last);
        for x in low.x..=high.x {
            for y in low.y..=high.y {
                for z in low.z..=high.z {
                    let index = self.layout.block_index(IVec3::new(x, y, z)) as u32;
                    let owner = self.slabs.owner(index);
                    if owner != me && !readers.contains(&owner) {
                        readers.push(owner);
                    }
                }
            }
        }
    }

    fn trade(&mut self, outgoing: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
        let words: usize = outgoing.iter().map(Vec::len).sum();
        self.traffic.bytes_sent += (words * std::mem::size_of::<u32>()) as u64;
        let started = std::time::Instant::now();
        let incoming = self.exchange.exchange_with(outgoing, &self.neighbours);
        self.traffic.exchange_seconds[Phase::Sums as usize] += started.elapsed().as_secs_f64();
        incoming
    }

    fn parts(&self) -> usize {
        self.exchange.size()
    }

    fn part(&self) -> usize {
        self.exchange.rank()
    }

    fn add_up(&mut self, values: &mut [u64]) {
        let started = std::time::Instant::now();
        let sums = self.exchange.sum_u64(values);
        values.copy_from_slice(&sums);
        self.traffic.exchange_seconds[Phase::Sums as usize] += started.elapsed().as_secs_f64();
    }
}

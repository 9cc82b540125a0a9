//! The scatter's block sums traded between the parts of a run split
//! between processes (MPI ranks); one process never comes here.
//!
//! Every block sums its particles into a dense copy of the nodes around it
//! ([`LocalNodes`]); a grid node is the sum, colour by colour, of the
//! copies of the (at most eight, one per colour) blocks that reach it. In a
//! split run every block's particles live in one part, which alone can sum
//! that block; the nodes a part reads (those around its own blocks) also
//! hear from the neighbouring blocks of other parts. So, before adding,
//! each part sends the sums of its blocks next to another part's to that
//! part ([`SumTrade`]), and adds the sums it receives in their colour's
//! turn: every node it reads then holds the one process's bits, and no
//! particle is copied between parts.

use glam::IVec3;
use rayon::prelude::*;

use crate::binning::{Bins, OccupiedBlock};
use crate::grid::GridLayout;
use crate::local_nodes::{LocalNodes, NodeSum};

/// How one part of a split run trades block sums with the others.
pub trait SumTrade {
    /// Appends to `readers` the other parts that read the nodes around
    /// this part's block `block` (a linear block index): those that own a
    /// block within one block of it in every axis.
    fn readers(&self, block: u32, readers: &mut Vec<usize>);

    /// Sends each part its words (`outgoing[part]`, empty for most) and
    /// returns the words each part sent this one.
    fn trade(&mut self, outgoing: Vec<Vec<u32>>) -> Vec<Vec<u32>>;

    /// The number of parts.
    fn parts(&self) -> usize;
}

/// The block sums of one substep's trade.
pub(crate) struct Traded<T> {
    /// Per occupied block (index into [`Bins::occupied`]), the place of its
    /// sums in `sent`, or `u32::MAX` when no other part reads it.
    sent_place: Vec<u32>,
    /// The sums of this part's blocks that other parts read.
    sent: Vec<Box<LocalNodes<T>>>,
    /// The other parts' sums this part reads, by colour.
    pub(crate) received: [Vec<Box<LocalNodes<T>>>; 8],
}

impl<T: NodeSum> Traded<T> {
    /// Sums the blocks other parts read, sends each part those it reads
    /// (per block: its index, then [`LocalNodes::push_words`]), and
    /// unpacks what the others sent.
    pub(crate) fn trade(
        bins: &Bins,
        layout: GridLayout,
        trade: &mut dyn SumTrade,
        sums_of: &(impl Fn(&OccupiedBlock, &mut LocalNodes<T>) + Sync),
    ) -> Traded<T> {
        let mut readers = Vec::new();
        let mut sent_place = vec![u32::MAX; bins.occupied().len()];
        let mut shared = Vec::new();
        for (place, block) in bins.occupied().iter().enumerate() {
            readers.clear();
            trade.readers(layout.block_index(block.coord) as u32, &mut readers);
            if !readers.is_empty() {
                sent_place[place] = shared.len() as u32;
                shared.push((place, readers.clone()));
            }
        }
        let sent: Vec<Box<LocalNodes<T>>> = shared
            .par_iter()
            .map(|&(place, _)| {
                let block = &bins.occupied()[place];
                let mut sums = Box::new(LocalNodes::around(block.coord));
                sums_of(block, &mut sums);
                sums
            })
            .collect();
        let mut outgoing = vec![Vec::new(); trade.parts()];
        for ((place, readers), sums) in shared.iter().zip(&sent) {
            let index = layout.block_index(bins.occupied()[*place].coord) as u32;
            for &part in readers {
                outgoing[part].push(index);
                sums.push_words(&mut outgoing[part]);
            }
        }
        let mut received: [Vec<Box<LocalNodes<T>>>; 8] = Default::default();
        for words in trade.trade(outgoing) {
            let mut rest = words.as_slice();
            while let Some((&index, after)) = rest.split_first() {
                let block = layout.block_coord(index as usize);
                let (sums, read) = LocalNodes::from_words(block, after);
                received[crate::binning::colour_of(block)].push(sums);
                rest = &after[read..];
            }
        }
        Traded {
            sent_place,
            sent,
            received,
        }
    }

    /// The sums made for the trade of occupied block `block`, if any.
    pub(crate) fn own_sums(&self, block: u32) -> Option<&LocalNodes<T>> {
        let place = self.sent_place[block as usize];
        (place != u32::MAX).then(|| &*self.sent[place as usize])
    }

    /// The blocks that need storage: those around this part's particles
    /// and those around every block whose sums it received.
    pub(crate) fn blocks_with_storage(&self, bins: &Bins, layout: GridLayout) -> Vec<u32> {
        let mut blocks = bins.active_blocks().to_vec();
        let last = layout.blocks.as_ivec3() - IVec3::ONE;
        for sums in self.received.iter().flatten() {
            let block = sums.block();
            let low = (block - IVec3::ONE).max(IVec3::ZERO);
            let high = (block + IVec3::ONE).min(last);
            for x in low.x..=high.x {
                for y in low.y..=high.y {
                    for z in low.z..=high.z {
                        blocks.push(layout.block_index(IVec3::new(x, y, z)) as u32);
                    }
                }
            }
        }
        blocks.sort_unstable();
        blocks.dedup();
        blocks
    }
}

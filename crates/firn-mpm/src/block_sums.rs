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
//!
//! Several parts hold such a node, each with the same sums. Where a sum
//! over nodes is wanted once for the whole run (a rigid body's exchange
//! with the snow, [`crate::coupling`]), [`NodeOwners`] names the one part
//! that counts each node.

use std::collections::HashMap;

use glam::IVec3;
use rayon::prelude::*;

use crate::binning::{Bins, OccupiedBlock};
use crate::grid::{BLOCK_WIDTH, GridLayout};
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

    /// This part's number, `0..parts()`.
    fn part(&self) -> usize;

    /// Sums each of `values` over the parts, modulo 2⁶⁴ (exact and
    /// order-free: integers), in place; every part must call it alike.
    fn add_up(&mut self, values: &mut [u64]);
}

/// The other parts' occupied blocks whose sums this part received in a
/// scatter, each with the part that sent it (its owner), by block index.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ForeignBlocks {
    owners: Vec<(u32, u32)>,
}

/// Which part of a split run counts each grid node in a sum over nodes:
/// of the parts owning an occupied block whose particles may reach the
/// node, the lowest. Each of those parts reads the node, so each holds
/// the one process's sums there and updates it alike; this part knows
/// them all, as their blocks are next to its own and were traded to it.
#[derive(Clone, Debug)]
pub struct NodeOwners {
    part: u32,
    layout: GridLayout,
    /// The owner of every occupied block this part knows, by block index.
    owners: HashMap<u32, u32>,
}

impl NodeOwners {
    /// The owners as part `part` sees them after a scatter: its own
    /// occupied blocks (`bins`) and those it received (`foreign`).
    pub fn new(
        part: usize,
        layout: GridLayout,
        bins: &Bins,
        foreign: &ForeignBlocks,
    ) -> NodeOwners {
        let part = part as u32;
        let mut owners: HashMap<u32, u32> = foreign.owners.iter().copied().collect();
        for block in bins.occupied() {
            owners.insert(layout.block_index(block.coord) as u32, part);
        }
        NodeOwners {
            part,
            layout,
            owners,
        }
    }

    /// Whether this part counts the node at grid coordinate `node`.
    pub fn counts(&self, node: IVec3) -> bool {
        let last = self.layout.blocks.as_ivec3() - IVec3::ONE;
        let (low, high) = reaching_blocks(node);
        let (low, high) = (low.max(IVec3::ZERO), high.min(last));
        let mut lowest = u32::MAX;
        for x in low.x..=high.x {
            for y in low.y..=high.y {
                for z in low.z..=high.z {
                    let index = self.layout.block_index(IVec3::new(x, y, z)) as u32;
                    if let Some(&owner) = self.owners.get(&index) {
                        lowest = lowest.min(owner);
                    }
                }
            }
        }
        lowest == self.part
    }
}

/// The first and last block (per axis) whose particles may reach grid node
/// `node`: block b's particles reach the nodes from b·W − 1 to
/// b·W + W + 1 (W = [`BLOCK_WIDTH`]; the reach of a block's node copy).
fn reaching_blocks(node: IVec3) -> (IVec3, IVec3) {
    let low = (node - IVec3::splat(2)).div_euclid(IVec3::splat(BLOCK_WIDTH));
    let high = (node + IVec3::ONE).div_euclid(IVec3::splat(BLOCK_WIDTH));
    (low, high)
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
    /// The blocks of those sums and their senders.
    pub(crate) foreign: ForeignBlocks,
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
        let mut foreign = ForeignBlocks::default();
        for (sender, words) in trade.trade(outgoing).into_iter().enumerate() {
            let mut rest = words.as_slice();
            while let Some((&index, after)) = rest.split_first() {
                let block = layout.block_coord(index as usize);
                let (sums, read) = LocalNodes::from_words(block, after);
                received[crate::binning::colour_of(block)].push(sums);
                foreign.owners.push((index, sender as u32));
                rest = &after[read..];
            }
        }
        foreign.owners.sort_unstable();
        Traded {
            sent_place,
            sent,
            received,
            foreign,
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

//! The collectives the ranks use. The one a transport must implement is
//! [`Exchange::exchange`]: every rank hands every rank (itself included) a
//! buffer of 32-bit words and gets back what each rank handed it, by
//! sender. The reductions, the scan, the broadcasts and the barrier have
//! default implementations made from it (all-gathers, O(ranks) words per
//! rank), which a transport overrides with its own scalable collectives
//! (MPI's `MPI_Allreduce`, `MPI_Exscan`, `MPI_Bcast`, `MPI_Barrier`).

use std::sync::{Arc, Barrier, Mutex};

/// A group of ranks that exchange buffers of words.
pub trait Exchange {
    /// This rank's number, `0..size()`.
    fn rank(&self) -> usize;
    /// How many ranks there are.
    fn size(&self) -> usize;
    /// Sends `outgoing[r]` to rank `r` (one buffer per rank) and returns
    /// what every rank sent to this one, indexed by sender. Every rank must
    /// call it, the same number of times.
    fn exchange(&self, outgoing: Vec<Vec<u32>>) -> Vec<Vec<u32>>;

    /// [`Exchange::exchange`] between neighbours: only the ranks in
    /// `partners` (a relation every rank sees alike, and symmetric: `r`
    /// lists `s` exactly when `s` lists `r`) send to or receive from this
    /// one, and `outgoing` to every other rank is empty. Every rank must
    /// call it.
    fn exchange_with(&self, outgoing: Vec<Vec<u32>>, partners: &[usize]) -> Vec<Vec<u32>> {
        let _ = partners;
        self.exchange(outgoing)
    }

    /// Sends `words` to every rank; returns every rank's words, by rank.
    fn all_gather(&self, words: &[u32]) -> Vec<Vec<u32>> {
        self.exchange(vec![words.to_vec(); self.size()])
    }

    /// Rank 0's `words` on every rank (the others' `words` are ignored).
    fn broadcast(&self, words: Vec<u32>) -> Vec<u32> {
        self.broadcast_from(0, words)
    }

    /// Rank `root`'s `words` on every rank (the others' `words` are
    /// ignored).
    fn broadcast_from(&self, root: usize, words: Vec<u32>) -> Vec<u32> {
        let outgoing = if self.rank() == root {
            vec![words; self.size()]
        } else {
            vec![Vec::new(); self.size()]
        };
        self.exchange(outgoing).swap_remove(root)
    }

    /// Returns once every rank has called it.
    fn barrier(&self) {
        self.exchange(vec![Vec::new(); self.size()]);
    }

    /// The smallest of every rank's `values`, element by element.
    fn min_u64(&self, values: &[u64]) -> Vec<u64> {
        let words: Vec<u32> = values.iter().flat_map(|&v| split_u64(v)).collect();
        let mut result = values.to_vec();
        for theirs in self.all_gather(&words) {
            for (least, pair) in result.iter_mut().zip(theirs.chunks_exact(2)) {
                *least = (*least).min(join_u64(pair[0], pair[1]));
            }
        }
        result
    }

    /// The largest of every rank's `values`, element by element.
    fn max_u64(&self, values: &[u64]) -> Vec<u64> {
        let complements: Vec<u64> = values.iter().map(|&v| u64::MAX - v).collect();
        self.min_u64(&complements)
            .into_iter()
            .map(|least| u64::MAX - least)
            .collect()
    }

    /// The sum of `value` over the ranks below this one (0 on rank 0).
    fn exclusive_sum_u64(&self, value: u64) -> u64 {
        self.all_gather(&split_u64(value))[..self.rank()]
            .iter()
            .map(|words| join_u64(words[0], words[1]))
            .sum()
    }

    /// Every rank's `words` on rank 0, by rank; `None` on the others.
    fn gather(&self, words: &[u32]) -> Option<Vec<Vec<u32>>> {
        let mut outgoing = vec![Vec::new(); self.size()];
        outgoing[0] = words.to_vec();
        let incoming = self.exchange(outgoing);
        (self.rank() == 0).then_some(incoming)
    }

    /// The largest of every rank's `values`, element by element (a maximum
    /// does not depend on the order, so every rank gets the same bits).
    fn max_f32(&self, values: &[f32]) -> Vec<f32> {
        let words: Vec<u32> = values.iter().map(|v| v.to_bits()).collect();
        let mut result = values.to_vec();
        for theirs in self.all_gather(&words) {
            for (mine, word) in result.iter_mut().zip(theirs) {
                *mine = mine.max(f32::from_bits(word));
            }
        }
        result
    }

    /// The sum of every rank's `counts`, element by element, modulo 2⁶⁴
    /// (as MPI's sum of unsigned integers wraps), so that two's-complement
    /// i64 words add up too.
    fn sum_u64(&self, counts: &[u64]) -> Vec<u64> {
        let words: Vec<u32> = counts.iter().flat_map(|&c| split_u64(c)).collect();
        let mut result = vec![0u64; counts.len()];
        for theirs in self.all_gather(&words) {
            for (total, pair) in result.iter_mut().zip(theirs.chunks_exact(2)) {
                *total = total.wrapping_add(join_u64(pair[0], pair[1]));
            }
        }
        result
    }
}

/// A u64 as two words, high first.
pub fn split_u64(value: u64) -> [u32; 2] {
    [(value >> 32) as u32, value as u32]
}

/// The u64 of two words, high first.
pub fn join_u64(high: u32, low: u32) -> u64 {
    (u64::from(high) << 32) | u64::from(low)
}

/// Ranks as threads of one process, exchanging through shared memory: the
/// rank algorithm tested without MPI. Make them with [`ThreadRanks::group`]
/// and move each into its own thread.
#[derive(Clone)]
pub struct ThreadRanks {
    rank: usize,
    size: usize,
    shared: Arc<Mailboxes>,
}

/// `slots[to][from]`: the buffer on its way, and a barrier that separates
/// posting from collecting.
struct Mailboxes {
    slots: Mutex<Vec<Vec<Vec<u32>>>>,
    barrier: Barrier,
}

impl ThreadRanks {
    /// `size` ranks sharing one set of mailboxes, rank 0 first.
    pub fn group(size: usize) -> Vec<ThreadRanks> {
        let shared = Arc::new(Mailboxes {
            slots: Mutex::new(vec![vec![Vec::new(); size]; size]),
            barrier: Barrier::new(size),
        });
        (0..size)
            .map(|rank| ThreadRanks {
                rank,
                size,
                shared: Arc::clone(&shared),
            })
            .collect()
    }
}

impl Exchange for ThreadRanks {
    fn rank(&self) -> usize {
        self.rank
    }

    fn size(&self) -> usize {
        self.size
    }

    fn exchange(&self, outgoing: Vec<Vec<u32>>) -> Vec<Vec<u32>> {
        assert_eq!(outgoing.len(), self.size, "one buffer per rank");
        {
            let mut slots = self.shared.slots.lock().expect("a rank thread panicked");
            for (to, buffer) in outgoing.into_iter().enumerate() {
                slots[to][self.rank] = buffer;
            }
        }
        self.shared.barrier.wait();
        let incoming = {
            let mut slots = self.shared.slots.lock().expect("a rank thread panicked");
            std::mem::replace(&mut slots[self.rank], vec![Vec::new(); self.size])
        };
        // No rank posts the next exchange before every rank has collected.
        self.shared.barrier.wait();
        incoming
    }
}

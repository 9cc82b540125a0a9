//! Merging a migration's arrivals into a rank's key-sorted particles in
//! place: [`MergePlan`].
//!
//! A rank keeps its own particles sorted by key. After a migration some
//! have left and a few hundred have arrived (unpacked after the others), and
//! the array must be sorted again. Gathering every attribute through a
//! permutation reads and writes the whole array (146 bytes per particle, 4 to
//! 5 ms a substep at 133k particles on one core). But the kept particles stay
//! in order: they fall into a few runs, each shifted by the arrivals placed
//! before it less the leavers removed before it, so a merge is a handful of
//! `copy_within` moves, and none at all for the runs whose shift is zero (on
//! a slab's first rank, whose particles enter and leave at the end of its
//! key range, everything before the cut stays where it is).

/// A run of kept particles that keeps its order: `length` places from
/// `from` move to `to`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Run {
    from: usize,
    to: usize,
    length: usize,
}

/// How to turn an array of kept and leaving particles followed by arrivals
/// into the kept and the arrivals merged by key, in place.
#[derive(Clone, Debug, Default)]
pub struct MergePlan {
    /// The runs of kept particles, in array order.
    runs: Vec<Run>,
    /// Each arrival's place after the merge and its place before.
    arrivals: Vec<(usize, usize)>,
    /// Particles after the merge.
    length: usize,
}

impl MergePlan {
    /// The plan that puts the particles at `kept` (ascending places, whose
    /// keys ascend) and at `arrived` together in the order of their keys;
    /// every other place is dropped. `keys` holds every particle's key;
    /// keys are distinct.
    pub fn new(kept: &[u32], arrived: &[u32], keys: &[u64]) -> MergePlan {
        let mut arrived = arrived.to_vec();
        arrived.sort_unstable_by_key(|&p| keys[p as usize]);
        let mut plan = MergePlan::default();
        let mut next_arrival = arrived.iter().peekable();
        for &p in kept {
            while let Some(&&arrival) = next_arrival.peek() {
                if keys[arrival as usize] > keys[p as usize] {
                    break;
                }
                plan.arrivals.push((plan.length, arrival as usize));
                plan.length += 1;
                next_arrival.next();
            }
            plan.keep(p as usize);
        }
        for &arrival in next_arrival {
            plan.arrivals.push((plan.length, arrival as usize));
            plan.length += 1;
        }
        plan
    }

    /// Appends kept place `p` at the end of the merged array.
    fn keep(&mut self, p: usize) {
        let to = self.length;
        self.length += 1;
        if let Some(run) = self.runs.last_mut()
            && run.from + run.length == p
            && run.to + run.length == to
        {
            run.length += 1;
            return;
        }
        self.runs.push(Run {
            from: p,
            to,
            length: 1,
        });
    }

    /// Particles after the merge.
    pub fn len(&self) -> usize {
        self.length
    }

    /// Whether the merge leaves no particles.
    pub fn is_empty(&self) -> bool {
        self.length == 0
    }

    /// Whether the merge leaves every place as it is.
    pub fn is_identity(&self, length: usize) -> bool {
        length == self.length
            && self.arrivals.is_empty()
            && self.runs.iter().all(|run| run.from == run.to)
    }

    /// Merges one attribute array as planned.
    ///
    /// Runs that move towards the front are moved first, front to back, then
    /// those that move towards the back, back to front. Runs keep their
    /// order in both places (a run's source and destination both lie after
    /// every earlier run's), so neither sweep writes over a source not yet
    /// moved; the arrivals are read out before and written last.
    pub fn apply<T: Copy + Default>(&self, values: &mut Vec<T>) {
        let arriving: Vec<T> = self
            .arrivals
            .iter()
            .map(|&(_, from)| values[from])
            .collect();
        if values.len() < self.length {
            values.resize(self.length, T::default());
        }
        for run in self.runs.iter().filter(|run| run.to < run.from) {
            values.copy_within(run.from..run.from + run.length, run.to);
        }
        for run in self.runs.iter().rev().filter(|run| run.to > run.from) {
            values.copy_within(run.from..run.from + run.length, run.to);
        }
        for (&(to, _), value) in self.arrivals.iter().zip(arriving) {
            values[to] = value;
        }
        values.truncate(self.length);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a permutation by the merged order gives: the reference.
    fn merged_by_permutation(kept: &[u32], arrived: &[u32], keys: &[u64]) -> Vec<u64> {
        let mut places: Vec<u32> = kept.iter().chain(arrived).copied().collect();
        places.sort_by_key(|&p| keys[p as usize]);
        places.iter().map(|&p| keys[p as usize]).collect()
    }

    /// A small deterministic generator (xorshift).
    fn next(state: &mut u64) -> u64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        *state
    }

    #[test]
    fn merging_in_place_equals_sorting_the_kept_and_the_arrivals() {
        let mut state = 0x9E37_79B9_7F4A_7C15;
        for case in 0..500 {
            let stayed = (next(&mut state) % 60) as usize;
            let arriving = (next(&mut state) % 12) as usize;
            // Even keys for the particles here, ascending; odd keys anywhere
            // for the arrivals, all distinct.
            let mut keys: Vec<u64> = (0..stayed as u64).map(|k| 2 * k + 100).collect();
            let mut odd: Vec<u64> = Vec::new();
            while odd.len() < arriving {
                let key = 2 * (next(&mut state) % 120) + 1;
                if !odd.contains(&key) {
                    odd.push(key);
                }
            }
            keys.extend(&odd);
            let leave_every = 2 + (next(&mut state) % 6) as usize;
            let kept: Vec<u32> = (0..stayed as u32)
                .filter(|p| case % 3 == 0 || (*p as usize) % leave_every != 0)
                .collect();
            let arrived: Vec<u32> = (stayed as u32..(stayed + arriving) as u32).collect();
            let plan = MergePlan::new(&kept, &arrived, &keys);
            let expected = merged_by_permutation(&kept, &arrived, &keys);
            let mut merged = keys.clone();
            plan.apply(&mut merged);
            assert_eq!(merged, expected, "case {case}");
            assert_eq!(plan.len(), expected.len());
        }
    }

    #[test]
    fn a_merge_that_moves_nothing_is_the_identity() {
        let keys = [10, 20, 30, 40];
        let plan = MergePlan::new(&[0, 1, 2, 3], &[], &keys);
        assert!(plan.is_identity(4));
        // Leaving from the end or arriving after the last key moves nothing
        // that stays.
        let plan = MergePlan::new(&[0, 1, 2], &[], &keys);
        assert!(!plan.is_identity(4));
        assert_eq!(plan.runs.len(), 1);
        let plan = MergePlan::new(&[0, 1, 2], &[3], &[10, 20, 30, 50]);
        assert!(plan.runs.iter().all(|run| run.from == run.to));
    }
}

//! A flow split into parts, one per process of a run spread over several
//! (firn-mpi's ranks): the particles are cut into the chunks the time loop
//! already steps in parallel ([`crate::simulation`]), and chunk c belongs to
//! part c mod n. A particle keeps its index for life, so it keeps its part,
//! and the parts of a flow whose emitters keep adding particles stay even.
//!
//! Every particle moves through the field on its own (no particle reads
//! another), so a part stepped on its own gives its particles the bits the
//! whole flow gives them: each process steps its part of a full copy of the
//! flow, then one process puts every part's [`FlowPartState`] into its own.

use std::ops::Range;

use glam::Vec3;

use crate::simulation::CHUNK;

/// Part `part` of a flow cut into `parts`: the chunks of particles whose
/// number is `part` modulo `parts`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FlowPart {
    part: usize,
    parts: usize,
}

impl FlowPart {
    /// The whole flow, as one part.
    pub const WHOLE: FlowPart = FlowPart { part: 0, parts: 1 };

    /// Part `part` of `parts` (`part < parts`).
    pub fn new(part: usize, parts: usize) -> FlowPart {
        assert!(part < parts, "part {part} of {parts} does not exist");
        FlowPart { part, parts }
    }

    /// Whether chunk number `chunk` belongs to this part.
    pub(crate) fn holds_chunk(self, chunk: usize) -> bool {
        chunk % self.parts == self.part
    }

    /// The index ranges of this part's particles among the first `count`, in
    /// increasing order.
    pub fn ranges(self, count: usize) -> impl Iterator<Item = Range<usize>> {
        (self.part * CHUNK..count)
            .step_by(self.parts * CHUNK)
            .map(move |start| start..(start + CHUNK).min(count))
    }

    /// How many of the first `count` particles belong to this part.
    pub fn count(self, count: usize) -> usize {
        self.ranges(count).map(|range| range.len()).sum()
    }
}

/// The state of some of a part's particles, in index order, borrowed: what
/// changes as they move, are born again and record their trails (their
/// emitters do not change). The trail slices are empty when the flow keeps
/// no trails. [`crate::FlowSimulation::part_rows`] lends it for each run of
/// consecutive particles of a part; [`crate::FlowSimulation::set_part_state`]
/// takes it for a whole part.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FlowPartState<'a> {
    /// Positions, m.
    pub positions: &'a [Vec3],
    /// Velocities of the last substep, m/s.
    pub velocities: &'a [Vec3],
    /// Seconds since each current life began.
    pub ages: &'a [f32],
    /// Lengths of the current lives, s.
    pub lifetimes: &'a [f32],
    /// Generations.
    pub generations: &'a [u32],
    /// Trail rings, particle-major, the trails' capacity each.
    pub trail_points: &'a [Vec3],
    /// Valid positions per trail.
    pub trail_lengths: &'a [u32],
    /// Generation of each particle when its trail last recorded.
    pub trail_generations: &'a [u32],
}

impl FlowPartState<'_> {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether it holds no particle.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_parts_hold_every_particle_once() {
        for count in [0, 1, CHUNK - 1, CHUNK, 5 * CHUNK + 7] {
            for parts in 1..=4 {
                let mut seen = vec![0u32; count];
                for part in 0..parts {
                    let part = FlowPart::new(part, parts);
                    let mut held = 0;
                    for range in part.ranges(count) {
                        assert!(part.holds_chunk(range.start / CHUNK));
                        held += range.len();
                        for p in range {
                            seen[p] += 1;
                        }
                    }
                    assert_eq!(held, part.count(count));
                }
                assert!(seen.iter().all(|n| *n == 1), "{count} in {parts}");
            }
        }
    }
}

//! Trails: each particle's last k positions, one per frame, in a ring buffer
//! (seed 002, §2.3: the buffer C of the trail glyphs; firn keeps one ring per
//! particle and one shared write position, since all particles record at the
//! same frames).
//!
//! A particle that is born again starts a new trail: when it records, the
//! ring notices that the particle's generation changed and forgets the old
//! positions.

use glam::Vec3;
use rayon::prelude::*;

/// The recent positions of every particle.
#[derive(Clone, Debug, PartialEq)]
pub struct Trails {
    /// Positions kept per particle (k).
    capacity: usize,
    /// Ring slot of the newest position.
    head: usize,
    /// Particle-major rings: particle p's slot s is `points[p * capacity + s]`.
    points: Vec<Vec3>,
    /// Valid positions per particle (at most `capacity`).
    lengths: Vec<u32>,
    /// The generation of each particle when it last recorded.
    generations: Vec<u32>,
}

/// Particles per parallel task when recording.
const RECORD_CHUNK: usize = 4096;

impl Trails {
    /// Empty trails of `capacity` positions each (at least 1).
    pub fn new(capacity: usize) -> Trails {
        Trails {
            capacity: capacity.max(1),
            head: 0,
            points: Vec::new(),
            lengths: Vec::new(),
            generations: Vec::new(),
        }
    }

    /// Positions kept per particle.
    pub fn capacity(&self) -> usize {
        self.capacity
    }

    /// Particles with a ring.
    pub fn particle_count(&self) -> usize {
        self.lengths.len()
    }

    /// Number of positions particle `p` has recorded in its current life (at
    /// most [`Trails::capacity`]).
    pub fn len(&self, p: usize) -> usize {
        self.lengths[p] as usize
    }

    /// Whether particle `p` has no positions yet.
    pub fn is_empty(&self, p: usize) -> bool {
        self.lengths[p] == 0
    }

    /// Particle `p`'s positions from the oldest to the newest (the current
    /// position, at the last recorded frame); `.rev()` gives newest first.
    pub fn iter(&self, p: usize) -> impl DoubleEndedIterator<Item = Vec3> + ExactSizeIterator + '_ {
        self.view().iter(p)
    }

    /// Every ring unrolled oldest first, as renderers read trails: particle
    /// p's positions are `points[p * capacity..][..lengths[p]]`.
    pub fn oldest_first(&self) -> (Vec<Vec3>, Vec<u32>) {
        self.view().oldest_first()
    }

    /// The trails, borrowed.
    pub fn view(&self) -> TrailsView<'_> {
        TrailsView {
            capacity: self.capacity,
            head: self.head,
            points: &self.points,
            lengths: &self.lengths,
            generations: &self.generations,
        }
    }

    /// Gives particles up to `count` an empty ring (as recording their
    /// first position would, before it records).
    pub(crate) fn cover(&mut self, count: usize) {
        cover_rings(
            self.capacity,
            count,
            &mut self.points,
            &mut self.lengths,
            &mut self.generations,
        );
    }

    /// Record the current positions as the newest trail points.
    pub fn record(&mut self, positions: &[Vec3], generations: &[u32]) {
        let count = positions.len();
        self.cover(count);
        let capacity = self.capacity;
        let head = (self.head + 1) % capacity;
        self.head = head;
        let limit = capacity as u32;
        self.points
            .par_chunks_mut(RECORD_CHUNK * capacity)
            .zip(self.lengths.par_chunks_mut(RECORD_CHUNK))
            .zip(self.generations.par_chunks_mut(RECORD_CHUNK))
            .enumerate()
            .for_each(|(chunk, ((points, lengths), recorded))| {
                let start = chunk * RECORD_CHUNK;
                for (i, (length, recorded)) in lengths.iter_mut().zip(recorded).enumerate() {
                    let p = start + i;
                    if *recorded != generations[p] {
                        *recorded = generations[p];
                        *length = 0;
                    }
                    points[i * capacity + head] = positions[p];
                    *length = (*length + 1).min(limit);
                }
            });
    }

    /// The rings, lengths and recorded generations of the particles in
    /// `particles`.
    pub(crate) fn rows(&self, particles: std::ops::Range<usize>) -> (&[Vec3], &[u32], &[u32]) {
        let capacity = self.capacity;
        (
            &self.points[particles.start * capacity..particles.end * capacity],
            &self.lengths[particles.clone()],
            &self.generations[particles],
        )
    }

    /// Puts the rings, lengths and recorded generations of particles
    /// `first..` (as many as `lengths` holds) in place.
    pub(crate) fn set_rows(
        &mut self,
        first: usize,
        points: &[Vec3],
        lengths: &[u32],
        generations: &[u32],
    ) {
        let capacity = self.capacity;
        let rows = first..first + lengths.len();
        self.points[rows.start * capacity..rows.end * capacity].copy_from_slice(points);
        self.lengths[rows.clone()].copy_from_slice(lengths);
        self.generations[rows].copy_from_slice(generations);
    }

    /// The raw state, for checkpoints: capacity, head slot, rings, lengths and
    /// recorded generations.
    pub fn raw(&self) -> (usize, usize, &[Vec3], &[u32], &[u32]) {
        self.view().raw()
    }

    /// The raw state of [`Trails::raw`], taken out.
    pub fn into_raw(self) -> (usize, usize, Vec<Vec3>, Vec<u32>, Vec<u32>) {
        (
            self.capacity,
            self.head,
            self.points,
            self.lengths,
            self.generations,
        )
    }

    /// Trails from the raw state of [`Trails::raw`]; `None` if the arrays do
    /// not fit together.
    pub fn from_raw(
        capacity: usize,
        head: usize,
        points: Vec<Vec3>,
        lengths: Vec<u32>,
        generations: Vec<u32>,
    ) -> Option<Trails> {
        let trails = Trails {
            capacity,
            head,
            points,
            lengths,
            generations,
        };
        raw_fits(trails.view()).then_some(trails)
    }
}

/// Whether the raw arrays of `trails` fit together: a ring of `capacity`
/// points and a generation per length, no length above the capacity, and
/// the head inside the ring.
pub(crate) fn raw_fits(trails: TrailsView<'_>) -> bool {
    let TrailsView {
        capacity,
        head,
        points,
        lengths,
        generations,
    } = trails;
    capacity >= 1
        && head < capacity
        && points.len() == lengths.len() * capacity
        && generations.len() == lengths.len()
        && lengths.iter().all(|length| *length as usize <= capacity)
}

/// Gives particles up to `count` an empty ring of `capacity` points in the
/// raw arrays (length 0, never recorded).
pub(crate) fn cover_rings(
    capacity: usize,
    count: usize,
    points: &mut Vec<Vec3>,
    lengths: &mut Vec<u32>,
    generations: &mut Vec<u32>,
) {
    if lengths.len() < count {
        points.resize(count * capacity, Vec3::ZERO);
        lengths.resize(count, 0);
        generations.resize(count, u32::MAX);
    }
}

/// The recent positions of every particle, borrowed from [`Trails`] or
/// from a snapshot's raw arrays.
#[derive(Clone, Copy, Debug)]
pub struct TrailsView<'a> {
    capacity: usize,
    head: usize,
    points: &'a [Vec3],
    lengths: &'a [u32],
    generations: &'a [u32],
}

impl<'a> TrailsView<'a> {
    /// The raw state of [`Trails::raw`], borrowed; `None` if the arrays do
    /// not fit together (or the capacity is 0: no trails).
    pub(crate) fn from_raw(
        capacity: usize,
        head: usize,
        points: &'a [Vec3],
        lengths: &'a [u32],
        generations: &'a [u32],
    ) -> Option<TrailsView<'a>> {
        let trails = TrailsView {
            capacity,
            head,
            points,
            lengths,
            generations,
        };
        raw_fits(trails).then_some(trails)
    }

    /// Positions kept per particle.
    pub fn capacity(self) -> usize {
        self.capacity
    }

    /// Particles with a ring.
    pub fn particle_count(self) -> usize {
        self.lengths.len()
    }

    /// Particle `p`'s positions from the oldest to the newest, as
    /// [`Trails::iter`].
    pub fn iter(self, p: usize) -> impl DoubleEndedIterator<Item = Vec3> + ExactSizeIterator + 'a {
        let length = self.lengths[p] as usize;
        let capacity = self.capacity;
        // The oldest kept position sits length − 1 slots behind the head.
        let oldest = self.head + capacity - (length.max(1) - 1);
        let ring = &self.points[p * capacity..(p + 1) * capacity];
        (0..length).map(move |i| ring[(oldest + i) % capacity])
    }

    /// Every ring unrolled oldest first, as [`Trails::oldest_first`].
    pub fn oldest_first(self) -> (Vec<Vec3>, Vec<u32>) {
        let count = self.particle_count();
        let mut points = vec![Vec3::ZERO; self.capacity * count];
        for particle in 0..count {
            let row = &mut points[particle * self.capacity..][..self.capacity];
            for (slot, point) in row.iter_mut().zip(self.iter(particle)) {
                *slot = point;
            }
        }
        (points, self.lengths.to_vec())
    }

    /// The raw state, as [`Trails::raw`].
    pub fn raw(self) -> (usize, usize, &'a [Vec3], &'a [u32], &'a [u32]) {
        (
            self.capacity,
            self.head,
            self.points,
            self.lengths,
            self.generations,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rings_keep_the_last_k_in_age_order_and_restart_on_rebirth() {
        let mut trails = Trails::new(3);
        let mut generations = vec![0u32, 0];
        for frame in 0..5 {
            let f = frame as f32;
            trails.record(&[Vec3::splat(f), Vec3::splat(10.0 + f)], &generations);
        }
        let kept: Vec<f32> = trails.iter(0).map(|x| x.x).collect();
        assert_eq!(kept, vec![2.0, 3.0, 4.0]);
        let newest_first: Vec<f32> = trails.iter(1).rev().map(|x| x.x).collect();
        assert_eq!(newest_first, vec![14.0, 13.0, 12.0]);

        generations[1] = 1;
        trails.record(&[Vec3::splat(5.0), Vec3::splat(-1.0)], &generations);
        assert_eq!(trails.len(1), 1);
        assert_eq!(trails.iter(1).collect::<Vec<_>>(), vec![Vec3::splat(-1.0)]);
        assert_eq!(trails.len(0), 3);

        // A particle born later gets a ring of its own.
        trails.record(&[Vec3::ZERO, Vec3::ZERO, Vec3::ONE], &[0, 1, 0]);
        assert_eq!(trails.particle_count(), 3);
        assert_eq!(trails.iter(2).collect::<Vec<_>>(), vec![Vec3::ONE]);
        let (capacity, head, points, lengths, generations) = trails.raw();
        let copy = Trails::from_raw(
            capacity,
            head,
            points.to_vec(),
            lengths.to_vec(),
            generations.to_vec(),
        )
        .unwrap();
        assert_eq!(copy, trails);
    }
}

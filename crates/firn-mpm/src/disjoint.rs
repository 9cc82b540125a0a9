//! Writing from several threads into one array where the binning proves
//! the writes disjoint: grid nodes during the scatter (same-coloured blocks
//! never share a node, [`crate::binning`]) and particles during the gather
//! (each particle belongs to exactly one block). These two types hold the
//! crate's raw pointers; everything else reaches them through their
//! methods and the colour-by-colour drivers below.

use std::marker::PhantomData;

use glam::{Mat3, Vec3};
use rayon::prelude::*;

use crate::binning::{Bins, OccupiedBlock};
use crate::particles::Particles;

/// Writes into grid nodes from several threads at once. The nodes are stored
/// slot by slot, [`BLOCK_NODES`] per block: the grid's [`Node`]s, or the
/// implicit solver's per-node vectors.
///
/// Sound only because [`scatter_by_colour`] hands each thread a set of nodes
/// no other thread touches at the same time (see [`crate::binning`] for why
/// same-coloured blocks never share a node).
pub(crate) struct NodeWriter<'a, T> {
    nodes: *mut T,
    len: usize,
    _grid: PhantomData<&'a mut [T]>,
}

// SAFETY: the writer is only shared across threads by the driver below,
// whose callers never touch the same node from two threads; the nodes
// themselves may move between threads (`T: Send`).
unsafe impl<T: Send> Sync for NodeWriter<'_, T> {}

impl<'a, T> NodeWriter<'a, T> {
    pub(crate) fn new(nodes: &'a mut [T]) -> NodeWriter<'a, T> {
        NodeWriter {
            nodes: nodes.as_mut_ptr(),
            len: nodes.len(),
            _grid: PhantomData,
        }
    }

    /// Applies `change` to node `index`.
    #[inline(always)]
    pub(crate) fn update(&self, index: usize, change: impl FnOnce(&mut T)) {
        assert!(index < self.len, "node {index} outside the grid");
        // SAFETY: in bounds (checked above); no other thread writes this node
        // now (the drivers' disjointness), and no reference outlives the call.
        change(unsafe { &mut *self.nodes.add(index) });
    }
}

/// Runs `scatter` on every occupied block, colour by colour; blocks of one
/// colour run in parallel, so each node sums its contributions in the same
/// order whatever the thread count.
pub(crate) fn scatter_by_colour<T: Send>(
    nodes: &mut [T],
    bins: &Bins,
    scatter: impl Fn(&[u32], &NodeWriter<T>) + Sync,
) {
    scatter_blocks_by_colour(nodes, bins, |block, writer| {
        scatter(bins.particles_of(block), writer)
    });
}

/// [`scatter_by_colour`], handing over the occupied block itself.
pub(crate) fn scatter_blocks_by_colour<T: Send>(
    nodes: &mut [T],
    bins: &Bins,
    scatter: impl Fn(&OccupiedBlock, &NodeWriter<T>) + Sync,
) {
    let writer = NodeWriter::new(nodes);
    for colour in bins.colours() {
        colour
            .par_iter()
            .for_each(|&block| scatter(&bins.occupied()[block as usize], &writer));
    }
}

/// One particle's state, borrowed from the particle arrays.
pub(crate) struct ParticleState<'a> {
    pub(crate) position: &'a mut Vec3,
    pub(crate) velocity: &'a mut Vec3,
    pub(crate) elastic: &'a mut Mat3,
    pub(crate) plastic_j: &'a mut f32,
    pub(crate) stress: &'a mut Mat3,
    pub(crate) velocity_gradient: &'a mut Mat3,
}

/// The particle arrays, shared by the tasks of the block-by-block gather.
///
/// Sound only because every particle belongs to exactly one occupied block
/// ([`Bins::order`] is a permutation) and each block is one task: no two
/// tasks ever reach the same particle.
pub(crate) struct ParticleArrays<'a> {
    pub(crate) position: *mut Vec3,
    pub(crate) velocity: *mut Vec3,
    pub(crate) elastic: *mut Mat3,
    pub(crate) plastic_j: *mut f32,
    pub(crate) stress: *mut Mat3,
    pub(crate) velocity_gradient: *mut Mat3,
    pub(crate) volume0: &'a [f32],
    pub(crate) material: &'a [u16],
    pub(crate) _particles: PhantomData<&'a mut Particles>,
}

// SAFETY: shared across the gather's tasks only, which touch disjoint
// particles (see the type's documentation).
unsafe impl Sync for ParticleArrays<'_> {}

impl<'a> ParticleArrays<'a> {
    pub(crate) fn new(particles: &'a mut Particles) -> ParticleArrays<'a> {
        ParticleArrays {
            position: particles.position.as_mut_ptr(),
            velocity: particles.velocity.as_mut_ptr(),
            elastic: particles.elastic.as_mut_ptr(),
            plastic_j: particles.plastic_j.as_mut_ptr(),
            stress: particles.stress.as_mut_ptr(),
            velocity_gradient: particles.velocity_gradient.as_mut_ptr(),
            volume0: &particles.volume0,
            material: &particles.material,
            _particles: PhantomData,
        }
    }

    /// Particle `p`'s mutable state.
    ///
    /// # Safety
    /// No other reference to particle `p` may exist while the result lives.
    #[inline(always)]
    pub(crate) unsafe fn state(&self, p: usize) -> ParticleState<'_> {
        assert!(p < self.volume0.len(), "particle {p} out of range");
        // SAFETY: in bounds (all arrays have the same length, checked by
        // `Particles`' users); exclusive by the caller's contract.
        unsafe {
            ParticleState {
                position: &mut *self.position.add(p),
                velocity: &mut *self.velocity.add(p),
                elastic: &mut *self.elastic.add(p),
                plastic_j: &mut *self.plastic_j.add(p),
                stress: &mut *self.stress.add(p),
                velocity_gradient: &mut *self.velocity_gradient.add(p),
            }
        }
    }
}

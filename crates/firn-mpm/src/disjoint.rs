//! Writing from several threads into one array where the binning proves
//! the writes disjoint: grid nodes during the scatter (same-coloured blocks
//! never share a node, [`crate::binning`]) and particles during the gather
//! (each particle belongs to exactly one block). These two types hold the
//! crate's raw pointers; everything else reaches them through their
//! methods and the colour-by-colour drivers below.

// Threads write disjoint nodes and particles through raw pointers.
#![allow(unsafe_code)]

use std::marker::PhantomData;
use std::ops::Range;

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

/// Runs `scatter` on every occupied block's particles, colour by colour;
/// blocks of one colour run in parallel, so each node sums its
/// contributions in the same order whatever the thread count.
pub(crate) fn scatter_by_colour<T: Send>(
    nodes: &mut [T],
    bins: &Bins,
    scatter: impl Fn(&[u32], &NodeWriter<T>) + Sync,
) {
    let writer = NodeWriter::new(nodes);
    for colour in bins.colours() {
        colour.par_iter().for_each(|&block| {
            scatter(bins.particles_of(&bins.occupied()[block as usize]), &writer)
        });
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

/// The per-particle matrices the gather moves in and out of SIMD lanes
/// eight at a time.
#[derive(Clone, Copy)]
pub(crate) enum ParticleMatrix {
    /// F_E.
    Elastic,
    /// V_p^0 τ_p.
    Stress,
    /// ∇v_p (C_p for APIC).
    VelocityGradient,
}

/// Runs `update` on every occupied block's particles in parallel and
/// merges the results with `merge` (which must not depend on the order).
/// Each call gets a [`BlockParticles`] with exclusive access to its
/// block's particles, and a scratch value made by `scratch` per task.
pub(crate) fn update_by_block<S, R: Send>(
    particles: &mut Particles,
    bins: &Bins,
    scratch: impl Fn() -> S + Sync + Send,
    update: impl Fn(&mut S, &OccupiedBlock, BlockParticles) -> R + Sync + Send,
    merge: impl Fn(R, R) -> R + Sync + Send,
    empty: impl Fn() -> R + Sync + Send,
) -> R {
    let arrays = ParticleArrays::new(particles);
    bins.occupied()
        .par_iter()
        .map_init(scratch, |scratch, block| {
            let particles = BlockParticles {
                arrays: &arrays,
                indices: bins.particles_of(block),
            };
            update(scratch, block, particles)
        })
        .reduce(empty, merge)
}

/// One occupied block's particles, with exclusive access to their mutable
/// state, addressed by their place `k` in the block (`0..len()`).
///
/// Made only by [`update_by_block`], one per block: every particle belongs
/// to exactly one block ([`Bins::order`] is a permutation, written only by
/// [`Bins::rebuild`]), so no two of them reach the same particle, and a
/// `&mut self` method's borrow keeps this one from reaching a particle twice.
pub(crate) struct BlockParticles<'a> {
    arrays: &'a ParticleArrays<'a>,
    indices: &'a [u32],
}

impl BlockParticles<'_> {
    /// How many particles the block holds.
    #[inline(always)]
    pub(crate) fn len(&self) -> usize {
        self.indices.len()
    }

    /// The index in the particle arrays of the block's `k`-th particle.
    #[inline(always)]
    pub(crate) fn index(&self, k: usize) -> usize {
        self.indices[k] as usize
    }

    /// V_p^0 of the `k`-th particle.
    #[inline(always)]
    pub(crate) fn volume0(&self, k: usize) -> f32 {
        self.arrays.volume0[self.index(k)]
    }

    /// The material index of the `k`-th particle.
    #[inline(always)]
    pub(crate) fn material(&self, k: usize) -> u16 {
        self.arrays.material[self.index(k)]
    }

    /// The `k`-th particle's mutable state.
    #[inline(always)]
    pub(crate) fn state(&mut self, k: usize) -> ParticleState<'_> {
        let p = self.arrays.checked(self.index(k));
        // SAFETY: in bounds (checked); the particle is this block's alone
        // (the type's documentation) and `&mut self` lets no other
        // reference into the block live meanwhile.
        unsafe {
            ParticleState {
                position: &mut *self.arrays.position.add(p),
                velocity: &mut *self.arrays.velocity.add(p),
                elastic: &mut *self.arrays.elastic.add(p),
                plastic_j: &mut *self.arrays.plastic_j.add(p),
                stress: &mut *self.arrays.stress.add(p),
                velocity_gradient: &mut *self.arrays.velocity_gradient.add(p),
            }
        }
    }

    /// `matrix` of the particles at places `ks` (a place may repeat).
    #[inline(always)]
    pub(crate) fn matrices(&self, matrix: ParticleMatrix, ks: [usize; 8]) -> [&Mat3; 8] {
        let base = self.arrays.matrix(matrix);
        std::array::from_fn(|lane| {
            let p = self.arrays.checked(self.index(ks[lane]));
            // SAFETY: in bounds (checked); this block's alone, and only
            // read while `&self` is borrowed, so nothing writes it.
            unsafe { &*base.add(p) }
        })
    }

    /// `matrix` of the particles at the places `ks`, mutably, one after
    /// another.
    #[inline(always)]
    pub(crate) fn matrices_mut(
        &mut self,
        matrix: ParticleMatrix,
        ks: Range<usize>,
    ) -> impl Iterator<Item = &mut Mat3> + '_ {
        let base = self.arrays.matrix(matrix);
        let arrays = self.arrays;
        self.indices[ks].iter().map(move |&p| {
            let p = arrays.checked(p as usize);
            // SAFETY: in bounds (checked); the block's places hold distinct
            // particles, this block's alone, and `&mut self` stays borrowed
            // while the references live.
            unsafe { &mut *base.add(p) }
        })
    }
}

/// The particle arrays as raw pointers, shared by the tasks of
/// [`update_by_block`], which reach them only through [`BlockParticles`].
struct ParticleArrays<'a> {
    position: *mut Vec3,
    velocity: *mut Vec3,
    elastic: *mut Mat3,
    plastic_j: *mut f32,
    stress: *mut Mat3,
    velocity_gradient: *mut Mat3,
    volume0: &'a [f32],
    material: &'a [u16],
    _particles: PhantomData<&'a mut Particles>,
}

// SAFETY: shared across the gather's tasks only, which touch disjoint
// particles (see `BlockParticles`).
unsafe impl Sync for ParticleArrays<'_> {}

impl<'a> ParticleArrays<'a> {
    fn new(particles: &'a mut Particles) -> ParticleArrays<'a> {
        let count = particles.len();
        assert!(
            [
                particles.velocity.len(),
                particles.elastic.len(),
                particles.plastic_j.len(),
                particles.stress.len(),
                particles.velocity_gradient.len(),
                particles.volume0.len(),
                particles.material.len(),
            ]
            .iter()
            .all(|&len| len == count),
            "the particle arrays differ in length"
        );
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

    /// `p`, after checking that it is a particle of the arrays.
    #[inline(always)]
    fn checked(&self, p: usize) -> usize {
        assert!(p < self.volume0.len(), "particle {p} out of range");
        p
    }

    /// The first element of the array of `matrix`.
    #[inline(always)]
    fn matrix(&self, matrix: ParticleMatrix) -> *mut Mat3 {
        match matrix {
            ParticleMatrix::Elastic => self.elastic,
            ParticleMatrix::Stress => self.stress,
            ParticleMatrix::VelocityGradient => self.velocity_gradient,
        }
    }
}

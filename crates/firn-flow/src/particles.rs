//! Flow particles, structure of arrays: one array per attribute, indexed by
//! particle. A particle's index is its id: particles are appended as they
//! are born and never reordered or removed; one that expires or leaves the
//! domain is born again in place, with its generation counted up.

use firn_core::scene::FlowEmitter;
use glam::Vec3;

use crate::emitters;

/// The state of all particles.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlowParticles {
    /// Positions, m.
    pub positions: Vec<Vec3>,
    /// Velocity of the last step: the step's displacement over Δt (for RK2 the
    /// midpoint velocity), plus what is left of the birth velocity.
    pub velocities: Vec<Vec3>,
    /// Seconds since the particle's current life began.
    pub ages: Vec<f32>,
    /// Length of the current life, s (infinite: forever).
    pub lifetimes: Vec<f32>,
    /// Lives lived before the current one (0 for the first).
    pub generations: Vec<u32>,
    /// Index of the emitter the particle belongs to.
    pub emitters: Vec<u32>,
}

impl FlowParticles {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Makes room for `additional` more particles in every array.
    pub fn reserve(&mut self, additional: usize) {
        self.positions.reserve(additional);
        self.velocities.reserve(additional);
        self.ages.reserve(additional);
        self.lifetimes.reserve(additional);
        self.generations.reserve(additional);
        self.emitters.reserve(additional);
    }

    /// Appends the first life of particle `id` of emitter `index` (scene
    /// seed `seed`), `age` seconds old: at its birth point, at rest (the
    /// caller sets its velocity), with its drawn lifetime.
    pub fn push_newborn(
        &mut self,
        emitter: &FlowEmitter,
        index: usize,
        seed: u64,
        id: u64,
        age: f32,
    ) {
        self.positions
            .push(emitters::birth_position(emitter, seed, id, 0));
        self.velocities.push(Vec3::ZERO);
        self.ages.push(age.max(0.0));
        self.lifetimes
            .push(emitters::lifetime(emitter, seed, id, 0));
        self.generations.push(0);
        self.emitters.push(index as u32);
    }

    /// Bytes per particle (without trails).
    pub fn bytes_per_particle() -> usize {
        2 * size_of::<Vec3>() + 2 * size_of::<f32>() + 2 * size_of::<u32>()
    }

    /// Whether all arrays have the same length.
    pub fn is_consistent(&self) -> bool {
        let n = self.positions.len();
        [
            self.velocities.len(),
            self.ages.len(),
            self.lifetimes.len(),
            self.generations.len(),
            self.emitters.len(),
        ]
        .iter()
        .all(|len| *len == n)
    }
}

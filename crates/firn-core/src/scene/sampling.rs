//! Filling bodies with particles.
//!
//! Each body is covered by a lattice of spacing `s = h / cbrt(particles_per_cell)`
//! anchored at the minimum corner of its bounding box. Every lattice cell gets
//! one candidate at a uniformly random point inside it (the cell centre plus a
//! jitter in `[-s/2, s/2)³`); candidates inside the shape and inside the domain
//! become particles. Each particle stands for one lattice cell of volume `s³`,
//! so its mass is `ρ0 s³`. A body packed in clumps ([`super::clumps`]) also
//! gives each particle an initial plastic volume ratio J_P⁰; the solver's
//! initial state packs it to the density ρ0 / J_P⁰ (mass `ρ0 s³ / J_P⁰`).
//!
//! The jitter comes from a PCG generator seeded from the scene seed and the
//! body index, and the lattice is visited in a fixed z, y, x order, so the same
//! scene always gives bit-identical particles. The inside tests of each
//! z-slice run in parallel; their order, and so the result, does not depend
//! on the thread count.

use std::ops::ControlFlow;

use glam::Vec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;

use super::model::{Body, Domain, Scene};

/// Initial particles, structure of arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParticleSeeds {
    /// Positions in metres.
    pub positions: Vec<Vec3>,
    /// Initial velocities in m/s.
    pub velocities: Vec<Vec3>,
    /// Masses in kg.
    pub masses: Vec<f32>,
    /// Initial plastic volume ratios J_P⁰ (1 unless the body has clumps).
    pub plastic_j: Vec<f32>,
    /// Index into [`Scene::materials`] of each particle.
    pub materials: Vec<u16>,
}

impl ParticleSeeds {
    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

/// Lattice spacing `s = h / cbrt(particles_per_cell)`: the edge of the cube
/// each particle stands for.
pub fn particle_spacing(cell_size: f32, particles_per_cell: u32) -> f32 {
    cell_size / (particles_per_cell.max(1) as f32).cbrt()
}

/// Seed of a body's jitter generator, from the scene seed and the body index.
pub fn body_seed(scene_seed: u64, body_index: usize) -> u64 {
    scene_seed ^ (body_index as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
}

/// Particles of one body of `scene`: positions and the mass of each particle.
///
/// # Panics
///
/// If `body_index` is out of range or the body's material index is not a
/// valid index into [`Scene::materials`] (a validated scene has neither).
pub fn sample_body(scene: &Scene, body_index: usize) -> (Vec<Vec3>, f32) {
    let body = &scene.bodies[body_index];
    let density = scene.materials[body.material].density;
    let spacing = particle_spacing(scene.domain.cell_size, body.particles_per_cell);
    let seed = body_seed(scene.solver.seed, body_index);
    let mut positions = Vec::new();
    visit_lattice(body, &scene.domain, spacing, seed, |position| {
        positions.push(position);
        ControlFlow::Continue(())
    });
    (positions, density * spacing.powi(3))
}

/// Particles of all bodies of a (validated) scene, concatenated in body order.
///
/// # Panics
///
/// If a body's material index is not a valid index into [`Scene::materials`].
pub fn sample_bodies(scene: &Scene) -> ParticleSeeds {
    let mut seeds = ParticleSeeds::default();
    for (index, body) in scene.bodies.iter().enumerate() {
        let (positions, mass) = sample_body(scene, index);
        let count = positions.len();
        seeds.positions.extend(positions);
        seeds
            .velocities
            .extend(std::iter::repeat_n(body.velocity, count));
        seeds.masses.extend(std::iter::repeat_n(mass, count));
        match body.clumps {
            Some(clumps) => {
                let seed = body_seed(scene.solver.seed, index);
                let new = &seeds.positions[seeds.positions.len() - count..];
                let packing = new.iter().map(|&x| clumps.plastic_j(seed, x));
                seeds.plastic_j.extend(packing);
            }
            None => seeds.plastic_j.extend(std::iter::repeat_n(1.0, count)),
        }
        let material = u16::try_from(body.material).expect("more than 65535 materials");
        seeds.materials.extend(std::iter::repeat_n(material, count));
    }
    seeds
}

/// Whether a body of `scene` gets at least one particle (stops at the first).
pub(crate) fn body_has_particles(scene: &Scene, body_index: usize) -> bool {
    let body = &scene.bodies[body_index];
    let spacing = particle_spacing(scene.domain.cell_size, body.particles_per_cell);
    let seed = body_seed(scene.solver.seed, body_index);
    let mut found = false;
    visit_lattice(body, &scene.domain, spacing, seed, |_| {
        found = true;
        ControlFlow::Break(())
    });
    found
}

/// How many lattice points (candidate particles) fill `body` of a scene
/// with grid spacing `cell_size`: the cells of the lattice that covers its
/// bounding box, counted without visiting them (saturating at `u64::MAX`).
pub fn lattice_points(body: &Body, cell_size: f32) -> u64 {
    let spacing = particle_spacing(cell_size, body.particles_per_cell);
    let (low, high) = body.shape.bounds();
    lattice_counts(low, high, spacing).map_or(0, |counts| {
        counts
            .iter()
            .fold(1u64, |product, &count| product.saturating_mul(count))
    })
}

/// Lattice cells per axis covering the box `low .. high` at `spacing` (at
/// least one per axis), or `None` for a box or spacing that is not finite.
fn lattice_counts(low: Vec3, high: Vec3, spacing: f32) -> Option<[u64; 3]> {
    if !(spacing > 0.0 && spacing.is_finite() && low.is_finite() && high.is_finite()) {
        return None;
    }
    Some(((high - low) / spacing).to_array().map(|n| {
        let n = (n - 1e-4).ceil().max(1.0);
        n as u64
    }))
}

/// Call `keep` with every jittered lattice point of `body` that lies inside
/// the body and the domain, in z, y, x order, until it breaks.
fn visit_lattice(
    body: &Body,
    domain: &Domain,
    spacing: f32,
    seed: u64,
    mut keep: impl FnMut(Vec3) -> ControlFlow<()>,
) {
    let (low, high) = body.shape.bounds();
    let Some(counts) = lattice_counts(low, high, spacing) else {
        return;
    };
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut candidates = Vec::with_capacity((counts[0] * counts[1]) as usize);
    for k in 0..counts[2] {
        candidates.clear();
        for j in 0..counts[1] {
            for i in 0..counts[0] {
                // Draw the jitter before testing, so every candidate consumes
                // the same numbers whatever happens to its neighbours.
                let jitter = Vec3::new(rng.random(), rng.random(), rng.random());
                let cell = Vec3::new(i as f32, j as f32, k as f32);
                candidates.push(low + (cell + jitter) * spacing);
            }
        }
        // Inside tests of one slice run in parallel (mesh winding numbers
        // are costly); the results keep the lattice order.
        let inside: Vec<bool> = candidates
            .par_iter()
            .with_min_len(256)
            .map(|&position| body.shape.contains(position) && domain.contains(position))
            .collect();
        for (&position, _) in candidates
            .iter()
            .zip(&inside)
            .filter(|(_, inside)| **inside)
        {
            if keep(position).is_break() {
                return;
            }
        }
    }
}

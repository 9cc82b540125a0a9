//! [`Snapshot`]: the whole state of a snow run, what every backend starts
//! from (its time-0 state, step 2 of thesis §3.4) and what a checkpoint
//! stores to continue bit for bit.

use firn_core::Scene;
use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::scene::Transfer;
use firn_core::scene::sampling::sample_bodies;
use glam::Mat3;

use crate::binning::Bins;
use crate::grid::Grid;
use crate::p2g;
use crate::particles::Particles;
use crate::simulation::SimulationError;
use crate::snow_model::{MaterialConstants, max_wave_speed_squared};
use crate::spindrift::{Drift, Escaped};

/// The full state needed to continue a run bit for bit.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Simulated time.
    pub time: f64,
    /// Substeps taken so far.
    pub steps: u64,
    /// Largest |v_p|² after the last substep (drives the next Δt).
    pub max_speed_squared: f32,
    /// Largest squared wave speed after the last substep.
    pub max_wave_speed_squared: f32,
    /// All particle attributes, in their current order.
    pub particles: Particles,
    /// Snow the wind carries (`[wind.spindrift]`), in its current order.
    pub drift: Drift,
    /// Drift the wind carried out of the domain.
    pub escaped: Escaped,
    /// The rigid bodies' whole state (firn-rigid's saved world), if the
    /// scene has any and they have moved; `None` starts them afresh.
    pub rigid: Option<Vec<u8>>,
}

impl Snapshot {
    /// The state at time 0: the scene's bodies filled with particles
    /// ([`sample_bodies`]) and their volumes estimated from the scattered
    /// mass (step 2), as every backend starts. The scene should have passed
    /// [`Scene::validate`].
    pub fn initial(scene: &Scene) -> Result<Snapshot, SimulationError> {
        let seeds = sample_bodies(scene);
        if seeds.positions.is_empty() {
            return Err(SimulationError::NoParticles);
        }
        let count = seeds.positions.len();
        let mut particles = Particles {
            position: seeds.positions,
            velocity: seeds.velocities,
            mass: seeds.masses,
            volume0: vec![0.0; count],
            elastic: vec![Mat3::IDENTITY; count],
            plastic_j: seeds.plastic_j,
            stress: vec![Mat3::ZERO; count],
            velocity_gradient: vec![Mat3::ZERO; count],
            material: seeds.materials,
        };
        estimate_volumes(scene, &mut particles);
        pack_initially(&mut particles);
        let materials = MaterialConstants::of_each(&scene.materials);
        let max_speed_squared = particles
            .velocity
            .iter()
            .map(|v| v.length_squared())
            .fold(0.0, f32::max);
        Ok(Snapshot {
            time: 0.0,
            steps: 0,
            max_speed_squared,
            max_wave_speed_squared: max_wave_speed_squared(
                &materials,
                &particles.material,
                &particles.plastic_j,
            ),
            particles,
            drift: Drift::default(),
            escaped: Escaped::default(),
            rigid: None,
        })
    }

    /// `Ok` when this snapshot can continue a simulation of `scene`: some
    /// particles, their arrays of one length, and every particle and drift
    /// particle of a material the scene has.
    pub fn check(&self, scene: &Scene) -> Result<(), SimulationError> {
        let mismatch = |what: &str| Err(SimulationError::SnapshotMismatch(what.into()));
        let particles = &self.particles;
        let count = particles.len();
        let lengths = [
            particles.velocity.len(),
            particles.mass.len(),
            particles.volume0.len(),
            particles.elastic.len(),
            particles.plastic_j.len(),
            particles.stress.len(),
            particles.velocity_gradient.len(),
            particles.material.len(),
        ];
        if count == 0 || lengths.iter().any(|&len| len != count) {
            return mismatch("particle arrays are empty or of different lengths");
        }
        let materials = scene.materials.len();
        if particles.material.iter().any(|&m| m as usize >= materials) {
            return mismatch("a particle refers to an unknown material");
        }
        let drift = &self.drift;
        if !drift.is_consistent() || drift.material.iter().any(|&m| m as usize >= materials) {
            return mismatch("the drift arrays differ in length or refer to an unknown material");
        }
        Ok(())
    }
}

/// Particles that start compacted or loosened (J_P⁰ ≠ 1, a body with
/// clumps, [`firn_core::scene::clumps`]): step 2 gave the volume V the
/// particle fills, which it keeps (J_P⁰ V_p⁰ = V); its mass becomes
/// m_p / J_P⁰, so its density m_p / (J_P V_p⁰) starts at the scattered
/// density over J_P⁰. Without clumps J_P⁰ = 1 and no bit changes.
fn pack_initially(particles: &mut Particles) {
    let packing = particles.plastic_j.iter();
    let state = particles.mass.iter_mut().zip(particles.volume0.iter_mut());
    for ((mass, volume), plastic_j) in state.zip(packing) {
        *mass /= plastic_j;
        *volume /= plastic_j;
    }
}

/// Step 2: scatter the mass once and read the density back at each particle.
fn estimate_volumes(scene: &Scene, particles: &mut Particles) {
    let domain = &scene.domain;
    let mut grid = Grid::new(domain.min, domain.max, domain.cell_size);
    let mut bins = Bins::default();
    bins.rebuild(&grid.layout, &particles.position);
    grid.allocate(bins.active_blocks());
    match scene.solver.transfer {
        Transfer::PicFlip => {
            p2g::scatter_mass(&mut grid, &bins, particles, cubic_weights);
            p2g::estimate_volumes(&grid, particles, cubic_weights);
        }
        Transfer::Apic => {
            p2g::scatter_mass(&mut grid, &bins, particles, quadratic_weights);
            p2g::estimate_volumes(&grid, particles, quadratic_weights);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::Simulation;
    use crate::view::tests::ball;

    #[test]
    fn snapshots_that_do_not_fit_the_scene_are_refused() {
        let scene = ball();
        let snapshot = Simulation::new(scene.clone()).unwrap().snapshot();
        assert!(snapshot.check(&scene).is_ok());
        let mut short = snapshot.clone();
        short.particles.mass.pop();
        let mut unknown = snapshot.clone();
        unknown.particles.material[0] = 1;
        let mut drift = snapshot;
        drift.drift.material.push(0);
        for refused in [short, unknown, drift] {
            let error = refused.check(&scene).unwrap_err().to_string();
            assert!(error.contains("the checkpoint does not match"), "{error}");
        }
    }
}

//! [`SnowView`]: a snow simulation's state borrowed, from a running
//! [`Simulation`] or from a [`Snapshot`] of its scene (a GPU's read back),
//! so that writers, renderers and checkpoints read both alike; and the
//! per-particle values pictures are coloured by.

use firn_core::scene::{ColorBy, Scene};
use glam::Mat3;

use crate::coupling::RigidBodies;
use crate::particles::Particles;
use crate::simulation::{Diagnostics, Simulation, Snapshot, diagnostics};
use crate::spindrift::{Drift, Escaped};

/// A snow simulation's state, borrowed, with its scene.
#[derive(Clone, Copy, Debug)]
pub struct SnowView<'a> {
    scene: &'a Scene,
    time: f64,
    steps: u64,
    max_speed_squared: f32,
    max_wave_speed_squared: f32,
    particles: &'a Particles,
    drift: &'a Drift,
    escaped: Escaped,
    rigid: Option<RigidView<'a>>,
}

/// The rigid bodies of a view: a running simulation's, or a snapshot's
/// saved world.
#[derive(Clone, Copy, Debug)]
enum RigidView<'a> {
    Live(&'a RigidBodies),
    Saved(&'a [u8]),
}

impl Simulation {
    /// The simulation's state, borrowed.
    pub fn view(&self) -> SnowView<'_> {
        let (max_speed_squared, max_wave_speed_squared) = self.motion_bounds();
        SnowView {
            scene: self.scene(),
            time: self.time(),
            steps: self.steps(),
            max_speed_squared,
            max_wave_speed_squared,
            particles: self.particles(),
            drift: self.drift(),
            escaped: self.escaped(),
            rigid: self.rigid_world().map(RigidView::Live),
        }
    }
}

impl Snapshot {
    /// This state of a simulation of `scene`, borrowed.
    pub fn view<'a>(&'a self, scene: &'a Scene) -> SnowView<'a> {
        SnowView {
            scene,
            time: self.time,
            steps: self.steps,
            max_speed_squared: self.max_speed_squared,
            max_wave_speed_squared: self.max_wave_speed_squared,
            particles: &self.particles,
            drift: &self.drift,
            escaped: self.escaped,
            rigid: self.rigid.as_deref().map(RigidView::Saved),
        }
    }
}

impl<'a> SnowView<'a> {
    /// The scene simulated.
    pub fn scene(self) -> &'a Scene {
        self.scene
    }

    /// Simulated time in seconds.
    pub fn time(self) -> f64 {
        self.time
    }

    /// Substeps taken.
    pub fn steps(self) -> u64 {
        self.steps
    }

    /// The largest |v_p|² and squared elastic wave speed after the last
    /// substep, as [`Simulation::motion_bounds`].
    pub fn motion_bounds(self) -> (f32, f32) {
        (self.max_speed_squared, self.max_wave_speed_squared)
    }

    /// The snow particles (without the drift).
    pub fn particles(self) -> &'a Particles {
        self.particles
    }

    /// The snow the wind carries (`[wind.spindrift]`; empty without).
    pub fn drift(self) -> &'a Drift {
        self.drift
    }

    /// The drift the wind carried out of the domain so far.
    pub fn escaped(self) -> Escaped {
        self.escaped
    }

    /// The rigid bodies' whole state as a checkpoint keeps it
    /// ([`Snapshot::rigid`]); `None` without bodies.
    pub fn rigid_bytes(self) -> Option<Vec<u8>> {
        match self.rigid? {
            RigidView::Live(bodies) => Some(bodies.to_bytes()),
            RigidView::Saved(bytes) => Some(bytes.to_vec()),
        }
    }

    /// Every rigid body's state, in scene order (none without bodies).
    pub fn rigid_bodies(self) -> Vec<firn_rigid::BodyState> {
        match self.rigid {
            None => Vec::new(),
            Some(RigidView::Live(bodies)) => bodies.states(),
            Some(RigidView::Saved(bytes)) => RigidBodies::from_bytes(self.scene, bytes)
                .map(|bodies| bodies.states())
                .unwrap_or_default(),
        }
    }

    /// Current density of every particle (kg/m³).
    pub fn densities(self) -> Vec<f32> {
        (0..self.particles.len())
            .map(|p| self.particles.density(p))
            .collect()
    }

    /// J_E = det F_E of every particle.
    pub fn elastic_j(self) -> Vec<f32> {
        self.particles
            .elastic
            .iter()
            .map(Mat3::determinant)
            .collect()
    }

    /// Mass, momentum, angular momentum, centre of mass and kinetic energy.
    pub fn diagnostics(self) -> Diagnostics {
        diagnostics(
            self.particles,
            self.scene.domain.cell_size,
            self.scene.solver.transfer,
        )
    }

    /// Per-particle values of `color_by` (none for colourings that need no
    /// values): density m_p / V_p, plastic J_P or speed |v_p|.
    pub fn color_values(self, color_by: ColorBy) -> Option<Vec<f32>> {
        let particles = self.particles;
        match color_by {
            ColorBy::Density => Some(self.densities()),
            ColorBy::PlasticJ => Some(particles.plastic_j.clone()),
            ColorBy::Speed => Some(particles.velocity.iter().map(|v| v.length()).collect()),
            ColorBy::Position | ColorBy::Uniform => None,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A ball of snow falling in a box of 10 cells, a few hundred particles.
    pub(crate) fn ball() -> Scene {
        Scene::from_toml_str(
            "format = 1\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.1\n[time]\n\
             duration = 1.0\n[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\n\
             radius = 0.2\nvelocity = [0.5, -1.0, 0.0]\n",
            "ball.toml",
        )
        .expect("the ball is a valid scene")
    }

    #[test]
    fn a_simulation_and_its_snapshot_read_alike() {
        let mut simulation = Simulation::new(ball()).unwrap();
        simulation.advance_to(0.01).unwrap();
        let snapshot = simulation.snapshot();
        let (live, saved) = (simulation.view(), snapshot.view(simulation.scene()));
        assert_eq!((saved.time(), saved.steps()), (live.time(), live.steps()));
        assert_eq!(saved.motion_bounds(), simulation.motion_bounds());
        assert_eq!(saved.particles(), simulation.particles());
        assert_eq!(saved.diagnostics(), simulation.diagnostics());
        assert_eq!(saved.densities(), simulation.densities());
        assert_eq!(saved.elastic_j(), simulation.elastic_j());
        for color_by in [ColorBy::Density, ColorBy::PlasticJ, ColorBy::Speed] {
            let values = saved.color_values(color_by).expect("a ramp quantity");
            assert_eq!(values.len(), simulation.particles().len());
            assert_eq!(Some(values), live.color_values(color_by));
        }
        assert_eq!(live.color_values(ColorBy::Density), Some(live.densities()));
        assert_eq!(saved.color_values(ColorBy::Uniform), None);
    }
}

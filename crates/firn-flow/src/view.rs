//! [`FlowView`]: a flow's state borrowed, from a running
//! [`FlowSimulation`] or from a [`FlowSnapshot`] of its scene (a GPU's
//! read back), so that writers and renderers read both alike.

use firn_core::scene::{FlowSettings, Scene};
use glam::Vec3;

use crate::field::FlowField;
use crate::simulation::{FlowError, FlowSimulation};
use crate::snapshot::FlowSnapshot;
use crate::trails::TrailsView;

/// A flow's state, borrowed, with its scene.
#[derive(Clone, Copy, Debug)]
pub struct FlowView<'a> {
    scene: &'a Scene,
    settings: &'a FlowSettings,
    substeps: u64,
    births: &'a [u64],
    positions: &'a [Vec3],
    velocities: &'a [Vec3],
    ages: &'a [f32],
    lifetimes: &'a [f32],
    generations: &'a [u32],
    emitters: &'a [u32],
    trails: Option<TrailsView<'a>>,
}

impl FlowSimulation {
    /// The flow's state, borrowed.
    pub fn view(&self) -> FlowView<'_> {
        let particles = self.particles();
        FlowView {
            scene: self.scene(),
            settings: self.settings(),
            substeps: self.substeps(),
            births: self.births(),
            positions: &particles.positions,
            velocities: &particles.velocities,
            ages: &particles.ages,
            lifetimes: &particles.lifetimes,
            generations: &particles.generations,
            emitters: &particles.emitters,
            trails: self.trails().map(|trails| trails.view()),
        }
    }
}

impl FlowSnapshot {
    /// This state of a flow of `scene`, borrowed; refused for a snow scene.
    /// The trails are those of [`FlowSnapshot::cover_trails`] when it was
    /// called (a GPU's read back is).
    pub fn view<'a>(&'a self, scene: &'a Scene) -> Result<FlowView<'a>, FlowError> {
        Ok(FlowView {
            scene,
            settings: scene.kind.flow().ok_or(FlowError::NotAFlowScene)?,
            substeps: self.substeps,
            births: &self.births,
            positions: &self.positions,
            velocities: &self.velocities,
            ages: &self.ages,
            lifetimes: &self.lifetimes,
            generations: &self.generations,
            emitters: &self.emitters,
            trails: self.trails(),
        })
    }
}

impl<'a> FlowView<'a> {
    /// The scene simulated.
    pub fn scene(self) -> &'a Scene {
        self.scene
    }

    /// Substeps taken since time 0.
    pub fn substeps(self) -> u64 {
        self.substeps
    }

    /// Simulated time in seconds, as [`FlowSimulation::time`].
    pub fn time(self) -> f64 {
        self.substeps as f64 / (self.scene.time.fps * f64::from(self.settings.substeps))
    }

    /// The velocity field of the flow's settings now.
    pub fn field(self) -> FlowField {
        FlowField::new(self.settings)
    }

    /// Number of particles born so far (all alive).
    pub fn len(self) -> usize {
        self.positions.len()
    }

    /// Whether no particle is born yet.
    pub fn is_empty(self) -> bool {
        self.positions.is_empty()
    }

    /// Particles born so far by each emitter.
    pub fn births(self) -> &'a [u64] {
        self.births
    }

    /// Particle positions, m.
    pub fn positions(self) -> &'a [Vec3] {
        self.positions
    }

    /// Particle velocities of the last substep, m/s.
    pub fn velocities(self) -> &'a [Vec3] {
        self.velocities
    }

    /// Seconds since each particle's current life began.
    pub fn ages(self) -> &'a [f32] {
        self.ages
    }

    /// Length of each particle's current life, s.
    pub fn lifetimes(self) -> &'a [f32] {
        self.lifetimes
    }

    /// Lives each particle lived before its current one.
    pub fn generations(self) -> &'a [u32] {
        self.generations
    }

    /// The emitter of each particle.
    pub fn emitters(self) -> &'a [u32] {
        self.emitters
    }

    /// The trails, if kept.
    pub fn trails(self) -> Option<TrailsView<'a>> {
        self.trails
    }

    /// A copy of the state, as [`FlowSimulation::snapshot`] takes it.
    pub fn snapshot(self) -> FlowSnapshot {
        let (capacity, head, points, lengths, generations) = match self.trails {
            Some(trails) => trails.raw(),
            None => (0, 0, &[][..], &[][..], &[][..]),
        };
        FlowSnapshot {
            substeps: self.substeps,
            births: self.births.to_vec(),
            positions: self.positions.to_vec(),
            velocities: self.velocities.to_vec(),
            ages: self.ages.to_vec(),
            lifetimes: self.lifetimes.to_vec(),
            generations: self.generations.to_vec(),
            emitters: self.emitters.to_vec(),
            trail_capacity: capacity as u32,
            trail_head: head as u32,
            trail_points: points.to_vec(),
            trail_lengths: lengths.to_vec(),
            trail_generations: generations.to_vec(),
        }
    }
}

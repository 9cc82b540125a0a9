//! [`FlowSnapshot`]: a flow's whole state as plain arrays. Every backend
//! starts from [`FlowSnapshot::initial`] and checks a snapshot it continues
//! from with [`FlowSnapshot::check`].

use firn_core::scene::{FlowSettings, RenderStyle, Scene};
use glam::Vec3;

use crate::emitters;
use crate::field::FlowField;
use crate::integrate::Simd;
use crate::particles::FlowParticles;
use crate::simulation::{FlowError, push_out_all, refresh_velocities};
use crate::trails::{Trails, TrailsView, cover_rings};

/// The full state needed to continue a flow bit for bit: plain arrays, so a
/// caller can store them (e.g. in a `firn_io::Checkpoint`, one array each).
#[derive(Clone, Debug, PartialEq)]
pub struct FlowSnapshot {
    /// Substeps taken since time 0.
    pub substeps: u64,
    /// Particles born so far by each emitter.
    pub births: Vec<u64>,
    /// Particle positions.
    pub positions: Vec<Vec3>,
    /// Particle velocities.
    pub velocities: Vec<Vec3>,
    /// Ages in the current life.
    pub ages: Vec<f32>,
    /// Lengths of the current lives.
    pub lifetimes: Vec<f32>,
    /// Generations.
    pub generations: Vec<u32>,
    /// Emitter of each particle.
    pub emitters: Vec<u32>,
    /// Positions kept per trail (0: trails off).
    pub trail_capacity: u32,
    /// Ring slot of the newest trail position.
    pub trail_head: u32,
    /// Trail rings, particle-major, `trail_capacity` each.
    pub trail_points: Vec<Vec3>,
    /// Valid positions per trail.
    pub trail_lengths: Vec<u32>,
    /// Generation of each particle when its trail last recorded.
    pub trail_generations: Vec<u32>,
}

impl FlowSnapshot {
    /// The state at time 0, as every backend starts: the scene checked, the
    /// particles of every `count` emitter and the first of each `rate`
    /// emitter, pushed out of the obstacles with their velocities in the
    /// field, and, if the scene renders trails, their first trail point.
    pub fn initial(scene: &Scene) -> Result<FlowSnapshot, FlowError> {
        let settings = checked_settings(scene)?;
        let slots = run_slots(scene, settings);
        let mut births = vec![0; settings.emitters.len()];
        let mut particles = FlowParticles::default();
        for (index, emitter) in settings.emitters.iter().enumerate() {
            let count = emitters::births_by(emitter, slots[index], 0.0);
            births[index] = count;
            particles.reserve(count as usize);
            for k in 0..count {
                let id = particles.len() as u64;
                let age = 0.0 - emitters::birth_time(emitter, k) as f32;
                particles.push_newborn(emitter, index, settings.seed, id, age);
            }
        }
        push_out_all(settings, &mut particles.positions);
        let field = FlowField::new(settings);
        refresh_velocities(Simd::detect(), &field, settings, 0.0, &mut particles);
        let trails = scene.render.styles.contains(&RenderStyle::Trails).then(|| {
            let mut trails = Trails::new(scene.render.trail_length as usize);
            trails.record(&particles.positions, &particles.generations);
            trails
        });
        Ok(FlowSnapshot::from_parts(0, births, particles, trails))
    }

    /// The snapshot of a flow after `substeps` substeps, whose emitters
    /// have made `births` particles, `particles`, with `trails` if it keeps
    /// them.
    pub(crate) fn from_parts(
        substeps: u64,
        births: Vec<u64>,
        particles: FlowParticles,
        trails: Option<Trails>,
    ) -> FlowSnapshot {
        let (capacity, head, trail_points, trail_lengths, trail_generations) = match trails {
            Some(trails) => trails.into_raw(),
            None => (0, 0, Vec::new(), Vec::new(), Vec::new()),
        };
        FlowSnapshot {
            substeps,
            births,
            positions: particles.positions,
            velocities: particles.velocities,
            ages: particles.ages,
            lifetimes: particles.lifetimes,
            generations: particles.generations,
            emitters: particles.emitters,
            trail_capacity: capacity as u32,
            trail_head: head as u32,
            trail_points,
            trail_lengths,
            trail_generations,
        }
    }

    /// `Ok` when this snapshot can continue a flow of `scene` (a valid flow
    /// scene): as many emitters, particle arrays of one length, as many
    /// particles as the emitters made, each of an emitter the scene has,
    /// and trail arrays that fit together.
    pub fn check(&self, scene: &Scene) -> Result<(), FlowError> {
        let settings = checked_settings(scene)?;
        let mismatch = |what: String| Err(FlowError::SnapshotMismatch(what));
        let emitter_count = settings.emitters.len();
        if self.births.len() != emitter_count {
            return mismatch(format!(
                "it has {} emitters, the scene {emitter_count}",
                self.births.len(),
            ));
        }
        let count = self.positions.len();
        let lengths = [
            self.velocities.len(),
            self.ages.len(),
            self.lifetimes.len(),
            self.generations.len(),
            self.emitters.len(),
        ];
        if lengths.iter().any(|len| *len != count) {
            return mismatch("its particle arrays differ in length".into());
        }
        let expected: u64 = self.births.iter().sum();
        if expected != count as u64 {
            return mismatch(format!(
                "it has {count} particles but its emitters made {expected}"
            ));
        }
        if self.emitters.iter().any(|e| *e as usize >= emitter_count) {
            return mismatch("a particle names an emitter the scene lacks".into());
        }
        if self.trail_capacity > 0 && self.trails().is_none() {
            return mismatch("its trail arrays do not fit together".into());
        }
        Ok(())
    }

    /// Gives every particle a trail ring, as a flow has after every substep
    /// (particles born since the trails last recorded have an empty one);
    /// nothing to do without trails.
    pub fn cover_trails(&mut self) {
        if self.trail_capacity > 0 {
            cover_rings(
                self.trail_capacity as usize,
                self.positions.len(),
                &mut self.trail_points,
                &mut self.trail_lengths,
                &mut self.trail_generations,
            );
        }
    }

    /// The trails, borrowed, if the snapshot keeps them and their arrays
    /// fit together.
    pub(crate) fn trails(&self) -> Option<TrailsView<'_>> {
        TrailsView::from_raw(
            self.trail_capacity as usize,
            self.trail_head as usize,
            &self.trail_points,
            &self.trail_lengths,
            &self.trail_generations,
        )
    }
}

/// The flow settings of `scene`, once the scene is a valid flow scene.
fn checked_settings(scene: &Scene) -> Result<&FlowSettings, FlowError> {
    let settings = scene.kind.flow().ok_or(FlowError::NotAFlowScene)?;
    scene
        .validate()
        .map_err(|error| FlowError::Scene(Box::new(error)))?;
    Ok(settings)
}

/// The particle slots of each emitter of `settings` over the whole run of
/// `scene`.
pub(crate) fn run_slots(scene: &Scene, settings: &FlowSettings) -> Vec<u64> {
    settings
        .emitters
        .iter()
        .map(|emitter| emitter.slots(scene.time.duration))
        .collect()
}

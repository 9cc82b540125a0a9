//! The time loop of a flow: one [`FlowSimulation`] owns the field, the
//! particles and their trails, and advances them substep by substep.
//!
//! Each frame (1 / fps seconds of the scene's `[time]`) is `flow.substeps`
//! equal substeps. A substep:
//!
//! 1. moves every particle through the field with RK2 or RK4
//!    ([`crate::integrate`]), in parallel over fixed chunks of particles;
//! 2. adds the fading birth velocity of its emitter, if any, as its exact
//!    displacement over the substep;
//! 3. ages it; a particle whose life is over, or that left the domain, is born
//!    again at its emitter (generation + 1; its age counts from the moment
//!    its last life ended, so lives keep their lengths);
//! 4. pushes particles that entered a sphere obstacle out to its surface (the
//!    flow never enters a sphere, but a finite step can cut a corner);
//! 5. appends the particles that `rate` emitters make during the substep, in
//!    emitter order, placed at their birth point at the end of the substep
//!    with the age they have by then.
//!
//! At the end of a frame every particle records its position in its trail.
//! All random numbers are keyed by (seed, particle id, generation) and chunks
//! are fixed, so the same scene gives the same bits on any thread count.

mod error;
mod live;
mod parts;
mod state;

pub use error::FlowError;
pub use live::scene_with_settings;

use firn_core::scene::{FlowEmission, FlowSettings, Scene};
use glam::Vec3;
use rayon::prelude::*;

use crate::emitters;
use crate::field::{FlowField, Prepared};
use crate::integrate::{self, Chunk, Limits, MAX_LANES, Simd, Stages};
use crate::lanes::F32s;
use crate::particles::FlowParticles;
use crate::parts::FlowPart;
use crate::snapshot::{FlowSnapshot, run_slots};
use crate::trails::Trails;

/// Particles per parallel task (a multiple of the SIMD batch), and the unit
/// of a [`FlowPart`].
pub(crate) const CHUNK: usize = 64 * MAX_LANES;

/// How far outside a sphere a particle is put when pushed out, relative to
/// the radius (so that `f32` rounding cannot leave it inside).
const PUSH_OUT_MARGIN: f32 = 1e-5;

/// A running curl-noise particle flow on the CPU (seed 002).
#[derive(Clone, Debug)]
pub struct FlowSimulation {
    scene: Scene,
    settings: FlowSettings,
    field: FlowField,
    particles: FlowParticles,
    trails: Option<Trails>,
    /// Particle slots of each emitter over the whole run.
    slots: Vec<u64>,
    /// Particles born so far by each emitter.
    births: Vec<u64>,
    substeps: u64,
    simd: Simd,
}

impl FlowSimulation {
    /// Checks the scene, makes the particles of time 0 (every `count`
    /// emitter's, and the first of each `rate` emitter) and, if the scene
    /// renders trails, their first trail point ([`FlowSnapshot::initial`]).
    pub fn new(scene: Scene) -> Result<FlowSimulation, FlowError> {
        let initial = FlowSnapshot::initial(&scene)?;
        Ok(FlowSimulation::from_checked(scene, initial))
    }

    /// Continues from a snapshot taken by [`FlowSimulation::snapshot`] of the
    /// same scene, once [`FlowSnapshot::check`] accepts it.
    pub fn from_snapshot(
        scene: Scene,
        snapshot: FlowSnapshot,
    ) -> Result<FlowSimulation, FlowError> {
        snapshot.check(&scene)?;
        Ok(FlowSimulation::from_checked(scene, snapshot))
    }

    /// The flow of `scene` from `snapshot`, which fits it (checked by
    /// [`FlowSnapshot::check`], or made by [`FlowSnapshot::initial`]).
    fn from_checked(scene: Scene, snapshot: FlowSnapshot) -> FlowSimulation {
        let settings = scene.kind.flow().expect("checked: a flow scene").clone();
        let particles = FlowParticles {
            positions: snapshot.positions,
            velocities: snapshot.velocities,
            ages: snapshot.ages,
            lifetimes: snapshot.lifetimes,
            generations: snapshot.generations,
            emitters: snapshot.emitters,
        };
        let trails = (snapshot.trail_capacity > 0).then(|| {
            let mut trails = Trails::from_raw(
                snapshot.trail_capacity as usize,
                snapshot.trail_head as usize,
                snapshot.trail_points,
                snapshot.trail_lengths,
                snapshot.trail_generations,
            )
            .expect("checked: the trail arrays fit together");
            // As after every substep: a ring for every particle.
            trails.cover(particles.len());
            trails
        });
        FlowSimulation {
            field: FlowField::new(&settings),
            slots: run_slots(&scene, &settings),
            births: snapshot.births,
            substeps: snapshot.substeps,
            settings,
            scene,
            particles,
            trails,
            simd: Simd::detect(),
        }
    }

    /// Keep the last `length` positions of every particle from now on (the
    /// current positions are the first).
    pub fn enable_trails(&mut self, length: usize) {
        let mut trails = Trails::new(length);
        trails.record(&self.particles.positions, &self.particles.generations);
        self.trails = Some(trails);
    }

    /// Stop keeping trails and free their memory.
    pub fn disable_trails(&mut self) {
        self.trails = None;
    }

    /// Use another code path than the one detected for this CPU, if the CPU
    /// can run it (all give the same bits; for tests and benchmarks).
    pub fn set_simd(&mut self, simd: Simd) {
        if simd.is_available() {
            self.simd = simd;
        }
    }

    /// The code path in use.
    pub fn simd(&self) -> Simd {
        self.simd
    }

    /// Δt of one substep: 1 / (fps × substeps).
    pub fn dt(&self) -> f64 {
        1.0 / self.steps_per_second()
    }

    fn steps_per_second(&self) -> f64 {
        self.scene.time.fps * f64::from(self.settings.substeps)
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.substeps as f64 / self.steps_per_second()
    }

    /// Substeps taken since time 0.
    pub fn substeps(&self) -> u64 {
        self.substeps
    }

    /// The frame the simulation is at (rounded down between frames).
    pub fn frame(&self) -> u64 {
        self.substeps / u64::from(self.settings.substeps)
    }

    /// Advance one substep.
    pub fn step(&mut self) {
        self.step_part(FlowPart::WHOLE);
    }

    /// Advance one substep, moving only `part`'s particles (another process
    /// moves the rest; see [`crate::parts`]). Every part makes the particles
    /// the emitters add and records every trail, so the copies stay the
    /// same size; the other parts' particles keep their state.
    pub fn step_part(&mut self, part: FlowPart) {
        let t0 = self.time();
        let t1 = (self.substeps + 1) as f64 / self.steps_per_second();
        let dt32 = (t1 - t0) as f32;
        let stages = Stages::new(self.simd, &self.field, t0, t1);
        let end = self.field.prepare::<F32s<1>>(t1);
        let integrator = self.settings.integrator;
        let FlowParticles {
            positions,
            velocities,
            ages,
            lifetimes,
            generations,
            emitters: emitter_of,
        } = &mut self.particles;
        let kicks = self
            .settings
            .emitters
            .iter()
            .any(|emitter| emitter.velocity != Vec3::ZERO);
        let limits = Limits {
            min: self.scene.domain.min,
            max: self.scene.domain.max,
            obstacles: &self.settings.obstacles,
            flag_all: kicks,
        };
        let context = StepContext {
            settings: &self.settings,
            domain: (self.scene.domain.min, self.scene.domain.max),
            emitter_of,
            end: &end,
            dt: dt32,
            kicks,
        };
        positions
            .par_chunks_mut(CHUNK)
            .zip(velocities.par_chunks_mut(CHUNK))
            .zip(ages.par_chunks_mut(CHUNK))
            .zip(lifetimes.par_chunks_mut(CHUNK))
            .zip(generations.par_chunks_mut(CHUNK))
            .enumerate()
            .filter(|(chunk_index, _)| part.holds_chunk(*chunk_index))
            .for_each(
                |(chunk_index, ((((positions, velocities), ages), lifetimes), generations))| {
                    let mut flagged = Vec::new();
                    let chunk = Chunk {
                        positions,
                        velocities,
                        ages,
                        lifetimes,
                    };
                    integrate::advance(&stages, integrator, dt32, &limits, chunk, &mut flagged);
                    context.finish(
                        chunk_index * CHUNK,
                        &flagged,
                        positions,
                        velocities,
                        ages,
                        lifetimes,
                        generations,
                    );
                },
            );
        self.substeps += 1;
        self.emit(t1, &end);
        if let Some(trails) = &mut self.trails {
            // Every particle has a ring, so that every part's state holds
            // its particles' rings.
            trails.cover(self.particles.len());
        }
        if self
            .substeps
            .is_multiple_of(u64::from(self.settings.substeps))
            && let Some(trails) = &mut self.trails
        {
            trails.record(&self.particles.positions, &self.particles.generations);
        }
    }

    /// Advance to the next frame; returns the substeps taken.
    pub fn advance_frame(&mut self) -> u32 {
        let per_frame = u64::from(self.settings.substeps);
        let mut taken = 0;
        loop {
            self.step();
            taken += 1;
            if self.substeps.is_multiple_of(per_frame) {
                return taken;
            }
        }
    }

    /// Advance by whole substeps up to time `until` (the last substep that
    /// does not end after it); returns the substeps taken.
    pub fn advance_to(&mut self, until: f64) -> u32 {
        self.advance_part_to(FlowPart::WHOLE, until)
    }

    /// Make the particles that `rate` emitters have born by time `t`.
    fn emit(&mut self, t: f64, end: &Prepared<F32s<1>>) {
        let start = self.particles.len();
        for index in 0..self.settings.emitters.len() {
            let emitter = self.settings.emitters[index];
            if !matches!(emitter.emission, FlowEmission::Rate(_)) {
                continue;
            }
            let target = emitters::births_by(&emitter, self.slots[index], t);
            let first = self.births[index];
            if target <= first {
                continue;
            }
            self.particles.reserve((target - first) as usize);
            for k in first..target {
                let age = (t - emitters::birth_time(&emitter, k)).max(0.0) as f32;
                self.push_newborn(index, age);
            }
            self.births[index] = target;
        }
        if self.particles.len() > start {
            let settings = &self.settings;
            let particles = &mut self.particles;
            for p in start..particles.len() {
                particles.positions[p] = push_out(settings, particles.positions[p]);
                let emitter = &settings.emitters[particles.emitters[p] as usize];
                particles.velocities[p] = velocity_at(end, particles.positions[p])
                    + emitters::kick_velocity(emitter, particles.ages[p]);
            }
        }
    }

    /// Append the first life of a new particle of emitter `index`.
    fn push_newborn(&mut self, index: usize, age: f32) {
        let id = self.particles.len() as u64;
        self.particles.push_newborn(
            &self.settings.emitters[index],
            index,
            self.settings.seed,
            id,
            age,
        );
    }
}

/// The seed's colour of a point (§2.3): |x − c| / (half extent) per axis,
/// clamped to [0, 1], with c the centre of the box `min..max`.
pub fn position_color(min: Vec3, max: Vec3, x: Vec3) -> [f32; 3] {
    let center = 0.5 * (min + max);
    let half = (0.5 * (max - min)).max(Vec3::splat(f32::MIN_POSITIVE));
    ((x - center).abs() / half)
        .clamp(Vec3::ZERO, Vec3::ONE)
        .to_array()
}

/// Moves every point of `positions` inside an obstacle of `settings` out
/// of it.
pub(crate) fn push_out_all(settings: &FlowSettings, positions: &mut [Vec3]) {
    positions.par_iter_mut().for_each(|x| {
        *x = push_out(settings, *x);
    });
}

/// Sets the velocities of all `particles` to the field's at `time`, plus
/// what is left of their emitters' birth velocities.
pub(crate) fn refresh_velocities(
    simd: Simd,
    field: &FlowField,
    settings: &FlowSettings,
    time: f64,
    particles: &mut FlowParticles,
) {
    particles
        .positions
        .par_chunks(CHUNK)
        .zip(particles.velocities.par_chunks_mut(CHUNK))
        .zip(particles.ages.par_chunks(CHUNK))
        .zip(particles.emitters.par_chunks(CHUNK))
        .for_each(|(((positions, velocities), ages), owners)| {
            integrate::evaluate(simd, field, time, positions, velocities);
            for ((velocity, age), owner) in velocities.iter_mut().zip(ages).zip(owners) {
                let emitter = &settings.emitters[*owner as usize];
                *velocity += emitters::kick_velocity(emitter, *age);
            }
        });
}

/// The velocity at one point from the scalar prepared field.
fn velocity_at(prepared: &Prepared<F32s<1>>, x: Vec3) -> Vec3 {
    let v = crate::field::velocity_lanes(prepared, [F32s([x.x]), F32s([x.y]), F32s([x.z])]);
    Vec3::new(v[0].0[0], v[1].0[0], v[2].0[0])
}

/// Move a point inside a sphere obstacle to just outside its surface, along
/// the ray from the centre.
fn push_out(settings: &FlowSettings, mut x: Vec3) -> Vec3 {
    for obstacle in &settings.obstacles {
        let rel = x - obstacle.center;
        let distance_squared = rel.length_squared();
        if distance_squared < obstacle.radius * obstacle.radius {
            let distance = distance_squared.sqrt();
            let normal = if distance > 0.0 {
                rel / distance
            } else {
                Vec3::Y
            };
            x = obstacle.center + normal * (obstacle.radius * (1.0 + PUSH_OUT_MARGIN));
        }
    }
    x
}

/// What the per-particle part of a substep needs.
struct StepContext<'a> {
    settings: &'a FlowSettings,
    domain: (Vec3, Vec3),
    emitter_of: &'a [u32],
    /// The field at the end of the substep, for particles born again.
    end: &'a Prepared<F32s<1>>,
    dt: f32,
    /// Whether any emitter has a birth velocity.
    kicks: bool,
}

impl StepContext<'_> {
    /// Steps 2-4 of a substep for the particles of a chunk starting at
    /// `first`, after the flow moved them; only the `flagged` ones (indices
    /// into the chunk) can need more than aging.
    #[allow(clippy::too_many_arguments)]
    fn finish(
        &self,
        first: usize,
        flagged: &[u32],
        positions: &mut [Vec3],
        velocities: &mut [Vec3],
        ages: &mut [f32],
        lifetimes: &mut [f32],
        generations: &mut [u32],
    ) {
        if self.kicks {
            for &i in flagged {
                let i = i as usize;
                let emitter = &self.settings.emitters[self.emitter_of[first + i] as usize];
                positions[i] += emitters::kick(emitter, ages[i], self.dt);
                velocities[i] += emitters::kick_velocity(emitter, ages[i] + self.dt);
            }
        }
        for age in ages.iter_mut() {
            *age += self.dt;
        }
        let (min, max) = self.domain;
        for &i in flagged {
            let i = i as usize;
            let x = positions[i];
            let outside = !(x.cmpge(min).all() && x.cmple(max).all());
            let expired = ages[i] >= lifetimes[i];
            if outside || expired {
                self.rebirth(
                    first + i,
                    outside,
                    &mut positions[i],
                    &mut velocities[i],
                    &mut ages[i],
                    &mut lifetimes[i],
                    &mut generations[i],
                );
            } else {
                positions[i] = push_out(self.settings, x);
            }
        }
    }

    /// A new life for particle `id` at its emitter, after it expired or left
    /// the domain.
    #[allow(clippy::too_many_arguments)]
    fn rebirth(
        &self,
        id: usize,
        outside: bool,
        position: &mut Vec3,
        velocity: &mut Vec3,
        age: &mut f32,
        lifetime: &mut f32,
        generation: &mut u32,
    ) {
        let emitter = &self.settings.emitters[self.emitter_of[id] as usize];
        let seed = self.settings.seed;
        let overshoot = if outside { 0.0 } else { *age - *lifetime };
        *generation += 1;
        let life = u64::from(*generation);
        *lifetime = emitters::lifetime(emitter, seed, id as u64, life);
        *age = overshoot.min(*lifetime);
        *position = push_out(
            self.settings,
            emitters::birth_position(emitter, seed, id as u64, life),
        );
        *velocity = velocity_at(self.end, *position) + emitters::kick_velocity(emitter, *age);
    }
}

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

use std::fmt;

use firn_core::scene::{FlowEmission, FlowSettings, Scene, SceneError, SceneKind};
use glam::Vec3;
use rayon::prelude::*;

use crate::emitters;
use crate::field::{FlowField, Prepared};
use crate::integrate::{self, Chunk, Limits, MAX_LANES, Simd, Stages};
use crate::lanes::F32s;
use crate::particles::FlowParticles;
use crate::parts::{FlowPart, FlowPartState};
use crate::snapshot::{FlowSnapshot, run_slots};
use crate::trails::Trails;

/// Particles per parallel task (a multiple of the SIMD batch), and the unit
/// of a [`FlowPart`].
pub(crate) const CHUNK: usize = 64 * MAX_LANES;

/// How far outside a sphere a particle is put when pushed out, relative to
/// the radius (so that `f32` rounding cannot leave it inside).
const PUSH_OUT_MARGIN: f32 = 1e-5;

/// Why a flow could not start or be restored.
#[derive(Debug, Clone, PartialEq)]
pub enum FlowError {
    /// The scene is a snow scene.
    NotAFlowScene,
    /// The scene breaks a rule of the format.
    Scene(Box<SceneError>),
    /// A snapshot does not fit the scene it is restored into.
    SnapshotMismatch(String),
}

impl fmt::Display for FlowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FlowError::NotAFlowScene => f.write_str(
                "the scene is a snow scene; a curl-noise flow needs kind = \"flow\" and a [flow] \
                 table",
            ),
            FlowError::Scene(error) => write!(f, "{error}"),
            FlowError::SnapshotMismatch(what) => {
                write!(f, "the checkpoint does not match the scene: {what}")
            }
        }
    }
}

impl std::error::Error for FlowError {}

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

    /// Replaces the field's parameters while the flow runs (an interactive
    /// viewer's parameter panel), from the next substep on: γ, M, L, the
    /// background flow, the speed scale, the evolution rate, the curl, the
    /// integrator, the seed and the obstacles. Checked as a scene is
    /// ([`scene_with_settings`]); the emitters and substeps cannot change.
    /// The particles keep their state, except that those inside a (new or
    /// grown) sphere are pushed out of it and every velocity is taken from
    /// the new field, as at the start of a run.
    pub fn set_settings(&mut self, settings: FlowSettings) -> Result<(), FlowError> {
        let scene = scene_with_settings(&self.scene, settings)?;
        let settings = scene.kind.flow().ok_or(FlowError::NotAFlowScene)?;
        self.field = FlowField::new(settings);
        self.settings = settings.clone();
        self.scene = scene;
        push_out_all(&self.settings, &mut self.particles.positions);
        let time = self.time();
        refresh_velocities(
            self.simd,
            &self.field,
            &self.settings,
            time,
            &mut self.particles,
        );
        Ok(())
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

    /// [`FlowSimulation::advance_to`], moving only `part`'s particles
    /// ([`FlowSimulation::step_part`]).
    pub fn advance_part_to(&mut self, part: FlowPart, until: f64) -> u32 {
        let mut taken = 0;
        let tolerance = 1e-6 * self.dt();
        while (self.substeps + 1) as f64 / self.steps_per_second() <= until + tolerance {
            self.step_part(part);
            taken += 1;
        }
        taken
    }

    /// The state of `part`'s particles, borrowed, one run of consecutive
    /// particles at a time, in index order.
    pub fn part_rows(&self, part: FlowPart) -> impl Iterator<Item = FlowPartState<'_>> {
        let particles = &self.particles;
        part.ranges(particles.len()).map(move |range| {
            let (trail_points, trail_lengths, trail_generations) = match &self.trails {
                Some(trails) => trails.rows(range.clone()),
                None => (&[][..], &[][..], &[][..]),
            };
            FlowPartState {
                positions: &particles.positions[range.clone()],
                velocities: &particles.velocities[range.clone()],
                ages: &particles.ages[range.clone()],
                lifetimes: &particles.lifetimes[range.clone()],
                generations: &particles.generations[range],
                trail_points,
                trail_lengths,
                trail_generations,
            }
        })
    }

    /// Puts `state`, all of `part`'s particles (its
    /// [`FlowSimulation::part_rows`] one after the other) taken from a copy
    /// of this flow at the same substep, in place of `part`'s particles.
    pub fn set_part_state(
        &mut self,
        part: FlowPart,
        state: &FlowPartState<'_>,
    ) -> Result<(), FlowError> {
        let count = part.count(self.particles.len());
        let trail_capacity = self.trails.as_ref().map_or(0, Trails::capacity);
        let trail_rows = if self.trails.is_some() { count } else { 0 };
        let fits = state.positions.len() == count
            && state.velocities.len() == count
            && state.ages.len() == count
            && state.lifetimes.len() == count
            && state.generations.len() == count
            && state.trail_points.len() == trail_rows * trail_capacity
            && state.trail_lengths.len() == trail_rows
            && state.trail_generations.len() == trail_rows;
        if !fits {
            return Err(FlowError::SnapshotMismatch(format!(
                "a part of {} particles where this flow's part holds {count}",
                state.positions.len()
            )));
        }
        let mut start = 0;
        let particles = &mut self.particles;
        for range in part.ranges(particles.len()) {
            let from = start..start + range.len();
            particles.positions[range.clone()].copy_from_slice(&state.positions[from.clone()]);
            particles.velocities[range.clone()].copy_from_slice(&state.velocities[from.clone()]);
            particles.ages[range.clone()].copy_from_slice(&state.ages[from.clone()]);
            particles.lifetimes[range.clone()].copy_from_slice(&state.lifetimes[from.clone()]);
            particles.generations[range.clone()].copy_from_slice(&state.generations[from.clone()]);
            if let Some(trails) = &mut self.trails {
                trails.set_rows(
                    range.start,
                    &state.trail_points[from.start * trail_capacity..from.end * trail_capacity],
                    &state.trail_lengths[from.clone()],
                    &state.trail_generations[from.clone()],
                );
            }
            start = from.end;
        }
        Ok(())
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

    /// Everything needed to continue this run bit for bit.
    pub fn snapshot(&self) -> FlowSnapshot {
        self.view().snapshot()
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The flow settings of the scene.
    pub fn settings(&self) -> &FlowSettings {
        &self.settings
    }

    /// The velocity field (for probing, tests and a future GPU port).
    pub fn field(&self) -> &FlowField {
        &self.field
    }

    /// All particle arrays.
    pub fn particles(&self) -> &FlowParticles {
        &self.particles
    }

    /// Number of particles born so far (all alive: a particle whose life ends
    /// is born again at once).
    pub fn len(&self) -> usize {
        self.particles.len()
    }

    /// Whether no particle is born yet.
    pub fn is_empty(&self) -> bool {
        self.particles.is_empty()
    }

    /// Particle positions, m.
    pub fn positions(&self) -> &[Vec3] {
        &self.particles.positions
    }

    /// Particle velocities of the last substep, m/s.
    pub fn velocities(&self) -> &[Vec3] {
        &self.particles.velocities
    }

    /// Seconds since each particle's current life began.
    pub fn ages(&self) -> &[f32] {
        &self.particles.ages
    }

    /// Length of each particle's current life, s (infinite: forever).
    pub fn lifetimes(&self) -> &[f32] {
        &self.particles.lifetimes
    }

    /// Lives each particle lived before its current one.
    pub fn generations(&self) -> &[u32] {
        &self.particles.generations
    }

    /// Particle ids: a particle's id is its index, stable for the whole run
    /// (particles are appended as they are born and never reordered).
    pub fn ids(&self) -> std::ops::Range<u32> {
        0..self.particles.len() as u32
    }

    /// Particles born so far by each emitter (a checkpoint keeps them).
    pub fn births(&self) -> &[u64] {
        &self.births
    }

    /// The trails, if kept.
    pub fn trails(&self) -> Option<&Trails> {
        self.trails.as_ref()
    }

    /// The seed's colouring (§2.3): |x|, |y|, |z| about the centre of the
    /// domain, each divided by the half extent, as red, green, blue in [0, 1].
    pub fn colors_by_position(&self) -> Vec<[f32; 3]> {
        let domain = &self.scene.domain;
        self.particles
            .positions
            .iter()
            .map(|x| position_color(domain.min, domain.max, *x))
            .collect()
    }

    /// The bytes [`FlowSimulation::memory_bytes`] reports once every
    /// particle slot of `scene`'s emitters is alive, known before anything
    /// is allocated: the particles and, when the scene draws trails, their
    /// rings of `trail_length` positions.
    pub fn estimate_memory_bytes(scene: &Scene) -> u64 {
        let slots = scene.estimate().particles;
        let trails = &firn_core::scene::RenderStyle::Trails;
        let trail_bytes = if scene.render.styles.contains(trails) {
            u64::from(scene.render.trail_length) * size_of::<Vec3>() as u64 + 8
        } else {
            0
        };
        slots.saturating_mul(FlowParticles::bytes_per_particle() as u64 + trail_bytes)
    }

    /// Bytes held by the particles and trails.
    pub fn memory_bytes(&self) -> usize {
        let trails = self.trails.as_ref().map_or(0, |trails| {
            trails.particle_count() * (trails.capacity() * size_of::<Vec3>() + 8)
        });
        self.particles.len() * FlowParticles::bytes_per_particle() + trails
    }
}

/// `scene` with its flow settings replaced by `settings`, for a change while
/// the flow runs (both backends check it so). The background direction is
/// normalised, as the scene loader does; then every rule of the scene format
/// applies ([`Scene::validate`]). The emitters cannot change (the particle
/// slots and births are planned from them), nor can the substeps per frame
/// (the clock counts them); the error's key names the field.
pub fn scene_with_settings(scene: &Scene, mut settings: FlowSettings) -> Result<Scene, FlowError> {
    let running = scene.kind.flow().ok_or(FlowError::NotAFlowScene)?;
    check_fixed_settings(running, &settings)?;
    let direction = settings.background_direction;
    let length = direction.length();
    if length > 0.0 && length.is_finite() {
        settings.background_direction = direction / length;
    }
    let mut changed = scene.clone();
    changed.kind = SceneKind::Flow(Box::new(settings));
    changed
        .validate()
        .map_err(|error| FlowError::Scene(Box::new(error)))?;
    Ok(changed)
}

/// The settings a running flow cannot change: its emitters and substeps.
fn check_fixed_settings(running: &FlowSettings, new: &FlowSettings) -> Result<(), FlowError> {
    if new.emitters != running.emitters {
        return Err(refusal(
            "flow.emitters",
            "flow.emitters cannot change while the flow runs: the particles' slots and births \
             are planned from them"
                .into(),
            "keep settings().emitters; to try other emitters, restart from a scene with them",
        ));
    }
    if new.substeps != running.substeps {
        return Err(refusal(
            "flow.substeps",
            format!(
                "flow.substeps cannot change while the flow runs (it is {}, {} was given): the \
                 clock counts substeps",
                running.substeps, new.substeps
            ),
            "keep settings().substeps; to try another, restart from a scene with it",
        ));
    }
    Ok(())
}

/// A refused change, keyed like a scene error so a panel can point at the field.
fn refusal(key: &str, message: String, hint: &str) -> FlowError {
    FlowError::Scene(Box::new(SceneError {
        file: String::new(),
        line: None,
        column: None,
        key: Some(key.to_string()),
        message,
        hint: hint.to_string(),
    }))
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

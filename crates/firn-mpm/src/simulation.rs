//! The time loop: one [`Simulation`] owns the particles, the grid and the
//! colliders, and advances them substep by substep (thesis §3.4, Figure 5).

use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::math::lanes::Simd;
use firn_core::scene::sampling::sample_bodies;
use firn_core::scene::{
    Integrator, Material, Scene, SceneError, TimeSettings, TimeStep, Transfer, Wind,
};
use glam::{DVec3, Mat3, Vec3};

use crate::binning::Bins;
use crate::block_sums::SumTrade;
use crate::contact::{ColliderSet, Colliders, PlacedCollider};
use crate::g2p::{
    GatherStats, ParticleProblem, ProblemKind, UpdateContext, gather_apic, gather_pic_flip,
    preferred_simd,
};
use crate::grid::{BLOCK_NODES, BLOCK_WIDTH, Grid, GridLayout, Node};
use crate::grid_update::{GridForces, WindStep, clear_grid, update_grid};
use crate::implicit::{ImplicitSolver, ImplicitStep, SolverStats};
use crate::p2g;
use crate::particles::{Particles, PermuteBuffers};
use crate::profile::{PhaseClock, PhaseTimes};
use crate::snow_model::{MaterialConstants, max_wave_speed_squared};
use crate::spindrift::{self, Drift, Escaped, SpindriftStep};
use crate::wind::AirDrag;

/// Particles are physically reordered by block every this many substeps, so
/// that the scatter and gather stream through memory.
pub const REORDER_INTERVAL: u64 = 16;

/// How far (in cells) a particle may stray outside the domain before the run
/// stops: the walls act on the grid, so snow can sit a fraction of a cell out.
const LEAVE_TOLERANCE_CELLS: f32 = 1.0;

/// Why a simulation could not start or continue.
#[derive(Debug, thiserror::Error)]
pub enum SimulationError {
    /// The scene's bodies produced no particles.
    #[error(
        "the scene has no particles: add a [[bodies]] table or make a body larger than a grid cell"
    )]
    NoParticles,
    /// The state went bad during a substep; nothing of that substep is kept.
    #[error("at t = {time:.4} s (substep {step}, Δt = {dt:.3e} s) particle {particle} {what} at ({x:.3}, {y:.3}, {z:.3}).\n  likely cause: {hint}", x = position.x, y = position.y, z = position.z)]
    Unstable {
        /// Simulated time at the start of the failed substep.
        time: f64,
        /// Index of the failed substep.
        step: u64,
        /// Δt of the failed substep.
        dt: f32,
        /// The first particle in trouble.
        particle: usize,
        /// "became non-finite" or "left the domain".
        what: &'static str,
        /// Where it was.
        position: Vec3,
        /// What to change in the scene.
        hint: String,
    },
    /// The time step fell so low that a frame would take more substeps
    /// than the scene allows (`time.max_substeps_per_frame`); the substep
    /// was not taken, so the state is that of the last one.
    #[error(
        "at t = {time:.4} s (substep {step}) the time step fell to Δt = {dt:.3e} s: the fastest particle moves at {speed:.4e} m/s and elastic waves at {wave_speed:.4e} m/s, so a frame (1/{fps} s) would take {needed:.3e} substeps, more than time.max_substeps_per_frame = {limit}.\n  fix: {hint}"
    )]
    TooManySubsteps {
        /// Simulated time when the step fell too low.
        time: f64,
        /// Substeps taken so far.
        step: u64,
        /// The Δt the next substep would take.
        dt: f32,
        /// The fastest particle's speed, m/s.
        speed: f32,
        /// The fastest elastic wave, m/s (0 when it does not limit Δt).
        wave_speed: f32,
        /// Output frames per simulated second.
        fps: f64,
        /// Substeps a frame would take at this Δt.
        needed: f64,
        /// The scene's limit.
        limit: u32,
        /// What to change in the scene.
        hint: String,
    },
    /// A snapshot does not fit the scene it is restored into.
    #[error("the checkpoint does not match the scene: {0}")]
    SnapshotMismatch(String),
    /// Materials that cannot replace the running scene's
    /// ([`Simulation::set_materials`]); the error's key names the field.
    #[error("{0}")]
    Materials(Box<SceneError>),
    /// A wind that cannot replace the running scene's
    /// ([`Simulation::set_wind`]); the error's key names the field.
    #[error("{0}")]
    Wind(Box<SceneError>),
}

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
        })
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

/// Totals over all particles, summed in f64 in particle order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Σ m_p.
    pub mass: f64,
    /// Σ m_p v_p.
    pub momentum: [f64; 3],
    /// Σ m_p x_p × v_p, plus the APIC affine part.
    pub angular_momentum: [f64; 3],
    /// Σ m_p x_p / Σ m_p.
    pub center_of_mass: [f64; 3],
    /// Σ ½ m_p |v_p|².
    pub kinetic_energy: f64,
}

/// A running snow simulation on the CPU.
#[derive(Clone, Debug)]
pub struct Simulation {
    scene: Scene,
    materials: Vec<MaterialConstants>,
    particles: Particles,
    grid: Grid,
    bins: Bins,
    /// Space for reordering the particles by block.
    permute_buffers: PermuteBuffers,
    colliders: ColliderSet,
    time: f64,
    steps: u64,
    stats: GatherStats,
    /// The step-6 solver, with the semi-implicit integrator only.
    implicit: Option<ImplicitSolver>,
    /// Wall-clock time per phase since the last reset.
    profile: PhaseTimes,
    /// The instruction set of the batched particle update.
    simd: Simd,
    /// The drag of the scene's wind on the grid, if it has one.
    wind: Option<AirDrag>,
    /// Σ of the wind's impulse on the snow since this simulation was made.
    wind_impulse: DVec3,
    /// Snow the wind carries (`[wind.spindrift]`).
    drift: Drift,
    /// ρ₀ of each material, for spindrift's loose-snow test.
    material_densities: Vec<f32>,
    /// Drift the wind carried out of the domain.
    escaped: Escaped,
}

impl Simulation {
    /// Fills the scene's bodies with particles and estimates their volumes
    /// (step 2). The scene should have passed [`Scene::validate`].
    pub fn new(scene: Scene) -> Result<Simulation, SimulationError> {
        let initial = Snapshot::initial(&scene)?;
        Simulation::from_snapshot(scene, initial)
    }

    /// Continues from a snapshot taken by [`Simulation::snapshot`] of the same scene.
    pub fn from_snapshot(scene: Scene, snapshot: Snapshot) -> Result<Simulation, SimulationError> {
        let particles = snapshot.particles;
        let count = particles.len();
        let lengths_match = [
            particles.velocity.len(),
            particles.mass.len(),
            particles.volume0.len(),
            particles.elastic.len(),
            particles.plastic_j.len(),
            particles.stress.len(),
            particles.velocity_gradient.len(),
            particles.material.len(),
        ]
        .iter()
        .all(|&len| len == count);
        if count == 0 || !lengths_match {
            return Err(SimulationError::SnapshotMismatch(
                "particle arrays are empty or of different lengths".into(),
            ));
        }
        if particles
            .material
            .iter()
            .any(|&m| m as usize >= scene.materials.len())
        {
            return Err(SimulationError::SnapshotMismatch(
                "a particle refers to an unknown material".into(),
            ));
        }
        if !snapshot.drift.is_consistent()
            || snapshot
                .drift
                .material
                .iter()
                .any(|&m| m as usize >= scene.materials.len())
        {
            return Err(SimulationError::SnapshotMismatch(
                "the drift arrays differ in length or refer to an unknown material".into(),
            ));
        }
        let mut simulation =
            Simulation::with_particles(scene, particles, snapshot.time, snapshot.steps);
        simulation.drift = snapshot.drift;
        simulation.escaped = snapshot.escaped;
        simulation.stats = GatherStats {
            max_speed_squared: snapshot.max_speed_squared,
            max_wave_speed_squared: snapshot.max_wave_speed_squared,
            problem: None,
        };
        Ok(simulation)
    }

    fn with_particles(scene: Scene, particles: Particles, time: f64, steps: u64) -> Simulation {
        let domain = &scene.domain;
        Simulation {
            materials: MaterialConstants::of_each(&scene.materials),
            grid: Grid::new(domain.min, domain.max, domain.cell_size),
            colliders: ColliderSet::new(domain, &scene.colliders),
            bins: Bins::default(),
            permute_buffers: PermuteBuffers::default(),
            particles,
            time,
            steps,
            stats: GatherStats::default(),
            implicit: match scene.solver.integrator {
                Integrator::Explicit => None,
                Integrator::SemiImplicit(_) => Some(ImplicitSolver::default()),
            },
            profile: PhaseTimes::default(),
            simd: preferred_simd(),
            wind: scene
                .wind
                .as_ref()
                .map(|wind| AirDrag::new(wind, domain.cell_size)),
            wind_impulse: DVec3::ZERO,
            drift: Drift::default(),
            escaped: Escaped::default(),
            material_densities: scene.materials.iter().map(|m| m.density).collect(),
            scene,
        }
    }

    /// A simulation of no particles yet, at simulated time `time` after
    /// `steps` substeps, for a caller that brings its own
    /// ([`Simulation::set_particles`]): one part of a run split between
    /// processes (firn-mpi), which steps by [`Simulation::step_part`].
    pub fn empty(scene: Scene, time: f64, steps: u64) -> Simulation {
        Simulation::with_particles(scene, Particles::default(), time, steps)
    }

    /// Replaces the particles for the substeps to come.
    pub fn set_particles(&mut self, particles: Particles) {
        self.particles = particles;
    }

    /// Takes the particles out, leaving none
    /// ([`Simulation::set_particles`] puts particles back).
    pub fn take_particles(&mut self) -> Particles {
        std::mem::take(&mut self.particles)
    }

    /// The largest |v_p|² and squared elastic wave speed of the particles
    /// after the last substep: what the next Δt is made of.
    pub fn motion_bounds(&self) -> (f32, f32) {
        (
            self.stats.max_speed_squared,
            self.stats.max_wave_speed_squared,
        )
    }

    /// Sets what the next Δt is made of (the maxima of
    /// [`Simulation::motion_bounds`] over all parts of a split run).
    pub fn set_motion_bounds(&mut self, max_speed_squared: f32, max_wave_speed_squared: f32) {
        self.stats.max_speed_squared = max_speed_squared;
        self.stats.max_wave_speed_squared = max_wave_speed_squared;
    }

    /// The largest squared wave speed of the particles as they are, with
    /// the current materials (what the last gather would have reported).
    fn max_wave_speed_squared(&self) -> f32 {
        let particles = &self.particles;
        max_wave_speed_squared(&self.materials, &particles.material, &particles.plastic_j)
    }

    /// Replaces the scene's materials while the simulation runs (an
    /// interactive viewer's parameter panel), from the next substep on: the
    /// snow model's constants and the elastic wave speed of the adaptive Δt.
    /// Refused, with nothing changed, when the materials differ in number,
    /// names, order or density, or break a rule of the scene format
    /// ([`crate::live::scene_with_materials`]). The particles keep their state.
    pub fn set_materials(&mut self, materials: &[Material]) -> Result<(), SimulationError> {
        self.scene = crate::live::scene_with_materials(&self.scene, materials)?;
        self.materials = MaterialConstants::of_each(&self.scene.materials);
        self.stats.max_wave_speed_squared = self.max_wave_speed_squared();
        Ok(())
    }

    /// Replaces the scene's wind while the simulation runs (an interactive
    /// viewer's parameter panel), from the next substep on; a scene without
    /// one gets it. Refused, with nothing changed, when the scene loader
    /// would refuse it ([`crate::live::scene_with_wind`]).
    pub fn set_wind(&mut self, wind: &Wind) -> Result<(), SimulationError> {
        self.scene = crate::live::scene_with_wind(&self.scene, wind)?;
        let cell_size = self.scene.domain.cell_size;
        self.wind = Some(AirDrag::new(wind, cell_size).with_simd(self.simd));
        Ok(())
    }

    /// The Δt the next substep will take (before clipping to a frame end):
    /// fixed, or Δt = CFL · h / (max |v_p| + max c_p) capped at the maximum,
    /// with c_p the elastic wave speed including hardening. The semi-implicit
    /// update is stable beyond the elastic wave limit, so with it only the
    /// particle speed bounds Δt: Δt = CFL · h / max |v_p|.
    pub fn next_dt(&self) -> f32 {
        match self.scene.time.step {
            TimeStep::Fixed { dt } => dt,
            TimeStep::Adaptive { cfl, max_dt } => {
                let wave_speed = match self.scene.solver.integrator {
                    Integrator::Explicit => self.stats.max_wave_speed_squared.sqrt(),
                    Integrator::SemiImplicit(_) => 0.0,
                };
                let speed = self.stats.max_speed_squared.sqrt() + wave_speed;
                if speed > 0.0 {
                    (cfl * self.scene.domain.cell_size / speed).min(max_dt)
                } else {
                    max_dt
                }
            }
        }
    }

    /// Advances one substep, never past time `until`; returns the Δt taken.
    /// Refuses, with nothing changed, when the Δt would be so short that a
    /// frame took more than `time.max_substeps_per_frame` substeps. Every
    /// [`REORDER_INTERVAL`] substeps it first sorts the particles by block.
    pub fn step(&mut self, until: f64) -> Result<f32, SimulationError> {
        let dt = self.clipped_dt(until)?;
        let layout = self.grid.layout;
        let mut clock = PhaseClock::start();
        if self.steps.is_multiple_of(REORDER_INTERVAL) {
            self.bins.rebuild(&layout, &self.particles.position);
            self.particles
                .permute(self.bins.order(), &mut self.permute_buffers);
        }
        self.bins.rebuild(&layout, &self.particles.position);
        clock.lap(&mut self.profile.binning);
        self.finish_substep(dt, clock, None, None)
    }

    /// [`Simulation::step`] for one part of a run split between processes
    /// (MPI ranks), which holds the particles of its blocks in any order
    /// and never reorders them (see the MPI section of
    /// docs/architecture.md). `keys` gives each particle's place in the
    /// whole run's order: every block adds its particles in key order, and
    /// a failure names the particle with the lowest key. The block sums
    /// that other parts read, and those this part reads, go through `trade`
    /// ([`crate::block_sums`]). Every part must take the same Δt: the
    /// caller reduces [`Simulation::motion_bounds`] over the parts and
    /// hands the result back with [`Simulation::set_motion_bounds`].
    pub fn step_part(
        &mut self,
        until: f64,
        keys: &[u64],
        trade: &mut dyn SumTrade,
    ) -> Result<f32, SimulationError> {
        assert_eq!(keys.len(), self.particles.len(), "one key per particle");
        let dt = self.clipped_dt(until)?;
        let mut clock = PhaseClock::start();
        self.bins
            .rebuild(&self.grid.layout, &self.particles.position);
        self.bins.order_blocks_by(keys);
        clock.lap(&mut self.profile.binning);
        self.finish_substep(dt, clock, Some(trade), Some(keys))
    }

    /// The Δt of the next substep, never past time `until`, or the error
    /// of [`Simulation::check_step_length`].
    fn clipped_dt(&self, until: f64) -> Result<f32, SimulationError> {
        let next = self.next_dt();
        self.check_step_length(next)?;
        Ok((next as f64).min(until - self.time).max(0.0) as f32)
    }

    /// The rest of a substep of length `dt` once the particles are binned,
    /// `clock` timing it: the scatter (trading block sums through `trade`
    /// in a part of a split run), the grid update and solve, the gather
    /// (naming a failed particle by its key in `keys`, if given), spindrift
    /// and the clearing of the grid.
    fn finish_substep(
        &mut self,
        dt: f32,
        mut clock: PhaseClock,
        trade: Option<&mut dyn SumTrade>,
        keys: Option<&[u64]>,
    ) -> Result<f32, SimulationError> {
        let layout = self.grid.layout;
        let transfer_scheme = self.scene.solver.transfer;
        let (grid, bins, particles) = (&mut self.grid, &self.bins, &self.particles);
        match transfer_scheme {
            Transfer::PicFlip => p2g::scatter_pic_flip(grid, bins, particles, self.simd, trade),
            Transfer::Apic => p2g::scatter_apic(grid, bins, particles, dt, self.simd, trade),
        }
        clock.lap(&mut self.profile.scatter);
        let colliders = self.colliders.placed_at(self.time + dt as f64);
        let forces = match transfer_scheme {
            Transfer::PicFlip => GridForces::Separate,
            Transfer::Apic => GridForces::InMomentum,
        };
        // The semi-implicit solve applies the grid collisions itself, to learn
        // which velocity components they fix.
        let particle_colliders = Colliders::new(&colliders);
        let no_colliders = Colliders::new(&[]);
        let grid_colliders = match self.implicit {
            Some(_) => &no_colliders,
            None => &particle_colliders,
        };
        let wind = self.wind.as_ref().map(|drag| WindStep {
            drag,
            time: self.time + dt as f64,
        });
        let wind_impulse = update_grid(
            &mut self.grid,
            forces,
            dt,
            self.scene.solver.gravity,
            grid_colliders,
            wind,
        );
        clock.lap(&mut self.profile.grid_update);
        if let (Integrator::SemiImplicit(settings), Some(solver)) =
            (self.scene.solver.integrator, self.implicit.as_mut())
        {
            let step = ImplicitStep {
                dt,
                settings,
                transfer: transfer_scheme,
                materials: &self.materials,
                colliders: &colliders,
            };
            solver.solve(&mut self.grid, &self.bins, &self.particles, &step);
        }
        clock.lap(&mut self.profile.implicit_solve);
        let tolerance = Vec3::splat(LEAVE_TOLERANCE_CELLS * layout.cell_size);
        let context = UpdateContext {
            dt,
            materials: &self.materials,
            colliders: &particle_colliders,
            lower: self.scene.domain.min - tolerance,
            upper: self.scene.domain.max + tolerance,
            keys,
        };
        let stats = match transfer_scheme {
            Transfer::PicFlip => gather_pic_flip(
                &self.grid,
                &self.bins,
                &mut self.particles,
                self.scene.solver.flip_blend,
                &context,
                self.simd,
            ),
            Transfer::Apic => gather_apic(
                &self.grid,
                &self.bins,
                &mut self.particles,
                &context,
                self.simd,
            ),
        };
        clock.lap(&mut self.profile.gather);
        if stats.problem.is_none() {
            self.blow_spindrift(&colliders, dt);
        }
        clear_grid(&mut self.grid);
        clock.lap(&mut self.profile.clear);
        if let Some(problem) = stats.problem {
            return Err(self.instability(problem, dt));
        }
        self.time += dt as f64;
        self.steps += 1;
        self.stats = stats;
        self.wind_impulse += wind_impulse;
        Ok(dt)
    }

    /// Spindrift at the end of a substep of length `dt`, while the grid
    /// still holds its node masses ([`crate::spindrift`]): the drift moves
    /// and lands, then loose surface snow lifts. `placed` are the colliders
    /// at the end of the substep, the scene's first.
    fn blow_spindrift(&mut self, placed: &[PlacedCollider], dt: f32) {
        let (Some(drag), Some(wind)) = (self.wind.as_ref(), self.scene.wind.as_ref()) else {
            return;
        };
        let Some(settings) = wind.spindrift.as_ref() else {
            return;
        };
        let step = SpindriftStep {
            settings,
            drag,
            colliders: &placed[..self.scene.colliders.len()],
            domain: &self.scene.domain,
            gravity: self.scene.solver.gravity,
            interval: (self.time, self.time + f64::from(dt)),
            substep: self.steps,
            seed: wind.field.seed,
            integrator: wind.field.integrator,
            material_densities: &self.material_densities,
        };
        let mut landed = Particles::default();
        spindrift::carry(&step, &mut self.drift, &mut self.escaped, &mut landed);
        spindrift::detach(&step, &self.grid, &mut self.particles, &mut self.drift);
        self.particles.append(landed);
    }

    /// Chooses the instruction set of the batched particle update
    /// ([`preferred_simd`] by default; one the CPU lacks falls back to
    /// portable code).
    /// Every choice gives the same bits; this exists to show that.
    pub fn set_simd(&mut self, simd: Simd) {
        self.simd = simd;
        self.wind = self.wind.take().map(|drag| drag.with_simd(simd));
    }

    /// The instruction set of the batched particle update.
    pub fn simd(&self) -> Simd {
        self.simd
    }

    /// Wall-clock seconds spent in each phase of the substeps since the last
    /// [`Simulation::reset_phase_times`] (or since the start).
    pub fn phase_times(&self) -> PhaseTimes {
        self.profile
    }

    /// Starts the phase profile afresh, e.g. after untimed warm-up substeps.
    pub fn reset_phase_times(&mut self) {
        self.profile = PhaseTimes::default();
    }

    /// Substeps until time `until` is reached; returns the number of substeps.
    pub fn advance_to(&mut self, until: f64) -> Result<u32, SimulationError> {
        let mut substeps = 0;
        while until - self.time > 1e-9 {
            self.step(until)?;
            substeps += 1;
        }
        Ok(substeps)
    }

    /// The error for a next Δt that leaves a frame more substeps than the
    /// scene's `time.max_substeps_per_frame`, if it does.
    fn check_step_length(&self, dt: f32) -> Result<(), SimulationError> {
        let time = &self.scene.time;
        if f64::from(dt) >= time.shortest_dt() {
            return Ok(());
        }
        let wave_speed = match self.scene.solver.integrator {
            Integrator::Explicit => self.stats.max_wave_speed_squared.sqrt(),
            Integrator::SemiImplicit(_) => 0.0,
        };
        let speed = self.stats.max_speed_squared.sqrt();
        Err(SimulationError::too_many_substeps(
            time, self.time, self.steps, dt, speed, wave_speed,
        ))
    }

    /// An explanation of a failed substep with a concrete fix.
    fn instability(&self, problem: ParticleProblem, dt: f32) -> SimulationError {
        let material_index = self.particles.material[problem.particle] as usize;
        let material = &self.scene.materials[material_index];
        let h = self.scene.domain.cell_size;
        // The hardened wave speed of the last good substep, at least the material's own.
        let wave_speed = self
            .stats
            .max_wave_speed_squared
            .max(self.materials[material_index].wave_speed_squared)
            .sqrt();
        let stable_dt = 0.3 * h / (wave_speed + self.stats.max_speed_squared.sqrt());
        let waves = format!(
            "E = {:.3e} Pa makes elastic waves travel at {wave_speed:.0} m/s, crossing a cell (h = {h} m) in {:.2e} s",
            material.youngs_modulus,
            h / wave_speed
        );
        let step_fix = match self.scene.time.step {
            TimeStep::Fixed { .. } => {
                format!("in [time] set dt = {stable_dt:.1e} or step = \"adaptive\"")
            }
            TimeStep::Adaptive { cfl, .. } => {
                format!(
                    "in [time] set cfl = {:.2} (now {cfl}) or dt = {stable_dt:.1e}",
                    cfl * 0.5
                )
            }
        };
        let (what, hint) = match problem.kind {
            ProblemKind::NonFinite if self.implicit.is_some() => (
                "became non-finite (NaN or infinity)",
                format!(
                    "the semi-implicit step Δt = {dt:.2e} s is too large: {}",
                    self.implicit_fix()
                ),
            ),
            ProblemKind::NonFinite => (
                "became non-finite (NaN or infinity)",
                format!("the time step Δt = {dt:.2e} s is too large: {waves}; {step_fix}"),
            ),
            ProblemKind::LeftDomain if self.implicit.is_some() => (
                "left the domain",
                format!(
                    "snow moved too far in one semi-implicit step (Δt = {dt:.2e} s) or was pushed \
                     through a wall: {}, and check that moving colliders stay inside [domain]",
                    self.implicit_fix()
                ),
            ),
            ProblemKind::LeftDomain => (
                "left the domain",
                format!(
                    "snow moved too far in one step or was pushed through a wall ({waves}): {step_fix}, \
                     and check that moving colliders stay inside [domain]"
                ),
            ),
        };
        SimulationError::Unstable {
            time: self.time,
            step: self.steps,
            dt,
            particle: problem.particle,
            what,
            position: problem.position,
            hint,
        }
    }

    /// What to change when a semi-implicit step blew up
    /// ([`crate::implicit::blow_up_fix`]).
    fn implicit_fix(&self) -> String {
        crate::implicit::blow_up_fix(&self.scene, self.solver_stats().unwrap_or_default())
    }

    /// Everything needed to continue this run bit for bit.
    pub fn snapshot(&self) -> Snapshot {
        Snapshot {
            time: self.time,
            steps: self.steps,
            max_speed_squared: self.stats.max_speed_squared,
            max_wave_speed_squared: self.stats.max_wave_speed_squared,
            particles: self.particles.clone(),
            drift: self.drift.clone(),
            escaped: self.escaped,
        }
    }

    /// Statistics of the semi-implicit solves since this simulation was
    /// created or restored; `None` with the explicit integrator.
    pub fn solver_stats(&self) -> Option<SolverStats> {
        self.implicit.as_ref().map(ImplicitSolver::stats)
    }

    /// The scene being simulated.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The particles (read-only).
    pub fn particles(&self) -> &Particles {
        &self.particles
    }

    /// Simulated time in seconds.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Substeps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The impulse the wind's drag gave the snow since this simulation was
    /// made (from [`Simulation::new`] or a snapshot), N s: Σ over substeps and
    /// nodes of m_i Δv_i (equation W3 of [`firn_core::scene::wind`]).
    pub fn wind_impulse(&self) -> DVec3 {
        self.wind_impulse
    }

    /// The snow the wind carries (`[wind.spindrift]`; empty without).
    pub fn drift(&self) -> &Drift {
        &self.drift
    }

    /// The drift the wind carried out of the domain so far.
    pub fn escaped(&self) -> Escaped {
        self.escaped
    }

    /// Grid geometry.
    pub fn grid_layout(&self) -> GridLayout {
        self.grid.layout
    }

    /// Bytes allocated for the grid (page table and the blocks near the snow),
    /// the binning buffers and the particles (with the space to reorder them).
    pub fn memory_bytes(&self) -> usize {
        self.grid.memory_bytes()
            + self.bins.memory_bytes()
            + self.permute_buffers.memory_bytes()
            + self.particles.len() * Particles::bytes_per_particle()
    }

    /// The bytes [`Simulation::memory_bytes`] will report at the start for
    /// `scene` filled with `particles` particles, known before anything is
    /// sampled or allocated: the particles with their reorder and binning
    /// space, the grid's and the bins' tables of every block of the box,
    /// and the node blocks around each body's bounding box (a block of
    /// padding on every side). An upper bound at the start; it grows as the
    /// snow spreads over more blocks.
    pub fn estimate_memory_bytes(scene: &Scene, particles: u64) -> u64 {
        const WORD: u64 = std::mem::size_of::<u32>() as u64;
        let domain = &scene.domain;
        let layout = GridLayout::new(domain.min, domain.max, domain.cell_size);
        let box_blocks = layout.block_count() as u64;
        let near_bodies: u64 = scene
            .bodies
            .iter()
            .map(|body| blocks_around(&layout, body.shape.bounds()))
            .fold(0, u64::saturating_add);
        let active = near_bodies.min(box_blocks);
        // Per block: its nodes, its eight neighbours' slots, its place in
        // the resident list and in the bins' active list.
        let block_bytes = (BLOCK_NODES * std::mem::size_of::<Node>()) as u64 + 10 * WORD;
        // Per particle: its attributes (with the bin order), the reorder
        // space, and the bins' key and sorted slot.
        let particle_bytes = (Particles::bytes_per_particle() + PermuteBuffers::BYTES_PER_PARTICLE)
            as u64
            + 2 * WORD;
        particles
            .saturating_mul(particle_bytes)
            .saturating_add(box_blocks.saturating_mul(2 * WORD))
            .saturating_add(active.saturating_mul(block_bytes))
    }

    /// Current density of every particle (kg/m³).
    pub fn densities(&self) -> Vec<f32> {
        (0..self.particles.len())
            .map(|p| self.particles.density(p))
            .collect()
    }

    /// J_E = det F_E of every particle.
    pub fn elastic_j(&self) -> Vec<f32> {
        self.particles
            .elastic
            .iter()
            .map(Mat3::determinant)
            .collect()
    }

    /// Mass, momentum, angular momentum, centre of mass and kinetic energy.
    pub fn diagnostics(&self) -> Diagnostics {
        diagnostics(
            &self.particles,
            self.grid.layout.cell_size,
            self.scene.solver.transfer,
        )
    }
}

/// Grid blocks covering the box `low .. high` and one block around it.
fn blocks_around(layout: &GridLayout, (low, high): (Vec3, Vec3)) -> u64 {
    let width = f64::from(BLOCK_WIDTH);
    let first = (layout.to_grid(low).as_dvec3() / width).floor() - 1.0;
    let last = (layout.to_grid(high).as_dvec3() / width).ceil() + 1.0;
    let blocks = (last - first).max(glam::DVec3::ONE).element_product();
    if blocks.is_finite() {
        blocks.min(u64::MAX as f64) as u64
    } else {
        u64::MAX
    }
}

/// The same "frame would take too many substeps" error on every backend.
impl SimulationError {
    /// [`SimulationError::TooManySubsteps`] at simulated time `now` after
    /// `steps` substeps, for a next step `dt` set by the fastest particle
    /// (`speed`) or elastic wave (`wave_speed`), under `settings`' limit.
    pub fn too_many_substeps(
        settings: &TimeSettings,
        now: f64,
        steps: u64,
        dt: f32,
        speed: f32,
        wave_speed: f32,
    ) -> SimulationError {
        let limit = settings.max_substeps_per_frame;
        SimulationError::TooManySubsteps {
            time: now,
            step: steps,
            dt,
            speed,
            wave_speed,
            fps: settings.fps,
            needed: 1.0 / (settings.fps * f64::from(dt)),
            limit,
            hint: step_length_hint(speed, wave_speed, limit),
        }
    }
}

/// What to change when the step fell too low: whatever made the snow fast
/// or stiff, or the limit.
pub fn step_length_hint(speed: f32, wave_speed: f32, limit: u32) -> String {
    let cause = if speed >= wave_speed {
        "find what drives the snow this fast (gravity, an initial velocity, a collider that \
         moves or jumps quickly)"
    } else {
        "the snow has hardened into stiff ice (lower hardening or youngs_modulus, or use \
         integrator = \"semi-implicit\", whose step elastic waves do not limit)"
    };
    format!(
        "{cause}, use a larger cell_size, or raise [time] max_substeps_per_frame (now {limit}) \
         if the frames really need that many substeps"
    )
}

/// Totals over particles; with APIC the angular momentum includes the affine
/// part m_p (h²/4) ε : C_pᵀ of each particle's velocity field.
pub fn diagnostics(particles: &Particles, cell_size: f32, transfer: Transfer) -> Diagnostics {
    let mut totals = Diagnostics::default();
    let mut weighted_position = [0.0f64; 3];
    let inertia = (cell_size as f64).powi(2) / 4.0;
    for p in 0..particles.len() {
        let m = particles.mass[p] as f64;
        let x = particles.position[p].as_dvec3();
        let v = particles.velocity[p].as_dvec3();
        let mut angular = x.cross(v) * m;
        if transfer == Transfer::Apic {
            let c = particles.velocity_gradient[p].as_dmat3();
            // ε_abc C_cb: (C_zy − C_yz, C_xz − C_zx, C_yx − C_xy), C_rc = column c, row r.
            let curl = glam::DVec3::new(
                c.y_axis.z - c.z_axis.y,
                c.z_axis.x - c.x_axis.z,
                c.x_axis.y - c.y_axis.x,
            );
            angular += curl * (m * inertia);
        }
        totals.mass += m;
        totals.kinetic_energy += 0.5 * m * v.length_squared();
        for axis in 0..3 {
            totals.momentum[axis] += m * v[axis];
            totals.angular_momentum[axis] += angular[axis];
            weighted_position[axis] += m * x[axis];
        }
    }
    if totals.mass > 0.0 {
        totals.center_of_mass = weighted_position.map(|w| w / totals.mass);
    }
    totals
}

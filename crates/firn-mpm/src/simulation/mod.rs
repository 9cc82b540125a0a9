//! The time loop: one [`Simulation`] owns the particles, the grid and the
//! colliders, and advances them substep by substep (thesis §3.4, Figure 5).
//! A substep's stages are listed, in order, in substep.rs; a run's failures
//! are explained in error.rs and its memory told in memory.rs.

mod error;
mod memory;
mod substep;

use firn_core::math::lanes::Simd;
use firn_core::scene::{Integrator, Material, RigidBody, Scene, Wind};
use glam::DVec3;

use crate::binning::Bins;
use crate::contact::ColliderSet;
use crate::coupling::RigidBodies;
use crate::g2p::{GatherStats, preferred_simd};
use crate::grid::{Grid, GridLayout};
use crate::implicit::{ImplicitSolver, SolverStats};
use crate::particles::{Particles, PermuteBuffers};
use crate::profile::PhaseTimes;
use crate::snow_model::{MaterialConstants, max_wave_speed_squared};
use crate::spindrift::{Drift, Escaped};
use crate::wind::AirDrag;

pub use crate::diagnostics::{Diagnostics, diagnostics};
pub use crate::snapshot::Snapshot;
pub use error::{SimulationError, step_length_hint};

/// Particles are physically reordered by block every this many substeps, so
/// that the scatter and gather stream through memory.
pub const REORDER_INTERVAL: u64 = 16;

/// How far (in cells) a particle may stray outside the domain before the run
/// stops: the walls act on the grid, so snow can sit a fraction of a cell out.
const LEAVE_TOLERANCE_CELLS: f32 = 1.0;

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
    /// The scene's rigid bodies, if it has any.
    rigid: Option<RigidBodies>,
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
        snapshot.check(&scene)?;
        let particles = snapshot.particles;
        let mut simulation = Simulation::empty(
            scene,
            snapshot.time,
            snapshot.steps,
            snapshot.rigid.as_deref(),
        )?;
        simulation.set_particles(particles);
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
            rigid: None,
            material_densities: scene.materials.iter().map(|m| m.density).collect(),
            scene,
        }
    }

    /// A simulation of no particles yet, at simulated time `time` after
    /// `steps` substeps, for a caller that brings its own
    /// ([`Simulation::set_particles`]): one part of a run split between
    /// processes (firn-mpi), which steps by [`Simulation::step_part`]. Its
    /// rigid bodies, which every part holds whole, are as `rigid` saved
    /// them ([`Snapshot::rigid`]), or at their start without it.
    pub fn empty(
        scene: Scene,
        time: f64,
        steps: u64,
        rigid: Option<&[u8]>,
    ) -> Result<Simulation, SimulationError> {
        let mut simulation = Simulation::with_particles(scene, Particles::default(), time, steps);
        simulation.rigid = match rigid {
            Some(bytes) => Some(RigidBodies::from_bytes(&simulation.scene, bytes)?),
            None => RigidBodies::new(&simulation.scene)?,
        };
        Ok(simulation)
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
            rigid: self.rigid.as_ref().map(RigidBodies::to_bytes),
        }
    }

    /// The rigid bodies, if the scene has any.
    pub(crate) fn rigid_world(&self) -> Option<&RigidBodies> {
        self.rigid.as_ref()
    }

    /// Throws `body` into the running simulation from the next substep on
    /// (an interactive viewer's throw): it joins the scene's rigid bodies,
    /// last. Refused, with nothing changed, when the scene loader would
    /// refuse the body ([`crate::live::check_new_rigid_body`]), or the
    /// integrator is semi-implicit.
    pub fn add_rigid_body(&mut self, body: RigidBody) -> Result<(), SimulationError> {
        crate::live::check_new_rigid_body(&self.scene, &body)?;
        match self.rigid.as_mut() {
            Some(rigid) => rigid.add(&body)?,
            None => {
                let mut alone = self.scene.clone();
                alone.rigid_bodies = vec![body.clone()];
                self.rigid = RigidBodies::new(&alone)?;
            }
        }
        self.scene.rigid_bodies.push(body);
        Ok(())
    }

    /// The linear impulse the snow gave each rigid body since this
    /// simulation was made (from [`Simulation::new`] or a snapshot), N s,
    /// in scene order.
    pub fn snow_impulse_on_bodies(&self) -> Vec<DVec3> {
        self.rigid
            .as_ref()
            .map(|rigid| rigid.pushed().to_vec())
            .unwrap_or_default()
    }

    /// Every rigid body's state, in scene order (none without).
    pub fn rigid_bodies(&self) -> Vec<firn_rigid::BodyState> {
        self.view().rigid_bodies()
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

    /// Current density of every particle (kg/m³).
    pub fn densities(&self) -> Vec<f32> {
        self.view().densities()
    }

    /// J_E = det F_E of every particle.
    pub fn elastic_j(&self) -> Vec<f32> {
        self.view().elastic_j()
    }

    /// Mass, momentum, angular momentum, centre of mass and kinetic energy.
    pub fn diagnostics(&self) -> Diagnostics {
        self.view().diagnostics()
    }
}

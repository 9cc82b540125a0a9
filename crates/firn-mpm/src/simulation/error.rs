//! Why a run stops: [`SimulationError`], with the explanation and the fix
//! each failure prints (a blow-up names the particle, the likely cause and
//! the setting to change; a Δt that fell too low names what drove it).

use firn_core::scene::{SceneError, TimeSettings, TimeStep};
use glam::Vec3;

use super::Simulation;
use crate::g2p::{ParticleProblem, ProblemKind};
use firn_core::scene::Integrator;

/// Why a simulation could not start or continue.
#[derive(Debug, thiserror::Error)]
pub enum SimulationError {
    /// The scene's bodies produced no particles.
    #[error(
        "the scene has no particles: add a [[bodies]] table or make a body larger than a grid cell"
    )]
    NoParticles,
    /// The rigid bodies could not be made or restored.
    #[error("rigid bodies: {0}")]
    RigidBodies(#[from] firn_rigid::RigidError),
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
    /// A rigid body that cannot join the running scene
    /// ([`Simulation::add_rigid_body`]); the error's key names the field.
    #[error("{0}")]
    RigidBody(Box<SceneError>),
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

impl Simulation {
    /// The error for a next Δt that leaves a frame more substeps than the
    /// scene's `time.max_substeps_per_frame`, if it does.
    pub(super) fn check_step_length(&self, dt: f32) -> Result<(), SimulationError> {
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
    pub(super) fn instability(&self, problem: ParticleProblem, dt: f32) -> SimulationError {
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
}

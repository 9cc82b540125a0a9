//! The errors a batch of substeps that ended in trouble reports, as the
//! CPU's (`firn_mpm::SimulationError`): which particle, where, the likely
//! cause and the setting to change.

use firn_core::scene::{Integrator, TimeStep};
use firn_mpm::SimulationError;
use glam::Vec3;

use super::fixed_point::QUANTITY_NAMES;
use super::layout::{NO_PARTICLE, StepState};
use super::{GpuSnow, is_implicit};
use crate::buffers::read_back;
use crate::error::GpuError;

impl GpuSnow {
    /// The error for a batch that ended in trouble, if it did.
    pub(super) fn check_trouble(&self, state: &StepState) -> Result<(), GpuError> {
        let step_start = self.time_of(state) - f64::from(state.dt);
        if state.overflow != 0 {
            let quantity = QUANTITY_NAMES[state.overflow.trailing_zeros() as usize];
            return Err(GpuError::Overflow {
                time: step_start,
                quantity,
                speed_limit: self.scales.speed_limit(),
            });
        }
        let problem = match (state.non_finite, state.left_domain) {
            (NO_PARTICLE, NO_PARTICLE) => None,
            (NO_PARTICLE, particle) => Some((particle, "left the domain")),
            (particle, _) => Some((particle, "became non-finite (NaN or infinity)")),
        };
        let Some((particle, what)) = problem else {
            return Ok(());
        };
        let position = self.particle_position(particle as usize)?;
        Err(GpuError::Snow(SimulationError::Unstable {
            time: step_start,
            step: self.steps,
            dt: state.dt,
            particle: particle as usize,
            what,
            position,
            hint: self.instability_hint(state.dt),
        }))
    }

    /// The error for a frame still running whose next Δt (before it is
    /// clipped to the frame's end, from the maxima of the last gather)
    /// leaves it more substeps than the scene's
    /// `time.max_substeps_per_frame`, as on the CPU (the batch before it
    /// has been taken).
    pub(super) fn check_step_length(&self, state: &StepState) -> Result<(), GpuError> {
        let time = &self.scene.time;
        let speed = f32::from_bits(state.max_speed_bits)
            .max(0.0)
            .sqrt()
            .max(self.body_speed());
        let wave_speed = f32::from_bits(state.max_wave_bits).max(0.0).sqrt();
        // The semi-implicit step is not bound by elastic waves.
        let limiting_wave_speed = if is_implicit(&self.scene) {
            0.0
        } else {
            wave_speed
        };
        let dt = match time.step {
            TimeStep::Fixed { dt } => dt,
            TimeStep::Adaptive { cfl, max_dt } if speed + limiting_wave_speed > 0.0 => {
                (cfl * self.scene.domain.cell_size / (speed + limiting_wave_speed)).min(max_dt)
            }
            TimeStep::Adaptive { max_dt, .. } => max_dt,
        };
        if state.running == 0 || f64::from(dt) >= time.shortest_dt() {
            return Ok(());
        }
        Err(GpuError::Snow(SimulationError::too_many_substeps(
            time, self.time, self.steps, dt, speed, wave_speed,
        )))
    }

    pub(super) fn time_of(&self, state: &StepState) -> f64 {
        f64::from(self.params.lower[3]) + f64::from(state.elapsed)
    }

    /// What to change when a substep blew up.
    pub(super) fn instability_hint(&self, dt: f32) -> String {
        if let Integrator::SemiImplicit(_) = self.scene.solver.integrator {
            return self.implicit_hint(dt);
        }
        let h = self.scene.domain.cell_size;
        let wave_speed = self.last.wave_speed_squared.max(1e-12).sqrt();
        let step_fix = match self.scene.time.step {
            TimeStep::Fixed { .. } => {
                format!(
                    "in [time] set dt = {:.1e} or step = \"adaptive\"",
                    0.3 * h / wave_speed
                )
            }
            TimeStep::Adaptive { cfl, .. } => {
                format!("in [time] set cfl = {:.2} (now {cfl})", cfl * 0.5)
            }
        };
        format!(
            "the time step Δt = {dt:.2e} s is too large for elastic waves of {wave_speed:.0} m/s \
             in cells of h = {h} m, or snow was pushed through a wall: {step_fix}, and check \
             that moving colliders stay inside [domain]"
        )
    }

    /// What to change when a semi-implicit substep blew up: the solve's
    /// limit if solves stopped short, else the step (as on the CPU).
    pub(super) fn implicit_hint(&self, dt: f32) -> String {
        let fix =
            firn_mpm::implicit::blow_up_fix(&self.scene, self.solver_stats().unwrap_or_default());
        format!(
            "the semi-implicit step Δt = {dt:.2e} s is too large, or snow was pushed through a \
             wall: {fix}, and check that moving colliders stay inside [domain]"
        )
    }

    pub(super) fn particle_position(&self, index: usize) -> Result<Vec3, GpuError> {
        let all = read_back::<[f32; 4]>(
            &self.context,
            &[(&self.buffers.particles.position_mass, self.particle_count)],
        )?;
        let [x, y, z, _] = all[0][index.min(self.particle_count - 1)];
        Ok(Vec3::new(x, y, z))
    }
}

//! Spindrift (scene `[wind.spindrift]`): loose snow at the surface that the
//! wind lifts off becomes drift particles carried by the air, and settles
//! back into snow where it lands. The model and its equations S1 to S3 are
//! in [`firn_core::scene::wind`].
//!
//! Each substep, after the gather has moved the snow and while the grid still
//! holds the substep's node masses:
//!
//! 1. [`carry`] moves the drift through the wind's field with the flow's own
//!    integrator ([`firn_flow::integrate::carry`], S3), adds the fall speed
//!    and sorts out the particles that landed (into a collider or through a
//!    floor) or left the domain;
//! 2. [`detach`] picks the snow particles that lift (S1, S2): a particle is
//!    looked at only when its draw ξ_p falls under the largest probability
//!    of the substep, 1 − exp(−r Δt), so the work is bounded by the rate;
//!    the chosen ones leave the snow arrays, in particle order, for the end
//!    of the drift arrays;
//! 3. landed drift with `settle` joins the end of the snow arrays.
//!
//! Every particle keeps its mass m_p bit for bit as it moves between snow,
//! drift and the escaped tally, so the scene's mass is conserved exactly.
//! Nothing depends on the thread count or the instruction set: the draws
//! hash each particle's own state with the substep index, the chosen
//! particles are collected in particle order, and the field is evaluated in
//! lanes that give the same bits on every path.

use firn_core::math::exp::exp;
use firn_core::scene::{Domain, FlowIntegrator, Spindrift};
use firn_flow::integrate::carry as carry_through_field;
use firn_flow::random;
use glam::{IVec3, Vec3};
use rayon::prelude::*;

use crate::contact::PlacedCollider;
use crate::grid::Grid;
use crate::particles::Particles;
use crate::wind::AirDrag;

/// Snow carried by the air: the drift particles, structure of arrays.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Drift {
    /// Positions x.
    pub position: Vec<Vec3>,
    /// Velocities over the last substep: the air's plus the fall speed.
    pub velocity: Vec<Vec3>,
    /// Masses m_p, unchanged from the snow particle each one was.
    pub mass: Vec<f32>,
    /// Volumes V_p⁰ J_p at detachment: the initial volume each settles back
    /// with, so that it lands at the density it lifted at.
    pub volume: Vec<f32>,
    /// Material index of the snow each one was.
    pub material: Vec<u16>,
}

impl Drift {
    /// Number of drift particles.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// Whether there is no drift.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Whether every array has one entry per particle.
    pub fn is_consistent(&self) -> bool {
        let count = self.len();
        [
            self.velocity.len(),
            self.mass.len(),
            self.volume.len(),
            self.material.len(),
        ]
        .iter()
        .all(|&len| len == count)
    }

    /// Σ m_p over the drift, in f64, in particle order.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().fold(0.0, |sum, &m| sum + f64::from(m))
    }

    /// Appends a particle.
    fn push(&mut self, position: Vec3, velocity: Vec3, mass: f32, volume: f32, material: u16) {
        self.position.push(position);
        self.velocity.push(velocity);
        self.mass.push(mass);
        self.volume.push(volume);
        self.material.push(material);
    }

    /// Keeps the particles for which `keep` (by index) is true, in order.
    fn retain_indices(&mut self, keep: &[bool]) {
        fn retain<T>(values: &mut Vec<T>, keep: &[bool]) {
            let mut index = 0;
            values.retain(|_| {
                index += 1;
                keep[index - 1]
            });
        }
        retain(&mut self.position, keep);
        retain(&mut self.velocity, keep);
        retain(&mut self.mass, keep);
        retain(&mut self.volume, keep);
        retain(&mut self.material, keep);
    }
}

/// Drift that the wind carried out of the domain: how many particles and
/// their mass, summed in f64 in the order they left.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Escaped {
    /// Particles that left.
    pub count: u64,
    /// Their mass, kg.
    pub mass: f64,
}

/// Where a drift particle ends a substep.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fate {
    /// Still in the air.
    Flying,
    /// Its step went into a collider or through a floor: it lands at its
    /// position before the step.
    Landed,
    /// Its step left the domain through a wall that is not a floor.
    Left,
}

/// What one substep of spindrift works with.
pub struct SpindriftStep<'a> {
    /// The scene's spindrift settings.
    pub settings: &'a Spindrift,
    /// The wind's drag law and field.
    pub drag: &'a AirDrag,
    /// The scene's colliders (not the domain walls), placed at the end of
    /// the substep.
    pub colliders: &'a [PlacedCollider],
    /// The simulation domain.
    pub domain: &'a Domain,
    /// Gravity, m/s²: the drift falls along it.
    pub gravity: Vec3,
    /// Simulated time at the start and the end of the substep.
    pub interval: (f64, f64),
    /// Index of the substep (part of each particle's draw).
    pub substep: u64,
    /// The wind field's seed (part of each particle's draw).
    pub seed: u64,
    /// How the drift is moved through the field (the wind's integrator).
    pub integrator: FlowIntegrator,
    /// ρ₀ of each of the scene's materials, kg/m³.
    pub material_densities: &'a [f32],
}

impl SpindriftStep<'_> {
    /// ρ_p = ρ₀ / J of snow particle `p` (S1): its material's density over
    /// its volume ratio J = J_E J_P. Equal to m_p / (V_p⁰ J) where V_p⁰ is
    /// the material's, not step 2's estimate from the grid, which is up to
    /// half as large at a surface (the grid's density falls off over a cell
    /// there) and would make the surface of any snow look loose.
    fn density(&self, snow: &Particles, p: usize) -> f32 {
        let j = snow.elastic[p].determinant() * snow.plastic_j[p];
        self.material_densities[snow.material[p] as usize] / j
    }

    /// Δt of the substep, s.
    fn dt(&self) -> f32 {
        (self.interval.1 - self.interval.0) as f32
    }

    /// Whether a step from inside the domain to `to` went into a collider or
    /// through a floor, out through another wall, or neither.
    fn fate(&self, to: Vec3) -> Fate {
        let (min, max) = (self.domain.min, self.domain.max);
        for axis in 0..3 {
            let through_floor = (self.gravity[axis] < 0.0 && to[axis] < min[axis])
                || (self.gravity[axis] > 0.0 && to[axis] > max[axis]);
            if through_floor {
                return Fate::Landed;
            }
        }
        if self
            .colliders
            .iter()
            .any(|collider| collider.signed_distance(to).0 <= 0.0)
        {
            return Fate::Landed;
        }
        if to.cmpge(min).all() && to.cmple(max).all() {
            Fate::Flying
        } else {
            Fate::Left
        }
    }
}

/// Step 1 of a substep: moves the drift by equation S3 and settles its
/// landings. Drift that left the domain is counted in `escaped` and
/// dropped; drift that landed rests at its position before the step, and
/// with `settle` leaves the drift for the end of `snow`, at rest and
/// undeformed.
pub fn carry(step: &SpindriftStep, drift: &mut Drift, escaped: &mut Escaped, snow: &mut Particles) {
    if drift.is_empty() {
        return;
    }
    let before = drift.position.clone();
    carry_through_field(
        step.drag.simd(),
        step.drag.field(),
        step.integrator,
        step.interval,
        &mut drift.position,
        &mut drift.velocity,
    );
    let fall = step.gravity.normalize_or_zero() * step.settings.fall_speed;
    let dt = step.dt();
    let fates: Vec<Fate> = drift
        .position
        .par_iter_mut()
        .zip(drift.velocity.par_iter_mut())
        .map(|(position, velocity)| {
            *position += fall * dt;
            *velocity += fall;
            step.fate(*position)
        })
        .collect();
    let mut keep = vec![true; drift.len()];
    for (p, fate) in fates.iter().enumerate() {
        match fate {
            Fate::Flying => {}
            Fate::Left => {
                escaped.count += 1;
                escaped.mass += f64::from(drift.mass[p]);
                keep[p] = false;
            }
            Fate::Landed if step.settings.settle => {
                snow.push_undeformed(
                    before[p],
                    Vec3::ZERO,
                    drift.mass[p],
                    drift.volume[p],
                    drift.material[p],
                );
                keep[p] = false;
            }
            Fate::Landed => {
                drift.position[p] = before[p];
                drift.velocity[p] = Vec3::ZERO;
            }
        }
    }
    drift.retain_indices(&keep);
}

/// Step 2 of a substep: the snow particles that lift (S1, S2), moved from
/// `snow` to the end of `drift` in particle order; returns how many.
/// `grid` holds the substep's node masses (the exposure of equation W2).
pub fn detach(step: &SpindriftStep, grid: &Grid, snow: &mut Particles, drift: &mut Drift) -> usize {
    let settings = step.settings;
    let dt = step.dt();
    let most_likely = 1.0 - exp(-settings.rate * dt);
    if most_likely <= 0.0 || most_likely.is_nan() {
        return 0;
    }
    let layout = grid.layout;
    let lifting: Vec<usize> = (0..snow.len())
        .into_par_iter()
        .filter(|&p| {
            let draw = draw(step.seed, step.substep, snow.position[p]);
            if draw >= most_likely || step.density(snow, p) >= settings.loose_density {
                return false;
            }
            let position = snow.position[p];
            let wind = step.drag.wind_at(position, step.interval.1);
            let relative = wind - snow.velocity[p];
            if relative.length() <= settings.threshold_speed {
                return false;
            }
            let node = layout.to_grid(position).round().as_ivec3();
            let exposure = surface_exposure(step, grid, node, relative);
            exposure > 0.0 && draw < 1.0 - exp(-settings.rate * exposure * dt)
        })
        .collect();
    for &p in &lifting {
        let volume = snow.mass[p] / snow.density(p);
        drift.push(
            snow.position[p],
            snow.velocity[p],
            snow.mass[p],
            volume,
            snow.material[p],
        );
    }
    snow.remove_sorted(&lifting);
    lifting.len()
}

/// The share of a node's own mass that a neighbour must hold to shelter it
/// fully: inside snow the node masses differ by the sampling's noise, which
/// must not read as exposure.
const SHELTERING_SHARE: f32 = 0.5;

/// e_p of equation S1 at grid node `node` for the relative wind `relative`:
/// the larger of the node's exposures (W2, [`AirDrag::exposure`]) against
/// the relative wind and from above (against gravity), each measured
/// against half the node's own mass ([`SHELTERING_SHARE`]), so that 0 inside snow of any density and in
/// the lee, 1 on a face the wind meets and on open snow under the sky.
fn surface_exposure(step: &SpindriftStep, grid: &Grid, node: IVec3, relative: Vec3) -> f32 {
    let own = grid.node_mass(node);
    if own <= 0.0 || own.is_nan() {
        return 0.0;
    }
    let sheltering = SHELTERING_SHARE * own;
    let mass_at = |node: IVec3| grid.node_mass(node);
    let windward = step.drag.exposure(node, relative, sheltering, mass_at);
    let from_above = step.drag.exposure(node, step.gravity, sheltering, mass_at);
    windward.unwrap_or(0.0).max(from_above.unwrap_or(0.0))
}

/// ξ_p of equation S2: a uniform number in [0, 1) from the wind's seed, the
/// substep and the bits of the particle's position, so that it depends on
/// the particle's own state alone.
fn draw(seed: u64, substep: u64, position: Vec3) -> f32 {
    let xy = u64::from(position.x.to_bits()) | u64::from(position.y.to_bits()) << 32;
    random::unit(seed, xy, substep, u64::from(position.z.to_bits()))
}

//! Totals over the particles (mass, momentum, angular momentum, centre of
//! mass, kinetic energy), the quantities the conservation tests hold.

use firn_core::scene::Transfer;

use crate::particles::Particles;

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

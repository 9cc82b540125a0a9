//! 64-bit fixed-point grid sums from 32-bit integer atomics.
//!
//! WGSL has no portable float atomics (the thesis avoided vendor-only float
//! atomics for the same reason, §6.1), so the scatter converts each
//! contribution x to the integer round(x S) and adds it into two 32-bit
//! words: the low word with `atomicAdd`, whose returned old value tells if
//! it carried, then the signed high word plus that carry. Integer addition
//! is associative, so a node's sum does not depend on the order in which
//! the GPU runs the particles: the GPU backend is deterministic run to run.
//!
//! Scales (`shaders/snow/fixed_point.wgsl` applies them):
//!
//! - mass: S_m = 2^40 / (ρ_max h³), so a node holding the mass of a cell of
//!   the densest material at rest is 2^40 units: sums resolve 2^-40 of it and
//!   overflow only past 2^23 times that density;
//! - momentum and the PIC/FLIP force impulse Δt f_i: S_p = S_m / (1 m/s),
//!   overflowing only at about 2^23 m/s times the rest-density mass.
//!
//! Every high-word addition checks whether the signed sum wrapped; if one
//! did, the substep's state carries a flag and the run stops with
//! [`crate::GpuError::Overflow`] instead of continuing from garbage.

use firn_core::Scene;

/// Fixed-point units per unit of mass at the scale's reference, 2^40.
pub const MASS_UNITS: f64 = (1u64 << 40) as f64;

/// The headroom of a 64-bit signed sum over the reference, 2^63 / 2^40.
pub const HEADROOM: f64 = (1u64 << 23) as f64;

/// Units per kilogram and per kg·m/s for a scene's densest material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    /// S_m, units per kilogram.
    pub mass: f32,
    /// S_p, units per kg·m/s.
    pub momentum: f32,
}

impl Scales {
    /// The scales for `scene` (see the module documentation).
    pub fn of(scene: &Scene) -> Scales {
        let density = scene
            .materials
            .iter()
            .map(|material| f64::from(material.density))
            .fold(1.0, f64::max);
        let cell_volume = f64::from(scene.domain.cell_size).powi(3);
        let mass = MASS_UNITS / (density * cell_volume);
        Scales {
            mass: mass as f32,
            momentum: mass as f32,
        }
    }

    /// The node speed (m/s) at which a momentum sum of a rest-density node overflows.
    pub fn speed_limit(&self) -> f64 {
        HEADROOM * f64::from(self.mass) / f64::from(self.momentum)
    }
}

/// Names of the grid quantities by overflow bit, as the kernels number them.
pub const QUANTITY_NAMES: [&str; 7] = [
    "mass",
    "momentum x",
    "momentum y",
    "momentum z",
    "force impulse x",
    "force impulse y",
    "force impulse z",
];

//! Where a substep's time goes: wall-clock seconds per phase of the MPM
//! step, summed over substeps, for `firn bench --phases`.
//!
//! The phases follow the loops of [`crate::Simulation::step`]. Some steps of
//! the thesis' algorithm (§3.4) share one loop, because fusing them saves a
//! pass over memory, so they share one phase:
//! - `binning`: sorting particles into grid blocks (and reordering them);
//! - `scatter`: particle-to-grid transfer of mass, momentum and stress
//!   (steps 1 and 3);
//! - `colliders`: placing the colliders at the substep's end (and building
//!   a deforming mesh's distance fields when the run reaches a mesh frame);
//! - `grid_update`: grid velocities from momentum and forces, gravity and
//!   grid collisions (steps 4 and 5);
//! - `implicit_solve`: the semi-implicit velocity solve (step 6), zero with
//!   the explicit integrator;
//! - `gather`: grid-to-particle transfer, deformation gradient update,
//!   plasticity and stress, particle collisions and advection (steps 7 to
//!   10);
//! - `clear`: zeroing the grid blocks the substep touched;
//! - `rigid_bodies`: placing the rigid bodies for the grid and stepping
//!   them in rapier with what the snow gave them (their contacts with the
//!   nodes are in `grid_update`), zero without bodies.

use std::time::Instant;

/// Seconds spent in each phase since the profile was last reset.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhaseTimes {
    /// Binning and reordering particles.
    pub binning: f64,
    /// Particle-to-grid transfer.
    pub scatter: f64,
    /// Placing the colliders, deforming meshes' field rebuilds included.
    pub colliders: f64,
    /// Grid velocity update and grid collisions.
    pub grid_update: f64,
    /// Semi-implicit solve.
    pub implicit_solve: f64,
    /// Grid-to-particle transfer, plasticity, particle collisions, advection.
    pub gather: f64,
    /// Clearing the touched grid blocks.
    pub clear: f64,
    /// Placing and stepping the rigid bodies.
    pub rigid_bodies: f64,
}

impl PhaseTimes {
    /// Each phase's name and seconds, in the order a substep runs them.
    pub fn entries(&self) -> [(&'static str, f64); 8] {
        [
            ("binning", self.binning),
            ("scatter", self.scatter),
            ("colliders", self.colliders),
            ("grid_update", self.grid_update),
            ("implicit_solve", self.implicit_solve),
            ("gather", self.gather),
            ("clear", self.clear),
            ("rigid_bodies", self.rigid_bodies),
        ]
    }

    /// Seconds in all phases together.
    pub fn total(&self) -> f64 {
        self.entries().iter().map(|(_, seconds)| seconds).sum()
    }
}

/// A stopwatch that charges the time since its last lap to a phase.
pub(crate) struct PhaseClock {
    last: Instant,
}

impl PhaseClock {
    /// Starts timing now.
    pub(crate) fn start() -> PhaseClock {
        PhaseClock {
            last: Instant::now(),
        }
    }

    /// Adds the seconds since the last lap to `phase` and starts the next lap.
    pub(crate) fn lap(&mut self, phase: &mut f64) {
        let now = Instant::now();
        *phase += (now - self.last).as_secs_f64();
        self.last = now;
    }
}

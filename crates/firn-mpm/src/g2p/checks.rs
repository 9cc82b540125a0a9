//! The gather's checks: the fastest particle and elastic wave (for the
//! next Δt) and the first particle in trouble (a position, velocity or
//! deformation gone non-finite, or a particle out of the domain), merged
//! across blocks in an order that does not depend on the thread count.

use firn_core::math::lanes::U32s;
use glam::Vec3;

use super::BATCH;

/// What the gather learned about the particles, for the next Δt and for
/// catching a simulation that blows up.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GatherStats {
    /// Largest |v_p|².
    pub max_speed_squared: f32,
    /// Largest squared elastic wave speed, hardening included.
    pub max_wave_speed_squared: f32,
    /// The first particle in trouble (the lowest
    /// [`ParticleProblem::order`]), if any.
    pub problem: Option<ParticleProblem>,
}

/// A particle whose state went wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleProblem {
    /// Particle index.
    pub particle: usize,
    /// The particle's place in the whole run's order: its index, or in a
    /// part of a split run its key ([`UpdateContext::keys`]).
    pub order: u64,
    /// What went wrong.
    pub kind: ProblemKind,
    /// Where the particle was.
    pub position: Vec3,
}

/// Kinds of particle trouble.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProblemKind {
    /// Position, velocity or deformation became NaN or infinite.
    NonFinite,
    /// The particle moved outside the domain.
    LeftDomain,
}

impl GatherStats {
    /// Combines two partial results; order-independent, hence deterministic.
    #[inline(always)]
    pub(super) fn merge(self, other: GatherStats) -> GatherStats {
        let problem = match (self.problem, other.problem) {
            (Some(a), Some(b)) => Some(if a.order <= b.order { a } else { b }),
            (a, b) => a.or(b),
        };
        GatherStats {
            max_speed_squared: self.max_speed_squared.max(other.max_speed_squared),
            max_wave_speed_squared: self
                .max_wave_speed_squared
                .max(other.max_wave_speed_squared),
            problem,
        }
    }
}

/// Why lane `lane`, which failed a check, is in trouble.
#[inline(always)]
pub(super) fn problem_kind(finite: U32s<BATCH>, lane: usize) -> ProblemKind {
    if finite.0[lane] == 0 {
        ProblemKind::NonFinite
    } else {
        ProblemKind::LeftDomain
    }
}

//! The AVX2 path of the gather's matrices: ∇v_p and F_E into the SIMD
//! lanes and the new F_E and V_p^0 τ_p out of them, eight particles per
//! 8x8 transpose.

use std::ops::Range;

use firn_core::math::isa::Avx2;

use super::{BATCH, Interpolated};
use crate::disjoint::{BlockParticles, ParticleMatrix};
use crate::snow_model::ElasticUpdate;

/// Loads the batch's ∇v_p (stored by the interpolation) and F_E into the
/// lanes, eight particles per transpose; lanes past the batch's end repeat
/// its last particle, so they stay finite.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn load_matrices(
    avx2: Avx2,
    particles: &BlockParticles,
    batch: Range<usize>,
    interpolated: &mut Interpolated,
) {
    let last = batch.end - 1;
    for first in (0..batch.len()).step_by(8) {
        let places = std::array::from_fn(|lane| (batch.start + first + lane).min(last));
        avx2.load_eight(
            &mut interpolated.velocity_gradient,
            first,
            particles.matrices(ParticleMatrix::VelocityGradient, places),
        );
        avx2.load_eight(
            &mut interpolated.elastic,
            first,
            particles.matrices(ParticleMatrix::Elastic, places),
        );
    }
}

/// Stores the batch's new F_E and V_p^0 τ_p from the lanes, eight particles
/// per transpose.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn store_matrices(
    avx2: Avx2,
    particles: &mut BlockParticles,
    batch: Range<usize>,
    update: &ElasticUpdate<BATCH>,
) {
    for first in (0..batch.len()).step_by(8) {
        let places = batch.start + first..batch.end.min(batch.start + first + 8);
        avx2.store_eight(
            &update.elastic,
            first,
            particles.matrices_mut(ParticleMatrix::Elastic, places.clone()),
        );
        avx2.store_eight(
            &update.stress,
            first,
            particles.matrices_mut(ParticleMatrix::Stress, places),
        );
    }
}

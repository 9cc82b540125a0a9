//! Helpers the rank tests share.

use firn_mpm::Particles;

/// Every attribute's bits, in array order.
pub fn bits(particles: &Particles) -> Vec<u32> {
    let mut all = Vec::new();
    let vectors = [&particles.position, &particles.velocity];
    for vector in vectors {
        all.extend(vector.iter().flat_map(|v| v.to_array()).map(f32::to_bits));
    }
    for matrices in [
        &particles.elastic,
        &particles.stress,
        &particles.velocity_gradient,
    ] {
        all.extend(
            matrices
                .iter()
                .flat_map(|m| m.to_cols_array())
                .map(f32::to_bits),
        );
    }
    for scalars in [&particles.mass, &particles.volume0, &particles.plastic_j] {
        all.extend(scalars.iter().map(|s| s.to_bits()));
    }
    all
}

//! Counter-based random numbers: every draw is a hash of (seed, particle id,
//! generation, stream), so no generator state is shared between particles or
//! threads, and a particle's random numbers do not depend on the order in
//! which particles are processed or on the thread count.

/// Mixes 64 bits so that each output bit depends on every input bit
/// (a multiply-xorshift finaliser, as in SplitMix64).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed's part of every draw: the first step of [`bits`], which the GPU
/// backend takes once on the host.
#[inline]
pub fn seed_key(seed: u64) -> u64 {
    mix64(seed ^ 0x9E37_79B9_7F4A_7C15)
}

/// 64 random bits for draw `stream` of life `generation` of particle `id`.
#[inline]
pub fn bits(seed: u64, id: u64, generation: u64, stream: u64) -> u64 {
    let mut h = seed_key(seed);
    h = mix64(h ^ id.wrapping_mul(0xD6E8_FEB8_6659_FD93));
    h = mix64(h ^ generation.wrapping_mul(0xA076_1D64_78BD_642F));
    mix64(h ^ stream.wrapping_mul(0xE703_7ED1_A0B4_28DB))
}

/// A uniform number in [0, 1) with 24 random bits (exact in `f32`).
#[inline]
pub fn unit(seed: u64, id: u64, generation: u64, stream: u64) -> f32 {
    (bits(seed, id, generation, stream) >> 40) as f32 * (1.0 / 16_777_216.0)
}

/// A uniform number in [0, 1) with 53 random bits.
#[inline]
pub fn unit_f64(seed: u64, id: u64, generation: u64, stream: u64) -> f64 {
    (bits(seed, id, generation, stream) >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_uniform_and_independent_of_each_input() {
        let mut buckets = [0u32; 10];
        for id in 0..10_000 {
            let u = unit(7, id, 0, 0);
            assert!((0.0..1.0).contains(&u));
            buckets[(u * 10.0) as usize] += 1;
        }
        assert!(
            buckets.iter().all(|b| (850..1150).contains(b)),
            "{buckets:?}"
        );
        assert_ne!(bits(1, 2, 3, 4), bits(2, 2, 3, 4));
        assert_ne!(bits(1, 2, 3, 4), bits(1, 3, 3, 4));
        assert_ne!(bits(1, 2, 3, 4), bits(1, 2, 4, 4));
        assert_ne!(bits(1, 2, 3, 4), bits(1, 2, 3, 5));
        assert_eq!(bits(1, 2, 3, 4), bits(1, 2, 3, 4));
    }
}

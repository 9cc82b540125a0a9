//! Particles on the wire: each particle as [`WORDS_PER_PARTICLE`] 32-bit
//! words (its key, then every attribute's bits), so that what arrives is
//! bit for bit what left.

use firn_mpm::Particles;
use glam::{Mat3, Vec3};

use crate::exchange::{join_u64, split_u64};

/// Words per particle: the key (2), position and velocity (3 each), mass,
/// V⁰, J_P and the material (1 each), F_E, V⁰τ and ∇v (9 each).
pub const WORDS_PER_PARTICLE: usize = 2 + 3 + 3 + 1 + 1 + 9 + 1 + 9 + 9 + 1;

/// Particles with their keys: each particle's place in the one-process
/// array, which orders them the same way on every rank.
#[derive(Clone, Debug, Default)]
pub struct KeyedParticles {
    /// The particles.
    pub particles: Particles,
    /// One key per particle.
    pub keys: Vec<u64>,
}

impl KeyedParticles {
    /// How many particles.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Appends particle `p` of `self` to `words`.
    pub fn pack(&self, p: usize, words: &mut Vec<u32>) {
        pack(&self.particles, self.keys[p], p, words);
    }

    /// Appends every particle packed in `words` (whole records only).
    pub fn unpack(&mut self, words: &[u32]) {
        assert!(
            words.len().is_multiple_of(WORDS_PER_PARTICLE),
            "a particle message of {} words is not whole records",
            words.len()
        );
        let particles = &mut self.particles;
        for record in words.chunks_exact(WORDS_PER_PARTICLE) {
            let mut reader = record.iter().copied();
            let mut next = || reader.next().expect("record length checked");
            let high = next();
            self.keys.push(join_u64(high, next()));
            particles.position.push(read_vec3(&mut next));
            particles.velocity.push(read_vec3(&mut next));
            particles.mass.push(f32::from_bits(next()));
            particles.volume0.push(f32::from_bits(next()));
            particles.elastic.push(read_mat3(&mut next));
            particles.plastic_j.push(f32::from_bits(next()));
            particles.stress.push(read_mat3(&mut next));
            particles.velocity_gradient.push(read_mat3(&mut next));
            particles.material.push(next() as u16);
        }
    }

    /// Removes particle `p`, putting the last particle in its place.
    pub fn swap_remove(&mut self, p: usize) {
        let particles = &mut self.particles;
        self.keys.swap_remove(p);
        particles.position.swap_remove(p);
        particles.velocity.swap_remove(p);
        particles.mass.swap_remove(p);
        particles.volume0.swap_remove(p);
        particles.elastic.swap_remove(p);
        particles.plastic_j.swap_remove(p);
        particles.stress.swap_remove(p);
        particles.velocity_gradient.swap_remove(p);
        particles.material.swap_remove(p);
    }

    /// Reorders the particles so that new place `i` holds old particle
    /// `order[i]`; an `order` that leaves places out drops those particles.
    pub fn permute(&mut self, order: &[u32], buffers: &mut firn_mpm::PermuteBuffers) {
        self.particles.permute(order, buffers);
        self.keys = order.iter().map(|&p| self.keys[p as usize]).collect();
    }

    /// Sorts the particles by key (keys are distinct).
    pub fn sort_by_key(&mut self, buffers: &mut firn_mpm::PermuteBuffers) {
        if self.keys.is_sorted() {
            return;
        }
        let mut order: Vec<u32> = (0..self.len() as u32).collect();
        order.sort_unstable_by_key(|&p| self.keys[p as usize]);
        self.permute(&order, buffers);
    }
}

/// Appends particle `p` of `particles`, with key `key`, to `words`.
pub fn pack(particles: &Particles, key: u64, p: usize, words: &mut Vec<u32>) {
    words.extend(split_u64(key));
    push_vec3(words, particles.position[p]);
    push_vec3(words, particles.velocity[p]);
    words.push(particles.mass[p].to_bits());
    words.push(particles.volume0[p].to_bits());
    push_mat3(words, particles.elastic[p]);
    words.push(particles.plastic_j[p].to_bits());
    push_mat3(words, particles.stress[p]);
    push_mat3(words, particles.velocity_gradient[p]);
    words.push(u32::from(particles.material[p]));
}

fn push_vec3(words: &mut Vec<u32>, v: Vec3) {
    words.extend(v.to_array().map(f32::to_bits));
}

fn push_mat3(words: &mut Vec<u32>, m: Mat3) {
    words.extend(m.to_cols_array().map(f32::to_bits));
}

fn read_vec3(next: &mut impl FnMut() -> u32) -> Vec3 {
    Vec3::from_array(std::array::from_fn(|_| f32::from_bits(next())))
}

fn read_mat3(next: &mut impl FnMut() -> u32) -> Mat3 {
    Mat3::from_cols_array(&std::array::from_fn(|_| f32::from_bits(next())))
}

/// Bytes on the wire: their count, then four to a word (little-endian,
/// the last word padded with zeros).
pub fn bytes_to_words(bytes: &[u8]) -> Vec<u32> {
    let mut words = Vec::with_capacity(1 + bytes.len().div_ceil(4));
    words.push(bytes.len() as u32);
    words.extend(bytes.chunks(4).map(|chunk| {
        let mut word = [0u8; 4];
        word[..chunk.len()].copy_from_slice(chunk);
        u32::from_le_bytes(word)
    }));
    words
}

/// The bytes [`bytes_to_words`] put into `words`.
pub fn words_to_bytes(words: &[u32]) -> Vec<u8> {
    let (&count, words) = words.split_first().expect("a byte count first");
    let mut bytes: Vec<u8> = words.iter().flat_map(|word| word.to_le_bytes()).collect();
    bytes.truncate(count as usize);
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_packed_particle_arrives_bit_for_bit() {
        let mut sent = KeyedParticles::default();
        let odd = f32::from_bits(0x7fc0_1234);
        let mut words = Vec::new();
        sent.keys.push(u64::MAX - 7);
        let p = &mut sent.particles;
        p.position.push(Vec3::new(1.0, -0.0, odd));
        p.velocity.push(Vec3::new(3.5, 1e-38, -2.0));
        p.mass.push(0.25);
        p.volume0.push(1e-6);
        p.elastic
            .push(Mat3::from_cols_array(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]));
        p.plastic_j.push(0.9);
        p.stress.push(Mat3::IDENTITY * -3.0);
        p.velocity_gradient.push(Mat3::ZERO);
        p.material.push(65535);
        sent.pack(0, &mut words);
        assert_eq!(words.len(), WORDS_PER_PARTICLE);
        let mut received = KeyedParticles::default();
        received.unpack(&words);
        assert_eq!(received.keys, sent.keys);
        let (a, b) = (&received.particles, &sent.particles);
        assert_eq!(
            a.position[0].to_array().map(f32::to_bits),
            b.position[0].to_array().map(f32::to_bits)
        );
        assert_eq!(a.elastic, b.elastic);
        assert_eq!(a.material, b.material);
        assert_eq!(a.velocity, b.velocity);
    }

    #[test]
    fn bytes_come_back_whole_at_any_length() {
        for length in 0..9 {
            let bytes: Vec<u8> = (0..length).map(|b: u8| b * 29 + 1).collect();
            assert_eq!(words_to_bytes(&bytes_to_words(&bytes)), bytes);
        }
    }
}

//! Clumpy snow (`clumps = { size, contrast }` on a `[[bodies]]` table): a
//! body packed unevenly, in clumps joined by looser seams, as hand-packed
//! snow is.
//!
//! A uniform body of Stomakhin's snow only compacts where it is hit: every
//! particle hardens alike, so a snowball squashes into one lens and stays
//! whole. Real snowballs break along the weak bonds between the lumps they
//! were packed from. firn gives a body that structure through its initial
//! plastic state, which the model already has, so nothing else changes:
//!
//! - Clump centres are the sites of a jittered lattice of spacing `size`
//!   (one site per lattice cube, placed by a hash of the cube and the body's
//!   seed). A particle belongs to its nearest site's clump (a Voronoi cell).
//! - Its distance to the seam, the plane halfway between the nearest and the
//!   second-nearest site, is d = (F2² − F1²) / (2 |s2 − s1|), with F1, F2
//!   the distances to those sites.
//! - The seam share σ = 1 − smoothstep(0, w, d) with w = [`SEAM_WIDTH`] ×
//!   `size` is 1 on a seam and 0 inside a clump.
//! - The initial plastic volume ratio is J_P⁰ = exp(c (2σ − 1)) with c the
//!   `contrast`: clumps start compacted (J_P⁰ = e^−c, denser by e^c and,
//!   through the hardening e^{ξ(1 − J_P)}, stiffer), seams start loose.
//!
//! The particle stands for the same lattice volume s³ as without clumps, at
//! density ρ₀ / J_P⁰: its mass is ρ₀ s³ / J_P⁰ (see
//! [`crate::scene::sampling`]). Written by hand: no maintained crate gives
//! a seeded, f32-exact Voronoi seam distance with the bit-for-bit
//! reproducibility the solver promises, and it is a few lines.

use glam::{IVec3, Vec3};
use serde::{Deserialize, Serialize};

/// Width of the loose seam between two clumps, as a share of the clump size.
pub const SEAM_WIDTH: f32 = 0.2;

/// Largest `contrast`: e^0.5 ≈ 1.65 times looser seams than the body's
/// density, and 1.65 times denser clumps.
pub const MAX_CONTRAST: f32 = 0.5;

/// How a body's snow is packed in clumps (`clumps` on a `[[bodies]]` table).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clumps {
    /// Typical clump diameter, m (the spacing of the clump centres).
    pub size: f32,
    /// c: the natural log of how much denser clump interiors start than the
    /// material's density (and seams looser), 0 to [`MAX_CONTRAST`].
    pub contrast: f32,
}

impl Clumps {
    /// Initial plastic volume ratio J_P⁰ at `position` of a body whose
    /// clump sites come from `seed`.
    pub fn plastic_j(&self, seed: u64, position: Vec3) -> f32 {
        let seam = seam_share(self.size, seed, position);
        (self.contrast * (2.0 * seam - 1.0)).exp()
    }
}

/// σ: 1 on the seam between two clumps, falling to 0 at [`SEAM_WIDTH`] ×
/// `size` from it.
fn seam_share(size: f32, seed: u64, position: Vec3) -> f32 {
    let scaled = position / size;
    let cube = scaled.floor().as_ivec3();
    let mut nearest = (f32::INFINITY, Vec3::ZERO);
    let mut second = (f32::INFINITY, Vec3::ZERO);
    for dz in -1..=1 {
        for dy in -1..=1 {
            for dx in -1..=1 {
                let site = site_of(cube + IVec3::new(dx, dy, dz), seed);
                let distance_squared = (site - scaled).length_squared();
                if distance_squared < nearest.0 {
                    second = nearest;
                    nearest = (distance_squared, site);
                } else if distance_squared < second.0 {
                    second = (distance_squared, site);
                }
            }
        }
    }
    let gap = (second.1 - nearest.1).length();
    let to_seam = (second.0 - nearest.0) / (2.0 * gap);
    1.0 - smoothstep(to_seam / SEAM_WIDTH)
}

/// The clump site of lattice cube `cube`: a point inside it, placed by a
/// hash of the cube and the seed.
fn site_of(cube: IVec3, seed: u64) -> Vec3 {
    let hash = mix(seed
        ^ mix(cube.x as u32 as u64)
        ^ mix((cube.y as u32 as u64) << 21)
        ^ mix((cube.z as u32 as u64) << 42));
    let unit = |bits: u64| (bits & 0xFF_FFFF) as f32 / 16_777_216.0;
    cube.as_vec3() + Vec3::new(unit(hash), unit(hash >> 21), unit(hash >> 42))
}

/// SplitMix64's finaliser: a 64-bit mix with good avalanche.
fn mix(value: u64) -> u64 {
    let mut z = value.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 3t² − 2t³ on t clamped to [0, 1].
fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CLUMPS: Clumps = Clumps {
        size: 0.05,
        contrast: 0.2,
    };

    fn samples() -> impl Iterator<Item = Vec3> {
        (0..4000).map(|i| {
            let t = i as f32;
            Vec3::new(
                (t * 0.618_034).fract(),
                (t * 0.414_214).fract(),
                (t * 0.732_051).fract(),
            ) * 0.4
        })
    }

    #[test]
    fn packing_stays_between_the_clump_and_the_seam_values() {
        let (low, high) = ((-CLUMPS.contrast).exp(), CLUMPS.contrast.exp());
        let values: Vec<f32> = samples().map(|x| CLUMPS.plastic_j(7, x)).collect();
        assert!(
            values
                .iter()
                .all(|&j| j >= low * 0.9999 && j <= high * 1.0001)
        );
        let compacted = values.iter().filter(|&&j| j < 0.9).count();
        let loose = values.iter().filter(|&&j| j > 1.1).count();
        assert!(
            compacted > values.len() / 3,
            "clump interiors: {compacted} of {}",
            values.len()
        );
        assert!(
            loose > values.len() / 50,
            "seams: {loose} of {}",
            values.len()
        );
    }

    #[test]
    fn the_seed_moves_the_clumps() {
        let differ = samples()
            .filter(|&x| CLUMPS.plastic_j(1, x) != CLUMPS.plastic_j(2, x))
            .count();
        assert!(differ > 1000, "{differ} of 4000 samples changed");
    }

    #[test]
    fn a_point_on_a_site_lies_inside_its_clump() {
        let site = site_of(IVec3::new(3, 1, 2), 9) * CLUMPS.size;
        let j = CLUMPS.plastic_j(9, site);
        assert!(j < 0.9, "J_P at a clump centre: {j}");
    }
}

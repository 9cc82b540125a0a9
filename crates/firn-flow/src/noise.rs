//! 3D simplex noise with its analytic gradient (the noise n of seed 002,
//! eq. 1; Gustavson's simplex noise, extended with the gradient of each
//! corner's contribution as the "Known-good approaches" of the spec suggest).
//!
//! Space is skewed so that the cubic lattice becomes a lattice of
//! tetrahedra (simplices); a point gets contributions from the four corners of
//! the simplex it lies in. Corner c, at offset d from the point, adds
//!
//! ```text
//! n_c = t⁴ (g_c · d),   t = max(0, r² − |d|²),   r² = 1/2
//! ∇n_c = t⁴ g_c − 8 t³ (g_c · d) d
//! ```
//!
//! with a pseudo-random gradient g_c from a hash of the corner's lattice
//! coordinates. r² = 1/2 (not Gustavson's 0.6) keeps every kernel inside the
//! simplices around its corner, so the noise is continuous with three
//! continuous derivatives: the curl field built on it is then exactly
//! divergence-free, with no seams along simplex faces.
//!
//! No branches on values (comparisons select), and the hash is arithmetic (no
//! permutation table), so the same code runs on lanes of a SIMD register
//! ([`crate::lanes`]) and ports to a GPU shader as it is.

use glam::{DVec3, Vec3};

use crate::lanes::{F32s, Real, V3};

/// Skew factor of the 3D simplex lattice, (√(3+1) − 1) / 3.
const SKEW: f64 = 1.0 / 3.0;
/// Unskew factor, (1 − 1/√(3+1)) / 3.
const UNSKEW: f64 = 1.0 / 6.0;
/// Squared radius of each corner's kernel.
const RADIUS_SQUARED: f64 = 0.5;
/// Scales the sum to about [−1, 1] (measured: with this factor the largest
/// |n| over 10⁷ random points in a box of 1000 cells is 0.988 and the root
/// mean square 0.39, with the one-multiply hash as with the two-multiply one
/// before it; the test `noise_scale_keeps_the_noise_just_inside_one` repeats
/// the measurement on 10⁶ points).
pub const NOISE_SCALE: f64 = 76.0;

/// Odd multipliers of the lattice coordinates in the hash.
const HASH_X: u32 = 0x8DA6_B343;
const HASH_Y: u32 = 0xD816_3841;
const HASH_Z: u32 = 0xCB1A_B31F;

/// The finaliser's odd multiplier.
const MIX_MULTIPLIER: u32 = 0x7FEB_352D;

/// A xorshift-multiply-xorshift finaliser, one multiply: the first shift
/// folds the high bits of the lattice products (which depend on all the bits
/// of the coordinates) into the low ones, the multiply carries every low bit
/// upwards, and the last shift folds the well-mixed high bits back down onto
/// the bits the gradient reads (the low 16 and bits 16, 17). The shifts 15
/// and 13 were chosen by the same statistics as a two-multiply finaliser
/// passes: even shares of the twelve gradients and no correlation between the
/// gradients of lattice points up to 32 cells apart (χ² of the 12 × 12 pair
/// counts), in blocks of 48³ cells around the origin and far from it.
#[inline(always)]
fn mix<R: Real>(mut h: R::Int) -> R::Int {
    h = R::int_xor(h, R::int_shr(h, 15));
    h = R::int_mul(h, MIX_MULTIPLIER);
    R::int_xor(h, R::int_shr(h, 13))
}

/// Hash of a lattice point: the three coordinates are multiplied by odd
/// constants, combined, and mixed by a xorshift-multiply-xorshift finaliser.
#[inline(always)]
pub fn lattice_hash<R: Real>(i: R::Int, j: R::Int, k: R::Int) -> R::Int {
    mix::<R>(R::int_xor(
        R::int_xor(R::int_mul(i, HASH_X), R::int_mul(j, HASH_Y)),
        R::int_mul(k, HASH_Z),
    ))
}

/// [`lattice_hash`] of a corner of the cell whose products i·A, j·B, k·C
/// are `base` (and `next` one lattice step further): the corners of a
/// simplex share them, so each corner costs only the finaliser.
#[inline(always)]
fn corner_hash<R: Real>(base: [R::Int; 3], next: [R::Int; 3], step: [R::Mask; 3]) -> R::Int {
    mix::<R>(R::int_xor(
        R::int_xor(
            R::int_select(step[0], next[0], base[0]),
            R::int_select(step[1], next[1], base[1]),
        ),
        R::int_select(step[2], next[2], base[2]),
    ))
}

/// The gradient for a hash: one of the twelve edge midpoints of a cube,
/// (0, ±1, ±1), (±1, 0, ±1), (±1, ±1, 0), each with probability 1/12 up to
/// 2⁻¹⁶ (the axis that is zero is ⌊3 (h mod 2¹⁶) / 2¹⁶⌋, from the low 16
/// bits; the signs come from bits 16 and 17).
#[inline(always)]
pub fn gradient<R: Real>(hash: R::Int) -> V3<R> {
    // ⌊3 low / 2¹⁶⌋ is 0 up to 21845 and 2 from 43691 on.
    let low = R::int_and(hash, 0xFFFF);
    let x_nonzero = R::int_gt(low, 21_845);
    let z_zero = R::int_gt(low, 43_690);
    let zero = R::splat(0.0);
    let first = R::select_on_bit(hash, 16, R::splat(-1.0), R::splat(1.0));
    let second = R::select_on_bit(hash, 17, R::splat(-1.0), R::splat(1.0));
    [
        R::select(x_nonzero, first, zero),
        R::select(x_nonzero, R::select(z_zero, second, zero), first),
        R::select(z_zero, zero, second),
    ]
}

/// The contribution of one corner at offset `d`, with lattice hash `hash`,
/// added to `value` and `grad`.
#[inline(always)]
fn corner<R: Real>(d: V3<R>, hash: R::Int, value: &mut R, grad: &mut V3<R>) {
    let g = gradient::<R>(hash);
    let t =
        (R::splat(RADIUS_SQUARED) - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])).max(R::splat(0.0));
    let t2 = t * t;
    let t4 = t2 * t2;
    let g_dot_d = g[0] * d[0] + g[1] * d[1] + g[2] * d[2];
    *value = *value + t4 * g_dot_d;
    let falloff = R::splat(8.0) * t2 * t * g_dot_d;
    grad[0] = grad[0] + (t4 * g[0] - falloff * d[0]);
    grad[1] = grad[1] + (t4 * g[1] - falloff * d[1]);
    grad[2] = grad[2] + (t4 * g[2] - falloff * d[2]);
}

/// Simplex noise n(p) / [`NOISE_SCALE`] and its exact gradient, lane by
/// lane: the sum of the corner kernels, whose scale the caller folds into
/// its own factors ([`noise`] applies it).
#[inline(always)]
pub fn simplex3<R: Real>(p: V3<R>) -> (R, V3<R>) {
    // The lattice cell, in skewed space.
    let skew = (p[0] + p[1] + p[2]) * R::splat(SKEW);
    let (fi, i) = (p[0] + skew).floor_int();
    let (fj, j) = (p[1] + skew).floor_int();
    let (fk, k) = (p[2] + skew).floor_int();
    let unskew = (fi + fj + fk) * R::splat(UNSKEW);
    let d0 = [
        p[0] - (fi - unskew),
        p[1] - (fj - unskew),
        p[2] - (fk - unskew),
    ];

    // Which of the six simplices of the cell: walk the axes from the largest
    // offset to the smallest (ties go to x, then y).
    let x_ge_y = d0[1].le(d0[0]);
    let x_ge_z = d0[2].le(d0[0]);
    let y_ge_z = d0[2].le(d0[1]);
    let first = [
        R::and(x_ge_y, x_ge_z),
        R::and(R::not(x_ge_y), y_ge_z),
        R::and(R::not(x_ge_z), R::not(y_ge_z)),
    ];
    let second = [
        R::or(x_ge_y, x_ge_z),
        R::or(R::not(x_ge_y), y_ge_z),
        R::or(R::not(x_ge_z), R::not(y_ge_z)),
    ];
    let one = R::splat(1.0);
    let zero = R::splat(0.0);

    let g1 = R::splat(UNSKEW);
    let g2 = R::splat(2.0 * UNSKEW);
    let g3 = R::splat(3.0 * UNSKEW - 1.0);
    let d1 = [
        d0[0] - R::select(first[0], one, zero) + g1,
        d0[1] - R::select(first[1], one, zero) + g1,
        d0[2] - R::select(first[2], one, zero) + g1,
    ];
    let d2 = [
        d0[0] - R::select(second[0], one, zero) + g2,
        d0[1] - R::select(second[1], one, zero) + g2,
        d0[2] - R::select(second[2], one, zero) + g2,
    ];
    let d3 = [d0[0] + g3, d0[1] + g3, d0[2] + g3];

    let base = [
        R::int_mul(i, HASH_X),
        R::int_mul(j, HASH_Y),
        R::int_mul(k, HASH_Z),
    ];
    let next = [
        R::int_add(base[0], R::int_splat(HASH_X)),
        R::int_add(base[1], R::int_splat(HASH_Y)),
        R::int_add(base[2], R::int_splat(HASH_Z)),
    ];
    let mut value = zero;
    let mut grad = [zero; 3];
    let origin = mix::<R>(R::int_xor(R::int_xor(base[0], base[1]), base[2]));
    let far = mix::<R>(R::int_xor(R::int_xor(next[0], next[1]), next[2]));
    corner(d0, origin, &mut value, &mut grad);
    corner(
        d1,
        corner_hash::<R>(base, next, first),
        &mut value,
        &mut grad,
    );
    corner(
        d2,
        corner_hash::<R>(base, next, second),
        &mut value,
        &mut grad,
    );
    corner(d3, far, &mut value, &mut grad);
    (value, grad)
}

/// Simplex noise and its gradient at one point, in `f32` (the bits of the
/// batched path).
pub fn noise(p: Vec3) -> (f32, Vec3) {
    let (value, grad) = simplex3([F32s([p.x]), F32s([p.y]), F32s([p.z])]);
    let scale = NOISE_SCALE as f32;
    (
        value.0[0] * scale,
        Vec3::new(grad[0].0[0], grad[1].0[0], grad[2].0[0]) * scale,
    )
}

/// Simplex noise and its gradient at one point, in `f64` (the reference).
pub fn noise_f64(p: DVec3) -> (f64, DVec3) {
    let (value, grad) = simplex3([p.x, p.y, p.z]);
    (value * NOISE_SCALE, DVec3::from_array(grad) * NOISE_SCALE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gradients_are_cube_edges_in_even_shares() {
        let mut counts = std::collections::HashMap::new();
        for i in 0..12_000u32 {
            let g = gradient::<f64>(lattice_hash::<f64>(i, i.wrapping_mul(7), 3));
            let zeros = g.iter().filter(|c| **c == 0.0).count();
            assert_eq!(zeros, 1, "{g:?}");
            assert!(g.iter().all(|c| c.abs() == 1.0 || *c == 0.0));
            *counts.entry(g.map(|c| c as i32)).or_insert(0) += 1;
        }
        assert_eq!(counts.len(), 12);
        for count in counts.values() {
            assert!((800..1200).contains(count), "{counts:?}");
        }
    }

    /// Index 0 to 11 of the gradient of lattice point (i, j, k).
    fn gradient_index(i: i32, j: i32, k: i32) -> usize {
        let g = gradient::<f64>(lattice_hash::<f64>(i as u32, j as u32, k as u32));
        let zero_axis = g.iter().position(|c| *c == 0.0).unwrap();
        let signs = g
            .iter()
            .filter(|c| **c != 0.0)
            .map(|c| usize::from(*c < 0.0));
        zero_axis * 4 + signs.fold(0, |bits, sign| bits * 2 + sign)
    }

    #[test]
    fn gradients_of_nearby_lattice_points_are_independent() {
        // Pairs of lattice points at a fixed offset, over a block of 32³:
        // the 12 × 12 counts of their gradients must look like independent
        // draws (χ² with 143 degrees of freedom: mean 143, standard deviation
        // 17; 240 is beyond 5.5 of them). A weak hash shows streaks along the
        // lattice axes or diagonals as a far larger χ².
        let offsets = [
            [1, 0, 0],
            [0, 1, 0],
            [0, 0, 1],
            [1, 1, 0],
            [1, 0, 1],
            [0, 1, 1],
            [1, 1, 1],
            [1, -1, 0],
            [1, 0, -1],
            [0, 1, -1],
            [2, 0, 0],
            [0, 2, 0],
            [0, 0, 2],
            [4, 0, 0],
            [0, 8, 0],
            [0, 0, 16],
        ];
        for corner in [[-16, -16, -16], [1000, -70_000, 3_000_000]] {
            for offset in offsets {
                let mut counts = [0u32; 144];
                for i in 0..32 {
                    for j in 0..32 {
                        for k in 0..32 {
                            let [a, b, c] = [corner[0] + i, corner[1] + j, corner[2] + k];
                            let first = gradient_index(a, b, c);
                            let second =
                                gradient_index(a + offset[0], b + offset[1], c + offset[2]);
                            counts[first * 12 + second] += 1;
                        }
                    }
                }
                let expected = 32.0f64.powi(3) / 144.0;
                let chi_squared: f64 = counts
                    .iter()
                    .map(|n| (f64::from(*n) - expected).powi(2) / expected)
                    .sum();
                assert!(
                    chi_squared < 240.0,
                    "{corner:?} {offset:?}: χ² {chi_squared}"
                );
            }
        }
    }

    #[test]
    fn noise_is_zero_on_lattice_points_and_bounded() {
        // At a lattice corner only that corner's kernel is non-zero, and
        // g · d = 0 there.
        assert_eq!(noise_f64(DVec3::new(3.0, -2.0, 5.0)).0, 0.0);
        let mut largest: f64 = 0.0;
        let mut state = 1u64;
        for _ in 0..20_000 {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let p = DVec3::new(
                (state >> 40) as f64 / 16777216.0 * 50.0,
                ((state >> 20) & 0xFFFFF) as f64 / 1048576.0 * 50.0,
                (state & 0xFFFFF) as f64 / 1048576.0 * 50.0,
            );
            largest = largest.max(noise_f64(p).0.abs());
        }
        assert!(largest > 0.6 && largest <= 1.0, "{largest}");
    }
}

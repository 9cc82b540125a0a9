//! Numbers the field is evaluated in: one `f64` (the reference and test
//! path), or `N` lanes of `f32` at once ([`F32s`], the portable path; the
//! AVX2 and AVX-512 lane types implement the same trait with intrinsics).
//!
//! The noise and the curl are written once, generic over [`Real`], without
//! branches on values: comparisons give masks and masks select, so each
//! operation is one SIMD instruction on a whole batch of particles.
//! `F32s<1>` is the scalar `f32` path. As every lane does exactly the same
//! IEEE operations in the same order, a particle gets the same bits whether it
//! is evaluated alone or in a batch of 8 or 16, on any x86-64 CPU (no fused
//! multiply-add is ever formed).

use std::ops::{Add, Div, Mul, Neg, Sub};

pub use firn_core::math::lanes::{F32s, U32s};
use firn_core::math::lanes::{map1, map2, mask_bits};

/// Inputs of `floor_int` are clamped to ±this (2³⁰), so the integer
/// conversion is always defined.
pub const FLOOR_LIMIT: f64 = firn_core::math::isa::FLOOR_LIMIT as f64;

/// A real number, or a bundle of lanes of them, with the few operations the
/// simplex noise and the curl need.
///
/// `Int` holds 32-bit unsigned integers lane by lane (wrapping arithmetic),
/// used for the lattice hash; `Mask` holds the result of a comparison.
pub trait Real:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Per-lane result of a comparison.
    type Mask: Copy;
    /// Per-lane 32-bit unsigned integer.
    type Int: Copy;

    /// The same value in every lane (rounded to the lane type).
    fn splat(value: f64) -> Self;
    /// floor(self), as a number and as a wrapping 32-bit integer, for
    /// |self| < 2³⁰ (larger values and NaN are first clamped to ±2³⁰).
    fn floor_int(self) -> (Self, Self::Int);
    /// self < other.
    fn lt(self, other: Self) -> Self::Mask;
    /// self <= other.
    fn le(self, other: Self) -> Self::Mask;
    /// Per lane: `yes` where `mask` holds, else `no`.
    fn select(mask: Self::Mask, yes: Self, no: Self) -> Self;
    /// Per-lane minimum, `if self < other { self } else { other }` (the
    /// semantics of the x86 `minps` instruction).
    fn min(self, other: Self) -> Self;
    /// Per-lane maximum, `if self > other { self } else { other }` (`maxps`).
    fn max(self, other: Self) -> Self;
    /// Per-lane square root.
    fn sqrt(self) -> Self;

    /// Both masks.
    fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// Either mask.
    fn or(a: Self::Mask, b: Self::Mask) -> Self::Mask;
    /// The complement.
    fn not(a: Self::Mask) -> Self::Mask;
    /// Whether any lane holds.
    fn any(a: Self::Mask) -> bool;
    /// 1 where the mask holds, else 0.
    fn mask_to_int(a: Self::Mask) -> Self::Int;
    /// The mask as bits: bit i is lane i (at most 32 lanes).
    fn mask_bits(a: Self::Mask) -> u32;

    /// The same integer in every lane.
    fn int_splat(value: u32) -> Self::Int;
    /// Wrapping sum.
    fn int_add(a: Self::Int, b: Self::Int) -> Self::Int;
    /// Wrapping product with a constant.
    fn int_mul(a: Self::Int, b: u32) -> Self::Int;
    /// Bitwise exclusive or.
    fn int_xor(a: Self::Int, b: Self::Int) -> Self::Int;
    /// Bitwise and with a constant.
    fn int_and(a: Self::Int, b: u32) -> Self::Int;
    /// Logical shift right.
    fn int_shr(a: Self::Int, bits: u32) -> Self::Int;
    /// Shift left.
    fn int_shl(a: Self::Int, bits: u32) -> Self::Int;
    /// Per lane: `yes` where `mask` holds, else `no`.
    fn int_select(mask: Self::Mask, yes: Self::Int, no: Self::Int) -> Self::Int;
    /// a == b.
    fn int_eq(a: Self::Int, b: u32) -> Self::Mask;

    /// Simplex noise and its gradient, [`crate::noise::simplex3`]. Lane types
    /// keep it out of line (one copy per lane type and instruction set, called
    /// three times per velocity), which keeps compile times short.
    #[inline(always)]
    fn simplex(p: V3<Self>) -> (Self, V3<Self>) {
        crate::noise::simplex3(p)
    }
}

impl Real for f64 {
    type Mask = bool;
    type Int = u32;

    #[inline(always)]
    fn splat(value: f64) -> f64 {
        value
    }
    #[inline(always)]
    fn floor_int(self) -> (f64, u32) {
        let floor = Real::min(Real::max(self, -FLOOR_LIMIT), FLOOR_LIMIT).floor();
        // The same lattice index as the f32 path: i32 range, two's complement.
        (floor, (floor as i32) as u32)
    }
    #[inline(always)]
    fn lt(self, other: f64) -> bool {
        self < other
    }
    #[inline(always)]
    fn le(self, other: f64) -> bool {
        self <= other
    }
    #[inline(always)]
    fn select(mask: bool, yes: f64, no: f64) -> f64 {
        if mask { yes } else { no }
    }
    #[inline(always)]
    fn min(self, other: f64) -> f64 {
        if self < other { self } else { other }
    }
    #[inline(always)]
    fn max(self, other: f64) -> f64 {
        if self > other { self } else { other }
    }
    #[inline(always)]
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    #[inline(always)]
    fn and(a: bool, b: bool) -> bool {
        a & b
    }
    #[inline(always)]
    fn or(a: bool, b: bool) -> bool {
        a | b
    }
    #[inline(always)]
    fn not(a: bool) -> bool {
        !a
    }
    #[inline(always)]
    fn any(a: bool) -> bool {
        a
    }
    #[inline(always)]
    fn mask_to_int(a: bool) -> u32 {
        u32::from(a)
    }
    #[inline(always)]
    fn mask_bits(a: bool) -> u32 {
        u32::from(a)
    }
    #[inline(always)]
    fn int_splat(value: u32) -> u32 {
        value
    }
    #[inline(always)]
    fn int_add(a: u32, b: u32) -> u32 {
        a.wrapping_add(b)
    }
    #[inline(always)]
    fn int_mul(a: u32, b: u32) -> u32 {
        a.wrapping_mul(b)
    }
    #[inline(always)]
    fn int_xor(a: u32, b: u32) -> u32 {
        a ^ b
    }
    #[inline(always)]
    fn int_and(a: u32, b: u32) -> u32 {
        a & b
    }
    #[inline(always)]
    fn int_shr(a: u32, bits: u32) -> u32 {
        a >> bits
    }
    #[inline(always)]
    fn int_shl(a: u32, bits: u32) -> u32 {
        a << bits
    }
    #[inline(always)]
    fn int_select(mask: bool, yes: u32, no: u32) -> u32 {
        if mask { yes } else { no }
    }
    #[inline(always)]
    fn int_eq(a: u32, b: u32) -> bool {
        a == b
    }
}

impl<const N: usize> Real for F32s<N> {
    type Mask = U32s<N>;
    type Int = U32s<N>;

    #[inline(never)]
    fn simplex(p: V3<Self>) -> (Self, V3<Self>) {
        crate::noise::simplex3(p)
    }

    #[inline(always)]
    fn splat(value: f64) -> F32s<N> {
        F32s([value as f32; N])
    }
    #[inline(always)]
    fn floor_int(self) -> (F32s<N>, U32s<N>) {
        // No libm call, and it vectorises with plain SSE2.
        let int: [i32; N] = map1(self.0, firn_core::math::isa::floor_clamped);
        (F32s(map1(int, |i| i as f32)), U32s(map1(int, |i| i as u32)))
    }
    #[inline(always)]
    fn lt(self, other: F32s<N>) -> U32s<N> {
        F32s::lt(self, other)
    }
    #[inline(always)]
    fn le(self, other: F32s<N>) -> U32s<N> {
        F32s::le(self, other)
    }
    #[inline(always)]
    fn select(mask: U32s<N>, yes: F32s<N>, no: F32s<N>) -> F32s<N> {
        F32s::select(mask, yes, no)
    }
    #[inline(always)]
    fn min(self, other: F32s<N>) -> F32s<N> {
        F32s::min(self, other)
    }
    #[inline(always)]
    fn max(self, other: F32s<N>) -> F32s<N> {
        F32s::max(self, other)
    }
    #[inline(always)]
    fn sqrt(self) -> F32s<N> {
        F32s::sqrt(self)
    }
    #[inline(always)]
    fn and(a: U32s<N>, b: U32s<N>) -> U32s<N> {
        U32s(map2(a.0, b.0, |x, y| x & y))
    }
    #[inline(always)]
    fn or(a: U32s<N>, b: U32s<N>) -> U32s<N> {
        U32s(map2(a.0, b.0, |x, y| x | y))
    }
    #[inline(always)]
    fn not(a: U32s<N>) -> U32s<N> {
        U32s(map1(a.0, |x| !x))
    }
    #[inline(always)]
    fn any(a: U32s<N>) -> bool {
        a.any()
    }
    #[inline(always)]
    fn mask_bits(a: U32s<N>) -> u32 {
        let mut bits = 0;
        for (i, lane) in a.0.iter().enumerate() {
            bits |= (lane & 1) << i;
        }
        bits
    }
    #[inline(always)]
    fn mask_to_int(a: U32s<N>) -> U32s<N> {
        U32s(map1(a.0, |x| x & 1))
    }
    #[inline(always)]
    fn int_splat(value: u32) -> U32s<N> {
        U32s([value; N])
    }
    #[inline(always)]
    fn int_add(a: U32s<N>, b: U32s<N>) -> U32s<N> {
        U32s(map2(a.0, b.0, u32::wrapping_add))
    }
    #[inline(always)]
    fn int_mul(a: U32s<N>, b: u32) -> U32s<N> {
        U32s(map1(a.0, |x| x.wrapping_mul(b)))
    }
    #[inline(always)]
    fn int_xor(a: U32s<N>, b: U32s<N>) -> U32s<N> {
        U32s(map2(a.0, b.0, |x, y| x ^ y))
    }
    #[inline(always)]
    fn int_and(a: U32s<N>, b: u32) -> U32s<N> {
        U32s(map1(a.0, |x| x & b))
    }
    #[inline(always)]
    fn int_shr(a: U32s<N>, bits: u32) -> U32s<N> {
        U32s(map1(a.0, |x| x >> bits))
    }
    #[inline(always)]
    fn int_shl(a: U32s<N>, bits: u32) -> U32s<N> {
        U32s(map1(a.0, |x| x << bits))
    }
    #[inline(always)]
    fn int_select(mask: U32s<N>, yes: U32s<N>, no: U32s<N>) -> U32s<N> {
        let mut out = no.0;
        for ((o, y), m) in out.iter_mut().zip(yes.0).zip(mask.0) {
            *o = (y & m) | (*o & !m);
        }
        U32s(out)
    }
    #[inline(always)]
    fn int_eq(a: U32s<N>, b: u32) -> U32s<N> {
        U32s(map1(a.0, |x| mask_bits(x == b)))
    }
}

/// A vector of three [`Real`]s.
pub type V3<R> = [R; 3];

/// a + b.
#[inline(always)]
pub fn add3<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a − b.
#[inline(always)]
pub fn sub3<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// s a.
#[inline(always)]
pub fn scale3<R: Real>(s: R, a: V3<R>) -> V3<R> {
    [s * a[0], s * a[1], s * a[2]]
}

/// a · b.
#[inline(always)]
pub fn dot3<R: Real>(a: V3<R>, b: V3<R>) -> R {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// a × b.
#[inline(always)]
pub fn cross3<R: Real>(a: V3<R>, b: V3<R>) -> V3<R> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Per lane: `yes` where `mask` holds, else `no`.
#[inline(always)]
pub fn select3<R: Real>(mask: R::Mask, yes: V3<R>, no: V3<R>) -> V3<R> {
    [
        R::select(mask, yes[0], no[0]),
        R::select(mask, yes[1], no[1]),
        R::select(mask, yes[2], no[2]),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_matches_the_f64_path() {
        for x in [
            -2.5f32,
            -2.0,
            -1e-7,
            0.0,
            0.3,
            1.0,
            7.99,
            -1000.25,
            1e6 + 0.5,
        ] {
            let (floor, int) = F32s::<1>([x]).floor_int();
            let (floor64, int64) = f64::from(x).floor_int();
            assert_eq!(f64::from(floor.0[0]), floor64, "{x}");
            assert_eq!(int.0[0], int64, "{x}");
        }
    }

    #[test]
    fn integer_masks_work_lane_by_lane() {
        let a = F32s([1.0, 2.0, 3.0, 4.0]);
        let mask = Real::lt(a, F32s([4.0, 3.0, 2.0, 1.0]));
        assert_eq!(F32s::<4>::mask_to_int(mask).0, [1, 1, 0, 0]);
        assert_eq!(F32s::<4>::mask_bits(mask), 0b0011);
        assert!(F32s::<4>::any(mask));
        assert!(!F32s::<4>::any(F32s::<4>::and(mask, F32s::<4>::not(mask))));
    }
}

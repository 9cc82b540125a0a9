//! Numbers the field is evaluated in: one `f64` (the reference and test
//! path), or `N` lanes of `f32` at once ([`F32s`], the portable path; the
//! AVX2 and AVX-512 lane types implement the same trait with intrinsics), or
//! a [`Pair`] of such lane values side by side.
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
    /// Numbers in one value (at most 32, the bits of [`Real::mask_bits`]).
    const LANES: usize;

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
    /// a > b, for a and b below 2³¹.
    fn int_gt(a: Self::Int, b: u32) -> Self::Mask;
    /// Per lane: `yes` where bit `bit` of `bits` is set, else `no`.
    #[inline(always)]
    fn select_on_bit(bits: Self::Int, bit: u32, yes: Self, no: Self) -> Self {
        Self::select(Self::int_eq(Self::int_and(bits, 1 << bit), 0), no, yes)
    }

    /// Simplex noise and its gradient, [`crate::noise::simplex3`]. The
    /// portable and AVX-512 lane types keep it out of line (one copy per lane
    /// type and instruction set, called three times per velocity), which keeps
    /// compile times short; a [`Pair`] inlines it, as its three copies then
    /// overlap (out of line, the AVX2 pair took 1.4 times as long).
    #[inline(always)]
    fn simplex(p: V3<Self>) -> (Self, V3<Self>) {
        crate::noise::simplex3(p)
    }
}

impl<const N: usize> Real for F32s<N> {
    type Mask = U32s<N>;
    type Int = U32s<N>;
    const LANES: usize = N;

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
    #[inline(always)]
    fn int_gt(a: U32s<N>, b: u32) -> U32s<N> {
        U32s(map1(a.0, |x| mask_bits(x > b)))
    }
}

/// Implements [`Real`] for a bundle of several values of lane type `R` side
/// by side, each operation done on all of them: independent chains of
/// instructions for the CPU to overlap (the noise is a long chain of dependent operations, so one
/// register's worth of particles leaves much of the CPU idle). Lane by lane
/// the same operations as `R`, so the same bits. Written out field by field
/// (no closures), so that all of it inlines into code compiled for an
/// instruction set.
macro_rules! bundle {
    ($name:ident, $count:literal, $($field:tt),+) => {
        bundle!(@op $name, Add, add, $($field),+);
        bundle!(@op $name, Sub, sub, $($field),+);
        bundle!(@op $name, Mul, mul, $($field),+);
        bundle!(@op $name, Div, div, $($field),+);

        impl<R: Real> Neg for $name<R> {
            type Output = $name<R>;
            #[inline(always)]
            fn neg(self) -> $name<R> {
                $name($(-self.$field),+)
            }
        }

        impl<R: Real> Real for $name<R> {
            type Mask = $name<R::Mask>;
            type Int = $name<R::Int>;
            const LANES: usize = $count * R::LANES;

            #[inline(always)]
            fn splat(value: f64) -> Self {
                let one = R::splat(value);
                $name($(bundle!(@same one, $field)),+)
            }
            #[inline(always)]
            fn floor_int(self) -> (Self, Self::Int) {
                let parts = ($(self.$field.floor_int(),)+);
                ($name($(parts.$field.0),+), $name($(parts.$field.1),+))
            }
            #[inline(always)]
            fn lt(self, other: Self) -> Self::Mask {
                $name($(self.$field.lt(other.$field)),+)
            }
            #[inline(always)]
            fn le(self, other: Self) -> Self::Mask {
                $name($(self.$field.le(other.$field)),+)
            }
            #[inline(always)]
            fn select(mask: Self::Mask, yes: Self, no: Self) -> Self {
                $name($(R::select(mask.$field, yes.$field, no.$field)),+)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                $name($(self.$field.min(other.$field)),+)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                $name($(self.$field.max(other.$field)),+)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                $name($(self.$field.sqrt()),+)
            }
            #[inline(always)]
            fn and(a: Self::Mask, b: Self::Mask) -> Self::Mask {
                $name($(R::and(a.$field, b.$field)),+)
            }
            #[inline(always)]
            fn or(a: Self::Mask, b: Self::Mask) -> Self::Mask {
                $name($(R::or(a.$field, b.$field)),+)
            }
            #[inline(always)]
            fn not(a: Self::Mask) -> Self::Mask {
                $name($(R::not(a.$field)),+)
            }
            #[inline(always)]
            fn any(a: Self::Mask) -> bool {
                false $(|| R::any(a.$field))+
            }
            #[inline(always)]
            fn mask_to_int(a: Self::Mask) -> Self::Int {
                $name($(R::mask_to_int(a.$field)),+)
            }
            #[inline(always)]
            fn mask_bits(a: Self::Mask) -> u32 {
                0 $(| R::mask_bits(a.$field) << ($field * R::LANES))+
            }
            #[inline(always)]
            fn int_splat(value: u32) -> Self::Int {
                let one = R::int_splat(value);
                $name($(bundle!(@same one, $field)),+)
            }
            #[inline(always)]
            fn int_add(a: Self::Int, b: Self::Int) -> Self::Int {
                $name($(R::int_add(a.$field, b.$field)),+)
            }
            #[inline(always)]
            fn int_mul(a: Self::Int, b: u32) -> Self::Int {
                $name($(R::int_mul(a.$field, b)),+)
            }
            #[inline(always)]
            fn int_xor(a: Self::Int, b: Self::Int) -> Self::Int {
                $name($(R::int_xor(a.$field, b.$field)),+)
            }
            #[inline(always)]
            fn int_and(a: Self::Int, b: u32) -> Self::Int {
                $name($(R::int_and(a.$field, b)),+)
            }
            #[inline(always)]
            fn int_shr(a: Self::Int, bits: u32) -> Self::Int {
                $name($(R::int_shr(a.$field, bits)),+)
            }
            #[inline(always)]
            fn int_shl(a: Self::Int, bits: u32) -> Self::Int {
                $name($(R::int_shl(a.$field, bits)),+)
            }
            #[inline(always)]
            fn int_select(mask: Self::Mask, yes: Self::Int, no: Self::Int) -> Self::Int {
                $name($(R::int_select(mask.$field, yes.$field, no.$field)),+)
            }
            #[inline(always)]
            fn int_eq(a: Self::Int, b: u32) -> Self::Mask {
                $name($(R::int_eq(a.$field, b)),+)
            }
            #[inline(always)]
            fn int_gt(a: Self::Int, b: u32) -> Self::Mask {
                $name($(R::int_gt(a.$field, b)),+)
            }
            #[inline(always)]
            fn select_on_bit(bits: Self::Int, bit: u32, yes: Self, no: Self) -> Self {
                $name($(R::select_on_bit(bits.$field, bit, yes.$field, no.$field)),+)
            }
        }
    };
    (@same $value:ident, $field:tt) => { $value };
    (@op $name:ident, $trait:ident, $method:ident, $($field:tt),+) => {
        impl<R: Real> $trait for $name<R> {
            type Output = $name<R>;
            #[inline(always)]
            fn $method(self, other: $name<R>) -> $name<R> {
                $name($(self.$field.$method(other.$field)),+)
            }
        }
    };
}

/// Two values of lane type `R` side by side (see the `bundle!` macro): twice
/// the particles per batch, in two independent chains of instructions (the
/// AVX2 path's batches of 16).
#[derive(Clone, Copy, Debug)]
pub struct Pair<R>(pub R, pub R);

bundle!(Pair, 2, 0, 1);

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
mod tests;

//! [`Real`] for one `f64`: the reference path the noise and the curl are
//! tested against, with plain branches where the lanes use masks.

use crate::lanes::{FLOOR_LIMIT, Real};

impl Real for f64 {
    type Mask = bool;
    type Int = u32;
    const LANES: usize = 1;

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
    #[inline(always)]
    fn int_gt(a: u32, b: u32) -> bool {
        a > b
    }
}

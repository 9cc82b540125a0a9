//! Sixteen `f32` lanes in one AVX-512 register: [`Real`] written with the
//! x86 intrinsics, twice the width of [`crate::lanes_avx2`].
//!
//! Every operation matches the portable [`F32s`](crate::lanes::F32s) lane
//! by lane, bit for bit (the same IEEE operations; `min`/`max` with the
//! `minps`/`maxps` rule; the clamped truncating floor).
//!
//! Values of [`Avx16`] are only made after [`crate::Simd::detect`] found
//! AVX-512F on the running CPU (the type is crate-private); that is what makes
//! the intrinsic calls below sound.

// The AVX-512 lanes are `std::arch` intrinsics, sound where an `Avx16` exists.
#![allow(unsafe_code)]

use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

use crate::lanes::{FLOOR_LIMIT, Real, V3};

/// Sixteen `f32` lanes in a 512-bit register.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Avx16(__m512);

/// Sixteen 32-bit integers.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Avx16i(__m512i);

impl Avx16 {
    /// The lanes from an array.
    #[inline(always)]
    pub(crate) fn from_array(lanes: [f32; 16]) -> Avx16 {
        // SAFETY: Avx16 exists only where the CPU has AVX-512F (module docs).
        unsafe { Avx16(_mm512_loadu_ps(lanes.as_ptr())) }
    }

    /// The lanes as an array.
    #[inline(always)]
    pub(crate) fn to_array(self) -> [f32; 16] {
        let mut lanes = [0.0; 16];
        // SAFETY: as above; `lanes` holds 16 floats.
        unsafe { _mm512_storeu_ps(lanes.as_mut_ptr(), self.0) };
        lanes
    }
}

/// [`crate::noise::simplex3`] compiled for AVX-512, out of line.
#[target_feature(enable = "avx512f")]
#[inline(never)]
fn simplex_avx512(p: V3<Avx16>) -> (Avx16, V3<Avx16>) {
    crate::noise::simplex3(p)
}

macro_rules! avx512_op {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for Avx16 {
            type Output = Avx16;
            #[inline(always)]
            fn $method(self, other: Avx16) -> Avx16 {
                // SAFETY: Avx16 exists only where the CPU has AVX-512F.
                unsafe { Avx16($intrinsic(self.0, other.0)) }
            }
        }
    };
}

avx512_op!(Add, add, _mm512_add_ps);
avx512_op!(Sub, sub, _mm512_sub_ps);
avx512_op!(Mul, mul, _mm512_mul_ps);
avx512_op!(Div, div, _mm512_div_ps);

impl Neg for Avx16 {
    type Output = Avx16;
    #[inline(always)]
    fn neg(self) -> Avx16 {
        // SAFETY: Avx16 exists only where the CPU has AVX-512F. Flips the
        // sign bit, as `-x` does.
        unsafe {
            let sign = _mm512_set1_epi32(i32::MIN);
            Avx16(_mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(self.0),
                sign,
            )))
        }
    }
}

impl Real for Avx16 {
    type Mask = __mmask16;
    type Int = Avx16i;
    const LANES: usize = 16;

    #[inline(always)]
    fn simplex(p: V3<Avx16>) -> (Avx16, V3<Avx16>) {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { simplex_avx512(p) }
    }
    #[inline(always)]
    fn splat(value: f64) -> Avx16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16(_mm512_set1_ps(value as f32)) }
    }
    #[inline(always)]
    fn floor_int(self) -> (Avx16, Avx16i) {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe {
            let limit = FLOOR_LIMIT as f32;
            // maxps/minps return the second operand for NaN: NaN → −2³⁰.
            let x = _mm512_min_ps(
                _mm512_max_ps(self.0, _mm512_set1_ps(-limit)),
                _mm512_set1_ps(limit),
            );
            let truncated = _mm512_cvttps_epi32(x);
            let above = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_cvtepi32_ps(truncated), x);
            let int = _mm512_mask_sub_epi32(truncated, above, truncated, _mm512_set1_epi32(1));
            (Avx16(_mm512_cvtepi32_ps(int)), Avx16i(int))
        }
    }
    #[inline(always)]
    fn lt(self, other: Avx16) -> __mmask16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, other.0) }
    }
    #[inline(always)]
    fn le(self, other: Avx16) -> __mmask16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, other.0) }
    }
    #[inline(always)]
    fn select(mask: __mmask16, yes: Avx16, no: Avx16) -> Avx16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16(_mm512_mask_blend_ps(mask, no.0, yes.0)) }
    }
    #[inline(always)]
    fn min(self, other: Avx16) -> Avx16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16(_mm512_min_ps(self.0, other.0)) }
    }
    #[inline(always)]
    fn max(self, other: Avx16) -> Avx16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16(_mm512_max_ps(self.0, other.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Avx16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16(_mm512_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn and(a: __mmask16, b: __mmask16) -> __mmask16 {
        a & b
    }
    #[inline(always)]
    fn or(a: __mmask16, b: __mmask16) -> __mmask16 {
        a | b
    }
    #[inline(always)]
    fn not(a: __mmask16) -> __mmask16 {
        !a
    }
    #[inline(always)]
    fn any(a: __mmask16) -> bool {
        a != 0
    }
    #[inline(always)]
    fn mask_bits(a: __mmask16) -> u32 {
        u32::from(a)
    }
    #[inline(always)]
    fn mask_to_int(a: __mmask16) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_maskz_set1_epi32(a, 1)) }
    }
    #[inline(always)]
    fn int_splat(value: u32) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_set1_epi32(value as i32)) }
    }
    #[inline(always)]
    fn int_add(a: Avx16i, b: Avx16i) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_add_epi32(a.0, b.0)) }
    }
    #[inline(always)]
    fn int_mul(a: Avx16i, b: u32) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_mullo_epi32(a.0, _mm512_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn int_xor(a: Avx16i, b: Avx16i) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_xor_si512(a.0, b.0)) }
    }
    #[inline(always)]
    fn int_and(a: Avx16i, b: u32) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_and_si512(a.0, _mm512_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn int_shr(a: Avx16i, bits: u32) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_srl_epi32(a.0, _mm_cvtsi32_si128(bits as i32))) }
    }
    #[inline(always)]
    fn int_shl(a: Avx16i, bits: u32) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_sll_epi32(a.0, _mm_cvtsi32_si128(bits as i32))) }
    }
    #[inline(always)]
    fn int_select(mask: __mmask16, yes: Avx16i, no: Avx16i) -> Avx16i {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { Avx16i(_mm512_mask_blend_epi32(mask, no.0, yes.0)) }
    }
    #[inline(always)]
    fn int_eq(a: Avx16i, b: u32) -> __mmask16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { _mm512_cmpeq_epi32_mask(a.0, _mm512_set1_epi32(b as i32)) }
    }
    #[inline(always)]
    fn int_gt(a: Avx16i, b: u32) -> __mmask16 {
        // SAFETY: Avx16 values exist only where the CPU has AVX-512F.
        unsafe { _mm512_cmpgt_epu32_mask(a.0, _mm512_set1_epi32(b as i32)) }
    }
}

crate::integrate::entry_points!(Avx16, Avx512, "avx512f", "AVX-512F");

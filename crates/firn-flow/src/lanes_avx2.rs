//! Eight `f32` lanes in one AVX2 register: [`Real`] written with the x86
//! intrinsics, so the noise and the curl compile to straight vector code.
//! Batches are a [`Pair`] of them (16 particles), moved in and out of
//! `Vec3`s by 3×8 transposes in registers.
//!
//! Every operation matches the portable [`F32s`](crate::lanes::F32s) lane
//! by lane, bit for bit (the same IEEE operations; `min`/`max` with the
//! `minps`/`maxps` rule; the clamped truncating floor), so the AVX2 path and
//! the portable path give the same particles.
//!
//! Values of [`Avx8`] are only made after [`crate::Simd::detect`] found AVX2
//! on the running CPU (the type is crate-private); that is what makes the
//! intrinsic calls below sound.

// The AVX2 lanes are `std::arch` intrinsics, sound where an `Avx8` exists.
#![allow(unsafe_code)]

use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::Vec3;

use crate::lanes::{FLOOR_LIMIT, Pair, Real};

/// Eight `f32` lanes in a 256-bit register.
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Avx8(__m256);

/// Eight 32-bit integers (or masks: all bits set where true).
#[derive(Clone, Copy, Debug)]
#[repr(transparent)]
pub(crate) struct Avx8i(__m256i);

impl Avx8 {
    /// The lanes from an array.
    #[inline(always)]
    pub(crate) fn from_array(lanes: [f32; 8]) -> Avx8 {
        // SAFETY: Avx8 exists only where the CPU has AVX2 (module docs).
        unsafe { Avx8(_mm256_loadu_ps(lanes.as_ptr())) }
    }

    /// The lanes as an array.
    #[inline(always)]
    pub(crate) fn to_array(self) -> [f32; 8] {
        let mut lanes = [0.0; 8];
        // SAFETY: as above; `lanes` holds 8 floats.
        unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), self.0) };
        lanes
    }

    /// The x, y and z of eight points in lanes, by a 3×8 transpose in
    /// registers (three pairs of 128-bit loads, five shuffles).
    #[inline(always)]
    pub(crate) fn load_points(points: &[Vec3; 8]) -> [Avx8; 3] {
        let p = points.as_ptr().cast::<f32>();
        // SAFETY: as above; `points` is 24 consecutive floats (`Vec3` is
        // three `f32`, `repr(C)`), and the loads read floats 0-23.
        unsafe {
            // Per 128-bit half: [x0 y0 z0 x1], [y1 z1 x2 y2], [z2 x3 y3 z3]
            // (points 0-3 in the low half, 4-7 in the high one).
            let m0 = _mm256_loadu2_m128(p.add(12), p);
            let m1 = _mm256_loadu2_m128(p.add(16), p.add(4));
            let m2 = _mm256_loadu2_m128(p.add(20), p.add(8));
            let xy = _mm256_shuffle_ps::<0b10_01_11_10>(m1, m2); // x2 y2 x3 y3
            let yz = _mm256_shuffle_ps::<0b01_00_10_01>(m0, m1); // y0 z0 y1 z1
            [
                Avx8(_mm256_shuffle_ps::<0b10_00_11_00>(m0, xy)),
                Avx8(_mm256_shuffle_ps::<0b11_01_10_00>(yz, xy)),
                Avx8(_mm256_shuffle_ps::<0b11_00_11_01>(yz, m2)),
            ]
        }
    }

    /// Eight points from lanes of x, y and z: the inverse of
    /// [`Avx8::load_points`].
    #[inline(always)]
    pub(crate) fn store_points(value: [Avx8; 3], points: &mut [Vec3; 8]) {
        let p = points.as_mut_ptr().cast::<f32>();
        let [x, y, z] = [value[0].0, value[1].0, value[2].0];
        // SAFETY: as above; `points` is 24 consecutive floats, and the
        // stores write floats 0-23.
        unsafe {
            let xy = _mm256_shuffle_ps::<0b10_00_10_00>(x, y); // x0 x2 y0 y2
            let yz = _mm256_shuffle_ps::<0b11_01_11_01>(y, z); // y1 y3 z1 z3
            let zx = _mm256_shuffle_ps::<0b11_01_10_00>(z, x); // z0 z2 x1 x3
            let m0 = _mm256_shuffle_ps::<0b10_00_10_00>(xy, zx); // x0 y0 z0 x1
            let m1 = _mm256_shuffle_ps::<0b11_01_10_00>(yz, xy); // y1 z1 x2 y2
            let m2 = _mm256_shuffle_ps::<0b11_01_11_01>(zx, yz); // z2 x3 y3 z3
            _mm256_storeu2_m128(p.add(12), p, m0);
            _mm256_storeu2_m128(p.add(16), p.add(4), m1);
            _mm256_storeu2_m128(p.add(20), p.add(8), m2);
        }
    }
}

macro_rules! avx_op {
    ($trait:ident, $method:ident, $intrinsic:ident) => {
        impl $trait for Avx8 {
            type Output = Avx8;
            #[inline(always)]
            fn $method(self, other: Avx8) -> Avx8 {
                // SAFETY: Avx8 exists only where the CPU has AVX2.
                unsafe { Avx8($intrinsic(self.0, other.0)) }
            }
        }
    };
}

avx_op!(Add, add, _mm256_add_ps);
avx_op!(Sub, sub, _mm256_sub_ps);
avx_op!(Mul, mul, _mm256_mul_ps);
avx_op!(Div, div, _mm256_div_ps);

impl Neg for Avx8 {
    type Output = Avx8;
    #[inline(always)]
    fn neg(self) -> Avx8 {
        // SAFETY: Avx8 exists only where the CPU has AVX2. Flips the sign
        // bit, as `-x` does.
        unsafe { Avx8(_mm256_xor_ps(self.0, _mm256_set1_ps(-0.0))) }
    }
}

impl Real for Avx8 {
    type Mask = Avx8i;
    type Int = Avx8i;
    const LANES: usize = 8;

    #[inline(always)]
    fn splat(value: f64) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8(_mm256_set1_ps(value as f32)) }
    }
    #[inline(always)]
    fn floor_int(self) -> (Avx8, Avx8i) {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe {
            let limit = FLOOR_LIMIT as f32;
            // maxps/minps return the second operand for NaN: NaN → −2³⁰.
            let x = _mm256_min_ps(
                _mm256_max_ps(self.0, _mm256_set1_ps(-limit)),
                _mm256_set1_ps(limit),
            );
            // roundps rounds down exactly; ⌊−0⌋ = −0 becomes +0 (the
            // integer's conversion back) by adding +0.
            let floor = _mm256_floor_ps(x);
            let int = _mm256_cvttps_epi32(floor);
            (Avx8(_mm256_add_ps(floor, _mm256_setzero_ps())), Avx8i(int))
        }
    }
    #[inline(always)]
    fn lt(self, other: Avx8) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe {
            Avx8i(_mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(
                self.0, other.0,
            )))
        }
    }
    #[inline(always)]
    fn le(self, other: Avx8) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe {
            Avx8i(_mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(
                self.0, other.0,
            )))
        }
    }
    #[inline(always)]
    fn select(mask: Avx8i, yes: Avx8, no: Avx8) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8(_mm256_blendv_ps(no.0, yes.0, _mm256_castsi256_ps(mask.0))) }
    }
    #[inline(always)]
    fn min(self, other: Avx8) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8(_mm256_min_ps(self.0, other.0)) }
    }
    #[inline(always)]
    fn max(self, other: Avx8) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8(_mm256_max_ps(self.0, other.0)) }
    }
    #[inline(always)]
    fn sqrt(self) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8(_mm256_sqrt_ps(self.0)) }
    }
    #[inline(always)]
    fn and(a: Avx8i, b: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_and_si256(a.0, b.0)) }
    }
    #[inline(always)]
    fn or(a: Avx8i, b: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_or_si256(a.0, b.0)) }
    }
    #[inline(always)]
    fn not(a: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_xor_si256(a.0, _mm256_set1_epi32(-1))) }
    }
    #[inline(always)]
    fn any(a: Avx8i) -> bool {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { _mm256_testz_si256(a.0, a.0) == 0 }
    }
    #[inline(always)]
    fn mask_bits(a: Avx8i) -> u32 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { _mm256_movemask_ps(_mm256_castsi256_ps(a.0)) as u32 }
    }
    #[inline(always)]
    fn mask_to_int(a: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_srli_epi32::<31>(a.0)) }
    }
    #[inline(always)]
    fn int_splat(value: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_set1_epi32(value as i32)) }
    }
    #[inline(always)]
    fn int_add(a: Avx8i, b: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_add_epi32(a.0, b.0)) }
    }
    #[inline(always)]
    fn int_mul(a: Avx8i, b: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_mullo_epi32(a.0, _mm256_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn int_xor(a: Avx8i, b: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_xor_si256(a.0, b.0)) }
    }
    #[inline(always)]
    fn int_and(a: Avx8i, b: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_and_si256(a.0, _mm256_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn int_shr(a: Avx8i, bits: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_srl_epi32(a.0, _mm_cvtsi32_si128(bits as i32))) }
    }
    #[inline(always)]
    fn int_shl(a: Avx8i, bits: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_sll_epi32(a.0, _mm_cvtsi32_si128(bits as i32))) }
    }
    #[inline(always)]
    fn int_select(mask: Avx8i, yes: Avx8i, no: Avx8i) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_blendv_epi8(no.0, yes.0, mask.0)) }
    }
    #[inline(always)]
    fn int_eq(a: Avx8i, b: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2.
        unsafe { Avx8i(_mm256_cmpeq_epi32(a.0, _mm256_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn int_gt(a: Avx8i, b: u32) -> Avx8i {
        // SAFETY: Avx8 values exist only where the CPU has AVX2. A signed
        // comparison, right for values below 2³¹.
        unsafe { Avx8i(_mm256_cmpgt_epi32(a.0, _mm256_set1_epi32(b as i32))) }
    }
    #[inline(always)]
    fn select_on_bit(bits: Avx8i, bit: u32, yes: Avx8, no: Avx8) -> Avx8 {
        // SAFETY: Avx8 values exist only where the CPU has AVX2. blendvps
        // reads only the sign bit of each lane of the mask, so the bit is
        // shifted there.
        unsafe {
            let sign = _mm256_sll_epi32(bits.0, _mm_cvtsi32_si128(31 - bit as i32));
            Avx8(_mm256_blendv_ps(no.0, yes.0, _mm256_castsi256_ps(sign)))
        }
    }
}

/// Two AVX2 registers per batch (16 particles): see [`Pair`].
pub(crate) type Avx8x2 = Pair<Avx8>;

crate::integrate::entry_points!(Avx8x2, Avx2, "avx2", "AVX2");

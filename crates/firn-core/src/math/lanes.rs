//! `N` lanes of `f32` operated on together, and 3-vectors and 3x3 matrices
//! made of them: the portable batch numbers of the solvers' hot loops.
//!
//! Each operation is a plain loop over the lanes, which the compiler turns
//! into one SIMD instruction per operation (SSE by default, AVX2 or AVX-512
//! inside functions compiled for them). Every lane does exactly the same IEEE
//! operations in the same order as `F32s<1>`, the scalar path, and no fused
//! multiply-add is ever formed, so a value gets the same bits whether it is
//! computed alone or in a batch of 8 or 16, on any x86-64 CPU.

use std::ops::{Add, Div, Mul, Neg, Sub};

use glam::{Mat3, Vec3};

/// `N` lanes of `f32`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(transparent)]
pub struct F32s<const N: usize>(pub [f32; N]);

/// `N` lanes of `u32`: integers, or masks (all bits set where true).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub struct U32s<const N: usize>(pub [u32; N]);

/// Lane-wise map of one array.
///
/// The lane loops of this module count an index from 0 to `N` rather than
/// zip iterators: LLVM unrolls a counted loop with a constant trip count at
/// once, while a zipped loop stays a loop until the caller has been
/// simplified several times over. The snow model holds about a thousand of
/// them, and re-simplifying its 16-lane SVD for each took three quarters of
/// firn-mpm's release build (docs/benchmark-history.md, "Build time": "Why
/// it was slow").
#[inline(always)]
pub fn map1<T: Copy, U: Copy + Default, const N: usize>(a: [T; N], f: impl Fn(T) -> U) -> [U; N] {
    let mut out = [U::default(); N];
    for i in 0..N {
        out[i] = f(a[i]);
    }
    out
}

/// Lane-wise map of two arrays.
#[inline(always)]
pub fn map2<T: Copy, U: Copy + Default, const N: usize>(
    a: [T; N],
    b: [T; N],
    f: impl Fn(T, T) -> U,
) -> [U; N] {
    let mut out = [U::default(); N];
    for i in 0..N {
        out[i] = f(a[i], b[i]);
    }
    out
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const N: usize> $trait for F32s<N> {
            type Output = F32s<N>;
            #[inline(always)]
            fn $method(self, other: F32s<N>) -> F32s<N> {
                F32s(map2(self.0, other.0, |a, b| a $op b))
            }
        }
    };
}

lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

impl<const N: usize> Neg for F32s<N> {
    type Output = F32s<N>;
    #[inline(always)]
    fn neg(self) -> F32s<N> {
        F32s(map1(self.0, |a| -a))
    }
}

/// All bits set for true, none for false.
#[inline(always)]
pub fn mask_bits(b: bool) -> u32 {
    (b as u32).wrapping_neg()
}

impl<const N: usize> F32s<N> {
    /// The same value in every lane.
    #[inline(always)]
    pub fn splat(value: f32) -> F32s<N> {
        F32s([value; N])
    }

    /// Lane `i`.
    #[inline(always)]
    pub fn lane(self, i: usize) -> f32 {
        self.0[i]
    }

    /// `f` applied lane by lane.
    #[inline(always)]
    pub fn map(self, f: impl Fn(f32) -> f32) -> F32s<N> {
        F32s(map1(self.0, f))
    }

    /// self < other, as a mask.
    #[inline(always)]
    pub fn lt(self, other: F32s<N>) -> U32s<N> {
        U32s(map2(self.0, other.0, |a, b| mask_bits(a < b)))
    }

    /// self <= other, as a mask.
    #[inline(always)]
    pub fn le(self, other: F32s<N>) -> U32s<N> {
        U32s(map2(self.0, other.0, |a, b| mask_bits(a <= b)))
    }

    /// Per lane: `yes` where `mask` holds, else `no`.
    #[inline(always)]
    #[expect(
        clippy::needless_range_loop,
        reason = "counted loops compile fast (map1)"
    )]
    pub fn select(mask: U32s<N>, yes: F32s<N>, no: F32s<N>) -> F32s<N> {
        let mut out = no.0;
        for i in 0..N {
            let m = mask.0[i];
            out[i] = f32::from_bits((yes.0[i].to_bits() & m) | (out[i].to_bits() & !m));
        }
        F32s(out)
    }

    /// Per-lane minimum, `if self < other { self } else { other }` (the
    /// semantics of the x86 `minps` instruction).
    #[inline(always)]
    pub fn min(self, other: F32s<N>) -> F32s<N> {
        F32s(map2(self.0, other.0, |a, b| if a < b { a } else { b }))
    }

    /// Per-lane maximum, `if self > other { self } else { other }` (`maxps`).
    #[inline(always)]
    pub fn max(self, other: F32s<N>) -> F32s<N> {
        F32s(map2(self.0, other.0, |a, b| if a > b { a } else { b }))
    }

    /// All bits set in the lanes that hold a finite value (|x| < ∞ is
    /// false for ±∞ and NaN).
    #[inline(always)]
    pub fn finite_mask(self) -> U32s<N> {
        self.abs().lt(F32s::splat(f32::INFINITY))
    }

    /// Per-lane ⌊x⌋ (`vroundps` where compiled for AVX2; exact).
    #[inline(always)]
    pub fn floor(self) -> F32s<N> {
        F32s(map1(self.0, f32::floor))
    }

    /// Per-lane square root (correctly rounded, as `sqrtps`).
    #[inline(always)]
    pub fn sqrt(self) -> F32s<N> {
        self.map(f32::sqrt)
    }

    /// Per-lane eˣ by [`crate::math::exp::exp`]: vector instructions, not a
    /// library call per lane.
    #[inline(always)]
    pub fn exp(self) -> F32s<N> {
        self.map(crate::math::exp::exp)
    }

    /// Per-lane absolute value.
    #[inline(always)]
    pub fn abs(self) -> F32s<N> {
        F32s(map1(self.0, |a| f32::from_bits(a.to_bits() & 0x7fff_ffff)))
    }

    /// Per lane: 1 with the sign of `self` (−1 for −0.0).
    #[inline(always)]
    pub fn sign(self) -> F32s<N> {
        F32s(map1(self.0, |a| {
            f32::from_bits(1.0f32.to_bits() | (a.to_bits() & 0x8000_0000))
        }))
    }
}

impl<const N: usize> U32s<N> {
    /// Whether any lane holds.
    #[inline(always)]
    pub fn any(self) -> bool {
        let mut any = 0;
        for i in 0..N {
            any |= self.0[i];
        }
        any != 0
    }

    /// Whether every lane holds.
    #[inline(always)]
    pub fn all(self) -> bool {
        let mut all = u32::MAX;
        for i in 0..N {
            all &= self.0[i];
        }
        all == u32::MAX
    }

    /// Lanes where both masks hold.
    #[inline(always)]
    pub fn and(self, other: U32s<N>) -> U32s<N> {
        U32s(map2(self.0, other.0, |a, b| a & b))
    }
}

/// A 3-vector per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Vec3s<const N: usize> {
    /// x components.
    pub x: F32s<N>,
    /// y components.
    pub y: F32s<N>,
    /// z components.
    pub z: F32s<N>,
}

impl<const N: usize> Vec3s<N> {
    /// (x, y, z) in every lane.
    #[inline(always)]
    pub fn splat(v: Vec3) -> Vec3s<N> {
        Vec3s::new(F32s::splat(v.x), F32s::splat(v.y), F32s::splat(v.z))
    }

    /// From components.
    #[inline(always)]
    pub fn new(x: F32s<N>, y: F32s<N>, z: F32s<N>) -> Vec3s<N> {
        Vec3s { x, y, z }
    }

    /// Largest |component| per lane.
    #[inline(always)]
    pub fn max_abs(&self) -> F32s<N> {
        self.x.abs().max(self.y.abs()).max(self.z.abs())
    }

    /// All bits set in the lanes whose three components are finite.
    #[inline(always)]
    pub fn finite_mask(&self) -> U32s<N> {
        self.x
            .finite_mask()
            .and(self.y.finite_mask())
            .and(self.z.finite_mask())
    }

    /// Lane `i` as a glam vector.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Vec3 {
        Vec3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }

    /// Stores `v` in lane `i`.
    #[inline(always)]
    pub fn set_lane(&mut self, i: usize, v: Vec3) {
        self.x.0[i] = v.x;
        self.y.0[i] = v.y;
        self.z.0[i] = v.z;
    }

    /// a · b = ax bx + ay by + az bz, summed left to right.
    #[inline(always)]
    pub fn dot(self, other: Vec3s<N>) -> F32s<N> {
        self.x * other.x + self.y * other.y + self.z * other.z
    }

    /// a × b.
    #[inline(always)]
    pub fn cross(self, other: Vec3s<N>) -> Vec3s<N> {
        Vec3s::new(
            self.y * other.z - self.z * other.y,
            self.z * other.x - self.x * other.z,
            self.x * other.y - self.y * other.x,
        )
    }

    /// |a|².
    #[inline(always)]
    pub fn length_squared(self) -> F32s<N> {
        self.dot(self)
    }

    /// s a.
    #[inline(always)]
    pub fn scale(self, s: F32s<N>) -> Vec3s<N> {
        Vec3s::new(self.x * s, self.y * s, self.z * s)
    }

    /// Per lane: `yes` where `mask` holds, else `no`.
    #[inline(always)]
    pub fn select(mask: U32s<N>, yes: Vec3s<N>, no: Vec3s<N>) -> Vec3s<N> {
        Vec3s::new(
            F32s::select(mask, yes.x, no.x),
            F32s::select(mask, yes.y, no.y),
            F32s::select(mask, yes.z, no.z),
        )
    }
}

impl<const N: usize> Add for Vec3s<N> {
    type Output = Vec3s<N>;
    #[inline(always)]
    fn add(self, other: Vec3s<N>) -> Vec3s<N> {
        Vec3s::new(self.x + other.x, self.y + other.y, self.z + other.z)
    }
}

impl<const N: usize> Sub for Vec3s<N> {
    type Output = Vec3s<N>;
    #[inline(always)]
    fn sub(self, other: Vec3s<N>) -> Vec3s<N> {
        Vec3s::new(self.x - other.x, self.y - other.y, self.z - other.z)
    }
}

impl<const N: usize> Neg for Vec3s<N> {
    type Output = Vec3s<N>;
    #[inline(always)]
    fn neg(self) -> Vec3s<N> {
        Vec3s::new(-self.x, -self.y, -self.z)
    }
}

/// A 3x3 matrix per lane, stored by columns like glam's `Mat3`: in memory
/// its nine components one after the other, `N` lanes each (`repr(C)`, so
/// that eight matrices can be moved in and out by an 8x8 transpose).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Mat3s<const N: usize> {
    /// First column.
    pub x_axis: Vec3s<N>,
    /// Second column.
    pub y_axis: Vec3s<N>,
    /// Third column.
    pub z_axis: Vec3s<N>,
}

impl<const N: usize> Mat3s<N> {
    /// `m` in every lane.
    #[inline(always)]
    pub fn splat(m: Mat3) -> Mat3s<N> {
        Mat3s::from_cols(
            Vec3s::splat(m.x_axis),
            Vec3s::splat(m.y_axis),
            Vec3s::splat(m.z_axis),
        )
    }

    /// From columns.
    #[inline(always)]
    pub fn from_cols(x_axis: Vec3s<N>, y_axis: Vec3s<N>, z_axis: Vec3s<N>) -> Mat3s<N> {
        Mat3s {
            x_axis,
            y_axis,
            z_axis,
        }
    }

    /// diag(d).
    #[inline(always)]
    pub fn from_diagonal(d: Vec3s<N>) -> Mat3s<N> {
        let zero = F32s::splat(0.0);
        Mat3s::from_cols(
            Vec3s::new(d.x, zero, zero),
            Vec3s::new(zero, d.y, zero),
            Vec3s::new(zero, zero, d.z),
        )
    }

    /// Lane `i` as a glam matrix.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> Mat3 {
        Mat3::from_cols(
            self.x_axis.lane(i),
            self.y_axis.lane(i),
            self.z_axis.lane(i),
        )
    }

    /// Stores `m` in lane `i`.
    #[inline(always)]
    pub fn set_lane(&mut self, i: usize, m: Mat3) {
        self.x_axis.set_lane(i, m.x_axis);
        self.y_axis.set_lane(i, m.y_axis);
        self.z_axis.set_lane(i, m.z_axis);
    }

    /// M v = vx col0 + vy col1 + vz col2.
    #[inline(always)]
    pub fn mul_vec(&self, v: Vec3s<N>) -> Vec3s<N> {
        self.x_axis.scale(v.x) + self.y_axis.scale(v.y) + self.z_axis.scale(v.z)
    }

    /// A B, column by column.
    #[inline(always)]
    pub fn mul_mat(&self, other: &Mat3s<N>) -> Mat3s<N> {
        Mat3s::from_cols(
            self.mul_vec(other.x_axis),
            self.mul_vec(other.y_axis),
            self.mul_vec(other.z_axis),
        )
    }

    /// Mᵀ.
    #[inline(always)]
    pub fn transpose(&self) -> Mat3s<N> {
        let (a, b, c) = (self.x_axis, self.y_axis, self.z_axis);
        Mat3s::from_cols(
            Vec3s::new(a.x, b.x, c.x),
            Vec3s::new(a.y, b.y, c.y),
            Vec3s::new(a.z, b.z, c.z),
        )
    }

    /// A + B.
    #[inline(always)]
    pub fn add(&self, other: &Mat3s<N>) -> Mat3s<N> {
        Mat3s::from_cols(
            self.x_axis + other.x_axis,
            self.y_axis + other.y_axis,
            self.z_axis + other.z_axis,
        )
    }

    /// A − B.
    #[inline(always)]
    pub fn sub(&self, other: &Mat3s<N>) -> Mat3s<N> {
        Mat3s::from_cols(
            self.x_axis - other.x_axis,
            self.y_axis - other.y_axis,
            self.z_axis - other.z_axis,
        )
    }

    /// s M.
    #[inline(always)]
    pub fn scale(&self, s: F32s<N>) -> Mat3s<N> {
        Mat3s::from_cols(
            self.x_axis.scale(s),
            self.y_axis.scale(s),
            self.z_axis.scale(s),
        )
    }

    /// det M = c₀ · (c₁ × c₂) of the columns.
    #[inline(always)]
    pub fn determinant(&self) -> F32s<N> {
        self.x_axis.dot(self.y_axis.cross(self.z_axis))
    }

    /// Per lane: `yes` where `mask` holds, else `no`.
    #[inline(always)]
    pub fn select(mask: U32s<N>, yes: &Mat3s<N>, no: &Mat3s<N>) -> Mat3s<N> {
        Mat3s::from_cols(
            Vec3s::select(mask, yes.x_axis, no.x_axis),
            Vec3s::select(mask, yes.y_axis, no.y_axis),
            Vec3s::select(mask, yes.z_axis, no.z_axis),
        )
    }

    /// All bits set in the lanes whose nine entries are finite.
    #[inline(always)]
    pub fn finite_mask(&self) -> U32s<N> {
        self.x_axis
            .finite_mask()
            .and(self.y_axis.finite_mask())
            .and(self.z_axis.finite_mask())
    }

    /// Largest |entry| per lane.
    #[inline(always)]
    pub fn max_abs(&self) -> F32s<N> {
        self.x_axis
            .max_abs()
            .max(self.y_axis.max_abs())
            .max(self.z_axis.max_abs())
    }
}

/// Eight values of eight lanes turned into eight rows: row `l` holds lane
/// `l` of each value, in order (a plain copy).
#[inline(always)]
pub fn lanes_to_rows(values: &[F32s<8>; 8]) -> [[f32; 8]; 8] {
    let mut rows = [[0.0; 8]; 8];
    for (v, value) in values.iter().enumerate() {
        for (row, &lane) in rows.iter_mut().zip(&value.0) {
            row[v] = lane;
        }
    }
    rows
}

/// The instruction set batches of lanes run on, chosen at run time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Simd {
    /// Portable code: whatever the build targets (SSE2 on plain x86-64).
    Portable,
    /// 256-bit AVX2 registers (8 particles at once), chosen at run time where
    /// the CPU has them.
    Avx2,
    /// 512-bit AVX-512 registers (16 particles at once), chosen at run time
    /// where the CPU has them.
    Avx512,
}

impl Simd {
    /// The best the running CPU offers.
    pub fn detect() -> Simd {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                return Simd::Avx512;
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                return Simd::Avx2;
            }
        }
        Simd::Portable
    }

    /// Whether the running CPU can run this code path.
    pub fn is_available(self) -> bool {
        match self {
            Simd::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Simd::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// A short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Simd::Portable => "portable",
            Simd::Avx2 => "avx2",
            Simd::Avx512 => "avx512",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finite_masks_catch_infinities_and_nans_in_any_component() {
        let values = [
            1.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
        ];
        let lanes = F32s(values);
        assert_eq!(
            lanes.finite_mask().0.map(|m| m != 0),
            values.map(f32::is_finite)
        );
        for bad in [f32::INFINITY, f32::NAN] {
            let mut m = Mat3s::<2>::splat(Mat3::IDENTITY);
            m.y_axis.z.0[1] = bad;
            assert_eq!(m.finite_mask().0, [u32::MAX, 0]);
            let mut v = Vec3s::<2>::splat(Vec3::ONE);
            v.x.0[0] = bad;
            assert_eq!(v.finite_mask().0, [0, u32::MAX]);
        }
    }

    #[test]
    fn select_and_masks_work_lane_by_lane() {
        let a = F32s([1.0, 2.0, 3.0, 4.0]);
        let b = F32s([4.0, 3.0, 2.0, 1.0]);
        let mask = a.lt(b);
        assert_eq!(F32s::select(mask, a, b).0, [1.0, 2.0, 2.0, 1.0]);
        assert!(mask.any());
        assert!(!U32s::<4>([0; 4]).any());
        assert_eq!(a.min(b).0, [1.0, 2.0, 2.0, 1.0]);
        assert_eq!(a.max(b).0, [4.0, 3.0, 3.0, 4.0]);
    }

    #[test]
    fn sign_and_abs_follow_the_sign_bit() {
        let x = F32s([-2.0, -0.0, 0.0, 3.5]);
        assert_eq!(x.sign().0, [-1.0, -1.0, 1.0, 1.0]);
        assert_eq!(x.abs().0, [2.0, 0.0, 0.0, 3.5]);
    }

    #[test]
    fn matrix_products_match_glam_lane_by_lane() {
        let a = Mat3::from_cols_array(&[1.0, 2.0, 3.0, -1.0, 0.5, 2.0, 0.25, -3.0, 4.0]);
        let b = Mat3::from_cols_array(&[0.5, -1.0, 2.0, 3.0, 1.5, -2.0, 1.0, 0.0, -0.5]);
        let mut lanes_a = Mat3s::<2>::splat(Mat3::IDENTITY);
        let mut lanes_b = Mat3s::<2>::splat(Mat3::IDENTITY);
        lanes_a.set_lane(1, a);
        lanes_b.set_lane(1, b);
        let product = lanes_a.mul_mat(&lanes_b);
        assert_eq!(product.lane(0), Mat3::IDENTITY);
        assert_eq!(product.lane(1), a * b);
        assert_eq!(lanes_a.transpose().lane(1), a.transpose());
        assert_eq!(lanes_a.max_abs().lane(1), 4.0);
    }
}

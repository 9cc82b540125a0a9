//! The instruction sets the solvers choose at run time, as proofs: the
//! only `unsafe` of firn-core's lanes.
//!
//! An [`Avx2`] or [`Avx512`] value exists only where the running CPU has
//! that instruction set ([`Isa::of`] checks), so everything that needs one
//! can be a safe method taking the value:
//!
//! - [`Isa::run`] runs a [`Kernel`] compiled for the instruction set, the
//!   way every solver stage dispatches (one copy of the kernel per set);
//! - [`Vec4Pair`] puts two `Vec4`s in one 256-bit register, for the APIC
//!   stencils that handle two nodes or two particles at once, and
//!   [`PairLanes`] writes pair code once for AVX2 and portable code (the
//!   PIC/FLIP transfers, which weight both vectors of a node together);
//! - [`floor_sse2`] is B-spline weights' ⌊x⌋ in SSE2, which x86-64 always has;
//! - [`floor_clamped`] is ⌊x⌋ as an `i32` without `as`'s saturation checks,
//!   so that lanes of it vectorise;
//! - [`Avx2::lanes_to_rows`], [`Avx2::load_eight`] and [`Avx2::store_eight`]
//!   move eight particles' values in and out of [`F32s`]/[`Mat3s`] lanes by
//!   8x8 transposes in registers.
//!
//! Everything here is a plain copy or the same IEEE operation lane by lane
//! as the portable code, and no fused multiply-add is enabled, so results
//! have the same bits on every instruction set.
//!
//! Written by hand: the crates that wrap `std::arch` (`safe_arch`, `wide`,
//! `pulp`) either fix the instruction set at compile time or pick their own
//! operation order, and the solvers need run-time choice with our order.

// The instruction-set proofs call `std::arch` intrinsics and `target_feature` code.
#![allow(unsafe_code)]

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;
use std::ops::{Add, Mul};

use glam::{IVec3, Mat3, Vec3A, Vec4};

use super::lanes::{F32s, Mat3s, Simd};

/// Proof that the running CPU has AVX2: only [`Isa::of`] makes one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx2 {
    _checked: (),
}

/// Proof that the running CPU has AVX-512F and AVX2: only [`Isa::of`]
/// makes one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Avx512 {
    _checked: (),
}

/// An instruction set the running CPU has, to run kernels in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// Whatever the build targets (SSE2 on plain x86-64).
    Portable,
    /// 256-bit registers.
    Avx2(Avx2),
    /// 512-bit registers.
    Avx512(Avx512),
}

/// Work compiled once per instruction set by [`Isa::run`].
///
/// Implementations mark [`Kernel::run`] `#[inline(always)]`: its body then
/// becomes part of the function [`Isa::run`] compiles for the instruction
/// set, rather than a call into baseline code.
pub trait Kernel {
    /// What the work returns.
    type Output;
    /// Does the work; `isa` is the instruction set it is compiled for.
    fn run(self, isa: Isa) -> Self::Output;
}

impl Isa {
    /// `simd` where the running CPU has it, else portable code.
    pub fn of(simd: Simd) -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 = std::arch::is_x86_feature_detected!("avx2");
            match simd {
                Simd::Avx512 if avx2 && std::arch::is_x86_feature_detected!("avx512f") => {
                    return Isa::Avx512(Avx512 { _checked: () });
                }
                Simd::Avx2 if avx2 => return Isa::Avx2(Avx2 { _checked: () }),
                _ => {}
            }
        }
        let _ = simd;
        Isa::Portable
    }

    /// The instruction set's name as a [`Simd`].
    pub fn simd(self) -> Simd {
        match self {
            Isa::Portable => Simd::Portable,
            Isa::Avx2(_) => Simd::Avx2,
            Isa::Avx512(_) => Simd::Avx512,
        }
    }

    /// The AVX2 proof, which AVX-512 carries too.
    #[inline(always)]
    pub fn avx2(self) -> Option<Avx2> {
        match self {
            Isa::Portable => None,
            Isa::Avx2(avx2) => Some(avx2),
            Isa::Avx512(_) => Some(Avx2 { _checked: () }),
        }
    }

    /// Runs `kernel` compiled for this instruction set, out of line: one
    /// copy of each kernel per instruction set.
    #[inline(always)]
    pub fn run<K: Kernel>(self, kernel: K) -> K::Output {
        match self {
            Isa::Portable => run_portable(kernel),
            #[cfg(target_arch = "x86_64")]
            // SAFETY: an `Avx2` exists only where the CPU has AVX2 (`Isa::of`).
            Isa::Avx2(_) => unsafe { run_avx2(kernel) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: an `Avx512` exists only where the CPU has AVX-512F.
            Isa::Avx512(_) => unsafe { run_avx512(kernel) },
            #[cfg(not(target_arch = "x86_64"))]
            _ => run_portable(kernel),
        }
    }
}

/// [`Kernel::run`] in the baseline instruction set.
#[inline(never)]
fn run_portable<K: Kernel>(kernel: K) -> K::Output {
    kernel.run(Isa::Portable)
}

/// [`Kernel::run`] compiled for AVX2, told so by a constant that lets its
/// branches on the instruction set fold away.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline(never)]
fn run_avx2<K: Kernel>(kernel: K) -> K::Output {
    kernel.run(Isa::Avx2(Avx2 { _checked: () }))
}

/// [`Kernel::run`] compiled for AVX-512F: the kernel's scalar bookkeeping
/// gets its 3-operand encodings too.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline(never)]
fn run_avx512<K: Kernel>(kernel: K) -> K::Output {
    kernel.run(Isa::Avx512(Avx512 { _checked: () }))
}

/// Inputs of [`floor_clamped`] are clamped to ±this (2³⁰).
pub const FLOOR_LIMIT: f32 = 1_073_741_824.0;

/// ⌊x⌋ of `x` clamped into ±[`FLOOR_LIMIT`] (NaN counts as −2³⁰), as an
/// `i32`: a truncating conversion, then a step down where truncation rounded
/// up. The clamp makes the conversion exact, so it needs none of the
/// saturation checks of `x as i32`, and arrays of it vectorise into
/// `cvttps2dq`.
#[inline(always)]
pub fn floor_clamped(x: f32) -> i32 {
    let x = if x > -FLOOR_LIMIT { x } else { -FLOOR_LIMIT };
    let x = if x < FLOOR_LIMIT { x } else { FLOOR_LIMIT };
    // SAFETY: x is finite and within ±2³⁰ after the clamp, so it fits an i32.
    let truncated: i32 = unsafe { x.to_int_unchecked() };
    truncated - ((truncated as f32 > x) as i32)
}

/// [`super::bspline::floor`]'s per-lane ⌊x⌋ as a number and as an index,
/// by one truncating conversion for all three lanes (`cvttps2dq`), then a
/// step down where truncation rounded up. Needs nothing past SSE2, which
/// every x86-64 CPU has.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn floor_sse2(x: Vec3A) -> (Vec3A, IVec3) {
    let lanes: __m128 = x.into();
    // SAFETY: SSE2 is part of x86-64.
    unsafe {
        let truncated = _mm_cvttps_epi32(lanes);
        let truncated_float = _mm_cvtepi32_ps(truncated);
        // All ones (−1) where truncation rounded up.
        let rounded_up = _mm_cmpgt_ps(truncated_float, lanes);
        let below = _mm_sub_ps(truncated_float, _mm_and_ps(rounded_up, _mm_set1_ps(1.0)));
        let index = _mm_add_epi32(truncated, _mm_castps_si128(rounded_up));
        let ix = _mm_cvtsi128_si32(index);
        let iy = _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b01>(index));
        let iz = _mm_cvtsi128_si32(_mm_shuffle_epi32::<0b10>(index));
        (Vec3A::from(below), IVec3::new(ix, iy, iz))
    }
}

/// Two `Vec4`s in one 256-bit register, made by [`Avx2::pair`]: the low
/// half and the high half, each operated on as glam does a `Vec4`.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub struct Vec4Pair(__m256);

#[cfg(target_arch = "x86_64")]
impl Avx2 {
    /// `low` and `high` in one register.
    #[inline(always)]
    pub fn pair(self, low: Vec4, high: Vec4) -> Vec4Pair {
        // SAFETY: `self` proves the CPU has AVX2.
        Vec4Pair(unsafe { _mm256_set_m128(high.into(), low.into()) })
    }

    /// Both halves zero.
    #[inline(always)]
    pub fn zero_pair(self) -> Vec4Pair {
        self.pair(Vec4::ZERO, Vec4::ZERO)
    }

    /// Eight values of eight lanes turned into eight rows: row `l` holds
    /// lane `l` of each value, as [`super::lanes::lanes_to_rows`] does.
    #[inline(always)]
    pub fn lanes_to_rows(self, values: &[F32s<8>; 8]) -> [[f32; 8]; 8] {
        // SAFETY: `self` proves the CPU has AVX2.
        unsafe { lanes_to_rows_avx2(values) }
    }

    /// Lanes `first` to `first + 7` of `lanes` from `matrices`: the values
    /// [`Mat3s::set_lane`] would write, in a quarter of the instructions.
    #[inline(always)]
    pub fn load_eight<const N: usize>(
        self,
        lanes: &mut Mat3s<N>,
        first: usize,
        matrices: [&Mat3; 8],
    ) {
        assert!(first + 8 <= N, "lanes {first}.. past {N}");
        // SAFETY: `self` proves the CPU has AVX2; the lanes are in range.
        unsafe { load_eight_avx2(lanes, first, matrices) }
    }

    /// Lanes `first`, `first + 1`, … of `lanes` into `matrices`, as many as
    /// it yields up to eight: the values [`Mat3s::lane`] would read.
    #[inline(always)]
    pub fn store_eight<'a, const N: usize>(
        self,
        lanes: &Mat3s<N>,
        first: usize,
        matrices: impl IntoIterator<Item = &'a mut Mat3>,
    ) {
        assert!(first + 8 <= N, "lanes {first}.. past {N}");
        // SAFETY: `self` proves the CPU has AVX2; the lanes are in range.
        unsafe { store_eight_avx2(lanes, first, matrices) }
    }
}

#[cfg(target_arch = "x86_64")]
impl Vec4Pair {
    /// The low and the high `Vec4`.
    #[inline(always)]
    pub fn halves(self) -> [Vec4; 2] {
        // SAFETY: a `Vec4Pair` is only made with an `Avx2` proof.
        unsafe {
            [
                Vec4::from(_mm256_castps256_ps128(self.0)),
                Vec4::from(_mm256_extractf128_ps::<1>(self.0)),
            ]
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Add for Vec4Pair {
    type Output = Vec4Pair;
    #[inline(always)]
    fn add(self, other: Vec4Pair) -> Vec4Pair {
        // SAFETY: a `Vec4Pair` is only made with an `Avx2` proof.
        Vec4Pair(unsafe { _mm256_add_ps(self.0, other.0) })
    }
}

#[cfg(target_arch = "x86_64")]
impl Mul for Vec4Pair {
    type Output = Vec4Pair;
    #[inline(always)]
    fn mul(self, other: Vec4Pair) -> Vec4Pair {
        // SAFETY: a `Vec4Pair` is only made with an `Avx2` proof.
        Vec4Pair(unsafe { _mm256_mul_ps(self.0, other.0) })
    }
}

/// Two `Vec4`s operated on together, lane by lane as glam does each, on
/// any instruction set: code generic over it is written once and runs in
/// one 256-bit register per pair with an [`Avx2`] ([`Vec4Pair`]), or as two
/// `Vec4`s with [`PortablePairs`] ([`SplitPair`]). The same IEEE operations
/// either way, so the same bits.
pub trait PairLanes: Copy {
    /// Two `Vec4`s, low and high.
    type Pair: Copy + Add<Output = Self::Pair> + Mul<Output = Self::Pair>;

    /// `low` and `high` as one pair.
    fn pair(self, low: Vec4, high: Vec4) -> Self::Pair;

    /// The low and the high `Vec4` of `pair`.
    fn halves(self, pair: Self::Pair) -> [Vec4; 2];

    /// `value` in all eight lanes.
    #[inline(always)]
    fn splat(self, value: f32) -> Self::Pair {
        self.pair(Vec4::splat(value), Vec4::splat(value))
    }
}

#[cfg(target_arch = "x86_64")]
impl PairLanes for Avx2 {
    type Pair = Vec4Pair;

    #[inline(always)]
    fn pair(self, low: Vec4, high: Vec4) -> Vec4Pair {
        Avx2::pair(self, low, high)
    }

    #[inline(always)]
    fn halves(self, pair: Vec4Pair) -> [Vec4; 2] {
        pair.halves()
    }
}

/// [`PairLanes`] without AVX2: each pair is two `Vec4`s.
#[derive(Clone, Copy, Debug)]
pub struct PortablePairs;

/// Two `Vec4`s side by side, for [`PortablePairs`].
#[derive(Clone, Copy, Debug)]
pub struct SplitPair {
    low: Vec4,
    high: Vec4,
}

impl Add for SplitPair {
    type Output = SplitPair;
    #[inline(always)]
    fn add(self, other: SplitPair) -> SplitPair {
        SplitPair {
            low: self.low + other.low,
            high: self.high + other.high,
        }
    }
}

impl Mul for SplitPair {
    type Output = SplitPair;
    #[inline(always)]
    fn mul(self, other: SplitPair) -> SplitPair {
        SplitPair {
            low: self.low * other.low,
            high: self.high * other.high,
        }
    }
}

impl PairLanes for PortablePairs {
    type Pair = SplitPair;

    #[inline(always)]
    fn pair(self, low: Vec4, high: Vec4) -> SplitPair {
        SplitPair { low, high }
    }

    #[inline(always)]
    fn halves(self, pair: SplitPair) -> [Vec4; 2] {
        [pair.low, pair.high]
    }
}

/// The nine components of `lanes`, `N` lanes each, in column order.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn components<const N: usize>(lanes: &Mat3s<N>) -> [&[f32; N]; 9] {
    let Mat3s {
        x_axis,
        y_axis,
        z_axis,
    } = lanes;
    [
        &x_axis.x.0,
        &x_axis.y.0,
        &x_axis.z.0,
        &y_axis.x.0,
        &y_axis.y.0,
        &y_axis.z.0,
        &z_axis.x.0,
        &z_axis.y.0,
        &z_axis.z.0,
    ]
}

/// [`components`], to write.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn components_mut<const N: usize>(lanes: &mut Mat3s<N>) -> [&mut [f32; N]; 9] {
    let Mat3s {
        x_axis,
        y_axis,
        z_axis,
    } = lanes;
    [
        &mut x_axis.x.0,
        &mut x_axis.y.0,
        &mut x_axis.z.0,
        &mut y_axis.x.0,
        &mut y_axis.y.0,
        &mut y_axis.z.0,
        &mut z_axis.x.0,
        &mut z_axis.y.0,
        &mut z_axis.z.0,
    ]
}

/// [`Avx2::lanes_to_rows`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn lanes_to_rows_avx2(values: &[F32s<8>; 8]) -> [[f32; 8]; 8] {
    let mut columns = [_mm256_setzero_ps(); 8];
    for (column, value) in columns.iter_mut().zip(values) {
        // SAFETY: a value is eight contiguous floats.
        *column = unsafe { _mm256_loadu_ps(value.0.as_ptr()) };
    }
    let mut rows = [[0.0; 8]; 8];
    for (row, lanes) in rows.iter_mut().zip(transpose_eight(columns)) {
        // SAFETY: a row is eight floats.
        unsafe { _mm256_storeu_ps(row.as_mut_ptr(), lanes) };
    }
    rows
}

/// [`Avx2::load_eight`]: the first eight floats of each matrix by an 8x8
/// transpose, the ninth one by one.
///
/// # Safety
/// `first + 8 <= N`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn load_eight_avx2<const N: usize>(
    lanes: &mut Mat3s<N>,
    first: usize,
    matrices: [&Mat3; 8],
) {
    // SAFETY: a `Mat3` is nine contiguous floats; its first eight are read.
    let rows = matrices.map(|m| unsafe { _mm256_loadu_ps(AsRef::<[f32; 9]>::as_ref(m).as_ptr()) });
    let mut components = components_mut(lanes);
    for (component, column) in components.iter_mut().zip(transpose_eight(rows)) {
        // SAFETY: lanes `first..first + 8` lie inside the component (the caller's promise).
        unsafe { _mm256_storeu_ps(component.as_mut_ptr().add(first), column) };
    }
    for (lane, matrix) in components[8][first..first + 8].iter_mut().zip(matrices) {
        *lane = matrix.z_axis.z;
    }
}

/// [`Avx2::store_eight`].
///
/// # Safety
/// `first + 8 <= N`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn store_eight_avx2<'a, const N: usize>(
    lanes: &Mat3s<N>,
    first: usize,
    matrices: impl IntoIterator<Item = &'a mut Mat3>,
) {
    let components = components(lanes);
    // SAFETY: lanes `first..first + 8` lie inside each component (the caller's promise).
    let columns: [__m256; 8] =
        std::array::from_fn(|c| unsafe { _mm256_loadu_ps(components[c].as_ptr().add(first)) });
    let rows = transpose_eight(columns);
    for ((matrix, row), &last) in matrices.into_iter().zip(rows).zip(&components[8][first..]) {
        // SAFETY: a `Mat3` is nine contiguous floats; the first eight are written.
        unsafe { _mm256_storeu_ps(AsMut::<[f32; 9]>::as_mut(matrix).as_mut_ptr(), row) };
        matrix.z_axis.z = last;
    }
}

/// The 8x8 transpose of eight 256-bit rows: element j of row i becomes
/// element i of row j.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn transpose_eight(rows: [__m256; 8]) -> [__m256; 8] {
    let [r0, r1, r2, r3, r4, r5, r6, r7] = rows;
    let (t0, t1) = (_mm256_unpacklo_ps(r0, r1), _mm256_unpackhi_ps(r0, r1));
    let (t2, t3) = (_mm256_unpacklo_ps(r2, r3), _mm256_unpackhi_ps(r2, r3));
    let (t4, t5) = (_mm256_unpacklo_ps(r4, r5), _mm256_unpackhi_ps(r4, r5));
    let (t6, t7) = (_mm256_unpacklo_ps(r6, r7), _mm256_unpackhi_ps(r6, r7));
    let s0 = _mm256_shuffle_ps::<0x44>(t0, t2);
    let s1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
    let s2 = _mm256_shuffle_ps::<0x44>(t1, t3);
    let s3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
    let s4 = _mm256_shuffle_ps::<0x44>(t4, t6);
    let s5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
    let s6 = _mm256_shuffle_ps::<0x44>(t5, t7);
    let s7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
    [
        _mm256_permute2f128_ps::<0x20>(s0, s4),
        _mm256_permute2f128_ps::<0x20>(s1, s5),
        _mm256_permute2f128_ps::<0x20>(s2, s6),
        _mm256_permute2f128_ps::<0x20>(s3, s7),
        _mm256_permute2f128_ps::<0x31>(s0, s4),
        _mm256_permute2f128_ps::<0x31>(s1, s5),
        _mm256_permute2f128_ps::<0x31>(s2, s6),
        _mm256_permute2f128_ps::<0x31>(s3, s7),
    ]
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::math::lanes::lanes_to_rows;

    #[test]
    fn clamped_floor_rounds_down_and_clamps() {
        for x in [
            -2.5_f32, -1.0, -0.75, -0.0, 0.0, 0.25, 1.0, 2.999, 1e9, -1e9,
        ] {
            assert_eq!(floor_clamped(x), x.floor() as i32, "{x}");
        }
        assert_eq!(floor_clamped(f32::INFINITY), 1 << 30);
        assert_eq!(floor_clamped(f32::NAN), -(1 << 30));
    }

    #[test]
    fn lanes_become_rows_the_same_by_transpose() {
        let values: [F32s<8>; 8] =
            std::array::from_fn(|v| F32s(std::array::from_fn(|l| (10 * v + l) as f32)));
        let rows = lanes_to_rows(&values);
        assert_eq!(rows[3][5], 53.0);
        if let Some(avx2) = Isa::of(Simd::Avx2).avx2() {
            assert_eq!(avx2.lanes_to_rows(&values), rows);
        }
    }

    /// Eight matrices in, shifted by two lanes, and out again: every float
    /// lands where `set_lane` and `lane` put it.
    #[test]
    fn eight_matrices_move_in_and_out_of_lanes_by_transpose() {
        let Some(avx2) = Isa::of(Simd::Avx2).avx2() else {
            return;
        };
        let matrix =
            |l: usize| Mat3::from_cols_array(&std::array::from_fn(|c| (10 * l + c) as f32));
        let matrices: [Mat3; 8] = std::array::from_fn(matrix);
        let mut lanes = Mat3s::<16>::splat(Mat3::ZERO);
        avx2.load_eight(&mut lanes, 2, matrices.each_ref());
        let mut expected = Mat3s::<16>::splat(Mat3::ZERO);
        for (l, m) in matrices.iter().enumerate() {
            expected.set_lane(l + 2, *m);
        }
        assert_eq!(lanes, expected);
        let mut out = [Mat3::IDENTITY; 8];
        avx2.store_eight(&lanes, 2, out.iter_mut().take(5));
        for (l, m) in out.iter().enumerate() {
            let want = if l < 5 { matrices[l] } else { Mat3::IDENTITY };
            assert_eq!(*m, want, "matrix {l}");
        }
    }

    #[test]
    fn pairs_add_and_multiply_each_half_as_glam_does() {
        let Some(avx2) = Isa::of(Simd::Avx2).avx2() else {
            return;
        };
        let (a, b) = (
            Vec4::new(1.5, -2.0, 0.1, 7.0),
            Vec4::new(0.3, 0.7, -9.0, 2.5),
        );
        let (c, d) = (Vec4::splat(0.1), Vec4::new(3.0, 0.2, 1e-3, -1.0));
        let pair = (avx2.pair(a, b) + avx2.pair(c, d)) * avx2.pair(d, c);
        assert_eq!(pair.halves(), [(a + c) * d, (b + d) * c]);
        assert_eq!(avx2.zero_pair().halves(), [Vec4::ZERO; 2]);
    }

    /// Kernels see the instruction set they run in.
    #[test]
    fn kernels_run_in_the_set_asked_for_or_portable() {
        struct Which;
        impl Kernel for Which {
            type Output = Simd;
            #[inline(always)]
            fn run(self, isa: Isa) -> Simd {
                isa.simd()
            }
        }
        for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
            let isa = Isa::of(simd);
            let ran = isa.run(Which);
            assert_eq!(ran, isa.simd());
            assert!(ran == simd || ran == Simd::Portable);
            assert_eq!(ran == simd, simd.is_available());
        }
    }
}

//! [`Batch`]: the lane types a batch of particles moves in (portable
//! lanes, two AVX2 registers side by side, one AVX-512 register), how a
//! batch's numbers go into and out of them, and which compiled field
//! evaluation each one calls.

use glam::Vec3;

use crate::field::{Prepared, velocity_lanes};
#[cfg(target_arch = "x86_64")]
use crate::lanes::Pair;
use crate::lanes::{F32s, Real, V3};
#[cfg(target_arch = "x86_64")]
use crate::lanes_avx2::{Avx8, Avx8x2};
#[cfg(target_arch = "x86_64")]
use crate::lanes_avx512::Avx16;

/// Particles per portable SIMD batch.
pub(crate) const LANES: usize = 8;

/// The widest batch (AVX-512); chunks of particles are multiples of it.
pub(crate) const MAX_LANES: usize = 16;

/// A lane type a batch of particles is evaluated in.
pub(crate) trait Batch: Real {
    /// Particles per batch.
    const WIDTH: usize;
    /// The first `WIDTH` numbers of `lanes`.
    fn load(lanes: &[f32; MAX_LANES]) -> Self;
    /// The lanes into the first `WIDTH` numbers of `out`.
    fn store(self, out: &mut [f32; MAX_LANES]);
    /// The field velocity of the batch: a function of its own (not inlined
    /// into the integrators).
    fn velocity(prepared: &Prepared<Self>, x: V3<Self>) -> V3<Self>;
    /// A whole batch of points (`WIDTH` of them) in lanes.
    #[inline(always)]
    fn load_points(points: &[Vec3]) -> V3<Self> {
        let mut lanes = [[0.0f32; MAX_LANES]; 3];
        for (i, x) in points.iter().enumerate() {
            lanes[0][i] = x.x;
            lanes[1][i] = x.y;
            lanes[2][i] = x.z;
        }
        [
            Self::load(&lanes[0]),
            Self::load(&lanes[1]),
            Self::load(&lanes[2]),
        ]
    }
    /// The lanes of a batch into `out` (`WIDTH` points).
    #[inline(always)]
    fn store_points(value: V3<Self>, out: &mut [Vec3]) {
        let mut lanes = [[0.0f32; MAX_LANES]; 3];
        for (axis, lanes) in lanes.iter_mut().enumerate() {
            value[axis].store(lanes);
        }
        for (i, slot) in out.iter_mut().enumerate() {
            *slot = Vec3::new(lanes[0][i], lanes[1][i], lanes[2][i]);
        }
    }
}

impl Batch for F32s<LANES> {
    const WIDTH: usize = LANES;
    #[inline(always)]
    fn load(lanes: &[f32; MAX_LANES]) -> Self {
        let mut out = [0.0; LANES];
        out.copy_from_slice(&lanes[..LANES]);
        F32s(out)
    }
    #[inline(always)]
    fn store(self, out: &mut [f32; MAX_LANES]) {
        out[..LANES].copy_from_slice(&self.0);
    }
    #[inline(never)]
    fn velocity(prepared: &Prepared<Self>, x: V3<Self>) -> V3<Self> {
        velocity_lanes(prepared, x)
    }
}

#[cfg(target_arch = "x86_64")]
impl Batch for Avx8x2 {
    const WIDTH: usize = 16;
    #[inline(always)]
    fn load(lanes: &[f32; MAX_LANES]) -> Self {
        let mut low = [0.0; 8];
        let mut high = [0.0; 8];
        low.copy_from_slice(&lanes[..8]);
        high.copy_from_slice(&lanes[8..]);
        Pair(Avx8::from_array(low), Avx8::from_array(high))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32; MAX_LANES]) {
        out[..8].copy_from_slice(&self.0.to_array());
        out[8..].copy_from_slice(&self.1.to_array());
    }
    #[inline(always)]
    fn velocity(prepared: &Prepared<Self>, x: V3<Self>) -> V3<Self> {
        Avx8x2::velocity(prepared, x)
    }
    #[inline(always)]
    fn load_points(points: &[Vec3]) -> V3<Self> {
        let (low, high) = points.split_at(8);
        let low = Avx8::load_points(low.try_into().expect("8 points"));
        let high = Avx8::load_points(high.try_into().expect("8 points"));
        [
            Pair(low[0], high[0]),
            Pair(low[1], high[1]),
            Pair(low[2], high[2]),
        ]
    }
    #[inline(always)]
    fn store_points(value: V3<Self>, out: &mut [Vec3]) {
        let (low, high) = out.split_at_mut(8);
        let [x, y, z] = value;
        Avx8::store_points([x.0, y.0, z.0], low.try_into().expect("8 points"));
        Avx8::store_points([x.1, y.1, z.1], high.try_into().expect("8 points"));
    }
}

#[cfg(target_arch = "x86_64")]
impl Batch for Avx16 {
    const WIDTH: usize = 16;
    #[inline(always)]
    fn load(lanes: &[f32; MAX_LANES]) -> Self {
        Avx16::from_array(*lanes)
    }
    #[inline(always)]
    fn store(self, out: &mut [f32; MAX_LANES]) {
        *out = self.to_array();
    }
    #[inline(always)]
    fn velocity(prepared: &Prepared<Self>, x: V3<Self>) -> V3<Self> {
        Avx16::velocity(prepared, x)
    }
}

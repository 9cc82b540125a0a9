//! Moving particles through the field: second-order (midpoint) or classic
//! fourth-order Runge-Kutta, 8 or 16 particles per batch in SIMD lanes.
//!
//! The seed moves each particle by x ← x + V(x) Δt once per frame (forward
//! Euler); Runge-Kutta follows the curved streamlines of curl noise far more
//! closely for the same number of field evaluations per frame.
//!
//! Batches are formed from a particle's index alone (a partial batch at the
//! end of a slice is padded), and every lane does the same operations, so a
//! particle's new position does not depend on how particles are split among
//! threads. On x86-64 CPUs with AVX-512 the lanes live in one 512-bit register
//! (16 particles, `lanes_avx512`), with AVX2 in two 256-bit registers side
//! by side (16, [`crate::lanes::Pair`] of `lanes_avx2`'s eight lanes, which
//! lets the CPU overlap two chains of dependent operations); elsewhere the
//! portable lanes of [`crate::lanes::F32s`] are used (8). The path is chosen at run time ([`Simd::detect`]); all give the
//! same bits.

use firn_core::scene::{FlowIntegrator, FlowObstacle};
use glam::Vec3;

use firn_core::math::isa::Isa;
#[cfg(target_arch = "x86_64")]
use firn_core::math::isa::{Avx2, Avx512};

pub(crate) use crate::batch::MAX_LANES;
use crate::batch::{Batch, LANES};
use crate::field::{FlowField, Prepared};
use crate::lanes::{F32s, Real, V3, add3, dot3, scale3, sub3};
#[cfg(target_arch = "x86_64")]
use crate::lanes_avx2::Avx8x2;
#[cfg(target_arch = "x86_64")]
use crate::lanes_avx512::Avx16;

pub use firn_core::math::lanes::Simd;

/// The field prepared at the times a step samples: its start, middle and end.
pub(crate) struct StagesOf<R: Real> {
    start: Prepared<R>,
    middle: Prepared<R>,
    end: Prepared<R>,
}

impl<R: Real> StagesOf<R> {
    fn new(field: &FlowField, t0: f64, t1: f64) -> StagesOf<R> {
        StagesOf {
            start: field.prepare(t0),
            middle: field.prepare(0.5 * (t0 + t1)),
            end: field.prepare(t1),
        }
    }
}

/// What a step checks after moving a batch: the domain box, the spheres, and
/// whether every particle must be looked at anyway (birth velocities).
pub(crate) struct Limits<'a> {
    pub min: Vec3,
    pub max: Vec3,
    pub obstacles: &'a [FlowObstacle],
    pub flag_all: bool,
}

/// One chunk of particles for a step.
pub(crate) struct Chunk<'a> {
    pub positions: &'a mut [Vec3],
    pub velocities: &'a mut [Vec3],
    pub ages: &'a [f32],
    pub lifetimes: &'a [f32],
}

/// The stages of one step, in the lane type of the chosen instruction set,
/// with the proof that the CPU has it.
pub(crate) enum Stages {
    Portable(Box<StagesOf<F32s<LANES>>>),
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2, Box<StagesOf<Avx8x2>>),
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512, Box<StagesOf<Avx16>>),
}

impl Stages {
    /// The field at the start, middle and end of the step from `t0` to `t1`,
    /// in the lanes of `simd` where the CPU has it (else portable lanes).
    pub(crate) fn new(simd: Simd, field: &FlowField, t0: f64, t1: f64) -> Stages {
        match Isa::of(simd) {
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2(avx2) => Stages::Avx2(avx2, Box::new(StagesOf::new(field, t0, t1))),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512(avx512) => Stages::Avx512(avx512, Box::new(StagesOf::new(field, t0, t1))),
            _ => Stages::Portable(Box::new(StagesOf::new(field, t0, t1))),
        }
    }
}

/// Advance a chunk by one step of `dt` through the field (the flow only),
/// store each step's velocity (its displacement over `dt`), and list in
/// `flagged` (as indices into the chunk) the particles that need more than
/// aging: those that left the domain, entered a sphere, or whose life ends
/// within the step (age + dt ≥ lifetime), or all with `limits.flag_all`.
pub(crate) fn advance(
    stages: &Stages,
    integrator: FlowIntegrator,
    dt: f32,
    limits: &Limits,
    chunk: Chunk,
    flagged: &mut Vec<u32>,
) {
    match stages {
        Stages::Portable(stages) => advance_batches(stages, integrator, dt, limits, chunk, flagged),
        #[cfg(target_arch = "x86_64")]
        Stages::Avx2(avx2, stages) => {
            Avx8x2::advance(*avx2, stages, integrator, dt, limits, chunk, flagged)
        }
        #[cfg(target_arch = "x86_64")]
        Stages::Avx512(avx512, stages) => {
            Avx16::advance(*avx512, stages, integrator, dt, limits, chunk, flagged)
        }
    }
}

/// Particles per parallel task of [`carry`].
const CARRY_CHUNK: usize = 64 * MAX_LANES;

/// Carries particles that follow the field without emitters or lifetimes
/// (a snow scene's spindrift): one step of `integrator` from time `t0` to
/// `t1` moves each of `positions`, and `velocities` receives its velocity
/// over the step (its displacement over t1 − t0). In parallel, in the lanes
/// of `simd` where the CPU has them; the bits depend neither on the thread
/// count nor on the instruction set.
pub fn carry(
    simd: Simd,
    field: &FlowField,
    integrator: FlowIntegrator,
    (t0, t1): (f64, f64),
    positions: &mut [Vec3],
    velocities: &mut [Vec3],
) {
    use rayon::prelude::*;
    if positions.is_empty() {
        return;
    }
    let stages = Stages::new(simd, field, t0, t1);
    let dt = (t1 - t0) as f32;
    let limits = Limits {
        min: Vec3::NEG_INFINITY,
        max: Vec3::INFINITY,
        obstacles: &[],
        flag_all: false,
    };
    positions
        .par_chunks_mut(CARRY_CHUNK)
        .zip(velocities.par_chunks_mut(CARRY_CHUNK))
        .for_each(|(positions, velocities)| {
            let ages = vec![0.0; positions.len()];
            let lifetimes = vec![f32::INFINITY; positions.len()];
            let chunk = Chunk {
                positions,
                velocities,
                ages: &ages,
                lifetimes: &lifetimes,
            };
            advance(&stages, integrator, dt, &limits, chunk, &mut Vec::new());
        });
}

/// Evaluate the field at time `t` at `positions` into `velocities`.
pub(crate) fn evaluate(
    simd: Simd,
    field: &FlowField,
    t: f64,
    positions: &[Vec3],
    velocities: &mut [Vec3],
) {
    match Isa::of(simd) {
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2(avx2) => {
            Avx8x2::evaluate(avx2, &field.prepare::<Avx8x2>(t), positions, velocities)
        }
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512(avx512) => {
            Avx16::evaluate(avx512, &field.prepare::<Avx16>(t), positions, velocities)
        }
        _ => evaluate_batches(&field.prepare::<F32s<LANES>>(t), positions, velocities),
    }
}

/// The integrator's entry points in one intrinsic lane type (`$lanes`),
/// written beside that type so that its file holds all of its `unsafe`:
/// `velocity`, `advance` and `evaluate`, each a safe method calling a copy
/// compiled for `$feature`. `advance` and `evaluate` take the instruction
/// set's proof; `velocity` relies on lane values existing only where the
/// CPU has the instruction set.
macro_rules! entry_points {
    ($lanes:ident, $proof:ident, $feature:literal, $name:literal) => {
        /// The integrator's entry points in these lanes.
        impl $lanes {
            /// The field velocity of a batch, in a function of its own (not
            /// inlined into the integrators).
            #[inline(always)]
            pub(crate) fn velocity(
                prepared: &$crate::field::Prepared<$lanes>,
                x: $crate::lanes::V3<$lanes>,
            ) -> $crate::lanes::V3<$lanes> {
                #[doc = concat!("Compiled for ", $name, ".")]
                #[target_feature(enable = $feature)]
                #[inline(never)]
                fn compiled(
                    prepared: &$crate::field::Prepared<$lanes>,
                    x: $crate::lanes::V3<$lanes>,
                ) -> $crate::lanes::V3<$lanes> {
                    $crate::field::velocity_lanes(prepared, x)
                }
                // SAFETY: lane values exist only where the CPU has the
                // instruction set (module docs).
                unsafe { compiled(prepared, x) }
            }

            /// The integrator's step in these lanes; `_proof` says the CPU
            /// has them.
            pub(crate) fn advance(
                _proof: firn_core::math::isa::$proof,
                stages: &$crate::integrate::StagesOf<$lanes>,
                integrator: firn_core::scene::FlowIntegrator,
                dt: f32,
                limits: &$crate::integrate::Limits,
                chunk: $crate::integrate::Chunk,
                flagged: &mut Vec<u32>,
            ) {
                #[doc = concat!("Compiled for ", $name, ".")]
                #[target_feature(enable = $feature)]
                fn compiled(
                    stages: &$crate::integrate::StagesOf<$lanes>,
                    integrator: firn_core::scene::FlowIntegrator,
                    dt: f32,
                    limits: &$crate::integrate::Limits,
                    chunk: $crate::integrate::Chunk,
                    flagged: &mut Vec<u32>,
                ) {
                    $crate::integrate::advance_batches(
                        stages, integrator, dt, limits, chunk, flagged,
                    )
                }
                // SAFETY: the proof says the CPU has the instruction set.
                unsafe { compiled(stages, integrator, dt, limits, chunk, flagged) }
            }

            /// The field at `positions` in these lanes; `_proof` says the CPU
            /// has them.
            pub(crate) fn evaluate(
                _proof: firn_core::math::isa::$proof,
                prepared: &$crate::field::Prepared<$lanes>,
                positions: &[glam::Vec3],
                velocities: &mut [glam::Vec3],
            ) {
                #[doc = concat!("Compiled for ", $name, ".")]
                #[target_feature(enable = $feature)]
                fn compiled(
                    prepared: &$crate::field::Prepared<$lanes>,
                    positions: &[glam::Vec3],
                    velocities: &mut [glam::Vec3],
                ) {
                    $crate::integrate::evaluate_batches(prepared, positions, velocities)
                }
                // SAFETY: the proof says the CPU has the instruction set.
                unsafe { compiled(prepared, positions, velocities) }
            }
        }
    };
}
#[cfg(target_arch = "x86_64")]
pub(crate) use entry_points;

/// Load a batch starting at `start`, padding with the last particle.
#[inline(always)]
fn load<R: Batch>(positions: &[Vec3], start: usize) -> V3<R> {
    if let Some(batch) = positions.get(start..start + R::WIDTH) {
        return R::load_points(batch);
    }
    let last = positions.len() - 1;
    let mut padded = [Vec3::ZERO; MAX_LANES];
    for (i, slot) in padded.iter_mut().enumerate() {
        *slot = positions[(start + i).min(last)];
    }
    R::load_points(&padded[..R::WIDTH])
}

/// Store the first `count` lanes of a batch at `start`.
#[inline(always)]
fn store<R: Batch>(out: &mut [Vec3], start: usize, count: usize, value: V3<R>) {
    if count == R::WIDTH {
        R::store_points(value, &mut out[start..start + count]);
    } else {
        let mut padded = [Vec3::ZERO; MAX_LANES];
        R::store_points(value, &mut padded[..R::WIDTH]);
        out[start..start + count].copy_from_slice(&padded[..count]);
    }
}

#[inline(always)]
pub(crate) fn evaluate_batches<R: Batch>(
    prepared: &Prepared<R>,
    positions: &[Vec3],
    velocities: &mut [Vec3],
) {
    for start in (0..positions.len()).step_by(R::WIDTH) {
        let count = (positions.len() - start).min(R::WIDTH);
        let v = R::velocity(prepared, load(positions, start));
        store(velocities, start, count, v);
    }
}

/// The numbers of a batch starting at `start` (padded with the last).
#[inline(always)]
fn load_numbers<R: Batch>(numbers: &[f32], start: usize) -> R {
    let mut lanes = [0.0f32; MAX_LANES];
    if let Some(batch) = numbers.get(start..start + R::WIDTH) {
        lanes[..R::WIDTH].copy_from_slice(batch);
    } else {
        let last = numbers.len() - 1;
        for (i, lane) in lanes.iter_mut().enumerate().take(R::WIDTH) {
            *lane = numbers[(start + i).min(last)];
        }
    }
    R::load(&lanes)
}

#[inline(always)]
pub(crate) fn advance_batches<R: Batch>(
    stages: &StagesOf<R>,
    integrator: FlowIntegrator,
    dt: f32,
    limits: &Limits,
    chunk: Chunk,
    flagged: &mut Vec<u32>,
) {
    let Chunk {
        positions,
        velocities,
        ages,
        lifetimes,
    } = chunk;
    let dt = R::splat(f64::from(dt));
    let half_dt = R::splat(0.5) * dt;
    let splat3 = |v: Vec3| {
        [
            R::splat(v.x.into()),
            R::splat(v.y.into()),
            R::splat(v.z.into()),
        ]
    };
    let (min, max) = (splat3(limits.min), splat3(limits.max));
    for start in (0..positions.len()).step_by(R::WIDTH) {
        let count = (positions.len() - start).min(R::WIDTH);
        let x = load::<R>(positions, start);
        let velocity = match integrator {
            FlowIntegrator::Rk2 => {
                let k1 = R::velocity(&stages.start, x);
                R::velocity(&stages.middle, add3(x, scale3(half_dt, k1)))
            }
            FlowIntegrator::Rk4 => {
                let k1 = R::velocity(&stages.start, x);
                let k2 = R::velocity(&stages.middle, add3(x, scale3(half_dt, k1)));
                let k3 = R::velocity(&stages.middle, add3(x, scale3(half_dt, k2)));
                let k4 = R::velocity(&stages.end, add3(x, scale3(dt, k3)));
                let sum = add3(add3(k1, k4), scale3(R::splat(2.0), add3(k2, k3)));
                scale3(R::splat(1.0 / 6.0), sum)
            }
        };
        let moved = add3(x, scale3(dt, velocity));
        store(positions, start, count, moved);
        store(velocities, start, count, velocity);

        // Outside the box (NaN included), expiring, or inside a sphere.
        let mut inside = R::and(min[0].le(moved[0]), moved[0].le(max[0]));
        inside = R::and(inside, R::and(min[1].le(moved[1]), moved[1].le(max[1])));
        inside = R::and(inside, R::and(min[2].le(moved[2]), moved[2].le(max[2])));
        let age = load_numbers::<R>(ages, start) + dt;
        let living = age.lt(load_numbers::<R>(lifetimes, start));
        let mut flag = R::not(R::and(inside, living));
        for obstacle in limits.obstacles {
            let rel = sub3(moved, splat3(obstacle.center));
            let radius = R::splat(obstacle.radius.into());
            flag = R::or(flag, dot3(rel, rel).lt(radius * radius));
        }
        if limits.flag_all || R::any(flag) {
            let bits = if limits.flag_all {
                u32::MAX
            } else {
                R::mask_bits(flag)
            };
            for i in 0..count {
                if bits >> i & 1 == 1 {
                    flagged.push((start + i) as u32);
                }
            }
        }
    }
}

//! Throughput of the batched 3x3 SVD, the snow model's costliest part:
//! `svd3_lanes` on 16 matrices per call, as the solver's gather runs it:
//! portable code (SSE2 on x86-64), then AVX2 where the CPU has it (the
//! solver's default there).
//!
//!     cargo run --release -p firn-core --example svd_throughput
//!
//! The matrices are near the identity, like the elastic gradients of snow.

use std::hint::black_box;
use std::time::Instant;

use firn_core::math::isa::{Isa, Kernel};
use firn_core::math::lanes::{Mat3s, Simd};
use firn_core::math::svd::svd3_lanes;
use glam::Mat3;

/// Matrices per decomposition call, the solver's batch.
const LANES: usize = 16;
/// Matrices per timed pass.
const MATRICES: usize = 1 << 20;

fn main() {
    let batches = near_identity_batches(MATRICES / LANES);
    let mut instruction_sets = vec![Simd::Portable];
    if Simd::detect() != Simd::Portable {
        instruction_sets.push(Simd::Avx2);
    }
    for simd in instruction_sets {
        for pass in 1..=3 {
            let start = Instant::now();
            let checksum = decompose_all(&batches, simd);
            let ns = start.elapsed().as_nanos() as f64 / MATRICES as f64;
            println!(
                "{}, pass {pass}: {ns:.2} ns per matrix (checksum {checksum})",
                simd.name()
            );
        }
    }
}

/// Batches of matrices I + E with the entries of E uniform in [−0.1, 0.1]
/// (a fixed linear congruential sequence, so every run decomposes the same).
fn near_identity_batches(count: usize) -> Vec<Mat3s<LANES>> {
    let mut state = 1_u32;
    let mut next = move || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1 << 24) as f32 * 0.2 - 0.1
    };
    (0..count)
        .map(|_| {
            let mut batch = Mat3s::splat(Mat3::IDENTITY);
            for lane in 0..LANES {
                let noise = Mat3::from_cols_array(&[(); 9].map(|()| next()));
                batch.set_lane(lane, Mat3::IDENTITY + noise);
            }
            batch
        })
        .collect()
}

/// Decomposes every batch on `simd`; returns a checksum.
fn decompose_all(batches: &[Mat3s<LANES>], simd: Simd) -> f32 {
    Isa::of(simd).run(DecomposeAll(batches))
}

/// [`decompose_portable`] as a kernel, compiled once per instruction set.
struct DecomposeAll<'a>(&'a [Mat3s<LANES>]);

impl Kernel for DecomposeAll<'_> {
    type Output = f32;

    #[inline(always)]
    fn run(self, _isa: Isa) -> f32 {
        decompose_portable(self.0)
    }
}

/// The decompositions, each stored whole (`black_box` of a reference: the
/// solver stores them too); the largest singular values summed. A plain
/// loop, not an iterator closure: a closure may be compiled as a function
/// of its own, without the caller's AVX2, and then measures SSE code.
#[inline(always)]
fn decompose_portable(batches: &[Mat3s<LANES>]) -> f32 {
    let mut checksum = 0.0;
    for batch in batches {
        let svd = svd3_lanes(black_box(batch));
        black_box(&svd);
        checksum += svd.sigma.x.lane(0);
    }
    checksum
}

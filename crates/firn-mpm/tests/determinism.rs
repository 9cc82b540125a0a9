//! The same scene gives the same bits for any thread count and any SIMD
//! instruction set, and a run continued from a snapshot gives the same bits
//! as an uninterrupted one.

mod common;

use firn_core::math::lanes::Simd;
use firn_mpm::g2p::preferred_simd;
use firn_mpm::{Particles, Simulation};
use glam::Vec3;

fn run_with_threads(threads: usize, transfer: firn_core::scene::Transfer) -> Particles {
    run_with(threads, preferred_simd(), transfer)
}

fn run_with(threads: usize, simd: Simd, transfer: firn_core::scene::Transfer) -> Particles {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        // Thrown against the +x wall so that collisions and plasticity take part.
        let scene = common::snowball(
            Vec3::new(0.75, 0.3, 0.5),
            Vec3::new(6.0, -2.0, 0.5),
            transfer,
        );
        let mut simulation = Simulation::new(scene).unwrap();
        simulation.set_simd(simd);
        simulation.advance_to(0.08).unwrap();
        simulation.particles().clone()
    })
}

fn bits(particles: &Particles) -> Vec<u32> {
    let mut all = Vec::new();
    all.extend(
        particles
            .position
            .iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_bits),
    );
    all.extend(
        particles
            .velocity
            .iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_bits),
    );
    all.extend(
        particles
            .elastic
            .iter()
            .flat_map(|m| m.to_cols_array())
            .map(f32::to_bits),
    );
    all.extend(particles.plastic_j.iter().map(|j| j.to_bits()));
    all
}

#[test]
fn results_are_bit_identical_across_thread_counts() {
    for transfer in common::TRANSFERS {
        let reference = run_with_threads(1, transfer);
        assert!(
            reference.plastic_j.iter().any(|&j| j != 1.0),
            "{transfer:?}: the scene must deform plastically to test anything"
        );
        for threads in [2, 8] {
            let other = run_with_threads(threads, transfer);
            assert!(
                bits(&reference) == bits(&other),
                "{transfer:?}: {threads} threads differ from 1"
            );
        }
        let again = run_with_threads(2, transfer);
        assert!(
            bits(&reference) == bits(&again),
            "{transfer:?}: two runs differ"
        );
    }
}

/// The batched SVD and plasticity give the same bits in portable code, AVX2
/// and AVX-512 (each where the CPU has it; CI's machines have AVX2 at least).
#[test]
fn results_are_bit_identical_across_instruction_sets() {
    for transfer in common::TRANSFERS {
        let portable = run_with(2, Simd::Portable, transfer);
        for simd in [Simd::Avx2, Simd::Avx512] {
            if !simd.is_available() {
                eprintln!("{} not on this CPU; compared where it is", simd.name());
                continue;
            }
            let other = run_with(2, simd, transfer);
            assert!(
                bits(&portable) == bits(&other),
                "{transfer:?}: {} differs from portable code",
                simd.name()
            );
        }
    }
}

#[test]
fn resuming_from_a_snapshot_gives_the_same_bits() {
    for transfer in common::TRANSFERS {
        let scene = common::snowball(
            Vec3::new(0.75, 0.3, 0.5),
            Vec3::new(6.0, -2.0, 0.5),
            transfer,
        );
        // Both runs stop at the same frame times; one is restored in between.
        let mut straight = Simulation::new(scene.clone()).unwrap();
        straight.advance_to(0.027).unwrap();
        straight.advance_to(0.06).unwrap();

        let mut first = Simulation::new(scene.clone()).unwrap();
        first.advance_to(0.027).unwrap();
        let mut resumed = Simulation::from_snapshot(scene, first.snapshot()).unwrap();
        resumed.advance_to(0.06).unwrap();
        assert_eq!(straight.steps(), resumed.steps());
        assert!(
            bits(straight.particles()) == bits(resumed.particles()),
            "{transfer:?}: resumed run differs"
        );
    }
}

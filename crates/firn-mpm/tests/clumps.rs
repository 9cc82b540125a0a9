//! Clumpy snow (`clumps` on a body): the initial state packs each particle
//! to the density its place in the clump pattern asks for.

mod common;

use firn_core::scene::{Clumps, Transfer};
use firn_mpm::simulation::Snapshot;
use glam::Vec3;

/// Every particle of a clumpy snowball keeps the volume it fills and starts
/// at the scattered density over J_P⁰: clump interiors denser, seams looser,
/// the body's mass Σ ρ0 s³ / J_P⁰.
#[test]
fn clumpy_snow_starts_packed_unevenly() {
    let plain = common::snowball(Vec3::new(0.5, 0.5, 0.5), Vec3::ZERO, Transfer::PicFlip);
    let mut clumpy = plain.clone();
    clumpy.bodies[0].clumps = Some(Clumps {
        size: 0.08,
        contrast: 0.3,
    });
    clumpy.validate().expect("a valid clumpy scene");
    let plain = Snapshot::initial(&plain).expect("particles").particles;
    let clumpy = Snapshot::initial(&clumpy).expect("particles").particles;
    assert_eq!(plain.position, clumpy.position);
    let (mut packed, mut loose) = (0, 0);
    for p in 0..plain.len() {
        let j = clumpy.plastic_j[p];
        assert_eq!(clumpy.mass[p], plain.mass[p] / j);
        let volume = |particles: &firn_mpm::particles::Particles| {
            particles.plastic_j[p] * particles.volume0[p]
        };
        let relative = (volume(&clumpy) - volume(&plain)).abs() / volume(&plain);
        assert!(
            relative < 1e-6,
            "particle {p} fills {relative:e} more or less"
        );
        let expected = plain.density(p) / j;
        assert!((clumpy.density(p) - expected).abs() < 1e-3 * expected);
        packed += usize::from(j < 0.8);
        loose += usize::from(j > 1.2);
    }
    println!(
        "{} particles: {packed} compacted, {loose} loose",
        plain.len()
    );
    assert!(packed > plain.len() / 4 && loose > plain.len() / 50);
}

//! The sparse grid changes where node data lives, not what the solver
//! computes: these scenes must give exactly the recorded bits (see
//! `results_match_the_dense_grid_bit_for_bit` for their history), and a
//! huge mostly empty domain must cost memory in proportion to the snow, not
//! to the box.

mod common;

use firn_core::scene::{ImplicitSettings, Integrator, Shape, TimeStep, Transfer};
use firn_mpm::{Particles, Simulation};
use glam::Vec3;

/// FNV-1a over the bits of every particle attribute the step changes.
fn fingerprint(particles: &Particles) -> u64 {
    let vectors = particles.position.iter().chain(&particles.velocity);
    let matrices = particles
        .elastic
        .iter()
        .chain(&particles.velocity_gradient)
        .chain(&particles.stress);
    let words = vectors
        .flat_map(|v| v.to_array())
        .chain(matrices.flat_map(|m| m.to_cols_array()))
        .chain(particles.plastic_j.iter().copied())
        .chain(particles.volume0.iter().copied())
        .map(f32::to_bits);
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    for word in words {
        for byte in word.to_le_bytes() {
            hash ^= u64::from(byte);
            hash = hash.wrapping_mul(0x0100_0000_01b3);
        }
    }
    hash
}

/// A snowball on a 50³ grid thrown across several blocks into the +x wall.
fn thrown_snowball(transfer: Transfer, integrator: Integrator, dt: f32) -> Simulation {
    let mut scene = common::scene_with(
        Shape::Sphere {
            center: Vec3::new(0.6, 0.4, 0.45),
            radius: 0.1,
        },
        Vec3::new(6.0, -2.0, 1.0),
        transfer,
        0.02,
    );
    scene.solver.integrator = integrator;
    scene.time.step = TimeStep::Fixed { dt };
    Simulation::new(scene).unwrap()
}

fn fingerprint_after(mut simulation: Simulation, substeps: usize) -> u64 {
    for _ in 0..substeps {
        simulation.step(f64::INFINITY).unwrap();
    }
    assert!(
        simulation.particles().plastic_j.iter().any(|&j| j != 1.0),
        "the snowball must hit the wall hard enough to deform plastically"
    );
    fingerprint(simulation.particles())
}

/// The sparse grid reproduced, bit for bit, the hashes recorded with the
/// dense grid (commit f2d7377). The batched SIMD snow model, the factorised
/// APIC transfers and the per-block sums of the scatter that followed round
/// differently (they add the same terms in another order), so the hashes were
/// recorded again with each. So they were once more when the hardening factor
/// moved from the C library's `expf` to firn's own portable `exp` (within 2 ulp
/// of it), and when particles inside the yield surface began to keep their
/// trial F_E and take R_E from Newton's iteration instead of the SVD, and the
/// PIC/FLIP ones when its scatter and gather began to sum the cubic stencil
/// as a tensor product (rows along z, then y, then x). They guard against
/// any unintended change.
#[test]
fn results_match_the_dense_grid_bit_for_bit() {
    let semi_implicit = Integrator::SemiImplicit(ImplicitSettings::DEFAULT);
    let cases = [
        (
            "PIC/FLIP explicit",
            thrown_snowball(Transfer::PicFlip, Integrator::Explicit, 5e-4),
            120,
            0xd4d1fe903cfd5b83,
        ),
        (
            "APIC explicit",
            thrown_snowball(Transfer::Apic, Integrator::Explicit, 5e-4),
            120,
            0x095b74c1b682bf90,
        ),
        (
            "APIC semi-implicit",
            thrown_snowball(Transfer::Apic, semi_implicit, 1e-3),
            60,
            0x84bba3f905253bbb,
        ),
        (
            "PIC/FLIP semi-implicit",
            thrown_snowball(Transfer::PicFlip, semi_implicit, 1e-3),
            60,
            0xc81ea02c08aa67fd,
        ),
    ];
    let mut failures = Vec::new();
    for (name, simulation, substeps, expected) in cases {
        let hash = fingerprint_after(simulation, substeps);
        if hash != expected {
            failures.push(format!("{name}: {hash:#018x}, recorded {expected:#018x}"));
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// A 1024³-cell unit box with a snowball of radius 10 cells: memory follows
/// the snow, so the whole run holds the page table and binning table (64 MiB
/// each) and a few hundred blocks, not the 34 GiB of a dense grid.
#[test]
fn a_huge_box_costs_memory_in_proportion_to_the_snow() {
    let mut scene = common::scene_with(
        Shape::Sphere {
            center: Vec3::new(0.3, 0.5, 0.7),
            radius: 0.01,
        },
        Vec3::new(1.0, 0.0, 0.0),
        Transfer::Apic,
        1.0 / 1024.0,
    );
    scene.time.step = TimeStep::Fixed { dt: 1e-5 };
    let mut simulation = Simulation::new(scene).unwrap();
    for _ in 0..4 {
        simulation.step(f64::INFINITY).unwrap();
    }
    let layout = simulation.grid_layout();
    assert!(layout.blocks.cmpge(glam::UVec3::splat(256)).all());
    let particles = simulation.particles().len();
    let particle_bytes = particles * Particles::bytes_per_particle();
    let grid_bytes = simulation.memory_bytes() - particle_bytes;
    assert!(
        grid_bytes < 200 << 20,
        "{particles} particles, {} MiB besides them",
        grid_bytes >> 20
    );
}

//! Particle-to-grid and grid-to-particle transfers conserve mass, linear
//! momentum and, with APIC, angular momentum.

use firn_core::math::bspline::{cubic_weights, quadratic_weights};
use firn_core::math::lanes::Simd;
use firn_core::scene::Transfer;
use firn_mpm::Particles;
use firn_mpm::binning::Bins;
use firn_mpm::contact::Colliders;
use firn_mpm::coupling::BodyContacts;
use firn_mpm::g2p::{self, UpdateContext, preferred_simd};
use firn_mpm::grid::{Grid, GridLayout};
use firn_mpm::grid_update::{self, GridForces};
use firn_mpm::p2g;
use firn_mpm::simulation::diagnostics;
use firn_mpm::snow_model::MaterialConstants;
use glam::{DVec3, Mat3, Vec3};

const H: f32 = 0.05;

/// Particles with pseudo-random positions, velocities and affine matrices.
fn particles(count: usize, apic: bool) -> Particles {
    let hash = |i: usize, salt: u32| {
        let mut x = (i as u32).wrapping_mul(0x9E37_79B9) ^ salt.wrapping_mul(0x85EB_CA6B);
        x ^= x >> 15;
        x = x.wrapping_mul(0x2C1B_3C6D);
        x ^= x >> 12;
        (x as f32 / u32::MAX as f32) - 0.5
    };
    let vector =
        |i: usize, salt: u32| Vec3::new(hash(i, salt), hash(i, salt + 1), hash(i, salt + 2));
    Particles {
        position: (0..count)
            .map(|i| Vec3::splat(0.5) + vector(i, 1) * 0.4)
            .collect(),
        velocity: (0..count).map(|i| vector(i, 10) * 4.0).collect(),
        mass: (0..count).map(|i| 0.01 + 0.005 * hash(i, 20)).collect(),
        volume0: vec![1e-5; count],
        elastic: vec![Mat3::IDENTITY; count],
        plastic_j: vec![1.0; count],
        stress: vec![Mat3::ZERO; count],
        velocity_gradient: (0..count)
            .map(|i| {
                if apic {
                    Mat3::from_cols(vector(i, 30), vector(i, 40), vector(i, 50)) * 10.0
                } else {
                    Mat3::ZERO
                }
            })
            .collect(),
        material: vec![0; count],
    }
}

/// Grid totals: mass, momentum and angular momentum Σ m_i x_i × v_i, from
/// nodes holding velocities (after the grid update).
fn grid_totals(grid: &Grid) -> (f64, DVec3, DVec3) {
    let layout = grid.layout;
    let (mut mass, mut momentum, mut angular) = (0.0, DVec3::ZERO, DVec3::ZERO);
    for (block, nodes) in grid.blocks() {
        for (local, node) in nodes.iter().enumerate() {
            let node_coord = GridLayout::node_in_block(block, local);
            let m = node.mass() as f64;
            let p = node.velocity_new().as_dvec3() * m;
            mass += m;
            momentum += p;
            angular += layout.node_position(node_coord).as_dvec3().cross(p);
        }
    }
    (mass, momentum, angular)
}

fn close(a: DVec3, b: DVec3, scale: f64) -> bool {
    (a - b).length() <= 1e-5 * scale.max(1e-12)
}

fn round_trip(transfer_scheme: Transfer) {
    let apic = transfer_scheme == Transfer::Apic;
    let mut particles = particles(3000, apic);
    let before = diagnostics(&particles, H, transfer_scheme);
    let mut grid = Grid::new(Vec3::ZERO, Vec3::ONE, H);
    let mut bins = Bins::default();
    bins.rebuild(&grid.layout, &particles.position);
    // No stress and Δt = 0: a pure transfer, no forces, no motion.
    let simd = preferred_simd();
    match transfer_scheme {
        Transfer::PicFlip => p2g::scatter_pic_flip(&mut grid, &bins, &particles, simd, None),
        Transfer::Apic => p2g::scatter_apic(&mut grid, &bins, &particles, 0.0, simd, None),
    };
    let forces = if apic {
        GridForces::InMomentum
    } else {
        GridForces::Separate
    };
    grid_update::update_grid(
        &mut grid,
        forces,
        0.0,
        Vec3::ZERO,
        &Colliders::new(&[]),
        None,
        &BodyContacts::default(),
    );
    let (grid_mass, grid_momentum, grid_angular) = grid_totals(&grid);
    let momentum = DVec3::from_array(before.momentum);
    let angular = DVec3::from_array(before.angular_momentum);
    assert!(
        (grid_mass - before.mass).abs() < 1e-5 * before.mass,
        "P2G mass {grid_mass} vs {}",
        before.mass
    );
    assert!(
        close(grid_momentum, momentum, momentum.length()),
        "P2G momentum {grid_momentum} vs {momentum}"
    );
    if apic {
        assert!(
            close(grid_angular, angular, angular.length()),
            "P2G angular momentum {grid_angular} vs {angular}"
        );
    }

    let constants = [MaterialConstants::new(
        &firn_core::Material::preset("snow").unwrap(),
    )];
    let context = UpdateContext {
        dt: 0.0,
        materials: &constants,
        colliders: &Colliders::new(&[]),
        lower: Vec3::splat(-1.0),
        upper: Vec3::splat(2.0),
        keys: None,
    };
    let stats = match transfer_scheme {
        // α = 0: pure PIC, so particle velocities are the interpolated grid ones.
        Transfer::PicFlip => {
            g2p::gather_pic_flip(&grid, &bins, &mut particles, 0.0, &context, Simd::detect())
        }
        Transfer::Apic => g2p::gather_apic(&grid, &bins, &mut particles, &context, Simd::detect()),
    };
    assert!(stats.problem.is_none());
    let after = diagnostics(&particles, H, transfer_scheme);
    let momentum_after = DVec3::from_array(after.momentum);
    assert!(after.mass == before.mass, "particle mass must not change");
    assert!(
        close(momentum_after, grid_momentum, grid_momentum.length()),
        "G2P momentum {momentum_after} vs {grid_momentum}"
    );
    if apic {
        let angular_after = DVec3::from_array(after.angular_momentum);
        assert!(
            close(angular_after, grid_angular, grid_angular.length()),
            "G2P angular momentum {angular_after} vs {grid_angular}"
        );
    }
}

#[test]
fn pic_flip_transfers_conserve_mass_and_momentum() {
    round_trip(Transfer::PicFlip);
}

#[test]
fn apic_transfers_conserve_mass_momentum_and_angular_momentum() {
    round_trip(Transfer::Apic);
}

#[test]
fn density_estimate_recovers_the_rest_density() {
    // A uniform block of 8 particles per cell at ρ0: interior densities ≈ ρ0.
    let spacing = H / 2.0;
    let mut positions = Vec::new();
    for x in 0..16 {
        for y in 0..16 {
            for z in 0..16 {
                positions.push(
                    Vec3::splat(0.3) + (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * spacing,
                );
            }
        }
    }
    let count = positions.len();
    let rho0 = 400.0;
    let mut particles = Particles {
        mass: vec![rho0 * spacing.powi(3); count],
        position: positions,
        volume0: vec![0.0; count],
        ..Particles::default()
    };
    for (transfer_scheme, is_cubic) in [(Transfer::PicFlip, true), (Transfer::Apic, false)] {
        let mut grid = Grid::new(Vec3::ZERO, Vec3::ONE, H);
        let mut bins = Bins::default();
        bins.rebuild(&grid.layout, &particles.position);
        grid.allocate(bins.active_blocks());
        if is_cubic {
            p2g::scatter_mass(&mut grid, &bins, &particles, cubic_weights);
            p2g::estimate_volumes(&grid, &mut particles, cubic_weights);
        } else {
            p2g::scatter_mass(&mut grid, &bins, &particles, quadratic_weights);
            p2g::estimate_volumes(&grid, &mut particles, quadratic_weights);
        }
        let centre = count / 2 + 8 * 16 + 8;
        let density = particles.mass[centre] / particles.volume0[centre];
        assert!(
            (density - rho0).abs() < 0.01 * rho0,
            "{transfer_scheme:?}: interior density {density}"
        );
    }
}

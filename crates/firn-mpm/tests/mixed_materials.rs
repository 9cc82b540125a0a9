//! Each particle yields by its own material, also where two materials share
//! a grid block: the gather fills the snow model's material lanes once per
//! block when all its particles share a material, and particle by particle
//! otherwise.

mod common;

use firn_core::Material;
use firn_core::scene::{Body, Shape, Transfer};
use firn_mpm::Simulation;
use glam::Vec3;

/// Where the two halves of the dropped box meet: inside the block of cells
/// x ∈ [0.4, 0.6) (blocks are 4 cells of 0.05 wide), so that block holds
/// particles of both materials.
const SEAM_X: f32 = 0.45;

/// A box of snow settling on the floor under its own weight (a strain near
/// 1 %), its part left of [`SEAM_X`] of a material that stays elastic there
/// (θc = θs = 0.3), the part right of it of one that yields at once
/// (θc = θs = 1e-4).
fn half_and_half(transfer: Transfer) -> Simulation {
    let half = |center_x: f32, size_x: f32, material: usize| Body {
        shape: Shape::Box {
            center: Vec3::new(center_x, 0.1, 0.5),
            size: Vec3::new(size_x, 0.2, 0.2),
        },
        velocity: Vec3::ZERO,
        material,
        particles_per_cell: 8,
        clumps: None,
    };
    let mut scene = common::scene_with(
        Shape::Sphere {
            center: Vec3::splat(0.5),
            radius: 0.1,
        },
        Vec3::ZERO,
        transfer,
        0.05,
    );
    let snow = Material::preset("snow").unwrap();
    let with_limits = |name: &str, limit: f32| Material {
        name: name.into(),
        critical_compression: limit,
        critical_stretch: limit,
        ..snow.clone()
    };
    scene.materials = vec![with_limits("elastic", 0.3), with_limits("brittle", 1e-4)];
    scene.bodies = vec![
        half(0.375, 2.0 * (SEAM_X - 0.3), 0),
        half(0.525, 2.0 * (0.6 - SEAM_X), 1),
    ];
    Simulation::new(scene).unwrap()
}

#[test]
fn particles_sharing_a_block_yield_by_their_own_material() {
    for transfer in common::TRANSFERS {
        let mut simulation = half_and_half(transfer);
        simulation.advance_to(0.1).unwrap();
        let particles = simulation.particles();
        let in_seam_block = |p: usize| (0.4..0.6).contains(&particles.position[p].x);
        let (mut elastic, mut yielded, mut brittle) = (0, 0, 0);
        for p in (0..particles.len()).filter(|&p| in_seam_block(p)) {
            let plastic_j = particles.plastic_j[p];
            match particles.material[p] {
                0 => {
                    assert_eq!(plastic_j, 1.0, "{transfer:?}: elastic particle {p} yielded");
                    elastic += 1;
                }
                _ => {
                    brittle += 1;
                    yielded += usize::from(plastic_j != 1.0);
                }
            }
        }
        assert!(
            elastic > 100 && brittle > 100,
            "{transfer:?}: {elastic} and {brittle}"
        );
        assert!(
            yielded * 2 > brittle,
            "{transfer:?}: only {yielded} of {brittle} brittle particles yielded"
        );
    }
}

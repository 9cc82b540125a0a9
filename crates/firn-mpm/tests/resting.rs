//! Snow resting on the floor settles and does not drift sideways.

mod common;

use firn_core::scene::Shape;
use firn_mpm::Simulation;
use glam::Vec3;

#[test]
fn a_block_on_the_floor_settles_without_drifting() {
    for transfer in common::TRANSFERS {
        let block = Shape::Box {
            center: Vec3::new(0.5, 0.1, 0.5),
            size: Vec3::new(0.3, 0.2, 0.3),
        };
        let scene = common::scene_with(block, Vec3::ZERO, transfer, 0.05);
        let mut simulation = Simulation::new(scene).unwrap();
        let start = simulation.diagnostics();
        simulation.advance_to(0.6).unwrap();
        let end = simulation.diagnostics();
        let sideways = ((end.center_of_mass[0] - start.center_of_mass[0]).powi(2)
            + (end.center_of_mass[2] - start.center_of_mass[2]).powi(2))
        .sqrt();
        assert!(
            sideways < 1e-3,
            "{transfer:?} drifted {sideways} m sideways"
        );
        let sag = start.center_of_mass[1] - end.center_of_mass[1];
        assert!((0.0..0.02).contains(&sag), "{transfer:?} sagged {sag} m");
        let speed = (2.0 * end.kinetic_energy / end.mass).sqrt();
        assert!(speed < 0.02, "{transfer:?} still moves at {speed} m/s rms");
        let lowest = simulation
            .particles()
            .position
            .iter()
            .map(|x| x.y)
            .fold(f32::MAX, f32::min);
        assert!(
            lowest > -0.01,
            "{transfer:?} sank through the floor to {lowest}"
        );
    }
}

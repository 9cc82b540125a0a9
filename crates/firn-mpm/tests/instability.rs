//! A simulation that blows up stops with an explanation and a fix.

mod common;

use firn_core::scene::TimeStep;
use firn_mpm::{Simulation, SimulationError};
use glam::Vec3;

#[test]
fn a_too_large_fixed_step_stops_with_a_suggested_dt() {
    let mut scene = common::snowball(
        Vec3::new(0.5, 0.3, 0.5),
        Vec3::new(0.0, -3.0, 0.0),
        firn_core::scene::Transfer::PicFlip,
    );
    scene.materials[0].youngs_modulus = 1e8;
    scene.time.step = TimeStep::Fixed { dt: 1e-2 };
    let mut simulation = Simulation::new(scene).unwrap();
    let error = simulation.advance_to(1.0).unwrap_err();
    let SimulationError::Unstable { hint, .. } = &error else {
        panic!("expected an instability, got {error}");
    };
    let message = error.to_string();
    assert!(message.contains("E = 1.000e8"), "{message}");
    assert!(hint.contains("set dt = "), "{message}");
    assert!(simulation.time() < 1.0, "the run must stop early");
}

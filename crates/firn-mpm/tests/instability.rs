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

/// One particle given an infinite velocity poisons the nodes of its stencil
/// in the next substep: the run stops there, naming a particle within that
/// reach as non-finite, whichever lanes and batches the update ran in.
#[test]
fn a_non_finite_particle_stops_the_next_substep_near_where_it_was() {
    let scene = common::snowball(
        Vec3::new(0.5, 0.5, 0.5),
        Vec3::ZERO,
        firn_core::scene::Transfer::Apic,
    );
    let h = scene.domain.cell_size;
    let mut snapshot = Simulation::new(scene.clone()).unwrap().snapshot();
    let poisoned = snapshot.particles.len() / 2 + 5;
    snapshot.particles.velocity[poisoned] = Vec3::new(f32::INFINITY, 0.0, 0.0);
    let starts = snapshot.particles.position.clone();
    let centre = starts[poisoned];
    let mut simulation = Simulation::from_snapshot(scene, snapshot).unwrap();
    let error = simulation.step(f64::INFINITY).unwrap_err();
    let SimulationError::Unstable {
        step,
        particle,
        what,
        position,
        ..
    } = error
    else {
        panic!("expected an instability, got {error}");
    };
    assert_eq!(step, 0);
    assert_eq!(what, "became non-finite (NaN or infinity)");
    let start = starts[particle];
    assert!(
        (start - centre).abs().max_element() <= 4.0 * h,
        "particle {particle} at {start} (reported at {position}) is beyond the reach of {centre}"
    );
    let first_near = starts
        .iter()
        .position(|&x| (x - centre).abs().max_element() <= 2.0 * h)
        .unwrap();
    assert!(
        particle <= first_near,
        "particle {particle} reported, but {first_near} shares the poisoned nodes"
    );
}

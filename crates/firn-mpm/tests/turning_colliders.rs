//! Colliders that turn: a turntable under a layer of snow carries it round
//! at ω × r with sticky contact and leaves it behind when it slips without
//! friction; a turned box holds the snow as the same box built turned does.

mod common;

use firn_core::scene::{Collider, Contact, ContactMode, Shape, Transfer};
use firn_mpm::Simulation;
use glam::{Quat, Vec3};

/// The turntable's spin, rad/s about +y.
const SPIN: f32 = 3.0;

/// A slab of snow resting on a cylinder (radius 0.4 m, the axis vertical
/// through the domain's centre) that turns at [`SPIN`] with `contact`.
fn turntable(contact: Contact) -> Simulation {
    let slab = Shape::Box {
        center: Vec3::new(0.5, 0.2, 0.5),
        size: Vec3::new(0.5, 0.1, 0.5),
    };
    let mut scene = common::scene_with(slab, Vec3::ZERO, Transfer::Apic, 0.04);
    scene.colliders.push(
        Collider::cylinder(Vec3::new(0.5, 0.075, 0.5), 0.4, 0.15)
            .moving_and_spinning(Vec3::ZERO, Vec3::new(0.0, SPIN, 0.0))
            .contact(contact),
    );
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(0.3).unwrap();
    simulation
}

/// The snow's mean angular velocity about the turntable's axis:
/// Σ m (r × v)·ŷ / Σ m |r|² with r the offset from the axis.
fn spin_of(simulation: &Simulation) -> f32 {
    let particles = simulation.particles();
    let (mut momentum, mut inertia) = (0.0, 0.0);
    for p in 0..particles.len() {
        let offset = particles.position[p] - Vec3::new(0.5, 0.0, 0.5);
        let arm = Vec3::new(offset.x, 0.0, offset.z);
        momentum += particles.mass[p] * arm.cross(particles.velocity[p]).y;
        inertia += particles.mass[p] * arm.length_squared();
    }
    momentum / inertia
}

#[test]
fn a_sticky_turntable_carries_the_snow_round_and_a_frictionless_one_does_not() {
    let sticky = spin_of(&turntable(Contact {
        mode: ContactMode::Sticky,
        friction: 0.0,
    }));
    assert!(
        (sticky - SPIN).abs() < 0.15 * SPIN,
        "sticky: the snow turns at {sticky} rad/s, the table at {SPIN}"
    );
    let slipping = spin_of(&turntable(Contact {
        mode: ContactMode::Slip,
        friction: 0.0,
    }));
    assert!(
        slipping.abs() < 0.05 * SPIN,
        "frictionless: the snow turns at {slipping} rad/s"
    );
}

#[test]
fn a_box_turned_by_its_rotation_holds_snow_as_the_same_box_built_turned() {
    // A box tilted 30° about z, and a quarter-turned copy of it with its
    // edges swapped: both are one solid, so the snow falls alike.
    let run = |collider: Collider| {
        let ball = Shape::Sphere {
            center: Vec3::new(0.5, 0.7, 0.5),
            radius: 0.1,
        };
        let mut scene = common::scene_with(ball, Vec3::ZERO, Transfer::Apic, 0.05);
        scene.colliders.push(collider);
        let mut simulation = Simulation::new(scene).unwrap();
        simulation.advance_to(0.25).unwrap();
        simulation.diagnostics().center_of_mass
    };
    let center = Vec3::new(0.5, 0.35, 0.5);
    let tilt = Quat::from_rotation_z(30f32.to_radians());
    let quarter = Quat::from_rotation_z(90f32.to_radians());
    let wide = run(Collider::cuboid(center, Vec3::new(0.6, 0.1, 0.6)).rotated(tilt));
    let tall =
        run(Collider::cuboid(center, Vec3::new(0.1, 0.6, 0.6)).rotated(tilt * quarter.inverse()));
    let untilted = run(Collider::cuboid(center, Vec3::new(0.6, 0.1, 0.6)));
    let gap = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    assert!(gap(wide, tall) < 1e-4, "{wide:?} vs {tall:?}");
    // The tilted box sheds the ball sideways; the level one holds it.
    assert!(gap(wide, untilted) > 1e-2, "{wide:?} vs {untilted:?}");
}

//! Two-way coupling with rigid bodies (crates/firn-mpm/src/coupling.rs):
//! momentum kept between snow and body, heavier bodies sinking deeper,
//! bodies kept out of the snow, and the same bits on resume.

use firn_core::Scene;
use firn_core::math::lanes::Simd;
use firn_core::scene::{Body, Contact, Material, RigidBody, Transfer};
use firn_mpm::simulation::{Simulation, diagnostics};
use firn_rigid::BodyState;
use glam::{DVec3, Quat, Vec3};

/// The snow's and the bodies' linear and angular momentum (about `about`).
fn totals(simulation: &Simulation, about: DVec3) -> (DVec3, DVec3) {
    let layout = simulation.grid_layout();
    let snow = diagnostics(simulation.particles(), layout.cell_size, Transfer::Apic);
    let mut momentum = DVec3::from_array(snow.momentum);
    let mut angular = DVec3::from_array(snow.angular_momentum);
    for body in simulation.rigid_bodies() {
        momentum += body.momentum().as_dvec3();
        angular += body.angular_momentum().as_dvec3();
    }
    (momentum, angular - about.cross(momentum))
}

/// A snowball thrown off-centre at a free, turned box, with no gravity:
/// it pushes the box along and sets it turning.
fn snowball_at_box() -> Scene {
    Scene::builder("snowball-at-box")
        .unit_box(1.0 / 32.0)
        .duration(0.08)
        .transfer(Transfer::Apic)
        .gravity(Vec3::ZERO)
        .fixed_dt(2e-4)
        .material(Material::preset("snow").unwrap())
        .body(
            Body::sphere(Vec3::new(0.3, 0.56, 0.5), 0.1)
                .velocity(Vec3::new(4.0, 0.0, 0.0))
                .particles_per_cell(8),
        )
        .rigid_body(
            RigidBody::cuboid(Vec3::new(0.6, 0.5, 0.5), Vec3::splat(0.16))
                .density(300.0)
                .rotated(Quat::from_rotation_z(0.3))
                .contact(Contact::separate(0.3)),
        )
        .build()
        .unwrap()
}

#[test]
fn a_snowball_hitting_a_free_box_keeps_the_momentum_of_snow_and_box() {
    let scene = snowball_at_box();
    let mut simulation = Simulation::new(scene).unwrap();
    let about = DVec3::new(0.45, 0.53, 0.5);
    let (p0, l0) = totals(&simulation, about);
    let start = simulation.rigid_bodies()[0];
    simulation.advance_to(0.08).unwrap();
    let (p1, l1) = totals(&simulation, about);
    let end = simulation.rigid_bodies()[0];
    // The box was hit: it moves along +x and turns about z.
    assert!(end.velocity.x > 0.3, "box velocity {:?}", end.velocity);
    assert!(
        end.angular_velocity.z.abs() > 0.5,
        "box spin {:?}",
        end.angular_velocity
    );
    assert!(end.position.x > start.position.x + 0.005);
    let linear_error = (p1 - p0).length() / p0.length();
    let angular_error = (l1 - l0).length() / l0.length();
    eprintln!("box {end:?}; momentum error {linear_error:.2e}, angular {angular_error:.2e}");
    assert!(
        linear_error < 0.005,
        "momentum {p0} -> {p1}: {linear_error:.2e}"
    );
    assert!(
        angular_error < 0.01,
        "angular momentum {l0} -> {l1}: {angular_error:.2e}"
    );
}

/// The bits of a run of [`snowball_at_box`] on `threads` threads with
/// `simd`: the particles and the box.
fn run_on(threads: usize, simd: Simd) -> String {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    pool.install(|| {
        let mut simulation = Simulation::new(snowball_at_box()).unwrap();
        simulation.set_simd(simd);
        simulation.advance_to(0.05).unwrap();
        let positions: Vec<u32> = simulation
            .particles()
            .position
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect();
        format!("{positions:?} {:?}", simulation.rigid_bodies())
    })
}

#[test]
fn a_run_with_a_body_gives_the_same_bits_on_any_thread_count_and_instruction_set() {
    let one = run_on(1, firn_mpm::g2p::preferred_simd());
    assert_eq!(one, run_on(3, firn_mpm::g2p::preferred_simd()));
    assert_eq!(one, run_on(2, Simd::Portable));
}

#[test]
fn a_box_resting_on_packed_snow_is_held_up_by_the_snow_alone() {
    let top = 0.2;
    let size = Vec3::new(0.16, 0.08, 0.16);
    let scene = Scene::builder("resting-box")
        .domain(Vec3::ZERO, Vec3::splat(0.5), 1.0 / 32.0)
        .duration(0.6)
        .transfer(Transfer::Apic)
        .material(Material::preset("icy").unwrap())
        .body(
            Body::cuboid(Vec3::new(0.25, 0.5 * top, 0.25), Vec3::new(0.5, top, 0.5))
                .particles_per_cell(4),
        )
        .rigid_body(
            RigidBody::cuboid(Vec3::new(0.25, top + 0.5 * size.y + 0.01, 0.25), size)
                .density(600.0),
        )
        .build()
        .unwrap();
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(0.4).unwrap();
    let pushed_before = simulation.snow_impulse_on_bodies()[0];
    simulation.advance_to(0.6).unwrap();
    let pushed = simulation.snow_impulse_on_bodies()[0] - pushed_before;
    let body = simulation.rigid_bodies()[0];
    let force = pushed / 0.2;
    let weight = f64::from(body.mass) * 9.81;
    eprintln!("snow's force {force:?} N against a weight of {weight:.3} N; box {body:?}");
    assert!(
        body.velocity.length() < 0.02,
        "the box still moves: {body:?}"
    );
    assert!(
        (force.y - weight).abs() < 0.02 * weight,
        "the snow holds up {:.3} N of {weight:.3} N",
        force.y
    );
    assert!(force.x.abs().max(force.z.abs()) < 0.02 * weight);
}

#[test]
fn a_run_with_a_body_resumes_to_the_same_bits() {
    let scene = snowball_at_box();
    let mut whole = Simulation::new(scene.clone()).unwrap();
    whole.advance_to(0.04).unwrap();
    let snapshot = whole.snapshot();
    whole.advance_to(0.06).unwrap();
    let mut resumed = Simulation::from_snapshot(scene, snapshot).unwrap();
    resumed.advance_to(0.06).unwrap();
    assert_eq!(whole.particles(), resumed.particles());
    let bits = |states: Vec<BodyState>| format!("{states:?}");
    assert_eq!(bits(whole.rigid_bodies()), bits(resumed.rigid_bodies()));
}

/// A ball of `density` dropped onto a slab of powder; returns how deep its
/// bottom ends below the slab's top, m. No particle may be more than half
/// a cell inside the ball at any frame.
fn sinking(density: f32) -> f32 {
    let top = 0.25;
    let radius = 0.08;
    let scene = Scene::builder("sinking")
        .domain(Vec3::ZERO, Vec3::splat(0.5), 1.0 / 32.0)
        .duration(0.4)
        .transfer(Transfer::Apic)
        .material(Material::preset("powder").unwrap())
        .body(
            Body::cuboid(Vec3::new(0.25, 0.5 * top, 0.25), Vec3::new(0.5, top, 0.5))
                .particles_per_cell(4),
        )
        .rigid_body(
            RigidBody::sphere(Vec3::new(0.25, top + radius + 0.02, 0.25), radius)
                .density(density)
                .moving(Vec3::new(0.0, -2.0, 0.0), Vec3::ZERO),
        )
        .build()
        .unwrap();
    let mut simulation = Simulation::new(scene).unwrap();
    let cell = simulation.grid_layout().cell_size;
    for frame in 1..=8 {
        simulation.advance_to(0.05 * f64::from(frame)).unwrap();
        let ball = simulation.rigid_bodies()[0];
        let deepest = simulation
            .particles()
            .position
            .iter()
            .map(|&x| radius - (x - ball.position).length())
            .fold(f32::MIN, f32::max);
        assert!(
            deepest < 0.5 * cell,
            "at {:.2} s a particle is {deepest:.4} m inside the ball",
            0.05 * f64::from(frame)
        );
    }
    let ball = simulation.rigid_bodies()[0];
    top - (ball.position.y - radius)
}

#[test]
fn a_heavy_ball_sinks_deeper_into_powder_than_a_light_one() {
    let light = sinking(150.0);
    let heavy = sinking(2000.0);
    eprintln!("sunk: light {light:.3} m, heavy {heavy:.3} m");
    assert!(
        heavy > light + 0.02,
        "heavy {heavy:.3} m, light {light:.3} m"
    );
    assert!(
        light > -0.01,
        "the light ball rests on or in the snow: {light:.3} m"
    );
    assert!(
        heavy < 0.25,
        "the heavy ball stays in the slab: {heavy:.3} m"
    );
}

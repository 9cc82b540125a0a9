//! Two-way coupling with rigid bodies on the GPU (`src/snow/coupling.rs`,
//! as `firn_mpm::coupling` on the CPU): the momentum of snow and body kept,
//! the same bits on every run and on resume, and a ball sinking into powder
//! as deep as on the CPU.

use firn_core::Scene;
use firn_core::scene::{Body, Contact, Material, RigidBody, Transfer};
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::Simulation;
use firn_mpm::simulation::diagnostics;
use glam::{DVec3, Quat, Vec3};

/// A snowball thrown off-centre at a free, turned box, with no gravity:
/// it pushes the box along and sets it turning (the scene of
/// `firn-mpm/tests/rigid_coupling.rs`).
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

/// The snow's and the bodies' linear and angular momentum (about `about`)
/// of the GPU run `gpu`.
fn totals(gpu: &GpuSnow, about: DVec3) -> (DVec3, DVec3) {
    let particles = gpu.snapshot().unwrap().particles;
    let snow = diagnostics(&particles, gpu.scene().domain.cell_size, Transfer::Apic);
    let mut momentum = DVec3::from_array(snow.momentum);
    let mut angular = DVec3::from_array(snow.angular_momentum);
    for body in gpu.rigid_bodies().unwrap().states() {
        momentum += body.momentum().as_dvec3();
        angular += body.angular_momentum().as_dvec3();
    }
    (momentum, angular - about.cross(momentum))
}

#[test]
fn a_snowball_hitting_a_free_box_keeps_the_momentum_of_snow_and_box() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut gpu = GpuSnow::new(context, snowball_at_box()).unwrap();
    let about = DVec3::new(0.45, 0.53, 0.5);
    let (p0, l0) = totals(&gpu, about);
    let start = gpu.rigid_bodies().unwrap().states()[0];
    gpu.advance_to(0.08).unwrap();
    let (p1, l1) = totals(&gpu, about);
    let end = gpu.rigid_bodies().unwrap().states()[0];
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

/// The bits of the particles and the bodies of a GPU run.
fn bits(gpu: &GpuSnow) -> String {
    let snapshot = gpu.snapshot().unwrap();
    let positions: Vec<u32> = snapshot
        .particles
        .position
        .iter()
        .chain(&snapshot.particles.velocity)
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect();
    format!(
        "{positions:?} {:?} {}",
        gpu.rigid_bodies().unwrap().states(),
        snapshot.steps
    )
}

#[test]
fn a_run_with_a_body_gives_the_same_bits_twice_and_on_resume() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = snowball_at_box();
    let run = || {
        let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
        gpu.advance_to(0.025).unwrap();
        let snapshot = gpu.snapshot().unwrap();
        gpu.advance_to(0.035).unwrap();
        let box_speed = gpu.rigid_bodies().unwrap().states()[0].velocity.x;
        assert!(box_speed > 0.1, "the box was not hit: {box_speed} m/s");
        (bits(&gpu), snapshot)
    };
    let (whole, snapshot) = run();
    assert!(snapshot.rigid.is_some(), "the snapshot keeps the bodies");
    assert_eq!(whole, run().0, "a second run differs");
    let mut resumed = GpuSnow::from_snapshot(context, scene, &snapshot).unwrap();
    resumed.advance_to(0.035).unwrap();
    assert_eq!(whole, bits(&resumed), "the resumed run differs");
}

/// A ball of granite dropped at 2 m/s onto a slab of powder in a narrow
/// box (the scene of `firn-mpm/tests/rigid_coupling.rs`, heavier and
/// smaller).
fn sinking_ball() -> Scene {
    let (top, radius, width) = (0.16, 0.08, 0.32);
    Scene::builder("sinking")
        .domain(Vec3::ZERO, Vec3::new(width, 0.4, width), 1.0 / 32.0)
        .duration(0.05)
        .transfer(Transfer::Apic)
        .material(Material::preset("powder").unwrap())
        .body(
            Body::cuboid(
                Vec3::new(0.5 * width, 0.5 * top, 0.5 * width),
                Vec3::new(width, top, width),
            )
            .particles_per_cell(4),
        )
        .rigid_body(
            RigidBody::sphere(
                Vec3::new(0.5 * width, top + radius + 0.02, 0.5 * width),
                radius,
            )
            .density(2000.0)
            .moving(Vec3::new(0.0, -2.0, 0.0), Vec3::ZERO),
        )
        .build()
        .unwrap()
}

/// The CPU and the GPU differ in rounding only (the GPU sums the grid in
/// fixed point, the CPU in floats, and each orders and contracts its
/// arithmetic its own way), so the ball sinks as deep on both to well
/// within 2 % of a cell, 0.6 mm: a hundredth of what a coupling that loses
/// a part of the exchange, or steps the ball by another Δt, would change.
/// (The snow meets the ball through the grid nodes, a cell apart, so a
/// cell is the scale of what the coupling resolves.)
#[test]
fn a_ball_sinks_into_powder_as_deep_on_the_gpu_as_on_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = sinking_ball();
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    let start = scene.rigid_bodies[0].geometry.reference_point().y;
    let tolerance = 0.02 * scene.domain.cell_size;
    for until in [0.025, 0.05] {
        let cpu_steps = cpu.advance_to(until).unwrap();
        let gpu_steps = gpu.advance_to(until).unwrap();
        let on_cpu = start - cpu.rigid_bodies()[0].position.y;
        let on_gpu = start - gpu.rigid_bodies().unwrap().states()[0].position.y;
        eprintln!(
            "{until} s: sunk {on_cpu:.7} m on the CPU ({cpu_steps} substeps), {on_gpu:.7} m \
             on the GPU ({gpu_steps} substeps)"
        );
        assert!(
            (on_cpu - on_gpu).abs() < tolerance,
            "at {until} s the ball sank {on_cpu:.5} m on the CPU and {on_gpu:.5} m on the GPU"
        );
    }
    let sunk = start - gpu.rigid_bodies().unwrap().states()[0].position.y;
    assert!(sunk > 0.06, "the ball sank only {sunk:.4} m");
}

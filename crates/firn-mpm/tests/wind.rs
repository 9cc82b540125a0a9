//! Wind on snow (`[wind]`, `firn_mpm::wind`): the drag law's analytic rate,
//! conservation, the difference between powder and packed snow, and bit
//! identity with the wind off, across thread counts and instruction sets.

mod common;

use firn_core::Material;
use firn_core::math::lanes::Simd;
use firn_core::scene::{Integrator, Scene, Shape, Transfer, Wind};
use firn_mpm::grid::GridLayout;
use firn_mpm::wind::{AirDrag, relax};
use firn_mpm::{Particles, Simulation};
use glam::{DVec3, IVec3, Vec3};

/// A ball of snow of `density` kg/m³ at rest in the middle of the unit box.
fn ball(density: f32, transfer: Transfer) -> Scene {
    let mut scene = common::scene_with(
        Shape::Sphere {
            center: Vec3::new(0.35, 0.5, 0.5),
            radius: 0.1,
        },
        Vec3::ZERO,
        transfer,
        0.04,
    );
    scene.materials = vec![Material {
        density,
        ..Material::preset("snow").unwrap()
    }];
    scene
}

/// A steady wind of `speed` m/s along +x with drag `drag`.
fn crosswind(speed: f32, drag: f32) -> Wind {
    Wind {
        drag,
        ..Wind::uniform(Vec3::X, speed)
    }
}

fn run(scene: Scene, until: f64) -> Simulation {
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(until).unwrap();
    simulation
}

fn bits(particles: &Particles) -> Vec<u32> {
    let vectors = particles.position.iter().chain(&particles.velocity);
    vectors
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect()
}

fn momentum(particles: &Particles) -> DVec3 {
    particles
        .mass
        .iter()
        .zip(&particles.velocity)
        .map(|(&m, v)| f64::from(m) * v.as_dvec3())
        .sum()
}

fn center_of_mass_x(simulation: &Simulation) -> f64 {
    simulation.diagnostics().center_of_mass[0]
}

#[test]
fn a_node_at_rest_reaches_the_wind_at_the_rate_of_the_drag_law() {
    let cell = 0.04;
    let wind = crosswind(5.0, 6.0);
    let drag = AirDrag::new(&wind, cell);
    let air = Vec3::new(5.0, 0.0, 0.0);
    // A node holding a quarter of a packed cell with nothing upwind: exposed
    // over φ = 1/4 of a cell face, so k = c_d h² φ / m (equation W3).
    let packed = wind.packed_density * cell * cell * cell;
    let mass = 0.25 * packed;
    let node = IVec3::new(5, 5, 5);
    let nothing = |_: IVec3| 0.0;
    let rate = drag.rate(node, mass, Vec3::ZERO, air, nothing);
    let expected = wind.drag * cell * cell * 0.25 / mass;
    assert!(
        (rate - expected).abs() < 1e-6 * expected,
        "k = {rate}, not {expected}"
    );
    let dt = 1e-3;
    let mut velocity = Vec3::ZERO;
    for step in 1..=2000 {
        let rate = drag.rate(node, mass, velocity, air, nothing);
        velocity = relax(velocity, air, rate, dt);
        let exact = 5.0 * (1.0 - (-f64::from(expected) * f64::from(dt) * f64::from(step)).exp());
        let error = (f64::from(velocity.x) - exact).abs();
        assert!(
            error < 2e-5 * 5.0,
            "step {step}: {} m/s, the drag law gives {exact} m/s",
            velocity.x
        );
    }
    assert!(velocity.x > 2.5, "after 2 s the node moves at {velocity}");
}

#[test]
fn snow_upwind_shelters_a_node() {
    let cell = 0.04;
    let wind = crosswind(5.0, 6.0);
    let drag = AirDrag::new(&wind, cell);
    let packed = wind.packed_density * cell * cell * cell;
    let node = IVec3::new(5, 5, 5);
    let air = Vec3::new(5.0, 0.0, 0.0);
    // Packed snow on the upwind side (-x) shelters the node completely;
    // on the downwind side it does not.
    let upwind_full = |n: IVec3| if n.x < 5 { packed } else { 0.0 };
    let downwind_full = |n: IVec3| if n.x > 5 { packed } else { 0.0 };
    assert_eq!(drag.rate(node, packed, Vec3::ZERO, air, upwind_full), 0.0);
    let exposed = drag.rate(node, packed, Vec3::ZERO, air, downwind_full);
    assert!((exposed - wind.drag * cell * cell / packed).abs() < 1e-6 * exposed);
    // A half-packed cell upwind shelters half.
    let half = |n: IVec3| if n.x < 5 { 0.5 * packed } else { 0.0 };
    let sheltered = drag.rate(node, packed, Vec3::ZERO, air, half);
    assert!((sheltered - 0.5 * exposed).abs() < 1e-6 * exposed);
    // Nothing happens without drag, or at the air's own speed.
    let still = AirDrag::new(&crosswind(5.0, 0.0), cell);
    assert_eq!(still.rate(node, packed, Vec3::ZERO, air, |_| 0.0), 0.0);
    assert_eq!(drag.rate(node, packed, air, air, |_| 0.0), 0.0);
    assert_eq!(relax(Vec3::Y, air, 0.0, 1e-3), Vec3::Y);
}

#[test]
fn without_drag_the_wind_changes_no_bit() {
    for transfer in common::TRANSFERS {
        let plain = run(ball(400.0, transfer), 0.03);
        let mut scene = ball(400.0, transfer);
        scene.wind = Some(crosswind(8.0, 0.0));
        let calm = run(scene, 0.03);
        assert_eq!(bits(plain.particles()), bits(calm.particles()));
        assert_eq!(calm.wind_impulse(), DVec3::ZERO);
    }
}

#[test]
fn momentum_changes_by_the_wind_impulse() {
    // APIC without gravity, away from the walls: the transfers and the
    // elastic forces conserve momentum, so only the wind changes it.
    let mut scene = ball(150.0, Transfer::Apic);
    scene.solver.gravity = Vec3::ZERO;
    let mut wind = crosswind(3.0, 20.0);
    wind.field.noise_share = 0.5;
    wind.field.length_scale = 0.2;
    wind.field.noise_strength = 0.1;
    scene.wind = Some(wind);
    let mut simulation = Simulation::new(scene).unwrap();
    let before = momentum(simulation.particles());
    simulation.advance_to(0.05).unwrap();
    let change = momentum(simulation.particles()) - before;
    let impulse = simulation.wind_impulse();
    println!("momentum change {change:?}, wind impulse {impulse:?}");
    assert!(impulse.x > 0.0, "the wind pushes along +x: {impulse:?}");
    assert!(
        (change - impulse).length() < 1e-4 * impulse.length(),
        "momentum changed by {change:?} but the wind gave {impulse:?}"
    );
}

#[test]
fn powder_drifts_downwind_and_packed_snow_barely_moves() {
    let drift = |density: f32| {
        let mut scene = ball(density, Transfer::Apic);
        scene.solver.gravity = Vec3::ZERO;
        scene.wind = Some(crosswind(6.0, Wind::DEFAULT_DRAG));
        let start = center_of_mass_x(&Simulation::new(scene.clone()).unwrap());
        center_of_mass_x(&run(scene, 0.2)) - start
    };
    let powder = drift(100.0);
    let packed = drift(400.0);
    println!("downwind drift in 0.2 s: powder {powder:.4} m, packed {packed:.4} m");
    // Packed: the drag on its frontal area, c_d π r² u, on its mass
    // ρ 4/3 π r³ gives a = 3 c_d u / (4 ρ r) = 0.675 m/s² and ½ a t² =
    // 13.5 mm in 0.2 s; the grid's surface is a cell thick, so allow 2x.
    assert!(
        (0.0135..0.027).contains(&packed),
        "packed snow drifted {packed} m, the frontal-area drag gives 0.0135 m"
    );
    // Powder lets the air through: every node feels the wind.
    assert!(
        powder > 1.6 * packed,
        "powder drifted {powder} m, packed snow {packed} m"
    );
}

#[test]
fn windy_runs_are_the_same_bits_for_any_thread_count_and_instruction_set() {
    let run_on = |threads: usize, simd: Simd| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut scene = ball(200.0, Transfer::PicFlip);
            let mut wind = crosswind(4.0, 30.0);
            wind.field.noise_share = 0.7;
            wind.field.length_scale = 0.25;
            wind.field.noise_strength = 0.2;
            wind.field.evolution_rate = 1.0;
            scene.wind = Some(wind);
            let mut simulation = Simulation::new(scene).unwrap();
            simulation.set_simd(simd);
            simulation.advance_to(0.03).unwrap();
            (
                bits(simulation.particles()),
                simulation.wind_impulse().to_array().map(f64::to_bits),
            )
        })
    };
    let one = run_on(1, Simd::Portable);
    for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
        if simd.is_available() {
            assert!(run_on(2, simd) == one, "{simd:?} on 2 threads differs");
        }
    }
}

#[test]
fn block_wind_is_the_field_at_each_node() {
    let mut wind = crosswind(2.0, 6.0);
    wind.field.noise_share = 0.8;
    wind.field.length_scale = 0.3;
    let layout = GridLayout::new(Vec3::ZERO, Vec3::ONE, 0.05);
    let block = IVec3::new(1, 2, 0);
    for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
        if !simd.is_available() {
            continue;
        }
        let drag = AirDrag::new(&wind, 0.05).with_simd(simd);
        let batch = drag.block_wind(&layout, block, 0.7);
        for (local, velocity) in batch.iter().enumerate() {
            let x = layout.node_position(GridLayout::node_in_block(block, local));
            assert_eq!(*velocity, drag.wind_at(x, 0.7), "{simd:?}, node {local}");
        }
    }
}

#[test]
fn the_semi_implicit_integrator_feels_the_same_wind() {
    let drift = |integrator: Integrator| {
        let mut scene = ball(100.0, Transfer::Apic);
        scene.solver.gravity = Vec3::ZERO;
        scene.solver.integrator = integrator;
        scene.wind = Some(crosswind(6.0, Wind::DEFAULT_DRAG));
        let start = center_of_mass_x(&Simulation::new(scene.clone()).unwrap());
        center_of_mass_x(&run(scene, 0.1)) - start
    };
    let explicit = drift(Integrator::Explicit);
    let semi_implicit = drift(Integrator::SemiImplicit(Default::default()));
    println!(
        "downwind drift in 0.1 s: explicit {explicit:.5} m, semi-implicit {semi_implicit:.5} m"
    );
    assert!(explicit > 0.0);
    assert!(
        (semi_implicit - explicit).abs() < 0.05 * explicit,
        "explicit {explicit} m, semi-implicit {semi_implicit} m"
    );
}

#[test]
fn a_running_simulation_takes_a_new_wind_and_refuses_a_bad_one() {
    let mut scene = ball(100.0, Transfer::Apic);
    scene.solver.gravity = Vec3::ZERO;
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(0.02).unwrap();
    let before = center_of_mass_x(&simulation);
    let mut bad = crosswind(6.0, 6.0);
    bad.packed_density = -1.0;
    let error = simulation.set_wind(&bad).unwrap_err();
    let firn_mpm::SimulationError::Wind(error) = error else {
        panic!("not a wind error: {error}");
    };
    assert_eq!(error.key.as_deref(), Some("wind.packed_density"), "{error}");
    assert_eq!(simulation.scene().wind, None, "a refused wind is not kept");
    simulation.set_wind(&crosswind(6.0, 6.0)).unwrap();
    simulation.advance_to(0.1).unwrap();
    let drift = center_of_mass_x(&simulation) - before;
    assert!(drift > 1e-3, "the new wind moved the ball {drift} m");
    assert!(simulation.wind_impulse().x > 0.0);
}

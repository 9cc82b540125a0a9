//! Changing the materials of a running simulation (`Simulation::set_materials`,
//! for the viewer's parameter panel): softer snow sags more, a change at
//! t = 0 is a run of the changed scene, an unchanged set changes nothing, and
//! bad sets are refused naming the field.

mod common;

use firn_core::Material;
use firn_core::scene::{ImplicitSettings, Integrator, Scene, Shape, TimeStep, Transfer};
use firn_mpm::{Simulation, SimulationError};
use glam::Vec3;

/// A slab of snow resting on the floor under gravity.
fn slab() -> Scene {
    let block = Shape::Box {
        center: Vec3::new(0.5, 0.1, 0.5),
        size: Vec3::new(0.3, 0.2, 0.3),
    };
    common::scene_with(block, Vec3::ZERO, Transfer::Apic, 0.05)
}

/// The slab with the adaptive Δt (which the wave speed bounds) and
/// `integrator`.
fn adaptive_slab(integrator: Integrator) -> Scene {
    let mut scene = slab();
    scene.time.step = TimeStep::Adaptive {
        cfl: 0.4,
        max_dt: 2e-3,
    };
    scene.solver.integrator = integrator;
    scene
}

const INTEGRATORS: [Integrator; 2] = [
    Integrator::Explicit,
    Integrator::SemiImplicit(ImplicitSettings::DEFAULT),
];

/// The scene's materials with Young's modulus divided by `factor`.
fn softened(scene: &Scene, factor: f32) -> Vec<Material> {
    let mut materials = scene.materials.clone();
    for material in &mut materials {
        material.youngs_modulus /= factor;
    }
    materials
}

/// Mean height, top height (the mean of the highest tenth of the particles)
/// and rms speed at time `until`.
fn heights(simulation: &mut Simulation, until: f64) -> (f32, f32, f64) {
    simulation.advance_to(until).unwrap();
    let mut ys: Vec<f32> = simulation
        .particles()
        .position
        .iter()
        .map(|x| x.y)
        .collect();
    ys.sort_by(f32::total_cmp);
    let mean = ys.iter().sum::<f32>() / ys.len() as f32;
    let top = &ys[ys.len() * 9 / 10..];
    let top = top.iter().sum::<f32>() / top.len() as f32;
    let end = simulation.diagnostics();
    (mean, top, (2.0 * end.kinetic_energy / end.mass).sqrt())
}

#[test]
fn snow_softened_live_sags_more() {
    let scene = slab();
    let mut stiff = Simulation::new(scene.clone()).unwrap();
    let mut soft = Simulation::new(scene.clone()).unwrap();
    soft.set_materials(&softened(&scene, 10.0)).unwrap();
    assert_eq!(soft.scene().materials[0].youngs_modulus, 1.4e4);
    let (stiff_mean, stiff_top, stiff_speed) = heights(&mut stiff, 0.6);
    let (soft_mean, soft_top, soft_speed) = heights(&mut soft, 0.6);
    eprintln!(
        "at rest: mean height {stiff_mean:.5} m (E) vs {soft_mean:.5} m (E/10), top \
         {stiff_top:.5} m vs {soft_top:.5} m, rms speed {stiff_speed:.4} vs {soft_speed:.4} m/s"
    );
    assert!(
        stiff_speed < 0.02 && soft_speed < 0.02,
        "both have come to rest"
    );
    // Measured: mean heights 99.86 and 94.40 mm (5.5 mm apart), tops 189.37
    // and 181.62 mm (7.7 mm apart).
    assert!(
        stiff_mean - soft_mean > 2e-3,
        "the softer slab's mean height is {soft_mean}, the stiffer's {stiff_mean}"
    );
    assert!(
        stiff_top - soft_top > 3e-3,
        "the softer slab's top is at {soft_top}, the stiffer's at {stiff_top}"
    );
}

#[test]
fn materials_set_at_the_start_run_as_a_scene_with_them() {
    for integrator in INTEGRATORS {
        let scene = adaptive_slab(integrator);
        let soft_materials = softened(&scene, 10.0);
        let mut changed = Simulation::new(scene.clone()).unwrap();
        changed.set_materials(&soft_materials).unwrap();
        let mut soft_scene = scene.clone();
        soft_scene.materials = soft_materials;
        let mut fresh = Simulation::new(soft_scene.clone()).unwrap();
        // The first adaptive Δt already follows the new wave speed.
        assert_eq!(changed.next_dt(), fresh.next_dt(), "{integrator:?}");
        changed.advance_to(0.05).unwrap();
        fresh.advance_to(0.05).unwrap();
        assert_eq!(changed.scene(), &soft_scene);
        assert!(
            changed.snapshot() == fresh.snapshot(),
            "{integrator:?}: a change at t = 0 differs from a run of the changed scene"
        );
    }
}

#[test]
fn unchanged_materials_change_nothing() {
    for integrator in INTEGRATORS {
        let scene = adaptive_slab(integrator);
        let mut plain = Simulation::new(scene.clone()).unwrap();
        let mut touched = Simulation::new(scene.clone()).unwrap();
        plain.advance_to(0.03).unwrap();
        touched.advance_to(0.03).unwrap();
        touched.set_materials(&scene.materials).unwrap();
        plain.advance_to(0.06).unwrap();
        touched.advance_to(0.06).unwrap();
        assert!(
            plain.snapshot() == touched.snapshot(),
            "{integrator:?}: setting the same materials mid-run changed the run"
        );
    }
}

/// The key and message of a refused change; the simulation is left as it was.
fn refusal(materials: &[Material]) -> (String, String) {
    let scene = slab();
    let mut simulation = Simulation::new(scene.clone()).unwrap();
    let error = simulation.set_materials(materials).unwrap_err();
    assert_eq!(
        simulation.scene(),
        &scene,
        "a refused change changes nothing"
    );
    let SimulationError::Materials(error) = error else {
        panic!("not a materials error: {error}");
    };
    (error.key.clone().unwrap_or_default(), error.to_string())
}

#[test]
fn bad_materials_are_refused_naming_the_field() {
    let scene = slab();
    let snow = scene.materials[0].clone();

    let (key, message) = refusal(&[snow.clone(), snow.clone()]);
    assert_eq!(key, "materials");
    assert!(
        message.contains("2 given") && message.contains("has 1"),
        "{message}"
    );

    let mut incompressible = snow.clone();
    incompressible.poisson_ratio = 0.5;
    let (key, message) = refusal(&[incompressible]);
    assert_eq!(key, "materials.snow.poisson_ratio");
    assert!(
        message.contains("poisson_ratio must be less than 0.5"),
        "{message}"
    );

    let mut negative = snow.clone();
    negative.youngs_modulus = -1.0;
    let (key, message) = refusal(&[negative]);
    assert_eq!(key, "materials.snow.youngs_modulus");
    assert!(
        message.contains("youngs_modulus must be greater than 0"),
        "{message}"
    );

    let mut renamed = snow.clone();
    renamed.name = "slush".into();
    let (key, message) = refusal(&[renamed]);
    assert_eq!(key, "materials.slush");
    assert!(
        message
            .contains("materials.slush is not material 0 of the running scene, which is \"snow\""),
        "{message}"
    );

    let mut denser = snow;
    denser.density = 500.0;
    let (key, message) = refusal(&[denser]);
    assert_eq!(key, "materials.snow.density");
    assert!(message.contains("cannot change"), "{message}");
}

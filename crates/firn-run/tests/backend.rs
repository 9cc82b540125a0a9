//! Where a scene runs: `[compute] backend` and the adapters present.

mod common;

use firn_core::scene::{Backend, FlowObstacle, ImplicitSettings, Integrator, Spindrift, Wind};
use firn_run::backend::gpu_supports;
use firn_run::choose_backend;

#[test]
fn a_scene_asking_for_the_cpu_runs_there() {
    let mut scene = common::slab();
    scene.compute.backend = Backend::Cpu;
    let chosen = choose_backend(&scene).expect("the CPU is always there");
    assert_eq!(chosen.placement.name(), "cpu");
    assert_eq!(chosen.placement.adapter(), None);
    assert!(chosen.placement.describe().starts_with("the CPU ("));
    assert!(chosen.note.is_none());
}

#[test]
fn the_gpu_runs_explicit_snow_and_flows() {
    assert!(gpu_supports(&common::slab()).is_ok());
    assert!(gpu_supports(&common::flow()).is_ok());
}

#[test]
fn a_semi_implicit_scene_runs_on_the_gpu() {
    let mut scene = common::slab();
    scene.solver.integrator = Integrator::SemiImplicit(ImplicitSettings::DEFAULT);
    assert!(
        gpu_supports(&scene).is_ok(),
        "the GPU runs the semi-implicit solve"
    );
}

#[test]
fn a_wind_around_too_many_obstacles_is_not_for_the_gpu() {
    let mut scene = common::slab();
    let mut wind = Wind::uniform(glam::Vec3::X, 8.0);
    wind.field.obstacles = (0..9)
        .map(|i| FlowObstacle::new(glam::Vec3::new(0.1 * i as f32, 0.5, 0.5), 0.02))
        .collect();
    scene.wind = Some(wind);
    let why = gpu_supports(&scene).expect_err("the GPU takes at most 8 obstacles");
    assert!(why.to_string().contains("9 spheres"), "{why}");
    scene.compute.backend = Backend::Gpu;
    assert!(choose_backend(&scene).is_err());
    scene.compute.backend = Backend::Auto;
    let chosen = choose_backend(&scene).expect("auto falls back to the CPU");
    assert_eq!(chosen.placement.name(), "cpu");
    if let Some(note) = chosen.note {
        assert!(
            note.starts_with(
                "firn: --backend auto stays on the CPU: the GPU backend cannot run this scene"
            ),
            "{note}"
        );
    }
}

#[test]
fn a_scene_with_spindrift_runs_on_the_gpu() {
    let mut scene = common::slab();
    scene.wind = Some(Wind::uniform(glam::Vec3::X, 8.0));
    assert!(gpu_supports(&scene).is_ok(), "wind alone runs on the GPU");
    scene.wind.as_mut().unwrap().spindrift = Some(Spindrift::default());
    assert!(gpu_supports(&scene).is_ok(), "spindrift runs on the GPU");
    scene.compute.backend = Backend::Auto;
    let chosen = choose_backend(&scene).expect("auto always chooses");
    assert!(chosen.note.is_none(), "{:?}", chosen.note);
}

//! Changing a running flow's field (`FlowSimulation::set_settings`, for the
//! viewer's parameter panel): a change at t = 0 is a run of the changed
//! scene, bit for bit; spheres that grow push particles out; emitters and
//! substeps cannot change, and bad values are refused naming the field.

mod common;

use common::scene;
use firn_core::Scene;
use firn_core::scene::{FlowEmission, FlowSettings, SceneKind};
use firn_flow::{FlowError, FlowSimulation};
use glam::Vec3;

/// Turbulence around a sphere, particles from a box that lose their life
/// now and then, with trails.
const FLOW: &str = "noise_share = 0.5
noise_strength = 5.0
length_scale = 20.0
background_strength = 4.0
evolution_rate = 0.2
seed = 5

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 10.0
influence = 6.0

[[flow.emitters]]
shape = \"box\"
center = [50.0, 50.0, 50.0]
size = [100.0, 100.0, 100.0]
count = 3000
lifetime = 0.5
lifetime_spread = 0.3

[render]
styles = [\"trails\"]
trail_length = 4
";

fn flow_scene() -> Scene {
    scene(FLOW, 100.0, 2.0, 20.0)
}

/// The flow's settings with other γ, M and L.
fn retuned(settings: &FlowSettings) -> FlowSettings {
    FlowSettings {
        noise_share: 0.8,
        noise_strength: 9.0,
        length_scale: 12.0,
        ..settings.clone()
    }
}

fn with_settings(scene: &Scene, settings: FlowSettings) -> Scene {
    Scene {
        kind: SceneKind::Flow(Box::new(settings)),
        ..scene.clone()
    }
}

fn frames(flow: &mut FlowSimulation, count: u32) {
    for _ in 0..count {
        flow.advance_frame();
    }
}

#[test]
fn settings_set_at_the_start_run_as_a_scene_with_them() {
    let scene = flow_scene();
    let settings = retuned(scene.kind.flow().unwrap());
    let mut changed = FlowSimulation::new(scene.clone()).unwrap();
    let mut unchanged = changed.clone();
    changed.set_settings(settings.clone()).unwrap();
    let changed_scene = with_settings(&scene, settings);
    let mut fresh = FlowSimulation::new(changed_scene.clone()).unwrap();
    assert_eq!(changed.scene(), &changed_scene);
    assert!(changed.snapshot() == fresh.snapshot(), "at t = 0");
    frames(&mut changed, 10);
    frames(&mut fresh, 10);
    frames(&mut unchanged, 10);
    assert!(
        changed.snapshot() == fresh.snapshot(),
        "a change at t = 0 differs from a run of the changed scene"
    );
    let moved = changed.positions()[0].distance(unchanged.positions()[0]);
    assert!(
        moved > 0.1,
        "the new field moved particle 0 by only {moved} m"
    );
}

#[test]
fn a_grown_sphere_pushes_particles_out_and_keeps_them_out() {
    let mut flow = FlowSimulation::new(flow_scene()).unwrap();
    frames(&mut flow, 3);
    let mut settings = flow.settings().clone();
    settings.obstacles[0].radius = 20.0;
    settings.obstacles[0].center = Vec3::new(45.0, 50.0, 50.0);
    let ages = flow.ages().to_vec();
    flow.set_settings(settings).unwrap();
    assert_eq!(flow.ages(), &ages[..], "particles keep their state");
    let center = Vec3::new(45.0, 50.0, 50.0);
    let inside = |flow: &FlowSimulation| {
        flow.positions()
            .iter()
            .filter(|x| x.distance(center) < 20.0)
            .count()
    };
    assert_eq!(inside(&flow), 0, "after the change");
    frames(&mut flow, 3);
    assert_eq!(inside(&flow), 0, "three frames later");
}

#[test]
fn the_background_direction_is_normalised() {
    let mut flow = FlowSimulation::new(flow_scene()).unwrap();
    let mut settings = flow.settings().clone();
    settings.background_direction = Vec3::new(0.0, 3.0, 4.0);
    flow.set_settings(settings).unwrap();
    let direction = flow.settings().background_direction;
    assert_eq!(direction, Vec3::new(0.0, 0.6, 0.8));
    assert_eq!(
        flow.scene().kind.flow().unwrap().background_direction,
        direction
    );
}

/// The key and message of a refused change; the flow is left as it was.
fn refusal(change: impl FnOnce(&mut FlowSettings)) -> (String, String) {
    let scene = flow_scene();
    let mut flow = FlowSimulation::new(scene.clone()).unwrap();
    let mut settings = flow.settings().clone();
    change(&mut settings);
    let error = flow.set_settings(settings).unwrap_err();
    assert_eq!(flow.scene(), &scene, "a refused change changes nothing");
    let FlowError::Scene(error) = error else {
        panic!("not a scene error: {error}");
    };
    (error.key.clone().unwrap_or_default(), error.to_string())
}

#[test]
fn emitters_substeps_and_bad_values_are_refused() {
    let (key, message) = refusal(|s| s.emitters[0].emission = FlowEmission::Count(10));
    assert_eq!(key, "flow.emitters");
    assert!(
        message.contains("emitters cannot change while the flow runs: the particles' slots and births are planned"),
        "{message}"
    );

    let (key, message) = refusal(|s| s.substeps = 5);
    assert_eq!(key, "flow.substeps");
    assert!(
        message.contains(
            "substeps cannot change while the flow runs (it is 2, 5 was given): the clock"
        ),
        "{message}"
    );

    let (key, message) = refusal(|s| s.noise_share = 1.5);
    assert_eq!(key, "flow.noise_share");
    assert!(
        message.contains("noise_share must be in [0, 1]"),
        "{message}"
    );

    let (key, _) = refusal(|s| s.length_scale = 0.0);
    assert_eq!(key, "flow.length_scale");

    let (key, _) = refusal(|s| s.background_direction = Vec3::ZERO);
    assert_eq!(key, "flow.background_direction");

    let (key, _) = refusal(|s| s.obstacles[0].radius = -1.0);
    assert_eq!(key, "flow.obstacles[0].radius");
}

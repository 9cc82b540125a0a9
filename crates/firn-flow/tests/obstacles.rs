//! Sphere obstacles (seed eq. 2-3, Bridson et al. 2007 §3.2): the flow
//! slides along the surface, and no particle ends up inside.

mod common;

use common::{OBSTACLES, Points, scene, settings};
use firn_core::scene::FlowCurl;
use firn_flow::{FlowField, FlowSimulation};
use glam::{DVec3, Vec3};

const SPHERES: [(DVec3, f64); 2] = [
    (DVec3::new(50.0, 50.0, 50.0), 12.0),
    (DVec3::new(20.0, 75.0, 30.0), 5.0),
];

#[test]
fn velocity_is_tangential_on_the_surface() {
    let field = FlowField::new(&settings(&scene(OBSTACLES, 100.0, 10.0, 30.0)));
    let finite = field
        .clone()
        .with_curl(FlowCurl::FiniteDifference { step: 2e-3 });
    let mut points = Points::new(4);
    let mut worst: f64 = 0.0;
    let mut worst_finite: f64 = 0.0;
    for (center, radius) in SPHERES {
        for _ in 0..2000 {
            let n = points.direction();
            let x = center + n * radius;
            // What particles use: f32, at an f32 surface point.
            let v = field.velocity(x.as_vec3(), 0.8).as_dvec3();
            let normal = (x.as_vec3().as_dvec3() - center).normalize();
            assert!(v.length() > 0.0);
            worst = worst.max(v.dot(normal).abs() / v.length());
            let v = finite.velocity_f64(x, 0.8);
            worst_finite = worst_finite.max(v.dot(n).abs() / v.length());
        }
    }
    assert!(worst < 1e-3, "v · n / |v| = {worst:e}");
    assert!(
        worst_finite < 1e-3,
        "finite differences: v · n / |v| = {worst_finite:e}"
    );
}

#[test]
fn without_the_modulation_the_flow_crosses_the_surface() {
    // The same field without spheres goes straight through: the check above
    // is not vacuous.
    let end_of_flow = OBSTACLES.find("[[flow.obstacles]]").unwrap();
    let emitters = OBSTACLES.find("[[flow.emitters]]").unwrap();
    let body = format!("{}{}", &OBSTACLES[..end_of_flow], &OBSTACLES[emitters..]);
    let field = FlowField::new(&settings(&scene(&body, 100.0, 10.0, 30.0)));
    let mut points = Points::new(4);
    let mut largest: f64 = 0.0;
    for _ in 0..200 {
        let n = points.direction();
        let v = field.velocity_f64(SPHERES[0].0 + n * SPHERES[0].1, 0.8);
        largest = largest.max(v.dot(n).abs() / v.length());
    }
    assert!(largest > 0.5, "{largest}");
}

#[test]
fn no_particle_is_inside_a_sphere_after_many_steps() {
    // A strong flow straight at the big sphere, particles born upstream and
    // all around it, large steps (a frame is one step).
    let body = "noise_share = 0.3
length_scale = 20.0
background_direction = [1.0, 0.0, 0.0]
background_strength = 8.0
substeps = 1
seed = 5

[[flow.obstacles]]
center = [50.0, 50.0, 50.0]
radius = 12.0
influence = 6.0

[[flow.emitters]]
shape = \"box\"
center = [30.0, 50.0, 50.0]
size = [20.0, 40.0, 40.0]
count = 6000

[[flow.emitters]]
shape = \"sphere\"
center = [50.0, 50.0, 50.0]
radius = 20.0
count = 6000
";
    let mut flow = FlowSimulation::new(scene(body, 100.0, 10.0, 10.0)).unwrap();
    let center = Vec3::splat(50.0);
    for _ in 0..60 {
        flow.advance_frame();
        let inside = flow
            .positions()
            .iter()
            .filter(|x| x.distance(center) < 12.0)
            .count();
        assert_eq!(inside, 0, "at t = {}", flow.time());
    }
    // The particles did go round the sphere: some are now beyond it.
    let downstream = flow.positions().iter().filter(|x| x.x > 65.0).count();
    assert!(downstream > 1000, "{downstream}");
}

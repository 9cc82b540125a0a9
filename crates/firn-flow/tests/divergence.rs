//! The velocity is divergence-free (the point of curl noise, Bridson et al.
//! 2007, and seed 002's eq. 4): measured independently of the curl, by
//! central differences of the velocity itself, in `f64`.

mod common;

use common::{OBSTACLES, Points, scene, settings};
use firn_core::scene::FlowCurl;
use firn_flow::FlowField;
use glam::DVec3;

/// Difference step for measuring ∇v, m. In f64 the round-off of a difference
/// is about 1e-14 |v| / h = 1e-10 |v|, and the truncation error (h/L)² is
/// 3e-11, both far below the tolerance; only points within h of the two
/// surfaces where the ramp's third derivative jumps (d = 0 and d = d0) could
/// see more, and the fixed sample below has none.
const H: f64 = 1e-4;

/// |∇·v| / |∇v| must stay below this (|∇v| is the Frobenius norm).
const TOLERANCE: f64 = 1e-5;

fn field() -> FlowField {
    FlowField::new(&settings(&scene(OBSTACLES, 100.0, 10.0, 30.0)))
}

/// (∇·v, |∇v|) at x by central differences of the velocity.
fn divergence(field: &FlowField, x: DVec3, t: f64) -> (f64, f64) {
    let mut divergence = 0.0;
    let mut norm_squared = 0.0;
    for axis in 0..3 {
        let mut step = DVec3::ZERO;
        step[axis] = H;
        let column =
            (field.velocity_f64(x + step, t) - field.velocity_f64(x - step, t)) / (2.0 * H);
        divergence += column[axis];
        norm_squared += column.length_squared();
    }
    (divergence, norm_squared.sqrt())
}

/// Sample points: the whole box, the influence shells of both spheres, and
/// the inside of the big sphere (away from its centre).
fn sample_points() -> Vec<(DVec3, &'static str)> {
    let mut points = Points::new(11);
    let mut samples = Vec::new();
    for _ in 0..2000 {
        samples.push((points.in_box(DVec3::ZERO, DVec3::splat(100.0)), "box"));
    }
    for (center, radius, influence) in [
        (DVec3::splat(50.0), 12.0, 8.0),
        (DVec3::new(20.0, 75.0, 30.0), 5.0, 5.0),
    ] {
        for _ in 0..1500 {
            let r = radius + influence * points.unit();
            samples.push((center + points.direction() * r, "shell"));
        }
    }
    for _ in 0..300 {
        let r = 12.0 * (0.3 + 0.7 * points.unit());
        samples.push((DVec3::splat(50.0) + points.direction() * r, "inside"));
    }
    samples
}

#[test]
fn analytic_curl_is_divergence_free_everywhere() {
    let field = field();
    let mut worst = (0.0, DVec3::ZERO, "");
    for (x, region) in sample_points() {
        for t in [0.0, 1.7] {
            let (div, norm) = divergence(&field, x, t);
            assert!(norm > 0.0, "no velocity gradient at {x}");
            let ratio = div.abs() / norm;
            if ratio > worst.0 {
                worst = (ratio, x, region);
            }
        }
    }
    assert!(
        worst.0 < TOLERANCE,
        "|div v| / |grad v| = {:e} at {} ({})",
        worst.0,
        worst.1,
        worst.2
    );
}

#[test]
fn a_point_by_point_normalised_velocity_is_not_divergence_free() {
    // The seed normalised each velocity; the same measurement catches it.
    let field = field();
    let x = DVec3::new(31.0, 42.0, 67.0);
    let normalised = |y: DVec3| {
        let v = field.velocity_f64(y, 0.0);
        v / v.length()
    };
    let mut divergence = 0.0;
    let mut norm_squared = 0.0;
    for axis in 0..3 {
        let mut step = DVec3::ZERO;
        step[axis] = H;
        let column = (normalised(x + step) - normalised(x - step)) / (2.0 * H);
        divergence += column[axis];
        norm_squared += column.length_squared();
    }
    assert!(divergence.abs() / norm_squared.sqrt() > 1e-2);
}

#[test]
fn finite_difference_curl_matches_the_analytic_one() {
    let analytic = field();
    // In f64, with a step of L / 10⁴: truncation of order (h / feature)² ≈ 1e-6.
    let fine = analytic
        .clone()
        .with_curl(FlowCurl::FiniteDifference { step: 2e-3 });
    // In f32 with the default step L / 1000, as a scene gets it.
    let default = analytic
        .clone()
        .with_curl(FlowCurl::FiniteDifference { step: 0.02 });
    let mut worst_f64: f64 = 0.0;
    let mut worst_f32: f64 = 0.0;
    for (x, _) in sample_points().into_iter().step_by(5) {
        let exact = analytic.velocity_f64(x, 1.7);
        let scale = exact.length().max(0.1);
        worst_f64 = worst_f64.max((fine.velocity_f64(x, 1.7) - exact).length() / scale);
        let f32_fd = default.velocity(x.as_vec3(), 1.7).as_dvec3();
        worst_f32 = worst_f32.max((f32_fd - exact).length() / scale);
    }
    assert!(
        worst_f64 < 1e-5,
        "f64 finite differences off by {worst_f64:e}"
    );
    assert!(
        worst_f32 < 2e-2,
        "f32 finite differences off by {worst_f32:e}"
    );
}

#[test]
fn f32_velocity_matches_the_f64_reference() {
    let field = field();
    let mut worst: f64 = 0.0;
    for (x, _) in sample_points().into_iter().step_by(3) {
        let exact = field.velocity_f64(x, 1.7);
        let single = field.velocity(x.as_vec3(), 1.7).as_dvec3();
        worst = worst.max((single - exact).length() / exact.length().max(0.1));
    }
    // f32 noise coordinates (|q| up to ~25 cells) carry about 2e-6 cells of
    // round-off, amplified by the second derivatives of the noise.
    assert!(worst < 1e-3, "f32 off by {worst:e}");
}

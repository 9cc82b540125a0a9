//! No clustering: particles seeded uniformly stay uniform (the "black holes"
//! of seed 002, §3.1, came from a field that was not divergence-free).
//!
//! Particles fill a large cube uniformly; the flow is pure turbulence. A
//! divergence-free flow preserves volume, so the density stays uniform
//! wherever no particle from outside the filled cube can have arrived: the
//! counting region keeps a margin larger than any displacement. Counts per
//! cell are then multinomial, and a chi-square test checks them. The same
//! test applied to a compressible flow (the gradient of the noise) fails,
//! so the test can tell.

mod common;

use common::scene;
use firn_flow::FlowSimulation;
use firn_flow::noise::noise;
use glam::Vec3;

/// Cells per axis of the counting region.
const CELLS: usize = 8;
/// The counting region, well inside the filled cube [100, 300]³.
const LOW: f32 = 150.0;
const HIGH: f32 = 250.0;

/// Chi-square of the counts per cell of the points inside the region, and
/// the number of points counted.
fn chi_square(points: &[Vec3]) -> (f64, usize) {
    let mut counts = vec![0u32; CELLS * CELLS * CELLS];
    let width = (HIGH - LOW) / CELLS as f32;
    let mut counted = 0;
    for x in points {
        if x.cmpge(Vec3::splat(LOW)).all() && x.cmplt(Vec3::splat(HIGH)).all() {
            let cell = ((*x - LOW) / width)
                .as_uvec3()
                .min(glam::UVec3::splat(CELLS as u32 - 1));
            counts[(cell.z as usize * CELLS + cell.y as usize) * CELLS + cell.x as usize] += 1;
            counted += 1;
        }
    }
    let expected = counted as f64 / counts.len() as f64;
    let chi = counts
        .iter()
        .map(|count| (f64::from(*count) - expected).powi(2) / expected)
        .sum();
    (chi, counted)
}

/// Chi-square above which uniformity is rejected: 511 degrees of freedom,
/// mean 511, standard deviation 32; this is p ≈ 10⁻⁴.
const CRITICAL: f64 = 630.0;

const BODY: &str = "noise_share = 1.0
noise_strength = 30.0
length_scale = 20.0
substeps = 2
seed = 17

[[flow.emitters]]
shape = \"box\"
center = [200.0, 200.0, 200.0]
size = [200.0, 200.0, 200.0]
count = 100000
";

#[test]
fn particles_seeded_uniformly_stay_uniform() {
    let mut flow = FlowSimulation::new(scene(BODY, 400.0, 5.0, 10.0)).unwrap();
    let start = flow.positions().to_vec();
    let (chi_start, counted) = chi_square(&start);
    assert!(counted > 10_000, "{counted}");
    assert!(
        chi_start < CRITICAL,
        "the start is not uniform: {chi_start}"
    );
    flow.advance_to(5.0);
    let moved = flow
        .positions()
        .iter()
        .zip(&start)
        .map(|(a, b)| a.distance(*b))
        .fold(0.0f32, f32::max);
    // They moved by several noise cells but not across the margin of 50 m.
    assert!(moved > 20.0 && moved < 50.0, "largest displacement {moved}");
    let (chi, _) = chi_square(flow.positions());
    assert!(
        chi < CRITICAL,
        "particles bunch up: chi-square {chi} (limit {CRITICAL})"
    );
}

#[test]
fn a_compressible_flow_fails_the_same_test() {
    // v = c ∇n(x / L): particles run uphill and collect at the maxima of n.
    let flow = FlowSimulation::new(scene(BODY, 400.0, 5.0, 10.0)).unwrap();
    let mut points = flow.positions().to_vec();
    let dt = 0.05;
    for _ in 0..100 {
        for x in &mut points {
            let (_, gradient) = noise(*x / 20.0);
            *x += gradient * (5.0 * dt);
        }
    }
    let (chi, _) = chi_square(&points);
    assert!(chi > 3.0 * CRITICAL, "chi-square {chi}");
}

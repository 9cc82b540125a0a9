//! The sparse grid (`src/snow/blocks.rs`, `shaders/snow/nodes.wgsl`): GPU
//! memory follows the snow, not the domain, and where a block is stored
//! does not change a bit.

use firn_core::Scene;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::Particles;
use glam::Vec3;

/// The ball's velocity when it is thrown.
const THROWN: Vec3 = Vec3::new(1.0, 0.5, 0.0);

/// Simulated seconds of each run: a few substeps.
const SECONDS: f64 = 0.002;

/// A ball of about 2,100 particles thrown through the air, far from the
/// walls, in a domain of `cells` cells per side from the origin: the
/// snow's nodes are the same in every such domain.
fn ball(cells: u32, transfer: &str, integrator: &str) -> Scene {
    let side = cells as f32 * 0.0125;
    let text = format!(
        r#"format = 1
name = "ball-{cells}"

[domain]
max = [{side}, {side}, {side}]
cell_size = 0.0125

[time]
duration = 0.1

[solver]
transfer = "{transfer}"
integrator = "{integrator}"

[[bodies]]
shape = "sphere"
center = [0.3, 0.3, 0.3]
radius = 0.05
velocity = [{}, {}, {}]
"#,
        THROWN.x, THROWN.y, THROWN.z
    );
    Scene::from_toml_str(&text, "ball.toml").expect("the test scene is valid")
}

/// Every particle's state, as bits.
fn bits(particles: &Particles) -> Vec<u32> {
    let vectors = particles.position.iter().chain(&particles.velocity);
    let matrices = particles.elastic.iter().chain(&particles.velocity_gradient);
    vectors
        .flat_map(|v| v.to_array())
        .chain(matrices.flat_map(|m| m.to_cols_array()))
        .chain(particles.plastic_j.iter().copied())
        .map(f32::to_bits)
        .collect()
}

/// The largest difference of a particle's velocity from the ball's in free
/// flight, v_0 + g t: the ball is unstressed, so its particles keep one
/// velocity unless nodes of their stencils are lost.
fn largest_departure_from_free_flight(particles: &Particles, scene: &Scene) -> f32 {
    let expected = THROWN + scene.solver.gravity * SECONDS as f32;
    particles
        .velocity
        .iter()
        .map(|v| (*v - expected).length())
        .fold(0.0, f32::max)
}

/// The same ball in a 48³-cell and a 256³-cell domain, explicit with both
/// transfer schemes and semi-implicit: the same substeps and the same bits,
/// the big domain's buffers a small fraction of a dense grid's, and the
/// ball in free flight.
#[test]
fn a_big_domain_runs_in_the_memory_of_its_snow_with_the_same_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    for (transfer, integrator) in [
        ("apic", "explicit"),
        ("pic-flip", "explicit"),
        ("apic", "semi-implicit"),
    ] {
        let run = |cells: u32| {
            let mut gpu = GpuSnow::new(context.clone(), ball(cells, transfer, integrator)).unwrap();
            let substeps = gpu.advance_to(SECONDS).unwrap();
            (gpu.snapshot().unwrap().particles, substeps, gpu.memory())
        };
        let (small, small_substeps, small_memory) = run(48);
        let (big, big_substeps, big_memory) = run(256);
        let case = format!("{transfer}, {integrator}");
        assert!(small.len() > 2000, "{case}: {} particles", small.len());
        assert_eq!(small_substeps, big_substeps, "{case}");
        assert!(
            bits(&small) == bits(&big),
            "{case}: the domains' runs differ"
        );
        let departure = largest_departure_from_free_flight(&big, &ball(256, transfer, integrator));
        assert!(
            departure < 1e-3,
            "{case}: a particle left free flight by {departure} m/s"
        );
        let dense_grid = big_memory.domain_blocks * 64 * big_memory.bytes_per_node;
        assert_eq!(big_memory.nodes, small_memory.nodes, "{case}");
        assert!(
            big_memory.total_bytes() * 50 < dense_grid,
            "{case}: {big_memory:?} needs {} bytes, a dense grid {dense_grid}",
            big_memory.total_bytes()
        );
    }
}

/// A grid sized for one block grows as soon as the snow needs more, before
/// the substep that found it too small runs: the run's bits are those of a
/// grid sized right from the start.
#[test]
fn the_grid_grows_when_the_snow_reaches_more_blocks_with_the_same_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = ball(48, "apic", "explicit");
    let mut sized = GpuSnow::new(context.clone(), scene.clone()).unwrap();
    sized.advance_to(SECONDS).unwrap();
    let mut grown = GpuSnow::new(context, scene).unwrap();
    grown.resize_grid(1).unwrap();
    assert_eq!(grown.memory().grid_blocks(), 1);
    grown.advance_to(SECONDS).unwrap();
    assert!(grown.memory().grid_blocks() > 8, "{:?}", grown.memory());
    let (sized, grown) = (sized.snapshot().unwrap(), grown.snapshot().unwrap());
    assert_eq!(sized.steps, grown.steps);
    assert!(bits(&sized.particles) == bits(&grown.particles));
}

//! The semi-implicit solve on the GPU (`snow/implicit.rs`) against the CPU's
//! (`firn_mpm::implicit`): after one substep the particles' velocities
//! agree, each substep's solve takes as many iterations give or take two,
//! a run of several frames stays close, snow meeting a sticky collider and
//! a wall keeps its constraints, and two GPU runs give the same bits. Both
//! backends start from the same particles; the GPU sums its products in
//! fixed point and its dot products in f32 trees, the CPU in f64, so they
//! differ by round-off.

use firn_core::Scene;
use firn_core::scene::TimeStep;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::Simulation;
use glam::Vec3;

/// A ball of stiff snow thrown at the +x wall of a small box, with a
/// sticky sphere in its path, at a Δt four times past the explicit step's
/// elastic limit (β Δt² H is about five times M).
fn stiff_ball(transfer: &str) -> Scene {
    let text = format!(
        r#"format = 1
name = "implicit-{transfer}"

[domain]
max = [0.4, 0.3, 0.3]
cell_size = 0.025

[time]
duration = 0.1
fps = 50
step = "fixed"
dt = 2e-3

[solver]
transfer = "{transfer}"
integrator = "semi-implicit"
implicit_beta = 1.0
solver_tolerance = 1e-4

[materials.stiff]
preset = "snow"
youngs_modulus = 1e6

[[bodies]]
shape = "sphere"
center = [0.24, 0.15, 0.15]
radius = 0.06
velocity = [3.0, -0.5, 0.0]
material = "stiff"

[[colliders]]
shape = "sphere"
center = [0.24, 0.04, 0.15]
radius = 0.035
mode = "sticky"
"#
    );
    Scene::from_toml_str(&text, "implicit.toml").expect("the test scene is valid")
}

/// For each GPU particle, the CPU particle nearest to it (the CPU reorders
/// its particles by grid block).
fn nearest(cpu: &[Vec3], gpu: &[Vec3]) -> Vec<usize> {
    gpu.iter()
        .map(|x| {
            (0..cpu.len())
                .min_by(|&a, &b| (cpu[a] - *x).length().total_cmp(&(cpu[b] - *x).length()))
                .expect("the CPU has particles")
        })
        .collect()
}

/// The largest velocity difference between matched particles after one
/// substep, relative to the largest velocity change the substep made.
fn one_substep_velocity_error(scene: &Scene) -> Option<f32> {
    let context = context_for_tests()?;
    let TimeStep::Fixed { dt } = scene.time.step else {
        panic!("the test scenes take fixed steps");
    };
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    let before = gpu.snapshot().unwrap().particles;
    cpu.step(f64::from(dt)).unwrap();
    gpu.advance_to(f64::from(dt)).unwrap();
    let after = gpu.snapshot().unwrap().particles;
    let cpu_particles = cpu.particles();
    let matched = nearest(&cpu_particles.position, &after.position);
    let mut change = 0.0f32;
    let mut error = 0.0f32;
    for (p, &c) in matched.iter().enumerate() {
        change = change.max((after.velocity[p] - before.velocity[p]).length());
        error = error.max((after.velocity[p] - cpu_particles.velocity[c]).length());
    }
    eprintln!(
        "{:?}: one substep changed velocities by up to {change:.3e} m/s; GPU and CPU differ by up to {error:.3e} m/s",
        scene.solver.transfer
    );
    Some(error / change)
}

#[test]
fn one_substep_matches_the_cpu_solve() {
    for transfer in ["pic-flip", "apic"] {
        let Some(error) = one_substep_velocity_error(&stiff_ball(transfer)) else {
            return;
        };
        assert!(error < 1e-3, "{transfer}: relative velocity error {error:.3e}");
    }
}

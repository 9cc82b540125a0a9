//! The semi-implicit solve on the GPU (`snow/implicit.rs`) against the CPU's
//! (`firn_mpm::implicit`): after one substep the particles' velocities
//! agree, each substep's solve takes as many iterations give or take two,
//! a run of several frames stays close, snow meeting a sticky collider and
//! a wall keeps its constraints, and two GPU runs give the same bits. Both
//! backends start from the same particles; the GPU sums its products in
//! fixed point and its dot products in f32 trees, the CPU in f64, so they
//! differ by round-off.

mod common;

use firn_core::Scene;
use firn_core::scene::TimeStep;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::simulation::diagnostics;
use firn_mpm::{Simulation, Snapshot};
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

/// The fixed Δt of a test scene.
fn fixed_dt(scene: &Scene) -> f64 {
    let TimeStep::Fixed { dt } = scene.time.step else {
        panic!("the test scenes take fixed steps");
    };
    f64::from(dt)
}

/// The CPU's state of `scene` at time `at`.
fn cpu_state_at(scene: &Scene, at: f64) -> Snapshot {
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    cpu.advance_to(at).unwrap();
    cpu.snapshot()
}

/// How one substep from the same state went on each backend.
struct OneSubstep {
    /// The largest velocity change the substep made.
    change: f32,
    /// The largest velocity difference between matched particles.
    error: f32,
    cpu_iterations: u32,
    gpu_iterations: u32,
}

/// One substep from `state` on both backends.
fn one_substep(scene: &Scene, state: Snapshot) -> Option<OneSubstep> {
    let context = context_for_tests()?;
    let until = state.time + fixed_dt(scene);
    let before = state.particles.clone();
    let mut gpu = GpuSnow::from_snapshot(context, scene.clone(), &state).unwrap();
    let mut cpu = Simulation::from_snapshot(scene.clone(), state).unwrap();
    cpu.step(until).unwrap();
    assert_eq!(gpu.advance_to(until).unwrap(), 1);
    let after = gpu.snapshot().unwrap().particles;
    let cpu_particles = cpu.particles();
    let matched = nearest(&cpu_particles.position, &after.position);
    let mut change = 0.0f32;
    let mut error = 0.0f32;
    for (p, &c) in matched.iter().enumerate() {
        change = change.max((after.velocity[p] - before.velocity[p]).length());
        error = error.max((after.velocity[p] - cpu_particles.velocity[c]).length());
    }
    let substep = OneSubstep {
        change,
        error,
        cpu_iterations: cpu.solver_stats().unwrap().last_iterations,
        gpu_iterations: gpu.solver_stats().unwrap().last_iterations,
    };
    eprintln!(
        "{:?} from {:.3} s: velocities changed by up to {change:.3e} m/s, GPU and CPU differ by \
         up to {error:.3e} m/s; {} CPU / {} GPU iterations",
        scene.solver.transfer,
        until - fixed_dt(scene),
        substep.cpu_iterations,
        substep.gpu_iterations
    );
    Some(substep)
}

/// From rest against the sticky sphere (0 s), in flight with the stress of
/// that contact (0.02 s) and while hitting the wall (0.04 s, the ball loses
/// metres per second in the substep).
#[test]
fn one_substep_matches_the_cpu_solve_in_contact() {
    for transfer in ["pic-flip", "apic"] {
        let scene = stiff_ball(transfer);
        for at in [0.0, 0.02, 0.04] {
            let Some(substep) = one_substep(&scene, cpu_state_at(&scene, at)) else {
                return;
            };
            assert!(
                substep.error < 1e-3 * substep.change,
                "{transfer} at {at} s: velocities differ by {:.3e} m/s",
                substep.error
            );
            assert!(
                substep.cpu_iterations.abs_diff(substep.gpu_iterations) <= 2,
                "{transfer} at {at} s: {} CPU and {} GPU iterations",
                substep.cpu_iterations,
                substep.gpu_iterations
            );
        }
    }
}

/// Five frames (50 substeps) through the impact on the wall: the mass is
/// equal, momentum, centre of mass and the positions' quantiles agree, and
/// the solves took as many iterations give or take two per substep.
#[test]
fn a_run_through_the_impact_follows_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    for transfer in ["pic-flip", "apic"] {
        let scene = stiff_ball(transfer);
        let mut cpu = Simulation::new(scene.clone()).unwrap();
        let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
        // Frame by frame, as `firn run` steps.
        for frame in 1..=5 {
            let until = f64::from(frame) / scene.time.fps;
            cpu.advance_to(until).unwrap();
            gpu.advance_to(until).unwrap();
        }
        let snapshot = gpu.snapshot().unwrap();
        let h = scene.domain.cell_size;
        let on_cpu = cpu.diagnostics();
        let on_gpu = diagnostics(&snapshot.particles, h, scene.solver.transfer);
        assert_eq!(on_cpu.mass, on_gpu.mass);
        // The wall stopped the ball: its x-momentum fell by more than half.
        let thrown = on_cpu.mass * 3.0;
        assert!(
            on_cpu.momentum[0] < 0.5 * thrown,
            "{transfer}: {:?}",
            on_cpu.momentum
        );
        for axis in 0..3 {
            let difference = (on_cpu.momentum[axis] - on_gpu.momentum[axis]).abs();
            assert!(
                difference <= 1e-3 * thrown,
                "{transfer}: momentum {axis} differs by {difference:e} (cpu {:?}, gpu {:?})",
                on_cpu.momentum,
                on_gpu.momentum
            );
            let shift = (on_cpu.center_of_mass[axis] - on_gpu.center_of_mass[axis]).abs();
            assert!(
                shift <= 1e-3 * f64::from(h),
                "{transfer}: centre of mass {axis} differs by {shift:e} m"
            );
        }
        let worst = common::quantile_gap(&cpu.particles().position, &snapshot.particles.position);
        assert!(
            worst <= 2e-3 * h,
            "{transfer}: the positions' quantiles differ by {worst:e} m"
        );
        let (on_cpu, on_gpu) = (cpu.solver_stats().unwrap(), gpu.solver_stats().unwrap());
        eprintln!(
            "{transfer}: CPU solves {on_cpu:?}\nGPU solves {on_gpu:?}\nquantiles within {worst:.2e} m"
        );
        assert_eq!(on_cpu.steps, on_gpu.steps, "{transfer}");
        assert_eq!(on_gpu.unconverged_steps, 0, "{transfer}: {on_gpu:?}");
        assert!(
            on_cpu.max_iterations.abs_diff(on_gpu.max_iterations) <= 2,
            "{transfer}"
        );
        assert!(
            on_cpu.total_iterations.abs_diff(on_gpu.total_iterations) <= 2 * on_cpu.steps,
            "{transfer}: {} CPU and {} GPU iterations in all",
            on_cpu.total_iterations,
            on_gpu.total_iterations
        );
    }
}

/// The products' fixed-point sums and the ordered reductions do not depend
/// on the order the GPU runs its invocations in.
#[test]
fn two_gpu_runs_give_the_same_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = stiff_ball("pic-flip");
    let run = || {
        let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
        gpu.advance_to(0.04).unwrap();
        (gpu.snapshot().unwrap(), gpu.solver_stats().unwrap())
    };
    let (first, first_stats) = run();
    let (second, second_stats) = run();
    let bits = |snapshot: &Snapshot| -> Vec<u32> {
        let particles = &snapshot.particles;
        particles
            .position
            .iter()
            .chain(&particles.velocity)
            .flat_map(|v| v.to_array().map(f32::to_bits))
            .collect()
    };
    assert!(bits(&first) == bits(&second), "two GPU runs differ");
    assert_eq!(first_stats, second_stats);
}

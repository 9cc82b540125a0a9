//! The same snow scenes on the CPU and the GPU: after a fixed simulated time
//! the mass is equal, and momentum, centre of mass and the particles'
//! positions agree to stated tolerances. Both start from the same particles
//! (the GPU takes the CPU's sampling and volume estimate); the GPU sums the
//! scatter in fixed point and its maths rounds differently, so the runs
//! drift apart by round-off that grows with the number of substeps.

use firn_core::Scene;
use firn_gpu::snow::Scatter;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::Simulation;
use firn_mpm::simulation::diagnostics;

/// A ball of snow thrown at the +x wall of a box, hitting it within the run,
/// with a moving sphere collider passing by.
fn thrown_ball(transfer: &str) -> Scene {
    let text = format!(
        r#"format = 1
name = "thrown-{transfer}"

[domain]
max = [0.6, 0.4, 0.4]
cell_size = 0.025

[time]
duration = 0.2
fps = 20

[solver]
transfer = "{transfer}"

[[bodies]]
shape = "sphere"
center = [0.35, 0.2, 0.2]
radius = 0.08
velocity = [3.0, 1.0, 0.0]

[[colliders]]
shape = "sphere"
center = [0.1, 0.06, 0.2]
radius = 0.05
velocity = [0.5, 0.0, 0.0]
"#
    );
    Scene::from_toml_str(&text, "thrown-ball.toml").expect("the test scene is valid")
}

/// [`thrown_ball`] in a gusty crosswind along +z that flows around a
/// sphere, strong enough to bend the ball's path within the run.
fn thrown_ball_in_wind(transfer: &str) -> Scene {
    let mut scene = thrown_ball(transfer);
    let text = r#"format = 1
[domain]
max = [0.6, 0.4, 0.4]
cell_size = 0.025
[time]
duration = 0.2
[[bodies]]
shape = "sphere"
center = [0.3, 0.2, 0.2]
radius = 0.05
[wind]
background_direction = [0.0, 0.0, 1.0]
background_strength = 12.0
noise_share = 0.4
length_scale = 0.2
noise_strength = 0.3
evolution_rate = 2.0
drag = 40.0
[[wind.obstacles]]
center = [0.3, 0.1, 0.1]
radius = 0.05
"#;
    scene.wind = Scene::from_toml_str(text, "wind.toml")
        .expect("the wind is valid")
        .wind;
    scene
}

fn compare_runs(transfer: &str, until: f64, momentum_tolerance: f64, position_tolerance: f64) {
    compare_scene(
        thrown_ball(transfer),
        until,
        momentum_tolerance,
        position_tolerance,
    );
}

fn compare_scene(scene: Scene, until: f64, momentum_tolerance: f64, position_tolerance: f64) {
    let Some(context) = context_for_tests() else {
        return;
    };
    let transfer = format!("{:?}", scene.solver.transfer);
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    let cpu_steps = cpu.advance_to(until).unwrap();
    let gpu_steps = gpu.advance_to(until).unwrap();
    assert!(
        (gpu.time() - until).abs() < 1e-9,
        "the GPU stopped at {}",
        gpu.time()
    );
    let snapshot = gpu.snapshot().unwrap();
    let h = scene.domain.cell_size;
    let transfer_scheme = scene.solver.transfer;
    let on_cpu = cpu.diagnostics();
    let on_gpu = diagnostics(&snapshot.particles, h, transfer_scheme);
    assert_eq!(
        on_cpu.mass, on_gpu.mass,
        "mass is carried by the particles and must not change"
    );
    let speed_scale = on_cpu.mass * 3.0;
    for axis in 0..3 {
        let difference = (on_cpu.momentum[axis] - on_gpu.momentum[axis]).abs();
        assert!(
            difference <= momentum_tolerance * speed_scale,
            "{transfer}: momentum {axis} differs by {difference:e} (cpu {:?}, gpu {:?}), {cpu_steps} vs {gpu_steps} substeps",
            on_cpu.momentum,
            on_gpu.momentum
        );
        let shift = (on_cpu.center_of_mass[axis] - on_gpu.center_of_mass[axis]).abs();
        assert!(
            shift <= 1e-3 * f64::from(h),
            "{transfer}: centre of mass {axis} differs by {shift:e} m"
        );
    }
    // The CPU reorders its particles by grid block as it goes, so the
    // positions are compared as distributions: the sorted coordinates along
    // each axis (the marginals' quantiles) must agree.
    let worst = (0..3)
        .map(|axis| {
            let sorted = |positions: &[glam::Vec3]| {
                let mut values: Vec<f32> = positions.iter().map(|x| x[axis]).collect();
                values.sort_by(f32::total_cmp);
                values
            };
            let (a, b) = (
                sorted(&cpu.particles().position),
                sorted(&snapshot.particles.position),
            );
            a.iter()
                .zip(&b)
                .map(|(x, y)| f64::from((x - y).abs()))
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    assert!(
        worst <= position_tolerance * f64::from(h),
        "{transfer}: the positions' quantiles differ by up to {worst:e} m ({:.3} cells)",
        worst / f64::from(h)
    );
    eprintln!(
        "{transfer}: {cpu_steps} CPU / {gpu_steps} GPU substeps, quantiles within {:.2e} cells",
        worst / f64::from(h)
    );
}

#[test]
fn apic_on_the_gpu_follows_the_cpu() {
    compare_runs("apic", 0.1, 1e-3, 2e-3);
}

#[test]
fn pic_flip_on_the_gpu_follows_the_cpu() {
    compare_runs("pic-flip", 0.1, 1e-3, 2e-3);
}

/// The wind's drag (`[wind]`) on the GPU follows the CPU's, for both
/// transfer schemes; a run without drag is checked above.
#[test]
fn snow_in_a_wind_on_the_gpu_follows_the_cpu() {
    for transfer in ["apic", "pic-flip"] {
        let scene = thrown_ball_in_wind(transfer);
        let calm = thrown_ball(transfer);
        // The wind must matter: the CPU's ball drifts along +z.
        let drift = |scene: Scene| {
            let mut cpu = Simulation::new(scene).unwrap();
            cpu.advance_to(0.1).unwrap();
            cpu.diagnostics().center_of_mass[2]
        };
        let (blown, still) = (drift(scene.clone()), drift(calm));
        assert!(
            blown - still > 2e-3,
            "{transfer}: the wind moved the ball {:.2e} m along +z",
            blown - still
        );
        compare_scene(scene, 0.1, 1e-3, 2e-3);
    }
}

/// The scatter's fixed-point sums are associative, so the GPU run does not
/// depend on the order its invocations happen to run in.
#[test]
fn two_gpu_runs_give_the_same_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let scene = thrown_ball("apic");
    let run = || {
        let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
        gpu.advance_to(0.05).unwrap();
        gpu.snapshot().unwrap().particles
    };
    let (first, second) = (run(), run());
    assert!(
        first
            .position
            .iter()
            .zip(&second.position)
            .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
    );
    assert!(
        first.elastic.iter().zip(&second.elastic).all(
            |(a, b)| a.to_cols_array().map(f32::to_bits) == b.to_cols_array().map(f32::to_bits)
        )
    );
}

/// Snow at absurd speed overflows the 64-bit momentum sums; the run stops
/// with that explanation instead of going on from wrapped integers.
#[test]
fn a_fixed_point_overflow_stops_the_run() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut scene = thrown_ball("apic");
    scene.bodies[0].velocity = glam::Vec3::new(3.0e7, 0.0, 0.0);
    let mut gpu = GpuSnow::new(context, scene).unwrap();
    let error = gpu.advance_to(1e-6).unwrap_err();
    let message = error.to_string();
    assert!(
        matches!(error, firn_gpu::GpuError::Overflow { .. }),
        "{message}"
    );
    assert!(
        message.contains("momentum x") && message.contains("fix:"),
        "{message}"
    );
}

/// A domain whose block table (4 bytes per 4³-node block) passes the
/// adapter's storage-binding limit is refused before anything is
/// allocated, with the numbers.
#[test]
fn a_grid_too_large_for_the_adapter_is_refused_with_the_numbers() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut scene = thrown_ball("apic");
    let limit = context.limits.max_storage_buffer_binding_size;
    let cells_per_axis = 4.0 * ((limit / 4) as f64).cbrt() as f32 + 16.0;
    scene.domain.max = glam::Vec3::splat(cells_per_axis * scene.domain.cell_size);
    let error = match GpuSnow::new(context, scene) {
        Ok(_) => panic!("a grid past the binding limit was accepted"),
        Err(error) => error,
    };
    let message = error.to_string();
    assert!(
        message.contains(&limit.to_string()) && message.contains("block table"),
        "{message}"
    );
    assert!(message.contains("--backend cpu"), "{message}");
}

/// The binned scatter (counting sort by block, sums in workgroup memory)
/// and the plain atomic scatter add the same integers, so whole runs agree
/// to the bit, for both transfer schemes.
#[test]
fn the_binned_and_the_atomic_scatter_give_the_same_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    for transfer in ["apic", "pic-flip"] {
        let scene = thrown_ball(transfer);
        let run = |scatter: Scatter| {
            let mut gpu = GpuSnow::new(context.clone(), scene.clone()).unwrap();
            assert_eq!(
                gpu.set_scatter(scatter),
                scatter,
                "{} lacks the workgroup memory",
                context.adapter.name
            );
            gpu.advance_to(0.05).unwrap();
            gpu.snapshot().unwrap().particles
        };
        let (binned, atomic) = (run(Scatter::Binned), run(Scatter::Atomic));
        let bits = |particles: &firn_mpm::Particles| {
            particles
                .position
                .iter()
                .flat_map(|x| x.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        let (binned, atomic) = (bits(&binned), bits(&atomic));
        let differing = binned.iter().zip(&atomic).filter(|(a, b)| a != b).count();
        assert_eq!(
            differing,
            0,
            "{transfer}: {differing} of {} coordinates differ",
            binned.len()
        );
    }
}

/// A closed unit cube centred at the origin, faces wound outwards.
const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// A mesh collider moving sideways under falling snow holds and carries it
/// on the GPU as on the CPU: its signed distance field is sampled in WGSL.
#[test]
fn a_moving_mesh_collider_acts_on_the_gpu_as_on_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("cube.obj"), CUBE_OBJ).unwrap();
    let text = r#"format = 1
name = "block-on-mesh"

[domain]
max = [0.6, 0.5, 0.6]
cell_size = 0.04

[time]
duration = 0.3
fps = 10

[[bodies]]
shape = "box"
center = [0.3, 0.35, 0.3]
size = [0.16, 0.08, 0.16]

[[colliders]]
shape = "mesh"
mesh = "cube.obj"
scale = [0.3, 0.2, 0.3]
center = [0.3, 0.1, 0.3]
velocity = [0.3, 0.0, 0.0]
friction = 0.8
"#;
    let scene =
        Scene::from_toml_str(text, &dir.path().join("scene.toml").display().to_string()).unwrap();
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    cpu.advance_to(0.3).unwrap();
    gpu.advance_to(0.3).unwrap();
    let lowest = |positions: &[glam::Vec3]| positions.iter().map(|p| p.y).fold(f32::MAX, f32::min);
    let mean_x = |positions: &[glam::Vec3]| {
        positions.iter().map(|p| p.x).sum::<f32>() / positions.len() as f32
    };
    let on_gpu = gpu.snapshot().unwrap().particles.position;
    let on_cpu = &cpu.particles().position;
    let top = 0.2;
    assert!(
        lowest(&on_gpu) > top && lowest(&on_gpu) < top + 1.5 * 0.04,
        "the snow's bottom is at {}",
        lowest(&on_gpu)
    );
    assert!(
        (lowest(&on_gpu) - lowest(on_cpu)).abs() < 0.05 * 0.04,
        "GPU {} vs CPU {}",
        lowest(&on_gpu),
        lowest(on_cpu)
    );
    assert!(
        mean_x(&on_gpu) > 0.3 + 0.02,
        "friction carried the snow along: mean x {}",
        mean_x(&on_gpu)
    );
    assert!(
        (mean_x(&on_gpu) - mean_x(on_cpu)).abs() < 0.05 * 0.04,
        "GPU {} vs CPU {}",
        mean_x(&on_gpu),
        mean_x(on_cpu)
    );
}

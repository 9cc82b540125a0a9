//! The GPU backend on an adapter with Metal's buffer limits: 29 buffers per
//! shader stage, storage and uniform together (wgpu's Metal backend), where
//! the snow step's 42 buffers cannot share one layout. Each kernel binds
//! only the buffers it uses (`snow/program.rs`), so every stage runs there,
//! with the same bits as on the full adapter: explicit APIC with the binned
//! and the atomic scatter, PIC/FLIP, the semi-implicit solve, wind with
//! spindrift, and a rigid body in the wind (the kernel with the most
//! buffers).

use firn_core::Scene;
use firn_gpu::snow::Scatter;
use firn_gpu::{GpuSnow, context_for_tests, context_for_tests_with_limits};

/// The buffer limits of wgpu's Metal backend (31 buffer slots, two kept
/// for its own use).
const METAL_BUFFERS: u32 = 29;

/// A ball of snow thrown through a wind along +x over a slab of fresh powder on the floor,
/// with spindrift, in a small box, at a rigid ball where `rigid`; `solver` is the
/// `[solver]` table.
fn scene(solver: &str, wind: bool, rigid: bool) -> Scene {
    let rigid = if rigid {
        "[[rigid_bodies]]\nshape = \"sphere\"\ncenter = [0.4, 0.18, 0.16]\nradius = 0.04\n\
         density = 1000.0\n"
    } else {
        ""
    };
    let wind = if wind {
        r#"
[wind]
background_direction = [1.0, 0.0, 0.0]
background_strength = 8.0
noise_share = 0.3

[wind.spindrift]
threshold_speed = 2.0
rate = 40.0
fall_speed = 0.5
"#
    } else {
        ""
    };
    let text = format!(
        r#"format = 1
name = "small-limits"

[domain]
max = [0.48, 0.32, 0.32]
cell_size = 0.04

[time]
duration = 0.04
fps = 50
step = "fixed"
dt = 1e-3

[solver]
{solver}

[materials.fresh]
preset = "snow"
density = 100.0

[[bodies]]
shape = "box"
center = [0.2, 0.06, 0.16]
size = [0.24, 0.12, 0.24]
material = "fresh"

[[bodies]]
shape = "sphere"
center = [0.3, 0.22, 0.16]
radius = 0.06
velocity = [2.0, -1.0, 0.0]

[[colliders]]
shape = "sphere"
center = [0.1, 0.2, 0.16]
radius = 0.04
velocity = [0.5, 0.0, 0.0]
{wind}{rigid}"#
    );
    Scene::from_toml_str(&text, "small-limits.toml").expect("the test scene is valid")
}

/// The bits of every particle's position and velocity after `seconds`, and
/// the drift's count, on `context` with `scatter`.
fn run(
    context: &std::sync::Arc<firn_gpu::GpuContext>,
    scene: &Scene,
    scatter: Scatter,
    seconds: f64,
) -> (Vec<u32>, usize) {
    let mut gpu = GpuSnow::new(context.clone(), scene.clone())
        .unwrap_or_else(|error| panic!("{}: {error}", scene.name));
    assert_eq!(
        gpu.set_scatter(scatter),
        scatter,
        "the adapter lacks the binned scatter"
    );
    gpu.advance_to(seconds)
        .unwrap_or_else(|error| panic!("{}: {error}", scene.name));
    let snapshot = gpu.snapshot().expect("the state reads back");
    let particles = &snapshot.particles;
    let bits = particles
        .position
        .iter()
        .chain(&particles.velocity)
        .flat_map(|v| v.to_array().map(f32::to_bits))
        .collect();
    (bits, snapshot.drift.position.len())
}

#[test]
fn every_stage_runs_with_metals_buffer_limits_and_gives_the_same_bits() {
    let Some(full) = context_for_tests() else {
        return;
    };
    let small = context_for_tests_with_limits(|limits| {
        limits.max_storage_buffers_per_shader_stage = METAL_BUFFERS;
        limits.max_buffers_and_acceleration_structures_per_shader_stage = METAL_BUFFERS;
    })
    .expect("the adapter opens with lower limits");
    let cases = [
        ("transfer = \"apic\"", false, false, Scatter::Binned),
        ("transfer = \"apic\"", false, false, Scatter::Atomic),
        ("transfer = \"pic-flip\"", false, false, Scatter::Binned),
        (
            "transfer = \"pic-flip\"\nintegrator = \"semi-implicit\"",
            false,
            false,
            Scatter::Binned,
        ),
        ("transfer = \"apic\"", true, false, Scatter::Binned),
        ("transfer = \"pic-flip\"", true, true, Scatter::Binned),
    ];
    for (solver, wind, rigid, scatter) in cases {
        let scene = scene(solver, wind, rigid);
        let (small_bits, small_drift) = run(&small, &scene, scatter, 0.04);
        let (full_bits, full_drift) = run(&full, &scene, scatter, 0.04);
        assert!(
            small_bits == full_bits && small_drift == full_drift,
            "{solver} (wind: {wind}, rigid body: {rigid}, {scatter:?}): the run with Metal's \
             limits differs"
        );
        if wind {
            assert!(
                full_drift > 0,
                "the wind lifts no drift: the case tests nothing"
            );
        }
    }
}

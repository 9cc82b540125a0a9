//! A deforming mesh collider (a mesh sequence) runs on the GPU as on the
//! CPU: a box that presses into a slab of snow while it is squashed and
//! dragged back, across several mesh frames (so the run uploads the bands
//! of each new interval). Both backends start from the same particles;
//! the mass is equal, and momentum, the centre of mass and the quantiles
//! of the particles' positions and velocities agree to stated tolerances
//! (the CPU reorders its particles, so they are compared as
//! distributions).

mod common;

use common::{BoxFrame, write_box_sequence};
use firn_core::Scene;
use firn_gpu::{GpuSnow, context_for_tests};
use firn_mpm::Simulation;
use firn_mpm::simulation::diagnostics;
use glam::Vec3;

/// Mesh frames per second of the foot.
const RATE: f32 = 60.0;

/// How fast the foot's sole sinks, m/s.
const SINK: f32 = 0.45;

/// A slab of snow 12 cm deep under a sticky foot, a box whose sole sinks
/// at [`SINK`] from 1 cm above the snow while it is squashed and its sole
/// drags back, written as five mesh frames at [`RATE`] into `folder`.
fn pressed_slab(folder: &std::path::Path) -> Scene {
    let frames: Vec<BoxFrame> = (0..5)
        .map(|k| {
            let sunk = SINK / RATE * k as f32;
            BoxFrame {
                low: Vec3::new(0.18, 0.13 - sunk, 0.18),
                high: Vec3::new(0.3, 0.22 - 0.5 * sunk, 0.3),
                shear: Vec3::new(-0.1 * sunk, 0.0, 0.0),
            }
        })
        .collect();
    let pattern = write_box_sequence(folder, &frames);
    let text = format!(
        "format = 1\nname = \"pressed-slab\"\n[domain]\nmax = [0.48, 0.3, 0.48]\ncell_size = 0.04\n\
         [time]\nduration = 0.2\nfps = 20\n[[bodies]]\nshape = \"box\"\n\
         center = [0.24, 0.06, 0.24]\nsize = [0.4, 0.12, 0.4]\n[[colliders]]\nshape = \"mesh\"\n\
         sequence = \"{pattern}\"\nframe_rate = {RATE}\nmode = \"sticky\"\n"
    );
    let path = folder.join("pressed-slab.toml").display().to_string();
    Scene::from_toml_str(&text, &path).expect("the test scene is valid")
}

#[test]
fn a_deforming_foot_presses_the_snow_on_the_gpu_as_on_the_cpu() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = pressed_slab(dir.path());
    // To the fourth mesh frame: four intervals, each uploaded when reached.
    let until = 0.05;
    let mut cpu = Simulation::new(scene.clone()).unwrap();
    let mut gpu = GpuSnow::new(context, scene.clone()).unwrap();
    let cpu_steps = cpu.advance_to(until).unwrap();
    let gpu_steps = gpu.advance_to(until).unwrap();
    let on_gpu = gpu.snapshot().unwrap().particles;
    let h = scene.domain.cell_size;
    let (a, b) = (
        cpu.diagnostics(),
        diagnostics(&on_gpu, h, scene.solver.transfer),
    );
    let speed = f64::from(SINK);
    assert_eq!(a.mass, b.mass, "the particles carry the mass");
    // The foot pushes the snow down: without its motion there is no such
    // momentum to compare.
    assert!(
        a.momentum[1] < -0.05 * a.mass * speed,
        "the foot presses the snow: momentum {:?}",
        a.momentum
    );
    for axis in 0..3 {
        let difference = (a.momentum[axis] - b.momentum[axis]).abs();
        assert!(
            difference <= 1e-3 * a.mass * speed,
            "momentum {axis} differs by {difference:e} (cpu {:?}, gpu {:?}), {cpu_steps} vs \
             {gpu_steps} substeps",
            a.momentum,
            b.momentum
        );
        let shift = (a.center_of_mass[axis] - b.center_of_mass[axis]).abs();
        assert!(
            shift <= 1e-3 * f64::from(h),
            "centre of mass {axis} differs by {shift:e} m"
        );
    }
    let on_cpu = cpu.particles();
    let positions = common::quantile_gap(&on_cpu.position, &on_gpu.position) / h;
    let velocities = common::quantile_gap(&on_cpu.velocity, &on_gpu.velocity) / SINK;
    eprintln!(
        "pressed slab: {} particles, {cpu_steps} CPU / {gpu_steps} GPU substeps; momentum {:?} \
         vs {:?}; quantiles within {positions:.1e} cells and {velocities:.1e} of {SINK} m/s",
        on_cpu.len(),
        a.momentum,
        b.momentum
    );
    assert!(
        positions <= 2e-3 && velocities <= 2e-3,
        "the quantiles differ by up to {positions:.2e} cells and {velocities:.2e} of {SINK} m/s"
    );
}

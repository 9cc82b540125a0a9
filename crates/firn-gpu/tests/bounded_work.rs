//! GPU snow stops a run whose time step collapses, as the CPU does: once
//! a frame would need more than `time.max_substeps_per_frame` substeps, it
//! returns the same error with the speed, the step and a fix.

use firn_core::Scene;
use firn_gpu::{GpuError, GpuSnow, context_for_tests};
use firn_mpm::SimulationError;

/// A soft ball falling freely under a gravity ten thousand times the
/// Earth's, allowed 40 substeps per frame.
fn heavy_fall() -> Scene {
    let text = "format = 1\n[domain]\nmax = [1.0, 4.0, 1.0]\ncell_size = 0.05\n\
                [time]\nduration = 0.05\nfps = 100\ndt = 0.01\nmax_substeps_per_frame = 40\n\
                [solver]\ngravity = [0.0, -1e5, 0.0]\n[materials.soft]\nyoungs_modulus = 3000.0\n\
                [[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 3.5, 0.5]\nradius = 0.1\n\
                material = \"soft\"\nparticles_per_cell = 1\n";
    Scene::from_toml_str(text, "heavy-fall.toml").unwrap()
}

#[test]
fn a_collapsing_step_stops_gpu_snow_with_the_speed_and_a_fix() {
    let Some(context) = context_for_tests() else {
        return;
    };
    let mut gpu = GpuSnow::new(context, heavy_fall()).unwrap();
    let error = (1..=5)
        .find_map(|frame| gpu.advance_to(f64::from(frame) * 0.01).err())
        .expect("a frame stops the run");
    let GpuError::Snow(SimulationError::TooManySubsteps {
        dt, speed, limit, ..
    }) = &error
    else {
        panic!("expected too many substeps, got {error}");
    };
    assert_eq!(*limit, 40);
    assert!(f64::from(*dt) < 1.0 / (100.0 * 40.0), "{dt}");
    assert!(*speed > 50.0, "the snow was falling at {speed} m/s");
    let message = error.to_string();
    assert!(message.contains("the time step fell to"), "{message}");
    assert!(
        message.contains("fix: find what drives the snow"),
        "{message}"
    );
}

//! The stages' times of a GPU substep (`src/snow/stage_times.rs`, timestamp
//! queries): every stage that works is timed, and the timed substeps, one
//! per submission, give the bits of a batched run to the same time.

use firn_core::Scene;
use firn_gpu::snow::stage_times::STAGE_NAMES;
use firn_gpu::{GpuSnow, context_for_tests};

/// A ball of about 2,100 particles falling in a small box.
fn ball() -> Scene {
    let text = r#"format = 1
name = "stage-times"

[domain]
max = [0.6, 0.6, 0.6]
cell_size = 0.0125

[time]
duration = 0.1

[solver]
transfer = "apic"

[[bodies]]
shape = "sphere"
center = [0.3, 0.3, 0.3]
radius = 0.05
velocity = [1.0, 0.5, 0.0]
"#;
    Scene::from_toml_str(text, "ball.toml").expect("the test scene is valid")
}

#[test]
fn timed_substeps_time_every_working_stage_and_keep_the_bits() {
    let Some(context) = context_for_tests() else {
        return;
    };
    if !context
        .device
        .features()
        .contains(firn_gpu::context::TIMESTAMPS)
    {
        eprintln!("skipped: the adapter has no timestamp queries");
        return;
    }
    let until = 0.002;
    let mut timed = GpuSnow::new(context.clone(), ball()).unwrap();
    let times = timed
        .stage_times(until, 1000)
        .unwrap()
        .expect("an explicit run on an adapter with timestamps is timed");
    let mut batched = GpuSnow::new(context, ball()).unwrap();
    let substeps = batched.advance_to(until).unwrap();
    assert_eq!(times.substeps, substeps, "the same substeps");
    assert_eq!(timed.time(), batched.time());
    let (a, b) = (timed.snapshot().unwrap(), batched.snapshot().unwrap());
    assert!(
        a.particles.position == b.particles.position
            && a.particles.velocity == b.particles.velocity,
        "timed substeps changed the bits"
    );
    for (name, seconds) in STAGE_NAMES.iter().zip(times.seconds) {
        assert!(seconds >= 0.0, "{name}: {seconds} s");
        if ["blocks", "scatter", "grid_update", "gather"].contains(name) {
            assert!(seconds > 0.0, "{name} was not timed");
        }
    }
}

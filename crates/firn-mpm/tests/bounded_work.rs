//! The work of a run is bounded: a substep whose Δt would make a frame take
//! more than `time.max_substeps_per_frame` substeps is refused with nothing
//! changed, and the memory estimated before sampling bounds what the solver
//! holds at the start.

use firn_core::Scene;
use firn_core::scene::CPU_BYTES_PER_PARTICLE;
use firn_mpm::{Particles, PermuteBuffers, Simulation, SimulationError};

/// A soft ball (elastic waves of about 3 m/s) falling freely under a
/// gravity ten thousand times the Earth's, allowed `limit` substeps per
/// frame; the step may grow to a whole frame.
fn heavy_fall(limit: u32) -> Scene {
    let text = format!(
        "format = 1\n[domain]\nmax = [1.0, 4.0, 1.0]\ncell_size = 0.05\n\
         [time]\nduration = 0.05\nfps = 100\ndt = 0.01\nmax_substeps_per_frame = {limit}\n\
         [solver]\ngravity = [0.0, -1e5, 0.0]\n[materials.soft]\nyoungs_modulus = 3000.0\n\
         [[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 3.5, 0.5]\nradius = 0.1\n\
         material = \"soft\"\nparticles_per_cell = 1\n"
    );
    Scene::from_toml_str(&text, "heavy-fall.toml").unwrap()
}

#[test]
fn a_frame_that_needs_more_substeps_than_the_limit_stops_the_run() {
    // The first step is long (soft snow at rest); the fall then speeds the
    // snow up until a frame would need more than 40 substeps.
    let scene = heavy_fall(40);
    assert!(scene.first_step().substeps_per_frame <= 40.0);
    let mut simulation = Simulation::new(scene).unwrap();
    let error = (1..=5)
        .find_map(|frame| simulation.advance_to(f64::from(frame) * 0.01).err())
        .expect("a frame stops the run");
    let SimulationError::TooManySubsteps {
        time,
        dt,
        speed,
        needed,
        limit,
        ..
    } = error
    else {
        panic!("expected too many substeps, got {error}");
    };
    assert_eq!(limit, 40);
    assert!(needed > 40.0, "{needed}");
    assert!(f64::from(dt) < 1.0 / (100.0 * 40.0), "{dt}");
    assert!(speed > 50.0, "the snow was falling at {speed} m/s");
    // Nothing of the refused substep was taken.
    assert_eq!(simulation.time(), time);
    let before = simulation.snapshot();
    assert!(simulation.step(1.0).is_err());
    assert_eq!(simulation.snapshot(), before);
}

#[test]
fn a_higher_limit_lets_the_same_frames_run() {
    let mut simulation = Simulation::new(heavy_fall(100_000)).unwrap();
    for frame in 1..=5 {
        simulation.advance_to(f64::from(frame) * 0.01).unwrap();
    }
}

#[test]
fn the_estimate_before_sampling_bounds_the_memory_at_the_start() {
    for body in [
        "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.3",
        "shape = \"box\"\ncenter = [0.3, 0.2, 0.4]\nsize = [0.4, 0.3, 0.2]\nparticles_per_cell = 27",
    ] {
        let text = format!(
            "format = 1\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = 0.04\n[time]\n\
             duration = 1.0\n[[bodies]]\n{body}\n"
        );
        let scene = Scene::from_toml_str(&text, "estimate.toml").unwrap();
        let estimated_particles = scene.estimate().particles;
        let simulation = Simulation::new(scene.clone()).unwrap();
        let particles = simulation.particles().len() as u64;
        let off = estimated_particles.abs_diff(particles) as f64 / particles as f64;
        assert!(
            off < 0.02,
            "{estimated_particles} estimated, {particles} sampled"
        );
        let estimate = Simulation::estimate_memory_bytes(&scene, estimated_particles);
        let held = simulation.memory_bytes() as u64;
        assert!(
            estimate >= held && estimate < 2 * held,
            "{estimate} bytes estimated, {held} held"
        );
    }
}

#[test]
fn the_scene_and_the_solver_agree_on_the_bytes_per_particle() {
    let solver = Particles::bytes_per_particle() + PermuteBuffers::BYTES_PER_PARTICLE + 8;
    assert_eq!(solver as u64, CPU_BYTES_PER_PARTICLE);
}

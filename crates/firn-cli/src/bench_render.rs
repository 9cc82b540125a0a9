//! `firn bench --render`: milliseconds per picture for the offscreen
//! renderer: the `points` style on the benchmark snowball (about 262k
//! particles) and the `volume` style on the bundled default scene.

use std::path::Path;
use std::time::Instant;

use firn_core::Scene;
use firn_core::scene::{RenderStyle, Transfer};
use firn_mpm::Simulation;
use firn_render::scene_view::{FrameParticles, scene_picture};
use firn_run::run_dir::style_name;
use firn_run::simulation::body_poses;
use serde::Serialize;

use crate::Failure;
use crate::bench::{snowball_drop, write_json};
use crate::scene_source::{DEFAULT_SCENE, DEFAULT_SCENE_NAME};

/// Simulated time of the default scene at which its volume picture is taken
/// (the snowball has just hit the wall).
const VOLUME_SCENE_TIME: f64 = 0.2;

/// One measured picture.
#[derive(Debug, Serialize)]
struct RenderRecord {
    scene: String,
    style: &'static str,
    particles: usize,
    width: u32,
    height: u32,
    repeats: u32,
    ms_per_frame: f64,
    threads: usize,
}

/// Measures both styles at `size` and writes the JSON record to `json`.
pub fn bench_render(
    particles: u32,
    size: [u32; 2],
    repeats: u32,
    json: &Path,
) -> Result<(), Failure> {
    let drop = snowball_drop(particles, 128, Transfer::Apic);
    let snowball = Simulation::new(drop).map_err(|error| Failure::Failed(error.to_string()))?;
    let default_scene = Scene::from_toml_str(DEFAULT_SCENE, DEFAULT_SCENE_NAME)
        .map_err(|error| Failure::Failed(error.to_string()))?;
    let mut wall =
        Simulation::new(default_scene).map_err(|error| Failure::Failed(error.to_string()))?;
    wall.advance_to(VOLUME_SCENE_TIME)
        .map_err(|error| Failure::Failed(error.to_string()))?;
    let records = vec![
        measure(&snowball, RenderStyle::Points, size, repeats),
        measure(&wall, RenderStyle::Volume, size, repeats),
    ];
    for record in &records {
        outln!(
            "firn render style={} scene={} particles={} size={}x{} ms_per_frame={:.1} threads={}",
            record.style,
            record.scene,
            record.particles,
            record.width,
            record.height,
            record.ms_per_frame,
            record.threads
        );
    }
    write_json(json, &records)
}

/// Renders the simulation's current state `repeats` times (after one
/// untimed warm-up) and reports the mean.
fn measure(
    simulation: &Simulation,
    style: RenderStyle,
    size: [u32; 2],
    repeats: u32,
) -> RenderRecord {
    let scene = simulation.scene();
    let particles = simulation.particles();
    let densities = simulation.densities();
    let bodies = body_poses(simulation.view());
    let frame = FrameParticles {
        positions: &particles.position,
        masses: Some(&particles.mass),
        values: Some(&densities),
        trails: None,
        surface: None,
        drift: None,
        rigid_bodies: &bodies,
    };
    let picture = scene_picture(scene, simulation.time(), style, frame, Some(size));
    firn_render::render(&picture);
    let repeats = repeats.max(1);
    let started = Instant::now();
    for _ in 0..repeats {
        firn_render::render(&picture);
    }
    RenderRecord {
        scene: scene.name.clone(),
        style: style_name(style),
        particles: particles.len(),
        width: size[0],
        height: size[1],
        repeats,
        ms_per_frame: started.elapsed().as_secs_f64() * 1e3 / repeats as f64,
        threads: rayon::current_num_threads(),
    }
}

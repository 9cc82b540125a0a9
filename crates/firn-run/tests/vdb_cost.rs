//! What the `vdb` cache costs per frame at about 262k particles: the time to
//! make the grids and encode the file, and its size. Ignored by default (it
//! simulates a quarter of a million particles); docs/benchmarks.md gives the
//! command and the figures:
//!
//! `cargo test -p firn-run --test vdb_cost -- --ignored --nocapture`

use std::time::Instant;

use firn_core::Scene;
use firn_io::vdb::encode_vdb;
use firn_mpm::Simulation;
use firn_run::volumes::snow_volumes;

/// A snowball of radius 20 cells falling onto the floor: 268k particles.
const SCENE: &str = r#"
format = 1
name = "vdb-cost"

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.01

[time]
duration = 0.2
fps = 30

[[bodies]]
shape = "sphere"
center = [0.5, 0.3, 0.5]
radius = 0.2
velocity = [0.0, -3.0, 0.0]
"#;

#[test]
#[ignore = "a quarter of a million particles: run with --ignored"]
fn vdb_cost_per_frame() {
    let scene = Scene::from_toml_str(SCENE, "vdb-cost.toml").unwrap();
    let mut simulation = Simulation::new(scene).unwrap();
    println!("{} particles", simulation.particles().position.len());
    for frame in 0..4 {
        if frame > 0 {
            simulation.advance_to(f64::from(frame) / 30.0).unwrap();
        }
        for level_set in [false, true] {
            let particles = simulation.particles();
            let start = Instant::now();
            let grids = snow_volumes(
                &particles.position,
                &particles.mass,
                simulation.scene().domain.min,
                simulation.scene().domain.cell_size,
                level_set.then_some(400.0),
            );
            let made = start.elapsed();
            let bytes = encode_vdb(&grids);
            let encoded = start.elapsed();
            let active: Vec<u64> = grids.iter().map(|g| g.active_voxel_count()).collect();
            println!(
                "frame {frame} level_set {level_set}: grids {:.1} ms, grids + encoding {:.1} ms, \
                 {} bytes, active voxels {active:?}",
                made.as_secs_f64() * 1e3,
                encoded.as_secs_f64() * 1e3,
                bytes.len()
            );
        }
    }
}

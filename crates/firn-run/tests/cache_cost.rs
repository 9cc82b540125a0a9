//! What the `vdb`, `mesh` and `usd` caches cost per frame at about 262k particles:
//! the time to make and encode a frame's file, and its size. Ignored by
//! default (they sample a quarter of a million particles); docs/benchmarks.md
//! gives the commands and the figures:
//!
//! `cargo test -p firn-run --test cache_cost vdb -- --ignored --nocapture`
//! `cargo test -p firn-run --test cache_cost usd -- --ignored --nocapture`
//! `cargo test -p firn-run --test cache_cost mesh -- --ignored --nocapture`

use std::time::Instant;

use firn_core::Scene;
use firn_core::scene::MeshSettings;
use firn_io::mesh::{encode_mesh_obj, encode_mesh_ply};
use firn_io::vdb::encode_vdb;
use firn_io::{Attribute, FrameData, MeshData, write_usd_frame};
use firn_mpm::Simulation;
use firn_run::surface::snow_surface;
use firn_run::usd_stage::{usd_collider_samples, usd_stage};
use firn_run::volumes::snow_volumes;

/// A snowball of radius 20 cells falling onto the floor: 268k particles.
const SCENE: &str = r#"
format = 1
name = "cache-cost"

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
    let scene = Scene::from_toml_str(SCENE, "cache-cost.toml").unwrap();
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

#[test]
#[ignore = "a quarter of a million particles: run with --ignored"]
fn usd_cost_per_frame() {
    let scene = Scene::from_toml_str(SCENE, "cache-cost.toml").unwrap();
    let simulation = Simulation::new(scene.clone()).unwrap();
    let particles = simulation.particles();
    let folder = tempfile::tempdir().unwrap();
    std::fs::create_dir(folder.path().join("usd")).unwrap();
    println!("{} particles", particles.position.len());
    for index in 0..3 {
        let start = Instant::now();
        let frame = FrameData::new(index, 0.0, &particles.position)
            .with_attribute(Attribute::vector("velocity", &particles.velocity))
            .with_attribute(Attribute::scalar("plastic_j", &particles.plastic_j));
        let stage = usd_stage(&scene, index);
        write_usd_frame(
            folder.path(),
            &stage,
            &[&frame],
            firn_io::UsdSolids {
                colliders: &usd_collider_samples(&scene, 0.0),
                bodies: &[],
            },
        )
        .unwrap();
        let clip = folder.path().join(firn_io::usd::clip_name(index));
        println!(
            "frame {index}: {:.1} ms, clip {} bytes, stage {} bytes",
            start.elapsed().as_secs_f64() * 1e3,
            std::fs::metadata(clip).unwrap().len(),
            std::fs::metadata(folder.path().join("particles.usda"))
                .unwrap()
                .len()
        );
    }
}

#[test]
#[ignore = "a quarter of a million particles: run with --ignored"]
fn mesh_cost_per_frame() {
    let scene = Scene::from_toml_str(SCENE, "cache-cost.toml").unwrap();
    let simulation = Simulation::new(scene).unwrap();
    let particles = simulation.particles();
    println!("{} particles", particles.position.len());
    // Frame 0 (the ball as sampled) three times: simulating further frames
    // at this size takes minutes on a small machine.
    for frame in 0..3 {
        let start = Instant::now();
        let mesh = snow_surface(
            &particles.position,
            &particles.mass,
            simulation.scene().domain.min,
            simulation.scene().domain.cell_size,
            &MeshSettings::default(),
            400.0,
        );
        let made = start.elapsed();
        let data = MeshData {
            vertices: &mesh.vertices,
            triangles: &mesh.triangles,
        };
        let ply = encode_mesh_ply(data);
        let with_ply = start.elapsed();
        let obj = encode_mesh_obj(data);
        let with_obj = start.elapsed();
        println!(
            "frame {frame}: surface {:.1} ms, + PLY {:.1} ms, + OBJ {:.1} ms; {} vertices, {} \
             triangles; PLY {} bytes, OBJ {} bytes",
            made.as_secs_f64() * 1e3,
            (with_ply - made).as_secs_f64() * 1e3,
            (with_obj - with_ply).as_secs_f64() * 1e3,
            mesh.vertices.len(),
            mesh.triangles.len(),
            ply.len(),
            obj.len()
        );
    }
}

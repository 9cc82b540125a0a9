//! firn as a library: build a scene in code (or load one), step it, and read
//! the particle arrays.
//!
//! Run with `cargo run --release -p firn-examples --example snowball_in_code`.

use std::error::Error;
use std::path::PathBuf;

use firn_core::Material;
use firn_core::scene::{
    Body, CacheFormat, Camera, Collider, ColliderGeometry, Contact, ContactMode, Domain,
    Integrator, Motion, OutputSettings, RenderSettings, Scene, SceneKind, Shape, SolverSettings,
    TimeSettings, TimeStep, Transfer,
};
use firn_mpm::Simulation;
use glam::Vec3;

fn main() -> Result<(), Box<dyn Error>> {
    // A wet snowball dropped onto a sphere that moves sideways.
    let mut wet = Material::preset("wet").ok_or("no wet preset")?;
    wet.youngs_modulus = 2.0e5;
    let scene = Scene {
        name: "snowball-in-code".into(),
        domain: Domain {
            min: Vec3::ZERO,
            max: Vec3::new(1.0, 1.0, 1.0),
            cell_size: 0.025,
            walls: Contact {
                mode: ContactMode::Separate,
                friction: 0.3,
            },
        },
        time: TimeSettings {
            duration: 0.5,
            fps: 20.0,
            step: TimeStep::Adaptive {
                cfl: 0.4,
                max_dt: 1e-3,
            },
        },
        solver: SolverSettings {
            transfer: Transfer::Apic,
            flip_blend: 0.95,
            gravity: Vec3::new(0.0, -9.81, 0.0),
            seed: 1,
            integrator: Integrator::Explicit,
        },
        materials: vec![wet],
        bodies: vec![Body {
            shape: Shape::Sphere {
                center: Vec3::new(0.5, 0.7, 0.5),
                radius: 0.12,
            },
            velocity: Vec3::ZERO,
            material: 0,
            particles_per_cell: 8,
        }],
        colliders: vec![Collider {
            geometry: ColliderGeometry::Sphere {
                center: Vec3::new(0.4, 0.25, 0.5),
                radius: 0.15,
            },
            motion: Motion::Linear {
                velocity: Vec3::new(0.3, 0.0, 0.0),
            },
            contact: Contact {
                mode: ContactMode::Separate,
                friction: 0.5,
            },
        }],
        output: OutputSettings {
            directory: PathBuf::from("out/snowball-in-code"),
            formats: vec![CacheFormat::Ply],
            attributes: Vec::new(),
            checkpoint_every: 0,
        },
        camera: Camera::default(),
        render: RenderSettings::default(),
        kind: SceneKind::Snow,
        compute: Default::default(),
    };
    // The same checks a scene file gets.
    scene.validate()?;

    let mut simulation = Simulation::new(scene)?;
    println!("{} particles", simulation.particles().len());
    let fps = simulation.scene().time.fps;
    for frame in 1..=simulation.scene().time.frame_count() {
        let substeps = simulation.advance_to(frame as f64 / fps)?;
        let totals = simulation.diagnostics();
        let particles = simulation.particles();
        let compacted = particles.plastic_j.iter().filter(|&&j| j < 0.98).count();
        println!(
            "t = {:.2} s  substeps {substeps:3}  centre of mass y = {:.3} m  compacted particles {compacted}",
            simulation.time(),
            totals.center_of_mass[1],
        );
    }
    Ok(())
}

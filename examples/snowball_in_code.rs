//! firn as a library: build a scene in code, step it, and read the particle
//! arrays.
//!
//! `Scene::builder` starts from the defaults a scene file gets for the keys
//! it leaves out, so only what differs needs saying; `build` checks the scene
//! as a file is checked. (`Scene::load` reads a scene file instead.)
//!
//! Run with `cargo run --release -p firn-examples --example snowball_in_code`.

use std::error::Error;

use firn_core::scene::{Body, Collider, Contact, Transfer};
use firn_core::{Material, Scene};
use firn_mpm::Simulation;
use glam::Vec3;

fn main() -> Result<(), Box<dyn Error>> {
    // A wet snowball dropped onto a sphere that moves sideways.
    let wet = Material {
        youngs_modulus: 2.0e5,
        ..Material::preset("wet").ok_or("no wet preset")?
    };
    let scene = Scene::builder("snowball-in-code")
        .unit_box(0.025)
        .walls(Contact::separate(0.3))
        .duration(0.5)
        .fps(20.0)
        .transfer(Transfer::Apic)
        .material(wet) // material 0
        .body(Body::sphere(Vec3::new(0.5, 0.7, 0.5), 0.12).material(0))
        .collider(
            Collider::sphere(Vec3::new(0.4, 0.25, 0.5), 0.15)
                .moving(Vec3::new(0.3, 0.0, 0.0))
                .friction(0.5),
        )
        .build()?;

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

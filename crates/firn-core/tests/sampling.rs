//! Filling bodies with particles: determinism, counts, masses, containment.

use std::f32::consts::PI;

use firn_core::Scene;
use firn_core::scene::sampling::{
    ParticleSeeds, body_seed, particle_spacing, sample_bodies, sample_body,
};
use firn_core::scene::{Body, Material, Shape};
use glam::Vec3;

/// A scene with the given bodies (TOML `[[bodies]]` tables) in a 2 m cube
/// with h = 0.05.
fn scene(bodies: &str, seed: u64) -> Scene {
    let text = format!(
        "format = 1\n\n[domain]\nmax = [2.0, 2.0, 2.0]\ncell_size = 0.05\n\n[time]\nduration = \
         1.0\n\n[solver]\nseed = {seed}\n\n{bodies}"
    );
    Scene::from_toml_str(&text, "sampling.toml").unwrap_or_else(|err| panic!("{err}"))
}

const SPHERE: &str = r#"
[[bodies]]
shape = "sphere"
center = [1.0, 1.0, 1.0]
radius = 0.3
velocity = [1.0, 2.0, 3.0]
"#;

const BOX_AND_CYLINDER: &str = r#"
[[bodies]]
shape = "box"
center = [0.5, 0.5, 0.5]
size = [0.4, 0.4, 0.4]
material = "wet"

[[bodies]]
shape = "cylinder"
center = [1.3, 1.3, 1.3]
radius = 0.2
height = 0.5
axis = [1.0, 1.0, 1.0]
material = "powder"
particles_per_cell = 27
"#;

fn bits(seeds: &ParticleSeeds) -> Vec<[u32; 3]> {
    seeds
        .positions
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect()
}

#[test]
fn spacing_is_cell_size_over_cube_root() {
    assert_eq!(particle_spacing(0.05, 8), 0.025);
    assert_eq!(particle_spacing(0.1, 1), 0.1);
    assert!((particle_spacing(0.09, 27) - 0.03).abs() < 1e-7);
}

#[test]
fn same_seed_gives_the_same_bits() {
    let a = sample_bodies(&scene(&format!("{SPHERE}{BOX_AND_CYLINDER}"), 7));
    let b = sample_bodies(&scene(&format!("{SPHERE}{BOX_AND_CYLINDER}"), 7));
    assert!(!a.is_empty());
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(a, b);
}

#[test]
fn different_seed_gives_different_jitter() {
    let a = sample_bodies(&scene(SPHERE, 1));
    let b = sample_bodies(&scene(SPHERE, 2));
    let shared = a.len().min(b.len());
    let differing = (0..shared)
        .filter(|&i| a.positions[i] != b.positions[i])
        .count();
    assert!(
        differing > shared * 9 / 10,
        "{differing} of {shared} differ"
    );
    // Bodies of one scene are seeded differently from each other too.
    assert_ne!(body_seed(1, 0), body_seed(1, 1));
}

#[test]
fn sphere_count_and_mass_match_its_volume() {
    let scene = scene(SPHERE, 1);
    let (positions, mass) = sample_body(&scene, 0);
    let s = particle_spacing(0.05, 8);
    let volume = 4.0 / 3.0 * PI * 0.3_f32.powi(3);
    let expected = volume / s.powi(3);
    let count = positions.len() as f32;
    assert!(
        (count - expected).abs() < 0.02 * expected,
        "{count} particles, expected about {expected}"
    );

    let density = Material::preset("snow").unwrap().density;
    assert!((mass - density * s.powi(3)).abs() <= 1e-6 * mass);
    let total = mass * count;
    let expected_mass = density * volume;
    assert!(
        (total - expected_mass).abs() < 0.02 * expected_mass,
        "{total} kg, expected about {expected_mass} kg"
    );
}

#[test]
fn lattice_aligned_box_gets_one_particle_per_lattice_cell() {
    // 0.4 m / 0.025 m = 16 lattice cells per axis, all inside the box.
    let scene = scene(BOX_AND_CYLINDER, 3);
    let (positions, mass) = sample_body(&scene, 0);
    assert_eq!(positions.len(), 16 * 16 * 16);
    let wet = Material::preset("wet").unwrap().density;
    assert!((mass * positions.len() as f32 - wet * 0.4_f32.powi(3)).abs() < 1e-3);
}

#[test]
fn tilted_cylinder_count_matches_its_volume() {
    let scene = scene(BOX_AND_CYLINDER, 3);
    let (positions, _) = sample_body(&scene, 1);
    let s = particle_spacing(0.05, 27);
    let expected = PI * 0.2 * 0.2 * 0.5 / s.powi(3);
    let count = positions.len() as f32;
    assert!(
        (count - expected).abs() < 0.03 * expected,
        "{count} particles, expected about {expected}"
    );
}

#[test]
fn particles_lie_inside_their_shape_and_the_domain() {
    let scene = scene(&format!("{SPHERE}{BOX_AND_CYLINDER}"), 11);
    let mut start = 0;
    for (index, body) in scene.bodies.iter().enumerate() {
        let (positions, _) = sample_body(&scene, index);
        assert!(!positions.is_empty());
        for p in &positions {
            assert!(body.shape.contains(*p), "body {index}: {p} outside");
            assert!(
                scene.domain.contains(*p),
                "body {index}: {p} outside the domain"
            );
        }
        start += positions.len();
    }
    assert_eq!(sample_bodies(&scene).len(), start);
}

#[test]
fn seeds_concatenate_bodies_in_order_with_their_attributes() {
    let scene = scene(&format!("{SPHERE}{BOX_AND_CYLINDER}"), 5);
    let seeds = sample_bodies(&scene);
    let mut offset = 0;
    for (index, body) in scene.bodies.iter().enumerate() {
        let (positions, mass) = sample_body(&scene, index);
        let range = offset..offset + positions.len();
        assert_eq!(seeds.positions[range.clone()], positions[..]);
        assert!(
            seeds.velocities[range.clone()]
                .iter()
                .all(|v| *v == body.velocity)
        );
        assert!(seeds.masses[range.clone()].iter().all(|m| *m == mass));
        let material = body.material as u16;
        assert!(seeds.materials[range].iter().all(|m| *m == material));
        offset += positions.len();
    }
    assert_eq!(seeds.len(), offset);
    assert_eq!(seeds.velocities.len(), offset);
    assert_eq!(seeds.masses.len(), offset);
    assert_eq!(seeds.materials.len(), offset);
    // The sphere comes first and moves.
    assert_eq!(seeds.velocities[0], Vec3::new(1.0, 2.0, 3.0));
    // Materials by first use: snow (sphere), wet, powder.
    let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["snow", "wet", "powder"]);
}

#[test]
fn particles_outside_the_domain_are_dropped() {
    // Built in code, bypassing validation: a box half outside the domain.
    let mut scene = scene(SPHERE, 1);
    scene.bodies.push(Body {
        shape: Shape::Box {
            center: Vec3::new(2.0, 1.0, 1.0),
            size: Vec3::splat(0.4),
        },
        velocity: Vec3::ZERO,
        material: 0,
        particles_per_cell: 8,
        clumps: None,
    });
    assert!(scene.validate().is_err());
    let (positions, _) = sample_body(&scene, 1);
    assert_eq!(positions.len(), 8 * 16 * 16);
    assert!(positions.iter().all(|p| scene.domain.contains(*p)));
}

const CLUMPY_SPHERE: &str = r#"
[[bodies]]
shape = "sphere"
center = [1.0, 1.0, 1.0]
radius = 0.3
clumps = { size = 0.15, contrast = 0.3 }
"#;

/// A clumpy body keeps its particles and their masses ρ0 s³, and gives each
/// an initial plastic volume ratio J_P⁰ between e^−c (clump interiors) and
/// e^c (seams), both of which occur.
#[test]
fn clumps_pack_the_same_particles_unevenly() {
    let plain = sample_bodies(&scene(SPHERE, 3));
    let clumpy = sample_bodies(&scene(CLUMPY_SPHERE, 3));
    assert_eq!(
        bits(&plain),
        bits(&clumpy),
        "clumps must not move particles"
    );
    assert!(plain.plastic_j.iter().all(|&j| j == 1.0));
    let (low, high) = ((-0.3f32).exp(), 0.3f32.exp());
    assert_eq!(plain.masses, clumpy.masses);
    for &j in &clumpy.plastic_j {
        assert!((low * 0.9999..=high * 1.0001).contains(&j), "J_P0 = {j}");
    }
    let packed = clumpy.plastic_j.iter().filter(|&&j| j < 0.8).count();
    let loose = clumpy.plastic_j.iter().filter(|&&j| j > 1.2).count();
    println!(
        "{} particles: {packed} in clump interiors, {loose} on seams",
        clumpy.len()
    );
    assert!(packed > clumpy.len() / 4 && loose > clumpy.len() / 50);
}

/// Clumps smaller than a grid cell, or a contrast out of range, are refused
/// with the key and a fix.
#[test]
fn clumps_are_checked() {
    let small = CLUMPY_SPHERE.replace("size = 0.15", "size = 0.01");
    let text = format!(
        "format = 1\n[domain]\nmax = [2.0, 2.0, 2.0]\ncell_size = 0.05\n[time]\nduration = 1.0\n{small}"
    );
    let error = Scene::from_toml_str(&text, "clumps.toml")
        .unwrap_err()
        .to_string();
    assert!(error.contains("bodies[0].clumps.size"), "{error}");
    assert!(error.contains("size = 0.1"), "{error}");
    let strong = CLUMPY_SPHERE.replace("contrast = 0.3", "contrast = 2.0");
    let text = text.replace(&small, &strong);
    let error = Scene::from_toml_str(&text, "clumps.toml")
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("bodies[0].clumps.contrast must be between 0 and 0.5"),
        "{error}"
    );
    let no_size = CLUMPY_SPHERE.replace("size = 0.15, ", "");
    let text = text.replace(&strong, &no_size);
    let error = Scene::from_toml_str(&text, "clumps.toml")
        .unwrap_err()
        .to_string();
    assert!(error.contains("clumps = { size = 0.05 }"), "{error}");
}

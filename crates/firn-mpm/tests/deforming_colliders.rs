//! Deforming mesh colliders (one mesh file per frame): a sequence that only
//! translates presses the snow as the rigid moving box does, a foot pressed
//! deeper leaves a deeper print over compacted snow, and a sole that drags
//! back while it presses carries the snow under it along.

mod common;

use std::path::Path;

use firn_core::scene::{
    Collider, ColliderGeometry, Contact, ContactMode, MeshSequenceCollider, Shape, Transfer,
};
use firn_mpm::Simulation;
use glam::Vec3;

/// Mesh frames per second of every sequence here.
const RATE: f64 = 30.0;

/// Writes the box `low..high` as an OBJ with outward triangles, its
/// corners in a fixed order so every frame has the same topology; `shear`
/// moves the bottom four corners.
fn write_box(path: &Path, low: Vec3, high: Vec3, shear: Vec3) {
    let mut text = String::new();
    for i in 0..8 {
        let pick = |bit: u32, a: f32, b: f32| if i & bit == 0 { a } else { b };
        let mut corner = Vec3::new(
            pick(1, low.x, high.x),
            pick(2, low.y, high.y),
            pick(4, low.z, high.z),
        );
        if i & 2 == 0 {
            corner += shear;
        }
        text += &format!("v {} {} {}\n", corner.x, corner.y, corner.z);
    }
    for [a, b, c, d] in [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ] {
        text += &format!(
            "f {} {} {}\nf {} {} {}\n",
            a + 1,
            b + 1,
            c + 1,
            a + 1,
            c + 1,
            d + 1
        );
    }
    std::fs::write(path, text).unwrap();
}

/// A deforming collider whose frame k is the box of `frame(k)`
/// (low, high, shear of the bottom), `count` frames from time 0.
fn sequence(
    folder: &Path,
    count: u32,
    frame: impl Fn(u32) -> (Vec3, Vec3, Vec3),
    contact: Contact,
) -> Collider {
    for k in 0..count {
        let (low, high, shear) = frame(k);
        write_box(
            &folder.join(format!("foot_{:04}.obj", k + 1)),
            low,
            high,
            shear,
        );
    }
    let loaded = MeshSequenceCollider::load(
        folder.join("foot_####.obj"),
        (Vec3::ONE, Vec3::ZERO, None),
        (RATE, 0.0),
        0.01,
        MeshSequenceCollider::band_for(0.02, 0.01),
    )
    .unwrap();
    Collider {
        contact,
        ..Collider::new(ColliderGeometry::MeshSequence(Box::new(loaded)))
    }
}

/// A slab of snow 0.1 m deep on the floor, under `collider`, run to `until`.
fn slab_under(collider: Collider, until: f64) -> Simulation {
    let slab = Shape::Box {
        center: Vec3::new(0.5, 0.05, 0.5),
        size: Vec3::new(0.3, 0.1, 0.24),
    };
    let mut scene = common::scene_with(slab, Vec3::ZERO, Transfer::Apic, 0.02);
    scene.colliders.push(collider);
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(until).unwrap();
    simulation
}

const STICKY: Contact = Contact {
    mode: ContactMode::Sticky,
    friction: 0.0,
};

/// The foot's box: 0.12 × 0.1 × 0.1 m over the slab's middle, its sole at
/// `sole` metres.
fn foot(sole: f32) -> (Vec3, Vec3) {
    (
        Vec3::new(0.44, sole, 0.45),
        Vec3::new(0.56, sole + 0.1, 0.55),
    )
}

#[test]
fn a_sequence_that_only_translates_presses_the_snow_as_the_rigid_moving_box_does() {
    let speed = -0.2;
    let start = foot(0.11);
    let rigid = Collider::cuboid(0.5 * (start.0 + start.1), start.1 - start.0)
        .moving(Vec3::new(0.0, speed, 0.0))
        .contact(STICKY);
    let folder = tempfile::tempdir().unwrap();
    let translating = sequence(
        folder.path(),
        8,
        |k| {
            let drop = Vec3::new(0.0, speed * k as f32 / RATE as f32, 0.0);
            (start.0 + drop, start.1 + drop, Vec3::ZERO)
        },
        STICKY,
    );
    // The sole ends 3 cm into the slab. The two differ in round-off from
    // the first contact (the sequence's velocity is a difference of
    // positions times the rate), which the particle sort then turns into
    // a different order, so the snow is compared as a whole: where its
    // mass is, how fast it moves, and how deep the box pressed it.
    let (a, b) = (slab_under(rigid, 0.2), slab_under(translating, 0.2));
    let (a, b) = (a.diagnostics(), b.diagnostics());
    let apart = |x: [f64; 3], y: [f64; 3]| glam::DVec3::from(x).distance(glam::DVec3::from(y));
    let moved = apart(a.center_of_mass, b.center_of_mass);
    assert!(moved < 1e-3, "centres of mass {moved} m apart");
    let momentum = apart(a.momentum, b.momentum) / glam::DVec3::from(a.momentum).length();
    assert!(momentum < 0.15, "momenta {momentum} apart (relative)");
}

/// The print's depth under a foot pressed `depth` into the slab and lifted
/// off, and the mean plastic J of the 3 cm of snow under its sole at the
/// deepest point.
fn print(depth: f32) -> (f32, f32) {
    let folder = tempfile::tempdir().unwrap();
    // Down over 6 frames from 2 cm above the slab, up again over 6.
    let path = [0, 1, 2, 3, 4, 5, 6, 5, 4, 3, 2, 1, 0];
    let sole = |k: usize| 0.12 - (0.02 + depth) * path[k] as f32 / 6.0;
    let pressing = sequence(
        folder.path(),
        path.len() as u32,
        |k| {
            let (low, high) = foot(sole(k as usize));
            (low, high, Vec3::ZERO)
        },
        Contact {
            mode: ContactMode::Separate,
            friction: 0.5,
        },
    );
    let mut simulation = slab_under(pressing, 6.0 / RATE);
    let under = |x: Vec3| (0.46..0.54).contains(&x.x) && (0.47..0.53).contains(&x.z);
    let particles = simulation.particles();
    let deepest = sole(6);
    let compacted: Vec<f32> = (0..particles.len())
        .filter(|&p| {
            let x = particles.position[p];
            under(x) && x.y < deepest && x.y > deepest - 0.03
        })
        .map(|p| particles.plastic_j[p])
        .collect();
    let mean_j = compacted.iter().sum::<f32>() / compacted.len() as f32;
    simulation.advance_to(13.0 / RATE).unwrap();
    let particles = simulation.particles();
    let surface = (0..particles.len())
        .filter(|&p| under(particles.position[p]))
        .map(|p| particles.position[p].y)
        .fold(0.0f32, f32::max);
    (0.1 - surface, mean_j)
}

#[test]
fn a_foot_pressed_deeper_leaves_a_deeper_print_over_compacted_snow() {
    let (shallow, shallow_j) = print(0.02);
    let (deep, deep_j) = print(0.05);
    assert!(
        shallow > 0.005,
        "a 2 cm press left a print {shallow} m deep"
    );
    assert!(
        deep > shallow + 0.015,
        "prints {shallow} m and {deep} m deep"
    );
    assert!(
        shallow_j < 1.0 && deep_j < shallow_j,
        "plastic J under the prints: {shallow_j}, {deep_j}"
    );
}

#[test]
fn a_sole_that_drags_back_while_it_presses_carries_the_snow_under_it() {
    // The top of the foot holds still; its sole slides +x at 0.3 m/s while
    // resting 1 cm into the slab: only the mesh's deformation moves it.
    let folder = tempfile::tempdir().unwrap();
    let dragging = sequence(
        folder.path(),
        10,
        |k| {
            let (low, high) = foot(0.09);
            (low, high, Vec3::new(0.3 * k as f32 / RATE as f32, 0.0, 0.0))
        },
        STICKY,
    );
    let simulation = slab_under(dragging, 0.25);
    let particles = simulation.particles();
    let top: Vec<usize> = (0..particles.len())
        .filter(|&p| {
            let x = particles.position[p];
            x.y > 0.07 && (0.5..0.62).contains(&x.x) && (0.47..0.53).contains(&x.z)
        })
        .collect();
    let mean_vx = top.iter().map(|&p| particles.velocity[p].x).sum::<f32>() / top.len() as f32;
    assert!(
        mean_vx > 0.1,
        "the snow under the sliding sole moves at {mean_vx} m/s along x ({} particles)",
        top.len()
    );
}

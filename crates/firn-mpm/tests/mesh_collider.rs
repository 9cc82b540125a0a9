//! A mesh collider holds snow like the primitive it is shaped as: a block
//! dropped on a cube mesh comes to rest where it rests on an equal box.

mod common;

use firn_core::scene::{
    Collider, ColliderGeometry, Contact, ContactMode, MeshCollider, MeshPlacement, Shape, Transfer,
};
use firn_mpm::Simulation;
use glam::Vec3;

/// A closed unit cube centred at the origin, faces wound outwards.
const CUBE_OBJ: &str = "v -0.5 -0.5 -0.5\nv 0.5 -0.5 -0.5\nv 0.5 0.5 -0.5\nv -0.5 0.5 -0.5\n\
v -0.5 -0.5 0.5\nv 0.5 -0.5 0.5\nv 0.5 0.5 0.5\nv -0.5 0.5 0.5\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

const PEDESTAL_CENTER: Vec3 = Vec3::new(0.5, 0.2, 0.5);
const PEDESTAL_SIZE: Vec3 = Vec3::new(0.5, 0.4, 0.5);
const CELL_SIZE: f32 = 0.04;

/// The height of the block's lowest particle after it has landed on the
/// pedestal and come to rest.
fn resting_bottom(geometry: ColliderGeometry) -> f32 {
    let block = Shape::Box {
        center: Vec3::new(0.5, 0.6, 0.5),
        size: Vec3::new(0.2, 0.1, 0.2),
    };
    let mut scene = common::scene_with(block, Vec3::ZERO, Transfer::Apic, CELL_SIZE);
    scene
        .colliders
        .push(Collider::new(geometry).contact(Contact {
            mode: ContactMode::Separate,
            friction: 0.5,
        }));
    let mut simulation = Simulation::new(scene).unwrap();
    simulation.advance_to(0.5).unwrap();
    simulation
        .particles()
        .position
        .iter()
        .map(|p| p.y)
        .fold(f32::MAX, f32::min)
}

#[test]
fn snow_rests_on_a_cube_mesh_as_on_a_box() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("cube.obj");
    std::fs::write(&file, CUBE_OBJ).unwrap();
    let placement = MeshPlacement {
        file,
        scale: PEDESTAL_SIZE,
        rotation_degrees: Vec3::ZERO,
        center: PEDESTAL_CENTER,
    };
    let mesh = MeshCollider::load(placement, 0.02).unwrap();
    let on_mesh = resting_bottom(ColliderGeometry::Mesh(Box::new(mesh)));
    let on_box = resting_bottom(ColliderGeometry::Box {
        center: PEDESTAL_CENTER,
        size: PEDESTAL_SIZE,
    });
    let top = PEDESTAL_CENTER.y + 0.5 * PEDESTAL_SIZE.y;
    // Grid contact stops snow about a cell above a surface (h = 0.04 here).
    assert!(
        on_mesh > top && on_mesh - top < 1.5 * CELL_SIZE,
        "the block rests at {on_mesh} on a mesh whose top is at {top}"
    );
    assert!(
        (on_mesh - on_box).abs() < 0.1 * CELL_SIZE,
        "on the mesh at {on_mesh}, on the box at {on_box}"
    );
}

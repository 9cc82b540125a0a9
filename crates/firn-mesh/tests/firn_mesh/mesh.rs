use firn_mesh::{MeshTransform, TriangleMesh, WindingNumber};
use glam::{Quat, Vec3};

use crate::common::cube;

#[test]
fn transform_scales_then_rotates_then_translates() {
    let transform = MeshTransform {
        scale: Vec3::new(2.0, 1.0, 1.0),
        rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
        translation: Vec3::new(0.0, 0.0, 5.0),
    };
    assert!(transform.apply(Vec3::X).distance(Vec3::new(0.0, 2.0, 5.0)) < 1e-6);
    assert_eq!(MeshTransform::IDENTITY.apply(Vec3::ONE), Vec3::ONE);
    assert_eq!(MeshTransform::default(), MeshTransform::IDENTITY);
}

#[test]
fn transformed_mesh_keeps_volume_sign_and_bounds() {
    let unit = cube(0.0, 1.0);
    assert_eq!(unit.bounds(), (Vec3::ZERO, Vec3::ONE));
    assert!((unit.signed_volume() - 1.0).abs() < 1e-12);
    let stretched = unit.transformed(&MeshTransform {
        scale: Vec3::new(2.0, 3.0, 0.5),
        translation: Vec3::splat(-1.0),
        ..MeshTransform::IDENTITY
    });
    assert_eq!(
        stretched.bounds(),
        (Vec3::splat(-1.0), Vec3::new(1.0, 2.0, -0.5))
    );
    assert!((stretched.signed_volume() - 3.0).abs() < 1e-6);
    let mirrored = unit.transformed(&MeshTransform {
        scale: Vec3::new(-1.0, 1.0, 1.0),
        ..MeshTransform::IDENTITY
    });
    assert!((mirrored.signed_volume() - 1.0).abs() < 1e-6);
    assert!(WindingNumber::new(&mirrored).contains(Vec3::new(-0.5, 0.5, 0.5)));
}

#[test]
fn empty_mesh_has_zero_bounds_and_volume() {
    let empty = TriangleMesh::default();
    assert_eq!(empty.bounds(), (Vec3::ZERO, Vec3::ZERO));
    assert_eq!(empty.signed_volume(), 0.0);
}

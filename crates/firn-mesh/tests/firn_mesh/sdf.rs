use firn_mesh::{SignedDistanceField, TriangleMesh};
use glam::Vec3;

use crate::common::{Random, cube, icosphere};

#[test]
fn sphere_field_matches_the_analytic_distance_and_normals() {
    let spacing = 0.05;
    let sphere = icosphere(1.0, 4);
    let field = SignedDistanceField::build(&sphere, spacing, 0.2);
    let (lo, hi) = field.bounds();
    let (mesh_lo, mesh_hi) = sphere.bounds();
    assert!(lo.distance(mesh_lo - 0.2) < 1e-6);
    assert!(hi.cmpge(mesh_hi + 0.2 - 1e-6).all() && hi.cmple(mesh_hi + 0.2 + spacing).all());
    assert_eq!(field.spacing(), spacing);
    let mut random = Random(5);
    let mut checked = 0;
    while checked < 5000 {
        let p = random.point(lo, hi);
        let r = p.length();
        if r < 3.0 * spacing {
            continue;
        }
        checked += 1;
        let (distance, normal) = field.sample(p);
        assert!(
            (distance - (r - 1.0)).abs() < 0.5 * spacing,
            "{distance} vs {} at {p}",
            r - 1.0
        );
        if r > 0.3 {
            let angle = normal.angle_between(p / r).to_degrees();
            assert!(
                angle < 10.0,
                "normal {normal} at {p} is {angle}° off radial"
            );
        }
    }
}

#[test]
fn outside_the_box_the_distance_keeps_growing() {
    let field = SignedDistanceField::build(&icosphere(1.0, 3), 0.1, 0.2);
    let (distance, normal) = field.sample(Vec3::new(3.0, 0.0, 0.0));
    assert!((distance - 2.0).abs() < 0.05, "distance {distance}");
    assert!(
        normal.angle_between(Vec3::X).to_degrees() < 10.0,
        "normal {normal}"
    );
    let (distance, normal) = field.sample(Vec3::new(0.0, -4.0, 4.0));
    assert!(
        distance > 4.0 && normal.y < -0.6 && normal.z > 0.6,
        "{distance} {normal}"
    );
}

#[test]
fn cube_field_is_negative_inside_and_sized_by_its_grid() {
    let field = SignedDistanceField::build(&cube(-0.5, 0.5), 0.1, 0.1);
    let (inside, _) = field.sample(Vec3::ZERO);
    assert!((inside + 0.5).abs() < 1e-5, "centre {inside}");
    let (face, normal) = field.sample(Vec3::new(0.3, 0.0, 0.0));
    assert!(
        (face + 0.2).abs() < 1e-5 && normal.distance(Vec3::X) < 1e-5,
        "{face} {normal}"
    );
    let (lo, hi) = field.bounds();
    let points = ((hi - lo) / 0.1).round().as_uvec3() + 1;
    let points = (points.x * points.y * points.z) as usize;
    assert!(field.byte_size() >= points * 4 && field.byte_size() < points * 4 + 1024);
}

#[test]
fn field_does_not_depend_on_the_thread_count() {
    let sphere = icosphere(1.0, 2);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = single.install(|| SignedDistanceField::build(&sphere, 0.07, 0.1));
    let b = SignedDistanceField::build(&sphere, 0.07, 0.1);
    let mut random = Random(9);
    for _ in 0..2000 {
        let p = random.point(Vec3::splat(-1.5), Vec3::splat(1.5));
        assert_eq!(a.sample(p).0.to_bits(), b.sample(p).0.to_bits());
    }
}

#[test]
fn empty_mesh_gives_a_positive_field() {
    let field = SignedDistanceField::build(&TriangleMesh::default(), 0.5, 1.0);
    let (distance, normal) = field.sample(Vec3::ZERO);
    assert!(distance > 0.0 && distance.is_finite());
    assert!((normal.length() - 1.0).abs() < 1e-6);
}

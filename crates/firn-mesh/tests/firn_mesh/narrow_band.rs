//! The narrow-band field of deforming mesh colliders: exact distances near
//! the surface, signs from pseudo-normals, per-vertex values at the closest
//! point, and bounded size.

use firn_mesh::{NarrowBandField, SignedDistanceField};
use glam::Vec3;

use crate::common::{Random, cube, icosphere};

/// The exact signed distance to the cube [lo, hi]³.
fn cube_distance(p: Vec3, lo: f32, hi: f32) -> f32 {
    let centre = Vec3::splat(0.5 * (lo + hi));
    let q = (p - centre).abs() - Vec3::splat(0.5 * (hi - lo));
    q.max(Vec3::ZERO).length() + q.max_element().min(0.0)
}

#[test]
fn cube_band_is_exact_near_the_surface_and_signed_by_the_fill_away_from_it() {
    let (spacing, band) = (0.05, 0.15);
    let field = NarrowBandField::build(&cube(-0.5, 0.5), spacing, band);
    let positions = cube(-0.5, 0.5).vertices;
    let mut random = Random(3);
    let mut near = 0;
    for _ in 0..4000 {
        let p = random.point(Vec3::splat(-1.0), Vec3::splat(1.0));
        let exact = cube_distance(p, -0.5, 0.5);
        let found = field.sample(p, &positions, Vec3::ZERO);
        if exact.abs() < band - 2.0 * spacing {
            near += 1;
            // Trilinear between exact samples: off by at most the curvature
            // of the distance near edges and corners within a cell.
            assert!(
                (found.distance - exact).abs() < 0.3 * spacing,
                "{p}: {found:?} vs {exact}"
            );
        } else if exact < -band - spacing {
            assert!(found.distance <= -0.99 * band, "{p} deep inside: {found:?}");
        } else if exact > band + spacing {
            assert!(found.distance >= 0.99 * band, "{p} far outside: {found:?}");
        }
    }
    assert!(near > 200, "only {near} probes near the surface");
    assert_eq!(
        field.sample(Vec3::ZERO, &positions, Vec3::ZERO).distance,
        -band
    );
    assert_eq!(
        field
            .sample(Vec3::splat(3.0), &positions, Vec3::ZERO)
            .distance,
        band
    );
    let face = field.sample(Vec3::new(0.0, 0.1, 0.52), &positions, Vec3::ZERO);
    assert!((face.distance - 0.02).abs() < 1e-5, "{face:?}");
    assert!(
        face.gradient.normalize().distance(Vec3::Z) < 1e-4,
        "{face:?}"
    );
}

#[test]
fn per_vertex_values_are_read_at_the_closest_surface_point() {
    let mesh = cube(-0.5, 0.5);
    let field = NarrowBandField::build(&mesh, 0.05, 0.15);
    // The vertices' own positions as values give back the closest surface
    // point, exactly on a flat face away from its edges.
    let p = Vec3::new(0.1, -0.2, 0.53);
    let found = field.sample(p, &mesh.vertices, Vec3::ZERO);
    assert!(
        found.value.distance(Vec3::new(0.1, -0.2, 0.5)) < 1e-5,
        "{found:?}"
    );
    // A velocity that shears the top face: vertices at y = 0.5 move +x.
    let velocities: Vec<Vec3> = mesh
        .vertices
        .iter()
        .map(|v| if v.y > 0.0 { Vec3::X } else { Vec3::ZERO })
        .collect();
    let top = field.sample(Vec3::new(0.0, 0.55, 0.0), &velocities, Vec3::ZERO);
    let side = field.sample(Vec3::new(0.55, 0.0, 0.0), &velocities, Vec3::ZERO);
    assert!(top.value.distance(Vec3::X) < 1e-5, "{top:?}");
    assert!(side.value.distance(0.5 * Vec3::X) < 1e-5, "{side:?}");
    let far = field.sample(Vec3::splat(5.0), &velocities, Vec3::Y);
    assert_eq!(far.value, Vec3::Y);
}

/// An icosphere with bumps and dents: closed, consistently oriented and
/// concave in many places, where a face's own normal would mis-sign points.
fn bumpy_sphere() -> firn_mesh::TriangleMesh {
    let mut mesh = icosphere(0.4, 3);
    for v in &mut mesh.vertices {
        let bump = 1.0 + 0.3 * (7.0 * v.x).sin() * (7.0 * v.y).sin() * (5.0 * v.z).cos();
        *v *= bump;
    }
    mesh
}

#[test]
fn sphere_band_agrees_with_the_dense_field_where_both_are_exact() {
    let sphere = bumpy_sphere();
    let (spacing, band) = (0.04, 0.12);
    let banded = NarrowBandField::build(&sphere, spacing, band);
    let dense = SignedDistanceField::build(&sphere, spacing, band);
    let mut random = Random(11);
    for _ in 0..6000 {
        let p = random.point(Vec3::splat(-0.6), Vec3::splat(0.6));
        let (expected, _) = dense.sample(p);
        if expected.abs() < band - 2.0 * spacing {
            let found = banded.sample(p, &sphere.vertices, Vec3::ZERO).distance;
            assert!(
                (found - expected).abs() < 0.1 * spacing,
                "{p}: {found} vs {expected}"
            );
        }
    }
}

#[test]
fn band_holds_far_fewer_samples_than_the_box_and_its_footprint_is_exact() {
    // A metre-sized sphere at 1 cm with a 4 cm band: the band's bricks
    // against a dense grid over the box.
    let (spacing, band) = (0.01, 0.04);
    let footprint = NarrowBandField::footprint(&icosphere(1.0, 4), spacing, band);
    let dense_bytes = 4.0 * ((2.0 + 2.0 * band) / spacing).powi(3);
    assert!(
        (footprint.bytes() as f32) < 0.5 * dense_bytes,
        "{} vs dense {dense_bytes}",
        footprint.bytes()
    );
    let small = icosphere(0.3, 2);
    let footprint = NarrowBandField::footprint(&small, 0.03, 0.09);
    let stored = NarrowBandField::build(&small, 0.03, 0.09).byte_size() as u64;
    assert!(stored >= footprint.bytes() && stored < footprint.bytes() + 64 * 1024);
}

#[test]
fn band_does_not_depend_on_the_thread_count() {
    let sphere = icosphere(0.5, 2);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = single.install(|| NarrowBandField::build(&sphere, 0.03, 0.09));
    let b = NarrowBandField::build(&sphere, 0.03, 0.09);
    let mut random = Random(5);
    for _ in 0..2000 {
        let p = random.point(Vec3::splat(-0.7), Vec3::splat(0.7));
        let (x, y) = (
            a.sample(p, &sphere.vertices, Vec3::ZERO),
            b.sample(p, &sphere.vertices, Vec3::ZERO),
        );
        assert_eq!(x.distance.to_bits(), y.distance.to_bits());
        assert_eq!(x.value, y.value);
        assert_eq!(
            a.distance(p).to_bits(),
            x.distance.to_bits(),
            "the cheap test's bits"
        );
    }
}

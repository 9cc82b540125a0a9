use firn_mesh::{TriangleMesh, WindingNumber};
use glam::Vec3;
use rayon::prelude::*;

use crate::common::{Random, brute_force_winding, cube, icosphere, lattice};

/// The volume inside the mesh by counting lattice points in the box.
fn lattice_volume(mesh: &TriangleMesh, lo: Vec3, hi: Vec3, spacing: f32) -> f64 {
    let winding = WindingNumber::new(mesh);
    let (points, _) = lattice(lo, hi, spacing);
    let inside = points.par_iter().filter(|&&p| winding.contains(p)).count();
    inside as f64 * f64::from(spacing).powi(3)
}

#[test]
fn cube_volume_from_lattice_is_exact() {
    let volume = lattice_volume(&cube(-0.5, 0.5), Vec3::splat(-1.0), Vec3::splat(1.0), 0.05);
    assert!((volume - 1.0).abs() < 1e-6, "volume {volume}");
}

#[test]
fn sphere_volume_from_lattice_matches_polyhedron_and_sphere() {
    let sphere = icosphere(1.0, 4);
    let polyhedron = sphere.signed_volume();
    let analytic = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(polyhedron > 0.99 * analytic && polyhedron < analytic);
    let volume = lattice_volume(&sphere, Vec3::splat(-1.1), Vec3::splat(1.1), 0.03);
    for reference in [polyhedron, analytic] {
        assert!(
            (volume / reference - 1.0).abs() < 0.02,
            "volume {volume} vs {reference}"
        );
    }
}

/// Largest |tree - exact| over random points, and whether points away
/// from the surface (exact value far from 1/2) are classified the same.
fn compare_with_brute_force(mesh: &TriangleMesh, points: &[Vec3]) -> f64 {
    let winding = WindingNumber::new(mesh);
    let errors: Vec<f64> = points
        .par_iter()
        .map(|&p| {
            let exact = brute_force_winding(mesh, p);
            let approximate = f64::from(winding.at(p));
            if (exact - 0.5).abs() > 0.05 {
                assert_eq!(winding.contains(p), exact > 0.5, "classification at {p}");
            }
            (approximate - exact).abs()
        })
        .collect();
    errors.into_iter().fold(0.0, f64::max)
}

#[test]
fn tree_approximation_agrees_with_the_exact_sum() {
    let mut random = Random(7);
    let sphere = icosphere(1.0, 3);
    let points: Vec<Vec3> = (0..3000)
        .map(|_| random.point(Vec3::splat(-1.5), Vec3::splat(1.5)))
        .collect();
    let error = compare_with_brute_force(&sphere, &points);
    assert!(error < 1e-2, "sphere: largest error {error}");
    let mut open = cube(-0.5, 0.5);
    open.triangles.truncate(10);
    let error = compare_with_brute_force(&open, &points);
    assert!(error < 1e-2, "open cube: largest error {error}");
}

#[test]
fn exact_classification_away_from_the_sphere_surface() {
    let mut random = Random(11);
    let sphere = icosphere(1.0, 3);
    let winding = WindingNumber::new(&sphere);
    for _ in 0..20_000 {
        let p = random.point(Vec3::splat(-2.0), Vec3::splat(2.0));
        let r = p.length();
        if (r - 1.0).abs() > 0.02 {
            assert_eq!(winding.contains(p), r < 1.0, "at {p}");
            let w = winding.at(p);
            let expected = if r < 1.0 { 1.0 } else { 0.0 };
            assert!((w - expected).abs() < 1e-2, "w = {w} at {p}");
        }
    }
}

#[test]
fn cube_with_a_missing_face_is_still_filled() {
    let mut open = cube(-0.5, 0.5);
    let top = open.triangles.drain(2..4).collect::<Vec<_>>();
    assert!(
        top.iter()
            .flatten()
            .all(|&i| open.vertices[i as usize].z == 0.5)
    );
    let winding = WindingNumber::new(&open);
    let deep = winding.at(Vec3::new(0.0, 0.0, -0.4));
    assert!(
        deep > 0.9 && winding.contains(Vec3::new(0.1, -0.2, -0.3)),
        "deep inside: {deep}"
    );
    for far in [
        Vec3::splat(5.0),
        Vec3::new(0.0, 0.0, 10.0),
        Vec3::new(-8.0, 0.0, -1.0),
    ] {
        assert!(
            winding.at(far).abs() < 0.02,
            "far outside at {far}: {}",
            winding.at(far)
        );
    }
}

#[test]
fn an_inside_out_mesh_fills_like_the_mesh() {
    let mut inverted = icosphere(0.5, 3);
    for triangle in &mut inverted.triangles {
        triangle.swap(1, 2);
    }
    let winding = WindingNumber::new(&inverted);
    assert!(winding.at(Vec3::ZERO) < -0.99, "{}", winding.at(Vec3::ZERO));
    assert!(winding.contains(Vec3::new(0.1, 0.2, -0.3)));
    assert!(!winding.contains(Vec3::new(0.6, 0.0, 0.0)));
}

#[test]
fn empty_mesh_is_everywhere_outside() {
    let winding = WindingNumber::new(&TriangleMesh::default());
    assert_eq!(winding.at(Vec3::ZERO), 0.0);
    assert!(!winding.contains(Vec3::ONE));
}

#[test]
fn queries_do_not_depend_on_the_thread_count() {
    let sphere = icosphere(1.0, 3);
    let single = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let a = single.install(|| WindingNumber::new(&sphere));
    let b = WindingNumber::new(&sphere);
    let mut random = Random(3);
    for _ in 0..1000 {
        let p = random.point(Vec3::splat(-1.5), Vec3::splat(1.5));
        assert_eq!(a.at(p).to_bits(), b.at(p).to_bits());
    }
}

use std::path::Path;
use std::time::Instant;

use firn_mesh::{MeshTransform, SignedDistanceField, TriangleMesh, WindingNumber, load_mesh};
use glam::Vec3;
use rayon::prelude::*;

use crate::common::{BUNNY, Random, brute_force_winding, lattice};

/// The bunny moved to the origin and scaled so its largest side is `size`.
fn bunny(size: f32) -> TriangleMesh {
    let loaded = load_mesh(Path::new(BUNNY)).unwrap_or_else(|e| panic!("{e}"));
    let (lo, hi) = loaded.mesh.bounds();
    let scale = size / (hi - lo).max_element();
    let transform = MeshTransform {
        scale: Vec3::splat(scale),
        translation: -lo * scale,
        ..MeshTransform::IDENTITY
    };
    loaded.mesh.transformed(&transform)
}

#[test]
fn bunny_loads_with_its_holes_diagnosed() {
    let loaded = load_mesh(Path::new(BUNNY)).unwrap();
    assert_eq!(loaded.mesh.vertices.len(), 35_947);
    assert_eq!(loaded.mesh.triangles.len(), 69_451);
    let diagnostics = &loaded.diagnostics;
    assert!(diagnostics.boundary_edges > 0, "{diagnostics:?}");
    assert!(diagnostics.warnings()[0].contains("boundary edges (holes)"));
    eprintln!("bunny: {diagnostics:?}");
}

/// Inside points of the lattice as a flag per point.
fn fill(mesh: &TriangleMesh, points: &[Vec3]) -> Vec<bool> {
    let winding = WindingNumber::new(mesh);
    points.par_iter().map(|&p| winding.contains(p)).collect()
}

/// Number of 26-connected groups of inside lattice points.
fn connected_bodies(inside: &[bool], [nx, ny, nz]: [usize; 3]) -> usize {
    let mut seen = vec![false; inside.len()];
    let mut bodies = 0;
    let mut stack = Vec::new();
    for start in 0..inside.len() {
        if !inside[start] || seen[start] {
            continue;
        }
        bodies += 1;
        seen[start] = true;
        stack.push(start);
        while let Some(at) = stack.pop() {
            let (i, j, k) = (at % nx, at / nx % ny, at / (nx * ny));
            for dk in 0..3 {
                for dj in 0..3 {
                    for di in 0..3 {
                        let (x, y, z) = (
                            (i + di).wrapping_sub(1),
                            (j + dj).wrapping_sub(1),
                            (k + dk).wrapping_sub(1),
                        );
                        if x < nx && y < ny && z < nz {
                            let next = (z * ny + y) * nx + x;
                            if inside[next] && !seen[next] {
                                seen[next] = true;
                                stack.push(next);
                            }
                        }
                    }
                }
            }
        }
    }
    bodies
}

#[test]
fn bunny_fills_as_one_body_of_its_volume() {
    let mesh = bunny(1.0);
    let (lo, hi) = mesh.bounds();
    let spacing = 0.02;
    let (points, dims) = lattice(lo - 0.1, hi + 0.1, spacing);
    let inside = fill(&mesh, &points);
    let count = inside.iter().filter(|&&b| b).count();
    assert_eq!(connected_bodies(&inside, dims), 1);
    let within = |p: &Vec3| p.cmpge(lo).all() && p.cmple(hi).all();
    assert!(points.iter().zip(&inside).all(|(p, &b)| !b || within(p)));
    let volume = count as f64 * f64::from(spacing).powi(3);
    let reference = mesh.signed_volume().abs();
    assert!(
        (volume / reference - 1.0).abs() < 0.05,
        "fill {volume} vs mesh {reference}"
    );
    eprintln!("bunny fill: {count} points, {volume:.4} vs signed volume {reference:.4}");
}

#[test]
fn bunny_tree_approximation_agrees_with_the_exact_sum() {
    let mesh = bunny(1.0);
    let (lo, hi) = mesh.bounds();
    let winding = WindingNumber::new(&mesh);
    let mut random = Random(17);
    let points: Vec<Vec3> = (0..300).map(|_| random.point(lo - 0.2, hi + 0.2)).collect();
    let worst = points
        .par_iter()
        .map(|&p| (f64::from(winding.at(p)) - brute_force_winding(&mesh, p)).abs())
        .reduce(|| 0.0, f64::max);
    assert!(worst < 1e-2, "largest error {worst}");
}

/// The bunny at 0.3 m filled on a lattice with about 183,000 inside points
/// and on a 2 mm lattice, and its 3 mm distance field, timed; run with
/// `cargo test -p firn-mesh --release -- --ignored --nocapture`.
#[test]
#[ignore = "timing only"]
fn bunny_fill_timing() {
    let start = Instant::now();
    let mesh = bunny(0.3);
    eprintln!("bunny: loaded and transformed in {:.2?}", start.elapsed());
    let (lo, hi) = mesh.bounds();
    let for_183k = (mesh.signed_volume().abs() / 183_000.0).cbrt() as f32;
    for spacing in [for_183k, 0.002] {
        let start = Instant::now();
        let winding = WindingNumber::new(&mesh);
        let built = start.elapsed();
        let (points, _) = lattice(lo, hi, spacing);
        let inside = points.par_iter().filter(|&&p| winding.contains(p)).count();
        eprintln!(
            "bunny 0.3 m, spacing {:.2} mm: {} lattice points, {inside} inside, tree {built:.2?}, \
             total {:.2?} on {} threads",
            spacing * 1000.0,
            points.len(),
            start.elapsed(),
            rayon::current_num_threads()
        );
    }
    let start = Instant::now();
    let field = SignedDistanceField::build(&mesh, 0.003, 0.01);
    eprintln!(
        "bunny 0.3 m, distance field at 3 mm: {} MB in {:.2?}",
        field.byte_size() / 1_000_000,
        start.elapsed()
    );
}

use firn_mesh::{MeshDiagnostics, TriangleMesh};
use glam::Vec3;

use crate::common::cube;

#[test]
fn closed_cube_is_clean() {
    let diagnostics = MeshDiagnostics::of(&cube(0.0, 1.0));
    assert_eq!(
        diagnostics,
        MeshDiagnostics {
            components: 1,
            ..MeshDiagnostics::default()
        }
    );
    assert!(diagnostics.warnings().is_empty());
}

#[test]
fn a_missing_face_leaves_four_boundary_edges() {
    let mut open = cube(0.0, 1.0);
    open.triangles.drain(2..4);
    let diagnostics = MeshDiagnostics::of(&open);
    assert_eq!(diagnostics.boundary_edges, 4);
    assert_eq!(
        diagnostics.warnings(),
        [
            "the mesh has 4 boundary edges (holes); its inside is taken from its generalized \
             winding number, which closes small holes"
        ]
    );
}

#[test]
fn a_flipped_triangle_makes_three_inconsistent_edges() {
    let mut flipped = cube(0.0, 1.0);
    flipped.triangles[5].swap(1, 2);
    let diagnostics = MeshDiagnostics::of(&flipped);
    assert_eq!(diagnostics.inconsistently_oriented_edges, 3);
    assert_eq!(diagnostics.boundary_edges, 0);
    assert!(diagnostics.warnings()[0].contains("3 edges between triangles facing opposite ways"));
}

#[test]
fn fins_degenerate_triangles_and_parts_are_counted() {
    let mut mesh = cube(0.0, 1.0);
    let n = mesh.vertices.len() as u32;
    mesh.vertices.extend([
        Vec3::new(0.5, -1.0, -1.0),
        Vec3::splat(5.0),
        Vec3::splat(6.0),
        Vec3::splat(7.0),
    ]);
    mesh.triangles.push([0, 1, n]);
    mesh.triangles.push([n + 1, n + 2, n + 3]);
    let diagnostics = MeshDiagnostics::of(&mesh);
    assert_eq!(diagnostics.non_manifold_edges, 1);
    assert_eq!(diagnostics.boundary_edges, 2 + 3);
    assert_eq!(diagnostics.degenerate_triangles, 1);
    assert_eq!(diagnostics.components, 2);
    assert_eq!(diagnostics.warnings().len(), 4);
}

#[test]
fn empty_mesh_has_no_parts() {
    assert_eq!(
        MeshDiagnostics::of(&TriangleMesh::default()),
        MeshDiagnostics::default()
    );
}

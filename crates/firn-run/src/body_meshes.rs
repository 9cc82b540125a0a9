//! The rigid bodies as triangles, for the `mesh` cache: each frame's
//! bodies in one mesh beside the snow's surface, every body at its pose.
//! Spheres, cylinders and capsules are turned about their axis from a
//! profile (a sphere in [`RINGS`] rings, every round shape in [`SEGMENTS`]
//! segments), boxes are their twelve triangles, and a mesh body is its
//! file placed as at the start (read again each frame, as the USD stage
//! does; a file that no longer reads gives no triangles), turned by its
//! rotation less the one its placement carries.

use std::f32::consts::{FRAC_PI_2, PI, TAU};

use firn_core::Scene;
use firn_core::scene::ColliderGeometry;
use firn_io::BodyPose;
use firn_mesh::TriangleMesh;
use glam::{Quat, Vec3};

/// Segments around the axis of a round shape.
const SEGMENTS: u32 = 32;
/// Rings from pole to pole of a sphere (half as many per capsule end).
const RINGS: u32 = 16;

/// The rigid bodies of `scene` at `poses` (in scene order) as one mesh,
/// outward-facing triangles counter-clockwise seen from outside.
pub fn bodies_mesh(scene: &Scene, poses: &[BodyPose]) -> TriangleMesh {
    let mut all = TriangleMesh::default();
    for (body, pose) in scene.rigid_bodies.iter().zip(poses) {
        let turn = Quat::from_array(pose.rotation) * body.baked_rotation().inverse();
        let position = Vec3::from_array(pose.position);
        let local = shape_mesh(&body.geometry);
        let first = all.vertices.len() as u32;
        all.vertices
            .extend(local.vertices.iter().map(|&v| position + turn * v));
        all.triangles
            .extend(local.triangles.iter().map(|t| t.map(|i| i + first)));
    }
    all
}

/// The triangles of a body's shape about its reference point, in its own
/// frame.
fn shape_mesh(geometry: &ColliderGeometry) -> TriangleMesh {
    match *geometry {
        ColliderGeometry::Sphere { radius, .. } => lathe(&arc(radius, -FRAC_PI_2, FRAC_PI_2, 0.0)),
        ColliderGeometry::Box { size, .. } => cuboid(size),
        ColliderGeometry::Cylinder { radius, height, .. } => {
            let half = 0.5 * height;
            lathe(&[(0.0, -half), (radius, -half), (radius, half), (0.0, half)])
        }
        ColliderGeometry::Capsule { radius, height, .. } => {
            let half = 0.5 * height - radius;
            let mut profile = arc(radius, -FRAC_PI_2, 0.0, -half);
            profile.extend(arc(radius, 0.0, FRAC_PI_2, half));
            lathe(&profile)
        }
        ColliderGeometry::Mesh(ref mesh) => {
            let placed = mesh.placement.load().map(|placed| placed.mesh);
            let mut local = placed.unwrap_or_default();
            let centre = mesh.placement.center;
            local.vertices.iter_mut().for_each(|v| *v -= centre);
            local
        }
        // Bodies are never planes or deforming meshes.
        ColliderGeometry::HalfPlane { .. } | ColliderGeometry::MeshSequence(_) => {
            TriangleMesh::default()
        }
    }
}

/// A profile arc of radius `radius` from latitude `from` to `to` (radians,
/// −π/2 the bottom pole) about the point `centre` on the axis, as (distance
/// from the axis, height) pairs, in steps of a sphere's rings.
fn arc(radius: f32, from: f32, to: f32, centre: f32) -> Vec<(f32, f32)> {
    let steps = ((to - from) / PI * RINGS as f32).round().max(1.0) as u32;
    (0..=steps)
        .map(|step| {
            let latitude = from + (to - from) * step as f32 / steps as f32;
            let reach = radius * latitude.cos();
            // The poles lie on the axis exactly.
            let reach = if reach.abs() < 1e-6 * radius {
                0.0
            } else {
                reach
            };
            (reach, centre + radius * latitude.sin())
        })
        .collect()
}

/// The surface swept by turning `profile` (distance from the y axis,
/// height; from the bottom up) about the y axis in [`SEGMENTS`] steps. A
/// point on the axis becomes one vertex, the tip of a fan.
fn lathe(profile: &[(f32, f32)]) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    let rings: Vec<Vec<u32>> = profile
        .iter()
        .map(|&(reach, height)| {
            let first = mesh.vertices.len() as u32;
            let count = if reach == 0.0 { 1 } else { SEGMENTS };
            mesh.vertices.extend((0..count).map(|k| {
                let angle = TAU * k as f32 / SEGMENTS as f32;
                Vec3::new(reach * angle.cos(), height, reach * angle.sin())
            }));
            (first..first + count).collect()
        })
        .collect();
    for pair in rings.windows(2) {
        let (below, above) = (&pair[0], &pair[1]);
        let at = |ring: &Vec<u32>, k: u32| ring[k as usize % ring.len()];
        for k in 0..SEGMENTS {
            if below.len() > 1 {
                mesh.triangles
                    .push([at(below, k), at(above, k), at(below, k + 1)]);
            }
            if above.len() > 1 {
                mesh.triangles
                    .push([at(below, k + 1), at(above, k), at(above, k + 1)]);
            }
        }
    }
    mesh
}

/// A box of edges `size` about the origin: its eight corners (bit 0 the x
/// side, bit 1 y, bit 2 z) and two triangles a face.
fn cuboid(size: Vec3) -> TriangleMesh {
    let half = 0.5 * size;
    let vertices = (0..8)
        .map(|corner: u32| {
            let side = |bit: u32| if corner & bit == 0 { -1.0 } else { 1.0 };
            half * Vec3::new(side(1), side(2), side(4))
        })
        .collect();
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    TriangleMesh {
        vertices,
        triangles: faces
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_shape_is_closed_faces_out_and_holds_about_its_volume() {
        let (radius, height) = (0.2, 0.6);
        let cases = [
            (
                ColliderGeometry::Sphere {
                    center: Vec3::ZERO,
                    radius,
                },
                4.0 / 3.0 * PI * radius.powi(3),
            ),
            (
                ColliderGeometry::Box {
                    center: Vec3::ZERO,
                    size: Vec3::new(0.1, 0.2, 0.3),
                },
                0.006,
            ),
            (
                ColliderGeometry::Cylinder {
                    center: Vec3::ZERO,
                    radius,
                    height,
                },
                PI * radius * radius * height,
            ),
            (
                ColliderGeometry::Capsule {
                    center: Vec3::ZERO,
                    radius,
                    height,
                },
                PI * radius * radius * (height - 2.0 * radius) + 4.0 / 3.0 * PI * radius.powi(3),
            ),
        ];
        for (geometry, volume) in cases {
            let mesh = shape_mesh(&geometry);
            let diagnostics = firn_mesh::MeshDiagnostics::of(&mesh);
            let open = diagnostics.boundary_edges
                + diagnostics.non_manifold_edges
                + diagnostics.inconsistently_oriented_edges
                + diagnostics.degenerate_triangles;
            assert_eq!(open, 0, "{geometry:?} is not closed: {diagnostics:?}");
            // Positive: the triangles face out.
            let enclosed = mesh.signed_volume() as f32;
            assert!(
                (enclosed - volume).abs() < 0.02 * volume,
                "{geometry:?}: {enclosed} m³ for {volume}"
            );
        }
    }
}

//! firn's shapes as rapier colliders, in the frame of the body or collider
//! they belong to (its reference point at the origin).

use firn_core::scene::{ColliderGeometry, MeshSolid};
use glam::Quat;
use rapier3d::na::Unit;
use rapier3d::prelude::{ColliderBuilder, Vector};

use crate::convert::to_rapier;
use crate::world::RigidError;

/// The rapier collider of a solid of `geometry`, whose own frame is turned
/// by `rotation` from the geometry's (a mesh's vertices are placed in the
/// world; the others are already in their own frame). `mesh_as` says how a
/// mesh meets other solids. `None` for a shape rapier does not take here
/// (a deforming mesh: see docs/scene-format.md).
pub(crate) fn collider_shape(
    geometry: &ColliderGeometry,
    rotation: Quat,
    mesh_as: MeshAs,
) -> Result<Option<ColliderBuilder>, RigidError> {
    Ok(Some(match *geometry {
        ColliderGeometry::HalfPlane { normal, .. } => {
            ColliderBuilder::halfspace(Unit::new_unchecked(to_rapier(normal.normalize())))
        }
        ColliderGeometry::Sphere { radius, .. } => ColliderBuilder::ball(radius),
        ColliderGeometry::Box { size, .. } => {
            let half = 0.5 * size;
            ColliderBuilder::cuboid(half.x, half.y, half.z)
        }
        ColliderGeometry::Cylinder { radius, height, .. } => {
            ColliderBuilder::cylinder(0.5 * height, radius)
        }
        ColliderGeometry::Capsule { radius, height, .. } => {
            ColliderBuilder::capsule_y(0.5 * height - radius, radius)
        }
        ColliderGeometry::Mesh(ref mesh) => {
            let placed = mesh
                .placement
                .load()
                .map_err(|err| RigidError::Mesh(err.to_string()))?
                .mesh;
            let inverse = rotation.inverse();
            let center = mesh.placement.center;
            let local: Vec<Vector> = placed
                .vertices
                .iter()
                .map(|&v| to_rapier(inverse * (v - center)))
                .collect();
            mesh_collider(&local, &placed.triangles, mesh_as, &mesh.placement.file)?
        }
        ColliderGeometry::MeshSequence(_) => return Ok(None),
    }))
}

/// How rapier meets a mesh.
#[derive(Clone, Copy, Debug)]
pub(crate) enum MeshAs {
    /// A body's solid ([`MeshSolid`]).
    Body(MeshSolid),
    /// A collider's triangles, which only kinematic or fixed bodies may have.
    Triangles,
}

/// A mesh as rapier meets it: its convex hull, a convex decomposition, or
/// (for a collider that never moves under forces) the triangles themselves.
fn mesh_collider(
    vertices: &[Vector],
    triangles: &[[u32; 3]],
    mesh_as: MeshAs,
    file: &std::path::Path,
) -> Result<ColliderBuilder, RigidError> {
    let flat = || RigidError::Mesh(format!("{}: the mesh has no volume", file.display()));
    match mesh_as {
        MeshAs::Body(MeshSolid::Hull) => ColliderBuilder::convex_hull(vertices).ok_or_else(flat),
        MeshAs::Body(MeshSolid::Decomposition) => {
            Ok(ColliderBuilder::convex_decomposition(vertices, triangles))
        }
        MeshAs::Triangles => ColliderBuilder::trimesh(vertices.to_vec(), triangles.to_vec())
            .map_err(|err| RigidError::Mesh(format!("{}: {err}", file.display()))),
    }
}

//! What a run's USD stage says besides the particles: the points prims'
//! names and widths (the snow, or a flow's particles, and a spindrift
//! scene's drift), the frame rate, the colliders and the rigid bodies (see
//! [`firn_io::usd`]); each frame's collider samples are
//! [`usd_collider_samples`], its bodies' [`usd_body_samples`].
//!
//! Planes are drawn as squares as wide as the domain's longest edge; mesh
//! colliders as their file's triangles, placed as at time zero about the
//! centre of their bounding box (read again from the file each time the
//! stage is written, since the scene keeps only their distance field; a
//! file that no longer reads gives an empty mesh); a deforming mesh as its
//! triangles, its points those of each frame's time. Rigid bodies are
//! drawn as colliders of their shapes are, a mesh body as its file placed
//! with its starting rotation, which its orient then leaves out.

use firn_core::Scene;
use firn_core::scene::ColliderGeometry;
use firn_core::scene::sampling::particle_spacing;
use firn_io::{
    BodyPose, ColliderPose, UsdCollider, UsdColliderSample, UsdPoints, UsdShape, UsdStage,
};
use glam::Quat;

use crate::recording::collider_poses;

/// The stage of `scene` with frames up to `last_frame`.
pub fn usd_stage(scene: &Scene, last_frame: u32) -> UsdStage {
    let width = particle_width(scene);
    let mut points = vec![UsdPoints {
        name: points_name(scene).to_string(),
        width,
    }];
    if scene.spindrift().is_some() {
        points.push(UsdPoints {
            name: "Drift".to_string(),
            width,
        });
    }
    UsdStage {
        points,
        fps: scene.time.fps,
        last_frame,
        colliders: scene
            .colliders
            .iter()
            .map(|collider| UsdCollider {
                shape: usd_shape(&collider.geometry, plane_half_size(scene)),
                turns: collider.turns(),
            })
            .collect(),
        bodies: scene
            .rigid_bodies
            .iter()
            .map(|body| usd_shape(&body.geometry, plane_half_size(scene)))
            .collect(),
    }
}

/// Where each of `scene`'s rigid bodies at `poses` (in scene order) has
/// its shape: at its reference point, turned by its rotation less the one
/// a mesh body's placed points already carry.
pub fn usd_body_samples(scene: &Scene, poses: &[BodyPose]) -> Vec<ColliderPose> {
    scene
        .rigid_bodies
        .iter()
        .zip(poses)
        .map(|(body, pose)| {
            let turn = Quat::from_array(pose.rotation) * body.baked_rotation().inverse();
            ColliderPose {
                position: pose.position,
                rotation: turn.to_array(),
            }
        })
        .collect()
}

/// Each of `scene`'s colliders at `time`: its pose, and a deforming mesh's
/// points then, about its reference point.
pub fn usd_collider_samples(scene: &Scene, time: f64) -> Vec<UsdColliderSample> {
    scene
        .colliders
        .iter()
        .zip(collider_poses(scene, time))
        .map(|(collider, pose)| {
            let points = match &collider.geometry {
                ColliderGeometry::MeshSequence(sequence) => {
                    let centre = sequence.reference_point();
                    let mesh = sequence.mesh_at(time);
                    mesh.vertices.iter().map(|&v| v - centre).collect()
                }
                _ => Vec::new(),
            };
            UsdColliderSample { pose, points }
        })
        .collect()
}

/// `Snow` for a snow scene, `Particles` for a flow.
fn points_name(scene: &Scene) -> &'static str {
    if scene.kind.flow().is_some() {
        "Particles"
    } else {
        "Snow"
    }
}

/// A snow particle's lattice spacing (the finest body's), or half a grid
/// cell for flow particles.
fn particle_width(scene: &Scene) -> f32 {
    let cell_size = scene.domain.cell_size;
    if scene.kind.flow().is_some() {
        return 0.5 * cell_size;
    }
    scene
        .bodies
        .iter()
        .map(|body| particle_spacing(cell_size, body.particles_per_cell))
        .reduce(f32::min)
        .unwrap_or(0.5 * cell_size)
}

/// Half the edge of a plane's square: the domain's longest edge.
fn plane_half_size(scene: &Scene) -> f32 {
    (scene.domain.max - scene.domain.min).max_element()
}

/// The USD shape of a collider, about its reference point.
fn usd_shape(geometry: &ColliderGeometry, half_size: f32) -> UsdShape {
    match *geometry {
        ColliderGeometry::HalfPlane { normal, .. } => UsdShape::Plane { normal, half_size },
        ColliderGeometry::Sphere { radius, .. } => UsdShape::Sphere { radius },
        ColliderGeometry::Box { size, .. } => UsdShape::Box { size },
        ColliderGeometry::Cylinder { radius, height, .. } => UsdShape::Cylinder { radius, height },
        ColliderGeometry::Capsule { radius, height, .. } => UsdShape::Capsule { radius, height },
        ColliderGeometry::Mesh(ref mesh) => {
            let placed = mesh.placement.load().map(|placed| placed.mesh);
            let placed = placed.unwrap_or_default();
            let centre = mesh.placement.center;
            UsdShape::Mesh {
                points: placed.vertices.iter().map(|&v| v - centre).collect(),
                triangles: placed.triangles,
            }
        }
        ColliderGeometry::MeshSequence(ref sequence) => UsdShape::DeformingMesh {
            triangles: sequence.frames.get().triangles.clone(),
        },
    }
}

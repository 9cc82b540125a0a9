//! What a run's USD stage says besides the particles: the points prim's
//! name and width, the frame rate and the colliders (see [`firn_io::usd`]).
//!
//! Planes are drawn as squares as wide as the domain's longest edge; mesh
//! colliders are left out (their triangles stay in their own file).

use firn_core::Scene;
use firn_core::scene::ColliderGeometry;
use firn_core::scene::sampling::particle_spacing;
use firn_io::{UsdShape, UsdStage};
use glam::Vec3;

/// The stage of `scene` with frames up to `last_frame`.
pub fn usd_stage(scene: &Scene, last_frame: u32) -> UsdStage {
    UsdStage {
        points_name: points_name(scene).to_string(),
        fps: scene.time.fps,
        last_frame,
        width: particle_width(scene),
        colliders: scene
            .colliders
            .iter()
            .filter_map(|collider| usd_shape(&collider.geometry, plane_half_size(scene)))
            .collect(),
    }
}

/// The reference points at `time` of the colliders that [`usd_stage`] draws.
pub fn collider_positions(scene: &Scene, time: f64) -> Vec<Vec3> {
    scene
        .colliders
        .iter()
        .filter(|collider| !matches!(collider.geometry, ColliderGeometry::Mesh(_)))
        .map(|collider| {
            let start = collider.geometry.reference_point();
            collider.motion.state_at(start, time).0
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
fn usd_shape(geometry: &ColliderGeometry, half_size: f32) -> Option<UsdShape> {
    match *geometry {
        ColliderGeometry::HalfPlane { normal, .. } => Some(UsdShape::Plane { normal, half_size }),
        ColliderGeometry::Sphere { radius, .. } => Some(UsdShape::Sphere { radius }),
        ColliderGeometry::Box { size, .. } => Some(UsdShape::Box { size }),
        ColliderGeometry::Mesh(_) => None,
    }
}

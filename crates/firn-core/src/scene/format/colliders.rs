//! Reads and checks the `[[colliders]]` tables: what the snow meets, and how it moves.

use serde::Deserialize;

use super::domain::{RawContact, RawMode, check_contact, contact};
use super::issue::{Check, Issue, KeyPath};
use super::shapes::{
    RawScale, check_ball, check_box, check_mesh_placement, check_sdf_size, check_sdf_spacing,
    mesh_issue, mesh_placement,
};
use super::values::{
    Num, ensure, finite_vec, missing, reject, require, unit_or_zero, unit_vec, vec3,
};
use crate::scene::mesh::MeshCollider;
use crate::scene::model::{Collider, ColliderGeometry, Domain, Keyframe, Motion};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCollider {
    shape: Option<RawColliderShape>,
    point: Option<[f32; 3]>,
    normal: Option<[f32; 3]>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    mode: Option<RawMode>,
    friction: Option<f32>,
    velocity: Option<[f32; 3]>,
    keyframes: Option<Vec<RawKeyframe>>,
    mesh: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    sdf_spacing: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawColliderShape {
    Plane,
    Sphere,
    Box,
    Mesh,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeyframe {
    time: Option<f64>,
    position: Option<[f32; 3]>,
}

fn collider_shape_name(shape: RawColliderShape) -> &'static str {
    match shape {
        RawColliderShape::Plane => "plane",
        RawColliderShape::Sphere => "sphere",
        RawColliderShape::Box => "box",
        RawColliderShape::Mesh => "mesh",
    }
}

/// Every `[[colliders]]` table; a mesh collider's default sample spacing
/// comes from `domain`.
pub(super) fn resolve_colliders(
    raw: Vec<RawCollider>,
    origin: &str,
    domain: &Domain,
) -> Result<Vec<Collider>, Issue> {
    let mut colliders = Vec::new();
    for (index, raw_collider) in raw.into_iter().enumerate() {
        let path = KeyPath::of("colliders").index(index);
        colliders.push(resolve_collider(&path, raw_collider, origin, domain)?);
    }
    Ok(colliders)
}

fn resolve_collider(
    path: &KeyPath,
    raw: RawCollider,
    origin: &str,
    domain: &Domain,
) -> Result<Collider, Issue> {
    let shape = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the collider's shape")
            .with_hint("add shape = \"plane\", \"sphere\", \"box\" or \"mesh\" with its dimensions")
    })?;
    if !matches!(shape, RawColliderShape::Mesh) {
        let name = collider_shape_name(shape);
        let takes = "mesh, scale, rotation, center and sdf_spacing";
        reject(&raw.mesh, path.key("mesh"), name, takes)?;
        reject(&raw.scale, path.key("scale"), name, takes)?;
        reject(&raw.rotation, path.key("rotation"), name, takes)?;
        reject(&raw.sdf_spacing, path.key("sdf_spacing"), name, takes)?;
    }
    let geometry = match shape {
        RawColliderShape::Mesh => {
            let takes = "mesh, scale, rotation, center and sdf_spacing";
            reject(&raw.point, path.key("point"), "mesh", takes)?;
            reject(&raw.normal, path.key("normal"), "mesh", takes)?;
            reject(&raw.radius, path.key("radius"), "mesh", takes)?;
            reject(&raw.size, path.key("size"), "mesh", takes)?;
            let center = vec3(require(raw.center, path.key("center"), "the centre")?);
            let placement =
                mesh_placement(path, raw.mesh, raw.scale, raw.rotation, center, origin)?;
            let spacing = raw.sdf_spacing.unwrap_or(0.5 * domain.cell_size);
            check_sdf_spacing(path, spacing)?;
            let placed = placement.load().map_err(|err| mesh_issue(path, &err))?;
            check_sdf_size(path, placed.mesh.bounds(), spacing)?;
            ColliderGeometry::Mesh(Box::new(MeshCollider::from_placed(
                placement, placed, spacing,
            )))
        }
        RawColliderShape::Plane => {
            let takes = "point and normal";
            reject(&raw.center, path.key("center"), "plane", takes)?;
            reject(&raw.radius, path.key("radius"), "plane", takes)?;
            reject(&raw.size, path.key("size"), "plane", takes)?;
            ColliderGeometry::HalfPlane {
                point: vec3(require(
                    raw.point,
                    path.key("point"),
                    "a point on the plane",
                )?),
                normal: unit_or_zero(require(
                    raw.normal,
                    path.key("normal"),
                    "the normal pointing into the free side",
                )?),
            }
        }
        RawColliderShape::Sphere => {
            let takes = "center and radius";
            reject(&raw.point, path.key("point"), "sphere", takes)?;
            reject(&raw.normal, path.key("normal"), "sphere", takes)?;
            reject(&raw.size, path.key("size"), "sphere", takes)?;
            ColliderGeometry::Sphere {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
            }
        }
        RawColliderShape::Box => {
            let takes = "center and size";
            reject(&raw.point, path.key("point"), "box", takes)?;
            reject(&raw.normal, path.key("normal"), "box", takes)?;
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            ColliderGeometry::Box {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
    };
    let motion = match (raw.velocity, raw.keyframes) {
        (Some(_), Some(_)) => {
            return Err(Issue::new(
                path.key("keyframes"),
                format!("{path} has both velocity and keyframes"),
                "a collider moves either with a constant velocity or through keyframes; \
                 remove one of the two",
            ));
        }
        (Some(velocity), None) => Motion::Linear {
            velocity: vec3(velocity),
        },
        (None, Some(raw_keys)) => {
            let mut keys = Vec::with_capacity(raw_keys.len());
            for (index, key) in raw_keys.into_iter().enumerate() {
                let key_path = path.key("keyframes").index(index);
                keys.push(Keyframe {
                    time: require(key.time, key_path.key("time"), "the key's time in seconds")?,
                    position: vec3(require(
                        key.position,
                        key_path.key("position"),
                        "where the collider's reference point is at that time",
                    )?),
                });
            }
            Motion::Keyframed { keys }
        }
        (None, None) => Motion::Static,
    };
    Ok(Collider {
        motion,
        contact: contact(Some(RawContact {
            mode: raw.mode,
            friction: raw.friction,
        })),
        ..Collider::new(geometry)
    })
}

pub(super) fn check_collider(path: &KeyPath, collider: &Collider) -> Check {
    match collider.geometry {
        ColliderGeometry::HalfPlane { point, normal } => {
            finite_vec(point, path.key("point"))?;
            unit_vec(normal, path.key("normal"))?;
        }
        ColliderGeometry::Sphere { center, radius } => {
            check_ball(path, center, radius)?;
        }
        ColliderGeometry::Box { center, size } => {
            check_box(path, center, size)?;
        }
        ColliderGeometry::Mesh(ref mesh) => {
            check_mesh_placement(path, &mesh.placement)?;
            check_sdf_spacing(path, mesh.sdf_spacing)?;
        }
    }
    check_contact(path, &collider.contact)?;
    match &collider.motion {
        Motion::Static => {}
        Motion::Linear { velocity } => finite_vec(*velocity, path.key("velocity"))?,
        Motion::Keyframed { keys } => {
            let keys_path = path.key("keyframes");
            if keys.len() < 2 {
                return Err(Issue::new(
                    keys_path.clone(),
                    format!("{keys_path} needs at least 2 keys (got {})", keys.len()),
                    "give at least a start and an end key, e.g. keyframes = [{ time = 0.0, \
                     position = [1.0, 0.5, 1.0] }, { time = 1.0, position = [1.0, 1.5, 1.0] }]",
                ));
            }
            for (index, key) in keys.iter().enumerate() {
                let key_path = keys_path.index(index);
                ensure(
                    key.time.is_finite(),
                    key_path.key("time"),
                    "finite",
                    Num(key.time),
                    "give the key's time in seconds, e.g. time = 0.5".to_string(),
                )?;
                finite_vec(key.position, key_path.key("position"))?;
                if index > 0 && key.time <= keys[index - 1].time {
                    let time_path = key_path.key("time");
                    return Err(Issue::new(
                        time_path.clone(),
                        format!(
                            "{time_path} must be later than the key before it ({} <= {})",
                            Num(key.time),
                            Num(keys[index - 1].time)
                        ),
                        "list keyframes in strictly increasing time order",
                    ));
                }
            }
        }
    }
    Ok(())
}

//! Reads and checks the `[[colliders]]` tables: what the snow meets, and how it moves.

use serde::Deserialize;

use super::domain::{RawContact, RawMode, check_contact, contact};
use super::issue::{Check, Issue, KeyPath};
use super::shapes::{
    RawScale, check_ball, check_box, check_capsule, check_cylinder, check_mesh_placement,
    check_sdf_size, check_sdf_spacing, mesh_issue, mesh_placement,
};
use super::values::{
    Num, ensure, finite_vec, missing, reject, require, unit_or_zero, unit_vec, vec3,
};
use crate::scene::mesh::{MAX_SDF_SAMPLES, MeshCollider};
use crate::scene::mesh_sequence::MeshSequenceCollider;
use crate::scene::model::{Collider, ColliderGeometry, Domain, TimeSettings};
use crate::scene::motion::{Keyframe, Motion, PathShape, rotation_from_degrees};
use glam::Quat;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCollider {
    shape: Option<RawColliderShape>,
    point: Option<[f32; 3]>,
    normal: Option<[f32; 3]>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    height: Option<f32>,
    mode: Option<RawMode>,
    friction: Option<f32>,
    velocity: Option<[f32; 3]>,
    angular_velocity: Option<[f32; 3]>,
    keyframes: Option<Vec<RawKeyframe>>,
    path: Option<PathShape>,
    mesh: Option<String>,
    sequence: Option<String>,
    frame_rate: Option<f64>,
    start: Option<f64>,
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
    Cylinder,
    Capsule,
    Mesh,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKeyframe {
    time: Option<f64>,
    position: Option<[f32; 3]>,
    rotation: Option<[f32; 3]>,
    quaternion: Option<[f32; 4]>,
}

fn collider_shape_name(shape: RawColliderShape) -> &'static str {
    match shape {
        RawColliderShape::Plane => "plane",
        RawColliderShape::Sphere => "sphere",
        RawColliderShape::Box => "box",
        RawColliderShape::Cylinder => "cylinder",
        RawColliderShape::Capsule => "capsule",
        RawColliderShape::Mesh => "mesh",
    }
}

/// Every `[[colliders]]` table; a mesh collider's default sample spacing
/// comes from `domain`, a mesh sequence's default frame rate from `time`.
pub(super) fn resolve_colliders(
    raw: Vec<RawCollider>,
    origin: &str,
    domain: &Domain,
    time: &TimeSettings,
) -> Result<Vec<Collider>, Issue> {
    let mut colliders = Vec::new();
    for (index, raw_collider) in raw.into_iter().enumerate() {
        let path = KeyPath::of("colliders").index(index);
        colliders.push(resolve_collider(&path, raw_collider, origin, domain, time)?);
    }
    Ok(colliders)
}

fn resolve_collider(
    path: &KeyPath,
    raw: RawCollider,
    origin: &str,
    domain: &Domain,
    time: &TimeSettings,
) -> Result<Collider, Issue> {
    let shape = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the collider's shape").with_hint(
            "add shape = \"plane\", \"sphere\", \"box\", \"cylinder\", \"capsule\" or \"mesh\" \
                 with its dimensions",
        )
    })?;
    if raw.sequence.is_some() && matches!(shape, RawColliderShape::Mesh) {
        return resolve_sequence(path, raw, origin, domain, time);
    }
    let takes = "sequence (with shape = \"mesh\")";
    reject(
        &raw.frame_rate,
        path.key("frame_rate"),
        "this collider",
        takes,
    )?;
    reject(&raw.start, path.key("start"), "this collider", takes)?;
    if !matches!(shape, RawColliderShape::Mesh) {
        let name = collider_shape_name(shape);
        let takes = "mesh, scale, center and sdf_spacing";
        reject(&raw.mesh, path.key("mesh"), name, takes)?;
        reject(&raw.sequence, path.key("sequence"), name, takes)?;
        reject(&raw.scale, path.key("scale"), name, takes)?;
        reject(&raw.sdf_spacing, path.key("sdf_spacing"), name, takes)?;
    }
    if !matches!(
        shape,
        RawColliderShape::Cylinder | RawColliderShape::Capsule
    ) {
        let name = collider_shape_name(shape);
        reject(
            &raw.height,
            path.key("height"),
            name,
            "center, radius and height",
        )?;
    }
    let geometry = match shape {
        RawColliderShape::Mesh => {
            let takes = "mesh, scale, rotation, center and sdf_spacing";
            reject(&raw.point, path.key("point"), "mesh", takes)?;
            reject(&raw.normal, path.key("normal"), "mesh", takes)?;
            reject(&raw.height, path.key("height"), "mesh", takes)?;
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
            reject(&raw.height, path.key("height"), "plane", takes)?;
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
            reject(&raw.height, path.key("height"), "sphere", takes)?;
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
            reject(&raw.height, path.key("height"), "box", takes)?;
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            ColliderGeometry::Box {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
        RawColliderShape::Cylinder => {
            let takes = "center, radius and height (its axis is y, turned by rotation)";
            reject(&raw.point, path.key("point"), "cylinder", takes)?;
            reject(&raw.normal, path.key("normal"), "cylinder", takes)?;
            reject(&raw.size, path.key("size"), "cylinder", takes)?;
            ColliderGeometry::Cylinder {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
                height: require(raw.height, path.key("height"), "the length along its axis")?,
            }
        }
        RawColliderShape::Capsule => {
            let takes = "center, radius and height (its axis is y, turned by rotation; height is \
                         the whole length, end to end)";
            reject(&raw.point, path.key("point"), "capsule", takes)?;
            reject(&raw.normal, path.key("normal"), "capsule", takes)?;
            reject(&raw.size, path.key("size"), "capsule", takes)?;
            ColliderGeometry::Capsule {
                center: vec3(require(raw.center, path.key("center"), "the centre")?),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
                height: require(
                    raw.height,
                    path.key("height"),
                    "the whole length along its axis, end to end",
                )?,
            }
        }
    };
    // A mesh's rotation places its vertices (its field is sampled so);
    // every other shape turns about its reference point.
    let rotation = match shape {
        RawColliderShape::Mesh => Quat::IDENTITY,
        _ => raw.rotation.map_or(Quat::IDENTITY, |degrees| {
            rotation_from_degrees(vec3(degrees))
        }),
    };
    let motion = resolve_motion(
        path,
        raw.velocity,
        raw.angular_velocity,
        raw.keyframes,
        raw.path,
        rotation,
    )?;
    Ok(Collider {
        motion,
        contact: contact(Some(RawContact {
            mode: raw.mode,
            friction: raw.friction,
        })),
        rotation,
        ..Collider::new(geometry)
    })
}

/// A deforming mesh collider: `sequence = "boot/frame_####.obj"`, its
/// `frame_rate` (the scene's fps unless given) and `start` time, placed by
/// `scale`, `rotation` and optionally `center`; it moves by its files only.
fn resolve_sequence(
    path: &KeyPath,
    raw: RawCollider,
    origin: &str,
    domain: &Domain,
    time: &TimeSettings,
) -> Result<Collider, Issue> {
    let takes = "sequence, frame_rate, start, scale, rotation, center and sdf_spacing";
    reject(&raw.mesh, path.key("mesh"), "a mesh sequence", takes)?;
    reject(&raw.point, path.key("point"), "a mesh sequence", takes)?;
    reject(&raw.normal, path.key("normal"), "a mesh sequence", takes)?;
    reject(&raw.radius, path.key("radius"), "a mesh sequence", takes)?;
    reject(&raw.size, path.key("size"), "a mesh sequence", takes)?;
    reject(&raw.height, path.key("height"), "a mesh sequence", takes)?;
    let moves = "a mesh sequence (it moves by its files: animate the mesh you export instead)";
    reject(&raw.velocity, path.key("velocity"), moves, takes)?;
    reject(
        &raw.angular_velocity,
        path.key("angular_velocity"),
        moves,
        takes,
    )?;
    reject(&raw.keyframes, path.key("keyframes"), moves, takes)?;
    reject(&raw.path, path.key("path"), moves, takes)?;
    let pattern = raw.sequence.unwrap_or_default();
    let center = raw.center.map(vec3);
    let placement = mesh_placement(
        path,
        Some(pattern),
        raw.scale,
        raw.rotation,
        center.unwrap_or_default(),
        origin,
    )?;
    let frame_rate = raw.frame_rate.unwrap_or(time.fps);
    ensure(
        frame_rate.is_finite() && frame_rate > 0.0,
        path.key("frame_rate"),
        "positive",
        Num(frame_rate),
        "give the mesh files per second, e.g. frame_rate = 24, or remove it to use the \
         scene's fps"
            .to_string(),
    )?;
    let start = raw.start.unwrap_or(0.0);
    ensure(
        start.is_finite(),
        path.key("start"),
        "finite",
        Num(start),
        "give the time of the first file in seconds, e.g. start = 0.0".to_string(),
    )?;
    let spacing = raw.sdf_spacing.unwrap_or(0.5 * domain.cell_size);
    check_sdf_spacing(path, spacing)?;
    let band = MeshSequenceCollider::band_for(domain.cell_size, spacing);
    // The pattern names no file; its folder is made canonical instead.
    let pattern = match (placement.file.parent(), placement.file.file_name()) {
        (Some(folder), Some(name)) => std::fs::canonicalize(folder)
            .map_or_else(|_| placement.file.clone(), |folder| folder.join(name)),
        _ => placement.file.clone(),
    };
    let sequence = MeshSequenceCollider::load(
        pattern,
        (placement.scale, placement.rotation_degrees, center),
        (frame_rate, start),
        spacing,
        band,
    )
    .map_err(|err| sequence_issue(path, &err))?;
    check_band_size(path, &sequence)?;
    Ok(Collider {
        contact: contact(Some(RawContact {
            mode: raw.mode,
            friction: raw.friction,
        })),
        ..Collider::new(ColliderGeometry::MeshSequence(Box::new(sequence)))
    })
}

/// A sequence's loading error at its `sequence` key.
fn sequence_issue(path: &KeyPath, err: &firn_mesh::MeshError) -> Issue {
    let location = match err.line {
        Some(line) => format!("{}:{line}", err.path.display()),
        None => err.path.display().to_string(),
    };
    Issue::new(
        path.key("sequence"),
        format!(
            "{path}.sequence cannot be used: {location}: {}",
            err.message
        ),
        err.hint.clone(),
    )
}

/// Every frame's band must stay under [`MAX_SDF_SAMPLES`].
fn check_band_size(path: &KeyPath, sequence: &MeshSequenceCollider) -> Check {
    let (largest, _) = sequence.footprint();
    ensure(
        largest.samples() <= MAX_SDF_SAMPLES,
        path.key("sdf_spacing"),
        &format!("coarse enough for at most {MAX_SDF_SAMPLES} distance samples per mesh frame"),
        format!("{} samples", largest.samples()),
        "raise sdf_spacing, or scale the mesh down".to_string(),
    )
}

/// The motion of a collider from its `velocity` and `angular_velocity`
/// or its `keyframes` (whose keys without a rotation take `rotation`) and
/// `path`.
fn resolve_motion(
    path: &KeyPath,
    velocity: Option<[f32; 3]>,
    angular_velocity: Option<[f32; 3]>,
    keyframes: Option<Vec<RawKeyframe>>,
    shape: Option<PathShape>,
    rotation: Quat,
) -> Result<Motion, Issue> {
    let Some(raw_keys) = keyframes else {
        reject(
            &shape,
            path.key("path"),
            "a collider without keyframes",
            "keyframes",
        )?;
        return Ok(match (velocity, angular_velocity) {
            (None, None) => Motion::Static,
            (velocity, angular_velocity) => Motion::Linear {
                velocity: vec3(velocity.unwrap_or_default()),
                angular_velocity: vec3(angular_velocity.unwrap_or_default()),
            },
        });
    };
    for (given, key) in [
        (velocity, "velocity"),
        (angular_velocity, "angular_velocity"),
    ] {
        if given.is_some() {
            return Err(Issue::new(
                path.key("keyframes"),
                format!("{path} has both {key} and keyframes"),
                "a collider moves either with a constant velocity and angular velocity or \
                 through keyframes; remove one of the two",
            ));
        }
    }
    let mut keys = Vec::with_capacity(raw_keys.len());
    for (index, key) in raw_keys.into_iter().enumerate() {
        let key_path = path.key("keyframes").index(index);
        if key.rotation.is_some() && key.quaternion.is_some() {
            return Err(Issue::new(
                key_path.key("quaternion"),
                format!("{key_path} has both rotation and quaternion"),
                "give the key's orientation once: rotation = [x, y, z] in degrees, or \
                 quaternion = [x, y, z, w]",
            ));
        }
        let key_rotation = match (key.rotation, key.quaternion) {
            (Some(degrees), _) => rotation_from_degrees(vec3(degrees)),
            (_, Some([x, y, z, w])) => Quat::from_xyzw(x, y, z, w).normalize(),
            (None, None) => rotation,
        };
        keys.push(Keyframe {
            time: require(key.time, key_path.key("time"), "the key's time in seconds")?,
            position: vec3(require(
                key.position,
                key_path.key("position"),
                "where the collider's reference point is at that time",
            )?),
            rotation: key_rotation,
        });
    }
    Ok(Motion::Keyframed {
        keys,
        path: shape.unwrap_or_default(),
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
        ColliderGeometry::Cylinder {
            center,
            radius,
            height,
        } => {
            check_cylinder(path, center, radius, height)?;
        }
        ColliderGeometry::Capsule {
            center,
            radius,
            height,
        } => {
            check_capsule(path, center, radius, height)?;
        }
        ColliderGeometry::Mesh(ref mesh) => {
            check_mesh_placement(path, &mesh.placement)?;
            check_sdf_spacing(path, mesh.sdf_spacing)?;
        }
        ColliderGeometry::MeshSequence(ref sequence) => {
            check_sdf_spacing(path, sequence.sdf_spacing)?;
        }
    }
    check_contact(path, &collider.contact)?;
    check_rotation(collider.rotation, path.key("rotation"))?;
    match &collider.motion {
        Motion::Static => {}
        Motion::Linear {
            velocity,
            angular_velocity,
        } => {
            finite_vec(*velocity, path.key("velocity"))?;
            finite_vec(*angular_velocity, path.key("angular_velocity"))?;
        }
        Motion::Keyframed { keys, .. } => {
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
                check_rotation(key.rotation, key_path.key("rotation"))?;
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

/// A finite orientation: NaN or infinite angles, or a zero quaternion,
/// leave none.
fn check_rotation(rotation: Quat, path: KeyPath) -> Check {
    ensure(
        rotation.is_finite(),
        path,
        "finite",
        format!("{rotation:?}"),
        "give finite angles in degrees, e.g. rotation = [0.0, 90.0, 0.0], or a non-zero \
         quaternion = [x, y, z, w]"
            .to_string(),
    )
}

/// A turning collider whose rim (its farthest point from the reference
/// point) would cross more than a cell per substep unless a frame took
/// more substeps than `time.max_substeps_per_frame` allows: the contact
/// needs the collider to move at most about a cell per substep.
pub(super) fn check_turning_speed(
    path: &KeyPath,
    collider: &Collider,
    domain: &Domain,
    time: &TimeSettings,
) -> Check {
    let Motion::Linear {
        angular_velocity, ..
    } = collider.motion
    else {
        return Ok(());
    };
    let reach = collider
        .geometry
        .reach()
        .min((domain.max - domain.min).length());
    let rim_speed = angular_velocity.length() * reach;
    let needed = f64::from(rim_speed / domain.cell_size) / time.fps;
    let limit = f64::from(time.max_substeps_per_frame);
    let key = path.key("angular_velocity");
    ensure(
        needed <= limit,
        key.clone(),
        "slow enough for the substeps a frame may take",
        format!(
            "{:.3} rad/s, a rim speed of {rim_speed:.3} m/s: one cell (h = {} m) per substep \
             needs {needed:.0} substeps a frame, more than time.max_substeps_per_frame = {limit}",
            angular_velocity.length(),
            domain.cell_size
        ),
        format!(
            "lower {key}, or raise [time] max_substeps_per_frame if the frames really need that \
             many substeps"
        ),
    )
}

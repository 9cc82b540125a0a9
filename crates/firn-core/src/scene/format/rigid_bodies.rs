//! Reads and checks the `[[rigid_bodies]]` tables: solids the snow pushes,
//! and that push the snow.

use glam::{DVec3, EulerRot, Quat, Vec3};
use serde::Deserialize;

use super::domain::{RawContact, RawMode, check_contact, contact_over};
use super::issue::{Check, Issue, KeyPath};
use super::rigid_body_overlap::{check_overlaps, surface_points};
use super::shapes::{
    RawScale, check_ball, check_box, check_capsule, check_cylinder, check_mesh_placement,
    check_sdf_size, check_sdf_spacing, mesh_issue, mesh_placement,
};
use super::values::{Num, ensure, finite_vec, missing, positive, reject, require, vec3};
use crate::scene::mesh::{MeshCollider, MeshPlacement};
use crate::scene::model::{ColliderGeometry, Domain, Integrator, Scene};
use crate::scene::motion::rotation_from_degrees;
use crate::scene::rigid_body::{BodyMass, MeshSolid, RigidBody};

/// Largest number of rigid bodies a scene may have: the checks at the
/// start and the solids' contacts stay bounded.
pub const MAX_RIGID_BODIES: usize = 10_000;

/// A mesh body must enclose more than this share of its bounding box.
const EMPTY_SHARE: f64 = 1e-6;

/// Most vertices of a mesh body tested against the other solids at the start.
const MAX_VERTEX_SAMPLES: usize = 4096;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRigidBody {
    shape: Option<RawBodyShape>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    height: Option<f32>,
    mesh: Option<String>,
    scale: Option<RawScale>,
    sdf_spacing: Option<f32>,
    solid: Option<RawSolid>,
    rotation: Option<[f32; 3]>,
    quaternion: Option<[f32; 4]>,
    density: Option<f32>,
    mass: Option<f32>,
    velocity: Option<[f32; 3]>,
    angular_velocity: Option<[f32; 3]>,
    mode: Option<RawMode>,
    friction: Option<f32>,
    restitution: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawBodyShape {
    Sphere,
    Box,
    Cylinder,
    Capsule,
    Mesh,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawSolid {
    Hull,
    Decomposition,
}

fn shape_name(shape: RawBodyShape) -> &'static str {
    match shape {
        RawBodyShape::Sphere => "sphere",
        RawBodyShape::Box => "box",
        RawBodyShape::Cylinder => "cylinder",
        RawBodyShape::Capsule => "capsule",
        RawBodyShape::Mesh => "mesh",
    }
}

/// The keys that give a shape's size, for messages.
fn shape_keys(shape: RawBodyShape) -> &'static str {
    match shape {
        RawBodyShape::Sphere => "center and radius",
        RawBodyShape::Box => "center and size",
        RawBodyShape::Cylinder => "center, radius and height (its axis is y, turned by rotation)",
        RawBodyShape::Capsule => {
            "center, radius and height (its axis is y, turned by rotation; height is the whole \
             length, end to end)"
        }
        RawBodyShape::Mesh => "mesh, scale, center, sdf_spacing and solid",
    }
}

/// Every `[[rigid_bodies]]` table; a mesh body's default sample spacing
/// comes from `domain`.
pub(super) fn resolve_rigid_bodies(
    raw: Vec<RawRigidBody>,
    origin: &str,
    domain: &Domain,
) -> Result<Vec<RigidBody>, Issue> {
    check_count(raw.len())?;
    let mut bodies = Vec::with_capacity(raw.len());
    for (index, raw_body) in raw.into_iter().enumerate() {
        let path = KeyPath::of("rigid_bodies").index(index);
        bodies.push(resolve_rigid_body(&path, raw_body, origin, domain)?);
    }
    Ok(bodies)
}

fn resolve_rigid_body(
    path: &KeyPath,
    mut raw: RawRigidBody,
    origin: &str,
    domain: &Domain,
) -> Result<RigidBody, Issue> {
    let shape = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the body's shape").with_hint(
            "add shape = \"sphere\", \"box\", \"cylinder\", \"capsule\" or \"mesh\" with its \
             dimensions",
        )
    })?;
    reject_other_keys(path, shape, &raw)?;
    reject_both(path, &raw)?;
    let quaternion = resolve_quaternion(path, raw.quaternion)?;
    let geometry = resolve_geometry(path, shape, &mut raw, quaternion, origin, domain)?;
    let rotation = match &geometry {
        // The placement's rotation, which its field was sampled with.
        ColliderGeometry::Mesh(mesh) => mesh.placement.rotation(),
        _ => match (raw.rotation, quaternion) {
            (Some(degrees), _) => rotation_from_degrees(vec3(degrees)),
            (None, Some(quaternion)) => quaternion,
            (None, None) => Quat::IDENTITY,
        },
    };
    let defaults = RigidBody::new(geometry);
    Ok(RigidBody {
        solid: match raw.solid {
            Some(RawSolid::Hull) => MeshSolid::Hull,
            Some(RawSolid::Decomposition) => MeshSolid::Decomposition,
            None => defaults.solid,
        },
        rotation,
        mass: match (raw.density, raw.mass) {
            (_, Some(mass)) => BodyMass::Mass(mass),
            (Some(density), None) => BodyMass::Density(density),
            (None, None) => defaults.mass,
        },
        velocity: raw.velocity.map_or(defaults.velocity, vec3),
        angular_velocity: raw.angular_velocity.map_or(defaults.angular_velocity, vec3),
        contact: contact_over(
            Some(RawContact {
                mode: raw.mode,
                friction: raw.friction,
            }),
            RigidBody::default_contact(),
        ),
        restitution: raw.restitution.unwrap_or(defaults.restitution),
        ..defaults
    })
}

/// `rotation` and `quaternion`, or `density` and `mass`, given together.
fn reject_both(path: &KeyPath, raw: &RawRigidBody) -> Check {
    for (given, key, other, hint) in [
        (
            raw.rotation.is_some() && raw.quaternion.is_some(),
            "quaternion",
            "rotation",
            "give the body's orientation once: rotation = [x, y, z] in degrees, or quaternion \
             = [x, y, z, w]",
        ),
        (
            raw.density.is_some() && raw.mass.is_some(),
            "mass",
            "density",
            "give the body's density in kg/m³ or its mass in kg, not both",
        ),
    ] {
        if given {
            return Err(Issue::new(
                path.key(key),
                format!("{path} has both {other} and {key}"),
                hint,
            ));
        }
    }
    Ok(())
}

/// The shape, in the body's own frame (a mesh placed with its rotation).
fn resolve_geometry(
    path: &KeyPath,
    shape: RawBodyShape,
    raw: &mut RawRigidBody,
    quaternion: Option<Quat>,
    origin: &str,
    domain: &Domain,
) -> Result<ColliderGeometry, Issue> {
    let center = vec3(require(raw.center, path.key("center"), "the centre")?);
    let radius = || require(raw.radius, path.key("radius"), "the radius in metres");
    Ok(match shape {
        RawBodyShape::Sphere => ColliderGeometry::Sphere {
            center,
            radius: radius()?,
        },
        RawBodyShape::Box => ColliderGeometry::Box {
            center,
            size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
        },
        RawBodyShape::Cylinder => ColliderGeometry::Cylinder {
            center,
            radius: radius()?,
            height: require(raw.height, path.key("height"), "the length along its axis")?,
        },
        RawBodyShape::Capsule => ColliderGeometry::Capsule {
            center,
            radius: radius()?,
            height: require(
                raw.height,
                path.key("height"),
                "the whole length along its axis, end to end",
            )?,
        },
        RawBodyShape::Mesh => {
            // The placement takes angles: a quaternion is turned into them.
            let degrees = raw.rotation.or(quaternion.map(degrees_of));
            let placement =
                mesh_placement(path, raw.mesh.take(), raw.scale, degrees, center, origin)?;
            sampled_mesh(path, placement, raw.sdf_spacing, domain)?
        }
    })
}

/// Keys the shape does not take are errors, as for colliders.
fn reject_other_keys(path: &KeyPath, shape: RawBodyShape, raw: &RawRigidBody) -> Check {
    let (name, takes) = (shape_name(shape), shape_keys(shape));
    let round = matches!(
        shape,
        RawBodyShape::Sphere | RawBodyShape::Cylinder | RawBodyShape::Capsule
    );
    let long = matches!(shape, RawBodyShape::Cylinder | RawBodyShape::Capsule);
    if !round {
        reject(&raw.radius, path.key("radius"), name, takes)?;
    }
    if !long {
        reject(&raw.height, path.key("height"), name, takes)?;
    }
    if !matches!(shape, RawBodyShape::Box) {
        reject(&raw.size, path.key("size"), name, takes)?;
    }
    if !matches!(shape, RawBodyShape::Mesh) {
        reject(&raw.mesh, path.key("mesh"), name, takes)?;
        reject(&raw.scale, path.key("scale"), name, takes)?;
        reject(&raw.sdf_spacing, path.key("sdf_spacing"), name, takes)?;
        reject(&raw.solid, path.key("solid"), name, takes)?;
    }
    Ok(())
}

/// A given quaternion, normalised; a zero or non-finite one is an error.
fn resolve_quaternion(path: &KeyPath, raw: Option<[f32; 4]>) -> Result<Option<Quat>, Issue> {
    let Some([x, y, z, w]) = raw else {
        return Ok(None);
    };
    let quaternion = Quat::from_xyzw(x, y, z, w);
    ensure(
        quaternion.is_finite() && quaternion.length() > 0.0,
        path.key("quaternion"),
        "finite and not zero",
        format!("[{x}, {y}, {z}, {w}]"),
        "give the orientation as a quaternion [x, y, z, w], e.g. quaternion = [0.0, 0.0, 0.0, \
         1.0] (it is normalised when loaded)"
            .to_string(),
    )?;
    Ok(Some(quaternion.normalize()))
}

/// The angles, in degrees about x, then y, then z, of a rotation.
fn degrees_of(rotation: Quat) -> [f32; 3] {
    let (z, y, x) = rotation.to_euler(EulerRot::ZYX);
    [x, y, z].map(f32::to_degrees)
}

/// The mesh loaded where its placement puts it, with its signed distance
/// field sampled as for a mesh collider.
fn sampled_mesh(
    path: &KeyPath,
    placement: MeshPlacement,
    spacing: Option<f32>,
    domain: &Domain,
) -> Result<ColliderGeometry, Issue> {
    let spacing = spacing.unwrap_or(0.5 * domain.cell_size);
    check_sdf_spacing(path, spacing)?;
    let placed = placement.load().map_err(|err| mesh_issue(path, &err))?;
    check_sdf_size(path, placed.mesh.bounds(), spacing)?;
    Ok(ColliderGeometry::Mesh(Box::new(MeshCollider::from_placed(
        placement, placed, spacing,
    ))))
}

fn check_count(count: usize) -> Check {
    if count <= MAX_RIGID_BODIES {
        return Ok(());
    }
    Err(Issue::new(
        KeyPath::of("rigid_bodies").index(MAX_RIGID_BODIES),
        format!("the scene has {count} rigid bodies; the limit is {MAX_RIGID_BODIES}"),
        "use fewer, larger bodies (a heap of small stones is better a heavy snow material)",
    ))
}

/// The rules on the rigid bodies, also for scenes built in code: their
/// number, the integrator, each body's values, and that each starts clear
/// of the walls, the colliders and the other bodies.
pub(super) fn check_rigid_bodies(scene: &Scene) -> Check {
    if scene.rigid_bodies.is_empty() {
        return Ok(());
    }
    let list = KeyPath::of("rigid_bodies");
    check_count(scene.rigid_bodies.len())?;
    if let Integrator::SemiImplicit(_) = scene.solver.integrator {
        return Err(Issue::new(
            list.index(0),
            "rigid bodies need solver.integrator = \"explicit\": the semi-implicit solve does \
             not couple them to the snow yet",
            "remove integrator = \"semi-implicit\" (and its keys) from [solver], or the \
             [[rigid_bodies]] tables",
        ));
    }
    let mut points = Vec::with_capacity(scene.rigid_bodies.len());
    for (index, body) in scene.rigid_bodies.iter().enumerate() {
        let path = list.index(index);
        check_rigid_body(&path, body)?;
        points.push(match &body.geometry {
            ColliderGeometry::Mesh(mesh) => mesh_points(&path, mesh)?,
            geometry => surface_points(geometry),
        });
    }
    check_overlaps(scene, &points)
}

fn check_rigid_body(path: &KeyPath, body: &RigidBody) -> Check {
    match body.geometry {
        ColliderGeometry::Sphere { center, radius } => check_ball(path, center, radius)?,
        ColliderGeometry::Box { center, size } => check_box(path, center, size)?,
        ColliderGeometry::Cylinder {
            center,
            radius,
            height,
        } => check_cylinder(path, center, radius, height)?,
        ColliderGeometry::Capsule {
            center,
            radius,
            height,
        } => check_capsule(path, center, radius, height)?,
        ColliderGeometry::Mesh(ref mesh) => {
            check_mesh_placement(path, &mesh.placement)?;
            check_sdf_spacing(path, mesh.sdf_spacing)?;
        }
        ColliderGeometry::HalfPlane { .. } | ColliderGeometry::MeshSequence(_) => {
            return Err(Issue::new(
                path.key("shape"),
                format!(
                    "{path} is a plane or a mesh sequence: a rigid body is a sphere, box, \
                     cylinder, capsule or mesh"
                ),
                "make it a collider, or give the body one of those shapes",
            ));
        }
    }
    ensure(
        body.rotation.is_finite() && (body.rotation.length() - 1.0).abs() <= 1e-3,
        path.key("rotation"),
        "a finite turn",
        format!("{:?}", body.rotation),
        "give finite angles in degrees, e.g. rotation = [0.0, 90.0, 0.0], or a non-zero \
         quaternion = [x, y, z, w] (in code: a normalised Quat)"
            .to_string(),
    )?;
    match body.mass {
        BodyMass::Density(density) => positive(
            density,
            path.key("density"),
            "give the body's density in kg/m³, e.g. density = 500.0 (wood), or its mass in kg"
                .to_string(),
        )?,
        BodyMass::Mass(mass) => positive(
            mass,
            path.key("mass"),
            "give the body's mass in kg, e.g. mass = 20.0, or its density in kg/m³".to_string(),
        )?,
    }
    finite_vec(body.velocity, path.key("velocity"))?;
    finite_vec(body.angular_velocity, path.key("angular_velocity"))?;
    check_contact(path, &body.contact)?;
    ensure(
        (0.0..=1.0).contains(&body.restitution),
        path.key("restitution"),
        "between 0 and 1",
        Num::from(body.restitution),
        "set the share of the speed a collision gives back, e.g. restitution = 0.3 (0: no \
         bounce, 1: all of it)"
            .to_string(),
    )
}

/// The vertices of a mesh body where it starts (at most
/// [`MAX_VERTEX_SAMPLES`], evenly picked), once its mesh, read again from
/// its file, is found to enclose a volume: a flat or open surface has no
/// mass or inside.
fn mesh_points(path: &KeyPath, mesh: &MeshCollider) -> Result<Vec<Vec3>, Issue> {
    let placed = mesh
        .placement
        .load()
        .map_err(|err| mesh_issue(path, &err))?;
    let (low, high) = placed.mesh.bounds();
    let extent = (high - low).as_dvec3();
    let box_volume = extent.x * extent.y * extent.z;
    let volume = enclosed_volume(&placed.mesh, 0.5 * (low + high).as_dvec3());
    // Written so that a NaN volume is refused too.
    let holds_some = volume > EMPTY_SHARE * box_volume;
    if !holds_some {
        let file = mesh.placement.file.display();
        return Err(Issue::new(
            path.key("mesh"),
            format!(
                "{path}.mesh ({file}) encloses no volume: {} m³ in a bounding box of {} m³",
                Num(volume),
                Num(box_volume)
            ),
            "a rigid body needs a closed solid: close the mesh's holes or give the surface a \
             thickness (a flat or open surface can be a [[colliders]] mesh)",
        ));
    }
    let shift = mesh.center - mesh.placement.center;
    let stride = placed.mesh.vertices.len().div_ceil(MAX_VERTEX_SAMPLES);
    Ok(placed
        .mesh
        .vertices
        .iter()
        .step_by(stride.max(1))
        .map(|&vertex| vertex + shift)
        .collect())
}

/// The volume a mesh encloses, as a magnitude, from the tetrahedra its
/// triangles span with `middle` (near the mesh, so that an open mesh's
/// figure does not depend on where the origin lies).
fn enclosed_volume(mesh: &firn_mesh::TriangleMesh, middle: DVec3) -> f64 {
    let corner = |index: u32| mesh.vertices[index as usize].as_dvec3() - middle;
    let sum: f64 = mesh
        .triangles
        .iter()
        .map(|&[a, b, c]| corner(a).dot(corner(b).cross(corner(c))))
        .sum();
    (sum / 6.0).abs()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degrees_of_a_rotation_place_a_mesh_alike() {
        let rotation = Quat::from_xyzw(0.3, -0.5, 0.2, 0.8).normalize();
        let again = rotation_from_degrees(vec3(degrees_of(rotation)));
        assert!(again.dot(rotation).abs() > 1.0 - 1e-6, "{again:?}");
    }
}

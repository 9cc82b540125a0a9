//! What `[[bodies]]` and `[[colliders]]` share: mesh placement, balls, boxes, the domain's bounds.

use std::path::Path;

use glam::Vec3;
use serde::Deserialize;

use super::MAX_SDF_SAMPLES;
use super::issue::{Check, Issue, KeyPath};
use super::values::{AXES, Num, ensure, finite_vec, positive, positive_vec, require, vec3};
use crate::scene::mesh::{MeshCollider, MeshPlacement};
use crate::scene::model::Domain;

/// A mesh's scale: one factor for all axes or one per axis.
#[derive(Clone, Copy, Deserialize)]
#[serde(untagged)]
pub(super) enum RawScale {
    Uniform(f32),
    PerAxis([f32; 3]),
}

/// The mesh file, scale, rotation and centre of a mesh body or collider,
/// checked before the file is read. A relative `mesh` path is taken from the
/// scene file's folder, like an `include` in other tools.
pub(super) fn mesh_placement(
    path: &KeyPath,
    file: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    center: Vec3,
    origin: &str,
) -> Result<MeshPlacement, Issue> {
    let file = require(file, path.key("mesh"), "the mesh file (OBJ, STL or PLY)")?;
    let scale = match scale.unwrap_or(RawScale::Uniform(1.0)) {
        RawScale::Uniform(factor) => Vec3::splat(factor),
        RawScale::PerAxis(factors) => vec3(factors),
    };
    let folder = Path::new(origin).parent().unwrap_or(Path::new(""));
    let joined = folder.join(&file);
    let placement = MeshPlacement {
        file: std::fs::canonicalize(&joined)
            .or_else(|_| std::path::absolute(&joined))
            .unwrap_or(joined),
        scale,
        rotation_degrees: vec3(rotation.unwrap_or([0.0; 3])),
        center,
    };
    check_mesh_placement(path, &placement)?;
    Ok(placement)
}

/// Scale factors greater than 0; finite rotation and centre.
pub(super) fn check_mesh_placement(path: &KeyPath, placement: &MeshPlacement) -> Check {
    for factor in placement.scale.to_array() {
        positive(
            factor,
            path.key("scale"),
            "scale by a factor greater than 0, e.g. scale = 2.0 or scale = [1.0, 2.0, 1.0]"
                .to_string(),
        )?;
    }
    finite_vec(placement.rotation_degrees, path.key("rotation"))?;
    finite_vec(placement.center, path.key("center"))
}

/// A mesh that cannot be read, located at the `mesh` key that names it.
pub(super) fn mesh_issue(path: &KeyPath, err: &firn_mesh::MeshError) -> Issue {
    let location = match err.line {
        Some(line) => format!("{}:{line}", err.path.display()),
        None => err.path.display().to_string(),
    };
    Issue::new(
        path.key("mesh"),
        format!("{path}.mesh cannot be used: {location}: {}", err.message),
        err.hint.clone(),
    )
}

/// The signed distance sample spacing: positive, and not so fine that the
/// field would not fit.
pub(super) fn check_sdf_spacing(path: &KeyPath, spacing: f32) -> Check {
    positive(
        spacing,
        path.key("sdf_spacing"),
        "set the signed distance sample spacing in metres, e.g. sdf_spacing = 0.01, or remove \
         it to use half the domain's cell size"
            .to_string(),
    )
}

/// The field of a placed mesh collider must stay under [`MAX_SDF_SAMPLES`].
pub(super) fn check_sdf_size(path: &KeyPath, (low, high): (Vec3, Vec3), spacing: f32) -> Check {
    let samples = MeshCollider::sdf_samples((low, high), spacing);
    ensure(
        samples <= MAX_SDF_SAMPLES,
        path.key("sdf_spacing"),
        &format!("coarse enough for at most {MAX_SDF_SAMPLES} signed distance samples"),
        format!("{samples} samples"),
        "raise sdf_spacing, or scale the mesh down".to_string(),
    )
}

/// The box `low .. high` of the thing at `path` (a `what`) must lie inside
/// the domain; the error names the axis and both spans.
pub(super) fn check_inside_domain(
    path: &KeyPath,
    what: &str,
    (low, high): (Vec3, Vec3),
    domain: &Domain,
    hint: &str,
) -> Check {
    let slack = 1e-6 * (domain.max - domain.min).max_element();
    for (axis, a) in AXES.iter().enumerate() {
        if low[axis] < domain.min[axis] - slack || high[axis] > domain.max[axis] + slack {
            return Err(Issue::new(
                path.key("center"),
                format!(
                    "{path} ({what}) sticks out of the domain along {a}: it spans {a} = {} .. {} \
                     but the domain spans {a} = {} .. {}",
                    Num::from(low[axis]),
                    Num::from(high[axis]),
                    Num::from(domain.min[axis]),
                    Num::from(domain.max[axis])
                ),
                hint,
            ));
        }
    }
    Ok(())
}

/// Centre and radius of a ball-shaped body or collider.
pub(super) fn check_ball(path: &KeyPath, center: Vec3, radius: f32) -> Check {
    finite_vec(center, path.key("center"))?;
    positive(
        radius,
        path.key("radius"),
        "set the radius in metres, e.g. radius = 0.1".to_string(),
    )?;
    Ok(())
}

/// Centre and edge lengths of a box-shaped body or collider.
pub(super) fn check_box(path: &KeyPath, center: Vec3, size: Vec3) -> Check {
    finite_vec(center, path.key("center"))?;
    positive_vec(
        size,
        path.key("size"),
        "set the edge lengths in metres, e.g. size = [0.2, 0.2, 0.2]".to_string(),
    )?;
    Ok(())
}

/// Centre, radius and length of a cylinder along its axis.
pub(super) fn check_cylinder(path: &KeyPath, center: Vec3, radius: f32, height: f32) -> Check {
    check_ball(path, center, radius)?;
    positive(
        height,
        path.key("height"),
        "set the length along the axis in metres, e.g. height = 0.2".to_string(),
    )
}

/// Centre and radius of a capsule, and its whole length end to end, which
/// holds both round ends: at least twice the radius.
pub(super) fn check_capsule(path: &KeyPath, center: Vec3, radius: f32, height: f32) -> Check {
    check_ball(path, center, radius)?;
    ensure(
        height.is_finite() && height >= 2.0 * radius,
        path.key("height"),
        "at least twice the radius (the length end to end)",
        Num::from(height),
        format!("set height = {} or more", Num::from(2.0 * radius)),
    )
}

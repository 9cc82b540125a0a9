//! Reads and checks the `[[bodies]]` tables: the snow's shapes, particles and clumps.

use std::collections::BTreeMap;

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::materials::unknown_material;
use super::shapes::{
    RawScale, check_ball, check_box, check_inside_domain, check_mesh_placement, mesh_issue,
    mesh_placement,
};
use super::values::{
    Num, ensure, finite_vec, missing, positive, reject, require, round_up_3_digits, unit_or_zero,
    unit_vec, vec3,
};
use crate::scene::clumps::{Clumps, MAX_CONTRAST};
use crate::scene::estimate::{Bytes, CPU_BYTES_PER_PARTICLE, body_estimate};
use crate::scene::material::Material;
use crate::scene::mesh::MeshBody;
use crate::scene::model::{Body, Scene, Shape};
use crate::scene::sampling;

/// `clumps.contrast` when a body's `clumps` table gives none.
pub const DEFAULT_CLUMP_CONTRAST: f32 = 0.15;

/// Largest `particles_per_cell` a body may ask for.
pub const MAX_PARTICLES_PER_CELL: u32 = 64;

/// Largest number of lattice points all bodies together may be filled from
/// (2^30). Each point is a candidate particle, tested once at the start, so
/// this bounds both the particles and the work of making them.
pub const MAX_LATTICE_POINTS: u64 = 1 << 30;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBody {
    shape: Option<RawBodyShape>,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    size: Option<[f32; 3]>,
    height: Option<f32>,
    axis: Option<[f32; 3]>,
    velocity: Option<[f32; 3]>,
    material: Option<String>,
    particles_per_cell: Option<u32>,
    mesh: Option<String>,
    scale: Option<RawScale>,
    rotation: Option<[f32; 3]>,
    clumps: Option<RawClumps>,
}

/// A body's `clumps = { size, contrast }`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawClumps {
    size: Option<f32>,
    contrast: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawBodyShape {
    Sphere,
    Box,
    Cylinder,
    Mesh,
}

fn body_shape_name(shape: RawBodyShape) -> &'static str {
    match shape {
        RawBodyShape::Sphere => "sphere",
        RawBodyShape::Box => "box",
        RawBodyShape::Cylinder => "cylinder",
        RawBodyShape::Mesh => "mesh",
    }
}

/// Every `[[bodies]]` table, and the materials they use in order of first
/// use: a declared `[materials.NAME]` table, else the preset of that name.
pub(super) fn resolve_bodies(
    raw: Vec<RawBody>,
    declared: &BTreeMap<String, Material>,
    origin: &str,
) -> Result<(Vec<Material>, Vec<Body>), Issue> {
    let mut materials: Vec<Material> = Vec::new();
    let mut bodies = Vec::new();
    for (index, raw_body) in raw.into_iter().enumerate() {
        let path = KeyPath::of("bodies").index(index);
        let material_name = raw_body
            .material
            .clone()
            .unwrap_or_else(|| Material::DEFAULT_PRESET.to_string());
        let material = match materials.iter().position(|m| m.name == material_name) {
            Some(found) => found,
            None => {
                let material = declared
                    .get(&material_name)
                    .cloned()
                    .or_else(|| Material::preset(&material_name))
                    .ok_or_else(|| unknown_material(&path, &material_name, declared))?;
                materials.push(material);
                materials.len() - 1
            }
        };
        bodies.push(resolve_body(&path, raw_body, material, origin)?);
    }
    Ok((materials, bodies))
}

fn resolve_body(
    path: &KeyPath,
    raw: RawBody,
    material: usize,
    origin: &str,
) -> Result<Body, Issue> {
    let shape_kind = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the shape to fill").with_hint(
            "add shape = \"sphere\", \"box\", \"cylinder\" or \"mesh\" with its dimensions",
        )
    })?;
    let center = vec3(require(raw.center, path.key("center"), "the centre")?);
    if !matches!(shape_kind, RawBodyShape::Mesh) {
        let shape = body_shape_name(shape_kind);
        let takes = "mesh, scale, rotation and center";
        reject(&raw.mesh, path.key("mesh"), shape, takes)?;
        reject(&raw.scale, path.key("scale"), shape, takes)?;
        reject(&raw.rotation, path.key("rotation"), shape, takes)?;
    }
    let shape = match shape_kind {
        RawBodyShape::Mesh => {
            let takes = "mesh, scale, rotation and center";
            reject(&raw.radius, path.key("radius"), "mesh", takes)?;
            reject(&raw.size, path.key("size"), "mesh", takes)?;
            reject(&raw.height, path.key("height"), "mesh", takes)?;
            reject(&raw.axis, path.key("axis"), "mesh", takes)?;
            let placement =
                mesh_placement(path, raw.mesh, raw.scale, raw.rotation, center, origin)?;
            let body = MeshBody::load(placement).map_err(|err| mesh_issue(path, &err))?;
            Shape::Mesh(Box::new(body))
        }
        RawBodyShape::Sphere => {
            let takes = "center and radius";
            reject(&raw.size, path.key("size"), "sphere", takes)?;
            reject(&raw.height, path.key("height"), "sphere", takes)?;
            reject(&raw.axis, path.key("axis"), "sphere", takes)?;
            Shape::Sphere {
                center,
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
            }
        }
        RawBodyShape::Box => {
            let takes = "center and size";
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            reject(&raw.height, path.key("height"), "box", takes)?;
            reject(&raw.axis, path.key("axis"), "box", takes)?;
            Shape::Box {
                center,
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
        RawBodyShape::Cylinder => {
            reject(
                &raw.size,
                path.key("size"),
                "cylinder",
                "center, radius, height and axis",
            )?;
            Shape::Cylinder {
                center,
                axis: unit_or_zero(raw.axis.unwrap_or([0.0, 1.0, 0.0])),
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
                height: require(raw.height, path.key("height"), "the length along the axis")?,
            }
        }
    };
    let mut body = Body::new(shape).material(material);
    if let Some(velocity) = raw.velocity {
        body.velocity = vec3(velocity);
    }
    if let Some(count) = raw.particles_per_cell {
        body.particles_per_cell = count;
    }
    if let Some(clumps) = raw.clumps {
        body.clumps = Some(Clumps {
            size: clumps.size.ok_or_else(|| {
                missing(path.key("clumps").key("size"), "the clump size in metres")
                    .with_hint("add the clump diameter, e.g. clumps = { size = 0.05 }")
            })?,
            contrast: clumps.contrast.unwrap_or(DEFAULT_CLUMP_CONTRAST),
        });
    }
    Ok(body)
}

fn shape_name(shape: &Shape) -> &'static str {
    match shape {
        Shape::Sphere { .. } => "sphere",
        Shape::Box { .. } => "box",
        Shape::Cylinder { .. } => "cylinder",
        Shape::Mesh(_) => "mesh",
    }
}

/// The scene must have snow; each body is checked, and the lattice points
/// of the bodies so far are counted before any is visited.
pub(super) fn check_bodies(scene: &Scene) -> Check {
    if scene.bodies.is_empty() {
        return Err(Issue::new(
            KeyPath::of("bodies"),
            "the scene has no snow: there is no [[bodies]] table",
            "add a [[bodies]] table, e.g. [[bodies]] shape = \"sphere\" center = [1.0, 0.5, 1.0] \
             radius = 0.1",
        ));
    }
    let mut lattice_points = 0u64;
    for (index, body) in scene.bodies.iter().enumerate() {
        check_body(scene, index, body)?;
        lattice_points =
            lattice_points.saturating_add(sampling::lattice_points(body, scene.domain.cell_size));
        check_lattice_points(scene, index, lattice_points)?;
        check_body_has_particles(scene, index, body)?;
    }
    Ok(())
}

fn check_body(scene: &Scene, index: usize, body: &Body) -> Check {
    let path = KeyPath::of("bodies").index(index);
    if body.material >= scene.materials.len() {
        return Err(Issue::new(
            path.key("material"),
            format!(
                "{path}.material is material {} but the scene has {} materials",
                body.material,
                scene.materials.len()
            ),
            "use an index into Scene::materials",
        ));
    }
    let ppc = body.particles_per_cell;
    ensure(
        (1..=MAX_PARTICLES_PER_CELL).contains(&ppc),
        path.key("particles_per_cell"),
        "between 1 and 64",
        ppc,
        "use particles_per_cell = 8 (the usual value)".to_string(),
    )?;
    finite_vec(body.velocity, path.key("velocity"))?;
    if let Some(clumps) = body.clumps {
        check_clumps(&path.key("clumps"), clumps, scene.domain.cell_size)?;
    }
    match body.shape {
        Shape::Sphere { center, radius } => {
            check_ball(&path, center, radius)?;
        }
        Shape::Box { center, size } => {
            check_box(&path, center, size)?;
        }
        Shape::Cylinder {
            center,
            axis,
            radius,
            height,
        } => {
            finite_vec(center, path.key("center"))?;
            unit_vec(axis, path.key("axis"))?;
            positive(
                radius,
                path.key("radius"),
                "set the radius in metres, e.g. radius = 0.1".to_string(),
            )?;
            positive(
                height,
                path.key("height"),
                "set the length along the axis in metres, e.g. height = 0.5".to_string(),
            )?;
        }
        Shape::Mesh(ref mesh) => check_mesh_placement(&path, &mesh.placement)?,
    }

    check_inside_domain(
        &path,
        shape_name(&body.shape),
        body.shape.bounds(),
        &scene.domain,
        "move or shrink the body so that it lies inside domain.min .. domain.max, or \
         enlarge the domain",
    )
}

/// Clumps must be resolved by the grid and their contrast bounded.
fn check_clumps(path: &KeyPath, clumps: Clumps, cell_size: f32) -> Check {
    let rule = if clumps.size.is_finite() {
        "at least domain.cell_size"
    } else {
        "a finite number, at least domain.cell_size"
    };
    ensure(
        clumps.size.is_finite() && clumps.size >= cell_size,
        path.key("size"),
        rule,
        clumps.size,
        format!(
            "clumps smaller than a grid cell are not resolved: use size = {} or more \
             (about 2 to 4 cells looks like hand-packed snow)",
            2.0 * cell_size
        ),
    )?;
    ensure(
        (0.0..=MAX_CONTRAST).contains(&clumps.contrast),
        path.key("contrast"),
        &format!("between 0 and {MAX_CONTRAST}"),
        clumps.contrast,
        format!("use contrast = {DEFAULT_CLUMP_CONTRAST} (the default)"),
    )
}

/// A body must catch at least one particle; its lattice has been checked
/// against [`MAX_LATTICE_POINTS`], so looking is bounded.
fn check_body_has_particles(scene: &Scene, index: usize, body: &Body) -> Check {
    let path = KeyPath::of("bodies").index(index);
    let domain = &scene.domain;
    let ppc = body.particles_per_cell;
    if !sampling::body_has_particles(scene, index) {
        let spacing = sampling::particle_spacing(domain.cell_size, ppc);
        let (cause, hint) = match body.shape {
            Shape::Mesh(_) => (
                "it encloses no volume larger than the particle spacing",
                "check that the mesh is a solid (not a single open sheet) and its scale, raise \
                 particles_per_cell (at most 64), or use a smaller domain.cell_size",
            ),
            _ => (
                "it is too small for the particle spacing",
                "make the body larger, raise particles_per_cell (at most 64), or use a smaller \
                 domain.cell_size",
            ),
        };
        return Err(Issue::new(
            path.clone(),
            format!(
                "{path} ({}) gets no particles: {cause} cell_size / cbrt(particles_per_cell) = \
                 {} m",
                shape_name(&body.shape),
                Num::from(spacing)
            ),
            hint,
        ));
    }
    Ok(())
}

/// The bodies up to `index` must be filled from at most
/// [`MAX_LATTICE_POINTS`] lattice points (`total`), checked before any is
/// visited.
fn check_lattice_points(scene: &Scene, index: usize, total: u64) -> Check {
    if total <= MAX_LATTICE_POINTS {
        return Ok(());
    }
    let body = &scene.bodies[index];
    let path = KeyPath::of("bodies").index(index);
    let h = scene.domain.cell_size;
    let ppc = body.particles_per_cell;
    let estimate = body_estimate(body, h);
    let earlier = total.saturating_sub(estimate.lattice_points);
    let room = MAX_LATTICE_POINTS.saturating_sub(earlier).max(1);
    // The lattice must get this much sparser (points scale with ppc / h³).
    let factor = room as f64 / estimate.lattice_points as f64;
    let coarser_cell = round_up_3_digits(f64::from(h) / factor.cbrt());
    let fewer_per_cell = (f64::from(ppc) * factor).floor() as u32;
    let mut hint = if fewer_per_cell >= 1 {
        format!(
            "lower particles_per_cell to {fewer_per_cell} (now {ppc}), use cell_size = \
             {coarser_cell} or more (now {}), or make the body smaller",
            Num::from(h)
        )
    } else {
        format!(
            "use cell_size = {coarser_cell} or more (now {}), or make the body smaller",
            Num::from(h)
        )
    };
    if estimate.lattice_points / 4 > estimate.particles {
        hint.push_str(
            "; a thin or slanted body is filled through its whole bounding box, so turning it \
             along the axes helps too",
        );
    }
    let before = if earlier > 0 {
        format!(" (with the {earlier} of the bodies before it)")
    } else {
        String::new()
    };
    Err(Issue::new(
        path.key("particles_per_cell"),
        format!(
            "{path} ({}) is filled from {} lattice points, about {} particles needing {} of \
             memory{before}; all bodies together may be filled from at most 2^30 = \
             {MAX_LATTICE_POINTS}",
            shape_name(&body.shape),
            estimate.lattice_points,
            estimate.particles,
            Bytes(estimate.particles.saturating_mul(CPU_BYTES_PER_PARTICLE)),
        ),
        hint,
    ))
}

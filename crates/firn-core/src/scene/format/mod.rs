//! The TOML scene format (`format = 1`).
//!
//! Loading happens in three passes over the text:
//!
//! 1. The text is parsed into a spanned TOML tree ([`toml::de::DeTable`]); syntax
//!    errors stop here, located by the parser.
//! 2. The text is deserialized into private raw structs that reject unknown
//!    keys (`deny_unknown_fields`) and wrong value types. The span that the
//!    TOML deserializer reports is turned into a key path (`bodies[1].radus`)
//!    by walking the spanned tree. The tree is then walked for numbers too
//!    large for the `f32` they were read into (they became infinite).
//! 3. Defaults and presets are resolved into the model types, and the model is
//!    checked by the same rules as [`Scene::validate`]. Those errors name a key
//!    path, which is looked up in the spanned tree to find the line and column
//!    of the offending value (or, for a missing key, of the table that should
//!    hold it).
//!
//! The model types stay free of spans; only this module knows about the text.
//! The format itself is documented in `docs/scene-format.md`.
//!
//! Each top-level table has its own file of raw structs, resolution and
//! checks: `domain.rs`, `time.rs`, `solver.rs`, `materials.rs`, `bodies.rs`,
//! `colliders.rs`, `rigid_bodies.rs` (with `rigid_body_overlap.rs`, whether
//! each body starts clear of the other solids), `wind.rs`, `output.rs`,
//! `camera.rs`, `render.rs`, `compute.rs` and `flow.rs` (with `field.rs`, the
//! curl-noise keys `[flow]` and `[wind]` share, and `emitters.rs`).
//! `shapes.rs` holds what bodies, colliders and rigid bodies share, `values.rs` the rules on numbers and vectors, `issue.rs`
//! the key paths and their place in the text, `messages.rs` the wording of
//! the deserializer's errors.

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

use super::flow::SceneKind;
use super::model::Scene;
use bodies::RawBody;
use camera::RawCamera;
use colliders::RawCollider;
use compute::RawCompute;
use domain::RawDomain;
use field::RawFlow;
use issue::{Check, Issue, KeyPath, Source};
use materials::RawMaterial;
use output::RawOutput;
use render::RawRender;
use rigid_bodies::RawRigidBody;
use solver::RawSolver;
use time::RawTime;

mod bodies;
mod camera;
mod colliders;
mod compute;
mod domain;
mod emitters;
mod field;
mod flow;
mod issue;
mod materials;
mod messages;
mod output;
mod render;
mod rigid_bodies;
mod rigid_body_overlap;
mod shapes;
mod solver;
mod time;
mod values;
mod wind;

pub use super::mesh::MAX_SDF_SAMPLES;
pub use bodies::{DEFAULT_CLUMP_CONTRAST, MAX_LATTICE_POINTS, MAX_PARTICLES_PER_CELL};
pub use domain::{MAX_CELLS, MAX_CELLS_PER_AXIS};
pub use flow::MAX_FLOW_PARTICLES;
pub use rigid_bodies::MAX_RIGID_BODIES;
pub use time::MAX_FRAMES;

/// The only scene format version this build reads.
pub const FORMAT_VERSION: i64 = 1;

/// A problem with a scene: where it is, what is wrong, and how to fix it.
///
/// Displayed as one block in the style of rustc and cargo:
///
/// ```text
/// error: scenes/x.toml:12:9: domain.cell_size must be greater than 0 (got -0.1)
///   fix: set cell_size to the grid spacing in metres, e.g. cell_size = 0.02
/// ```
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub struct SceneError {
    /// The scene file as the user named it; empty for a scene built in code.
    pub file: String,
    /// 1-based line of the offending text, if the error comes from a file.
    pub line: Option<usize>,
    /// 1-based column (in characters) of the offending text.
    pub column: Option<usize>,
    /// Key path of the offending value, e.g. `bodies[1].radius`.
    pub key: Option<String>,
    /// What is wrong.
    pub message: String,
    /// How to fix it.
    pub hint: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.column) {
            (Some(line), Some(column)) => write!(f, "error: {}:{line}:{column}: ", self.file)?,
            (Some(line), None) => write!(f, "error: {}:{line}: ", self.file)?,
            _ => f.write_str("error: ")?,
        }
        f.write_str(&self.message)?;
        if !self.hint.is_empty() {
            write!(f, "\n  fix: {}", self.hint)?;
        }
        Ok(())
    }
}

// `SceneError` is a plain record of public fields (part of the API); it is
// returned once, on a cold path, so its size does not matter.
#[allow(clippy::result_large_err)]
impl Scene {
    /// Load and validate a scene file.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|err| SceneError {
            message: format!("cannot read scene file '{file}': {err}"),
            file: file.clone(),
            line: None,
            column: None,
            key: None,
            hint: "check the path".to_string(),
        })?;
        Scene::from_toml_str(&text, &file)
    }

    /// Parse and validate scene text; `origin` names the file in messages.
    ///
    /// When the scene has no `name`, it is named after the file stem of
    /// `origin` if that ends in `.toml`, and `scene` otherwise.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let source = Source { text, origin };
        let doc = DeTable::parse(text).map_err(|err| source.syntax_error(&err))?;
        let root = Spanned::new(doc.span(), DeValue::Table(doc.into_inner()));

        check_format_version(&root).map_err(|issue| source.locate(&root, issue))?;
        let raw: RawScene =
            toml::from_str(text).map_err(|err| source.deserialize_error(&root, &err))?;
        values::check_f32_range(&root).map_err(|issue| source.locate(&root, issue))?;
        let scene = resolve(raw, origin).map_err(|issue| source.locate(&root, issue))?;
        check_scene(&scene).map_err(|issue| source.locate(&root, issue))?;
        Ok(scene)
    }

    /// Check a scene built in code (same rules; errors carry the key path but no line).
    pub fn validate(&self) -> Result<(), SceneError> {
        check_scene(self).map_err(|issue| SceneError {
            file: String::new(),
            line: None,
            column: None,
            key: Some(issue.key.to_string()),
            message: issue.message,
            hint: issue.hint,
        })
    }
}

/// The file as written: one optional field per top-level key.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    format: Option<i64>,
    name: Option<String>,
    domain: Option<RawDomain>,
    time: Option<RawTime>,
    solver: Option<RawSolver>,
    materials: Option<BTreeMap<String, RawMaterial>>,
    bodies: Option<Vec<RawBody>>,
    colliders: Option<Vec<RawCollider>>,
    rigid_bodies: Option<Vec<RawRigidBody>>,
    output: Option<RawOutput>,
    camera: Option<RawCamera>,
    render: Option<RawRender>,
    kind: Option<flow::RawKind>,
    flow: Option<RawFlow>,
    wind: Option<RawFlow>,
    compute: Option<RawCompute>,
}

/// Check `format` before anything else, so that a file written for another
/// version gets that message rather than one about unknown keys.
fn check_format_version(root: &Spanned<DeValue<'_>>) -> Check {
    let DeValue::Table(table) = root.get_ref() else {
        return Ok(());
    };
    let path = KeyPath::of("format");
    let Some(value) = table.get("format") else {
        return Err(Issue::new(
            path,
            "the scene file has no `format` key",
            "add `format = 1` as the first line of the file",
        ));
    };
    let version = match value.get_ref() {
        DeValue::Integer(integer) => {
            let digits: String = integer.as_str().chars().filter(|c| *c != '_').collect();
            i64::from_str_radix(&digits, integer.radix()).ok()
        }
        _ => None,
    };
    if version == Some(FORMAT_VERSION) {
        return Ok(());
    }
    let written = match version {
        Some(version) => version.to_string(),
        None => "a value that is not a whole number".to_string(),
    };
    Err(Issue::new(
        path,
        format!("this firn reads format {FORMAT_VERSION}, but the file says format = {written}"),
        format!(
            "write `format = {FORMAT_VERSION}` and use the keys described in docs/scene-format.md"
        ),
    ))
}

/// The default scene name for a file: its stem if it is a `.toml` file,
/// else [`Scene::DEFAULT_NAME`].
fn default_name(origin: &str) -> String {
    let path = Path::new(origin);
    let is_toml = path.extension().is_some_and(|ext| ext == "toml");
    match path.file_stem().and_then(|stem| stem.to_str()) {
        Some(stem) if is_toml && !stem.is_empty() => stem.to_string(),
        _ => Scene::DEFAULT_NAME.to_string(),
    }
}

/// The model the file describes, with the defaults and presets filled in.
fn resolve(raw: RawScene, origin: &str) -> Result<Scene, Issue> {
    // `format` was checked on the spanned tree already.
    let _ = raw.format;
    if flow::is_flow_scene(&raw)? {
        return flow::resolve_flow_scene(raw, origin);
    }
    let name = raw.name.unwrap_or_else(|| default_name(origin));
    let domain = domain::resolve_domain(raw.domain)?;
    let time = time::resolve_time(raw.time)?;
    let solver = solver::resolve_solver(raw.solver)?;
    let declared = materials::resolve_materials(raw.materials.unwrap_or_default())?;
    let (materials, bodies) =
        bodies::resolve_bodies(raw.bodies.unwrap_or_default(), &declared, origin)?;
    let colliders =
        colliders::resolve_colliders(raw.colliders.unwrap_or_default(), origin, &domain, &time)?;
    let rigid_bodies =
        rigid_bodies::resolve_rigid_bodies(raw.rigid_bodies.unwrap_or_default(), origin, &domain)?;
    let wind = wind::resolve_wind(raw.wind, &domain)?;
    let output = output::resolve_output(raw.output, &name, &SceneKind::Snow);
    let camera = camera::resolve_camera(raw.camera)?;
    let render = render::resolve_render(raw.render);
    Ok(Scene {
        name,
        domain,
        time,
        solver,
        materials,
        bodies,
        colliders,
        rigid_bodies,
        output,
        camera,
        render,
        kind: SceneKind::Snow,
        compute: compute::resolve_compute(raw.compute),
        wind,
    })
}

/// The rules every scene must satisfy, in document order. Key paths use the
/// names of the file format.
fn check_scene(scene: &Scene) -> Check {
    if scene.name.trim().is_empty() {
        return Err(Issue::new(
            KeyPath::of("name"),
            "name must not be empty",
            "name the scene, e.g. name = \"snowball\", or remove the key to use the file name",
        ));
    }
    if let SceneKind::Flow(settings) = &scene.kind {
        return flow::check_flow_scene(scene, settings);
    }
    domain::check_domain(&scene.domain)?;
    time::check_time(&scene.time)?;
    solver::check_solver(&scene.solver)?;
    for material in &scene.materials {
        materials::check_material(&KeyPath::of("materials").key(&material.name), material)?;
    }
    bodies::check_bodies(scene)?;
    time::check_first_step(scene)?;
    if let Some(wind) = &scene.wind {
        wind::check_wind(wind)?;
    }
    for (index, collider) in scene.colliders.iter().enumerate() {
        let path = KeyPath::of("colliders").index(index);
        colliders::check_collider(&path, collider)?;
        colliders::check_turning_speed(&path, collider, &scene.domain, &scene.time)?;
    }
    rigid_bodies::check_rigid_bodies(scene)?;
    output::check_output(&scene.output)?;
    output::check_vdb(&scene.output.vdb, scene.domain.cell_size)?;
    output::check_mesh(&scene.output.mesh, scene.domain.cell_size)?;
    camera::check_camera(&scene.camera)?;
    render::check_render(&scene.render)
}

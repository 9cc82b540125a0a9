//! Reads and checks the `[flow]` table and the rest of a `kind = "flow"` scene.
//!
//! Curl-noise particle flows (seed 002, after Bridson et al. 2007). The
//! field keys it shares with `[wind]` are read in `field.rs`, the emitters in
//! `emitters.rs`; errors go through the same key paths and issues as every
//! other scene error (file:line:col, key path, fix).

use serde::Deserialize;

use super::camera::{check_camera, resolve_camera};
use super::compute::resolve_compute;
use super::domain::check_domain;
use super::emitters::{check_emitters, resolve_emitter};
use super::field::{RawFlow, check_field, resolve_field};
use super::issue::{Check, Issue, KeyPath};
use super::output::{check_output, resolve_output};
use super::render::{check_render, resolve_render};
use super::solver::resolve_solver;
use super::time::{check_time, resolve_time};
use super::values::{ensure, require, vec3};
use super::{RawScene, default_name};
use crate::scene::flow::{FlowIntegrator, FlowSettings, SceneKind};
use crate::scene::model::{Attribute, CacheFormat, Domain, Scene};
use crate::scene::render::RenderStyle;

/// Largest number of particle slots a flow scene may ask for (2^26).
pub const MAX_FLOW_PARTICLES: u64 = 1 << 26;

/// Largest `substeps` per frame.
const MAX_SUBSTEPS: u32 = 1000;

/// The top-level `kind` key.
#[derive(Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawKind {
    Snow,
    Flow,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawIntegration {
    Rk2,
    Rk4,
}

// ---------------------------------------------------------------------------
// Resolution
// ---------------------------------------------------------------------------

/// Whether the scene is a flow; a `[flow]` table in a snow scene is an error.
pub(super) fn is_flow_scene(raw: &RawScene) -> Result<bool, Issue> {
    match raw.kind {
        Some(RawKind::Flow) => Ok(true),
        Some(RawKind::Snow) | None => {
            if raw.flow.is_some() {
                let snow = if raw.kind.is_some() {
                    "this scene has kind = \"snow\""
                } else {
                    "this scene is a snow scene (kind defaults to \"snow\")"
                };
                return Err(Issue::new(
                    KeyPath::of("flow"),
                    format!("[flow] only applies to curl-noise flow scenes, but {snow}"),
                    "add kind = \"flow\" above the first [table] header, or remove the [flow] \
                     table",
                ));
            }
            Ok(false)
        }
    }
}

/// A snow-only key in a flow scene: name it and say what to do instead.
fn snow_only(path: KeyPath, what: &str, instead: &str) -> Issue {
    Issue::new(
        path,
        format!("{what} is for snow scenes, but this scene has kind = \"flow\""),
        instead.to_string(),
    )
}

/// Reject the keys that only snow scenes take.
fn reject_snow_keys(raw: &RawScene) -> Check {
    if raw.bodies.is_some() {
        return Err(snow_only(
            KeyPath::of("bodies"),
            "[[bodies]]",
            "remove the [[bodies]] tables: a flow's particles come from [[flow.emitters]] (or \
             set kind = \"snow\")",
        ));
    }
    if raw.colliders.is_some() {
        return Err(snow_only(
            KeyPath::of("colliders"),
            "[[colliders]]",
            "remove the [[colliders]] tables: the obstacles of a flow are spheres in \
             [[flow.obstacles]]",
        ));
    }
    if raw.rigid_bodies.is_some() {
        return Err(snow_only(
            KeyPath::of("rigid_bodies"),
            "[[rigid_bodies]]",
            "remove the [[rigid_bodies]] tables: flow particles do not push solids (the \
             obstacles of a flow are spheres in [[flow.obstacles]])",
        ));
    }
    if raw.materials.is_some() {
        return Err(snow_only(
            KeyPath::of("materials"),
            "[materials]",
            "remove the [materials] tables: flow particles have no material",
        ));
    }
    if raw.wind.is_some() {
        return Err(snow_only(
            KeyPath::of("wind"),
            "[wind]",
            "remove [wind]: the particles of a flow scene follow the [flow] field itself",
        ));
    }
    if raw.solver.is_some() {
        return Err(snow_only(
            KeyPath::of("solver"),
            "[solver]",
            "remove [solver]: a flow's seed, integration and substeps are keys of [flow]",
        ));
    }
    if let Some(domain) = &raw.domain
        && domain.walls.is_some()
    {
        return Err(snow_only(
            KeyPath::of("domain").key("walls"),
            "domain.walls",
            "remove walls: flow particles that leave the domain are born again at their emitter",
        ));
    }
    if let Some(time) = &raw.time {
        let keys = [
            ("step", time.step.is_some()),
            ("dt", time.dt.is_some()),
            ("cfl", time.cfl.is_some()),
            (
                "max_substeps_per_frame",
                time.max_substeps_per_frame.is_some(),
            ),
        ];
        if let Some((key, _)) = keys.iter().find(|(_, given)| *given) {
            return Err(snow_only(
                KeyPath::of("time").key(key),
                &format!("time.{key}"),
                &format!(
                    "remove {key}: a flow takes flow.substeps steps of 1 / (fps × substeps) s \
                     per frame, e.g. substeps = 2"
                ),
            ));
        }
    }
    Ok(())
}

/// Resolve a scene with `kind = "flow"`.
pub(super) fn resolve_flow_scene(raw: RawScene, origin: &str) -> Result<Scene, Issue> {
    reject_snow_keys(&raw)?;
    let name = raw.name.unwrap_or_else(|| default_name(origin));

    let domain_path = KeyPath::of("domain");
    let raw_domain = raw.domain.ok_or_else(|| {
        Issue::new(
            domain_path.clone(),
            "the scene has no [domain] table",
            "add a [domain] table with the box particles live in, e.g. [domain] \
             min = [0.0, 0.0, 0.0] max = [100.0, 100.0, 100.0]",
        )
    })?;
    let min = vec3(raw_domain.min.unwrap_or([0.0; 3]));
    let max = vec3(require(
        raw_domain.max,
        domain_path.key("max"),
        "the upper corner",
    )?);
    // The flow has no grid; the renderer may use the spacing for sprite sizes.
    let extent = (max - min).max_element();
    let cell_size = raw_domain
        .cell_size
        .unwrap_or(if extent > 0.0 { extent / 100.0 } else { 1.0 });
    let domain = Domain::new(min, max, cell_size);

    let time = resolve_time(raw.time)?;
    let solver = resolve_solver(None)?;
    let camera = resolve_camera(raw.camera)?;
    let render = resolve_render(raw.render);
    let kind = SceneKind::Flow(Box::new(resolve_flow(raw.flow, &domain)?));
    let output = resolve_output(raw.output, &name, &kind);
    Ok(Scene {
        name,
        domain,
        time,
        solver,
        materials: Vec::new(),
        bodies: Vec::new(),
        colliders: Vec::new(),
        rigid_bodies: Vec::new(),
        output,
        camera,
        render,
        kind,
        compute: resolve_compute(raw.compute),
        wind: None,
    })
}

fn resolve_flow(raw: Option<RawFlow>, domain: &Domain) -> Result<FlowSettings, Issue> {
    let path = KeyPath::of("flow");
    let mut raw = raw.ok_or_else(|| {
        Issue::new(
            path.clone(),
            "a flow scene needs a [flow] table with at least one [[flow.emitters]]",
            "add [[flow.emitters]] with shape = \"box\", center, size and count = 10000",
        )
        .pointing_at(KeyPath::of("kind"))
    })?;
    for (key, given) in [
        ("drag", raw.drag.is_some()),
        ("packed_density", raw.packed_density.is_some()),
        ("spindrift", raw.spindrift.is_some()),
    ] {
        if given {
            return Err(Issue::new(
                path.key(key),
                format!("flow.{key} is a key of [wind], the wind over snow"),
                format!("remove {key}: flow particles follow the field without drag"),
            ));
        }
    }
    let emitters = raw.emitters.take().unwrap_or_default();
    let integration = raw.integration.take();
    let substeps = raw.substeps.take();
    let mut settings = resolve_field(raw, &path, domain)?;
    for (index, emitter) in emitters.into_iter().enumerate() {
        settings.emitters.push(resolve_emitter(
            &path.key("emitters").index(index),
            emitter,
        )?);
    }
    settings.integrator = match integration {
        Some(RawIntegration::Rk4) => FlowIntegrator::Rk4,
        Some(RawIntegration::Rk2) => FlowIntegrator::Rk2,
        None => settings.integrator,
    };
    settings.substeps = substeps.unwrap_or(settings.substeps);
    Ok(settings)
}

// ---------------------------------------------------------------------------
// Checks
// ---------------------------------------------------------------------------

/// The rules of a flow scene, in document order (also for scenes built in code).
pub(super) fn check_flow_scene(scene: &Scene, flow: &FlowSettings) -> Check {
    check_domain(&scene.domain)?;
    check_time(&scene.time)?;
    let snow_parts = [
        ("bodies", "[[bodies]]", scene.bodies.is_empty()),
        ("colliders", "[[colliders]]", scene.colliders.is_empty()),
        (
            "rigid_bodies",
            "[[rigid_bodies]]",
            scene.rigid_bodies.is_empty(),
        ),
        ("materials", "[materials]", scene.materials.is_empty()),
        ("wind", "[wind]", scene.wind.is_none()),
    ];
    if let Some((key, what, _)) = snow_parts.iter().find(|(_, _, empty)| !empty) {
        return Err(snow_only(
            KeyPath::of(key),
            what,
            &format!("leave Scene::{key} empty in a flow scene"),
        ));
    }
    check_flow(scene, flow)?;
    check_output(&scene.output)?;
    let mass_formats = [
        (
            CacheFormat::Vdb,
            "the \"vdb\" format (a volume of the snow's mass)",
            "remove \"vdb\" from formats: flow particles carry no mass to make a volume of",
        ),
        (
            CacheFormat::Mesh,
            "the \"mesh\" format (the surface of the snow's mass)",
            "remove \"mesh\" from formats: flow particles carry no mass to make a surface of",
        ),
    ];
    for (format, what, hint) in mass_formats {
        if let Some(index) = scene.output.formats.iter().position(|f| *f == format) {
            return Err(snow_only(
                KeyPath::of("output").key("formats").index(index),
                what,
                hint,
            ));
        }
    }
    let attributes = KeyPath::of("output").key("attributes");
    if let Some(index) = scene
        .output
        .attributes
        .iter()
        .position(|attribute| *attribute != Attribute::Velocity)
    {
        let at = attributes.index(index);
        return Err(Issue::new(
            at.clone(),
            format!("{at} is a snow attribute; flow particles carry only their velocity"),
            "use attributes = [\"velocity\"] (or [] for positions only)",
        ));
    }
    check_camera(&scene.camera)?;
    if let Some(index) = scene
        .render
        .styles
        .iter()
        .position(|style| *style == RenderStyle::Surface)
    {
        return Err(snow_only(
            KeyPath::of("render").key("styles").index(index),
            "the \"surface\" style (the snow's reconstructed surface)",
            "draw a flow as \"points\", \"billboards\" or \"trails\"",
        ));
    }
    check_render(&scene.render)
}

fn check_flow(scene: &Scene, flow: &FlowSettings) -> Check {
    let path = KeyPath::of("flow");
    check_field(&path, flow)?;
    ensure(
        (1..=MAX_SUBSTEPS).contains(&flow.substeps),
        path.key("substeps"),
        "between 1 and 1000",
        flow.substeps,
        "set the integration steps per frame, e.g. substeps = 2".to_string(),
    )?;
    check_emitters(scene, &path, flow)
}

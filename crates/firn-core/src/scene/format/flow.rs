//! The `[flow]` table of scenes with `kind = "flow"`: curl-noise particle
//! flows (seed 002, after Bridson et al. 2007).
//!
//! A child of the format module: it reuses the parent's raw scene, key paths,
//! issues and checks, so flow errors read like every other scene error
//! (file:line:col, key path, fix).

use serde::Deserialize;

use super::{
    Check, Issue, KeyPath, Num, RawScene, default_name, ensure, finite_vec, missing, not_negative,
    positive, positive_vec, reject, require, resolve_camera, resolve_output, resolve_render,
    resolve_solver, resolve_time, unit_or_zero, unit_vec, vec3,
};
use super::{
    check_camera, check_domain, check_inside_domain, check_output, check_render, check_time,
};
use crate::scene::flow::{
    FlowCurl, FlowEmission, FlowEmitter, FlowEmitterShape, FlowIntegrator, FlowObstacle,
    FlowSettings, SceneKind,
};
use crate::scene::model::{Attribute, CacheFormat, Domain, Scene};
use crate::scene::render::RenderStyle;
use crate::scene::wind::{Spindrift, Wind};

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

/// The `[flow]` table of a flow scene, and the `[wind]` table of a snow
/// scene: both give a curl-noise field with the same keys; each table
/// refuses, with a located error, the keys that belong only to the other.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawFlow {
    noise_share: Option<f32>,
    noise_strength: Option<f32>,
    length_scale: Option<f32>,
    background_direction: Option<[f32; 3]>,
    background_strength: Option<f32>,
    speed_scale: Option<f32>,
    seed: Option<u64>,
    offsets: Option<[[f32; 3]; 3]>,
    evolution_rate: Option<f32>,
    curl: Option<RawCurl>,
    curl_step: Option<f32>,
    integration: Option<RawIntegration>,
    substeps: Option<u32>,
    obstacles: Option<Vec<RawObstacle>>,
    emitters: Option<Vec<RawEmitter>>,
    drag: Option<f32>,
    packed_density: Option<f32>,
    spindrift: Option<RawSpindrift>,
}

/// The `[wind.spindrift]` table of a snow scene's wind.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSpindrift {
    threshold_speed: Option<f32>,
    loose_density: Option<f32>,
    rate: Option<f32>,
    fall_speed: Option<f32>,
    settle: Option<bool>,
}

#[derive(Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawCurl {
    Analytic,
    FiniteDifference,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawIntegration {
    Rk2,
    Rk4,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObstacle {
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    influence: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEmitter {
    shape: Option<RawEmitterShape>,
    center: Option<[f32; 3]>,
    size: Option<[f32; 3]>,
    radius: Option<f32>,
    normal: Option<[f32; 3]>,
    rate: Option<f32>,
    count: Option<u32>,
    lifetime: Option<f32>,
    lifetime_spread: Option<f32>,
    velocity: Option<[f32; 3]>,
    velocity_decay: Option<f32>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawEmitterShape {
    Box,
    Sphere,
    Disc,
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
        output,
        camera,
        render,
        kind,
        compute: super::resolve_compute(raw.compute),
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

/// The `[wind]` table of a snow scene: the field keys of `[flow]` plus the
/// drag and the packed density.
pub(super) fn resolve_wind(raw: Option<RawFlow>, domain: &Domain) -> Result<Option<Wind>, Issue> {
    let Some(mut raw) = raw else {
        return Ok(None);
    };
    let path = KeyPath::of("wind");
    for (key, given, what) in [
        (
            "emitters",
            raw.emitters.is_some(),
            "the wind carries the snow's own particles",
        ),
        (
            "integration",
            raw.integration.is_some(),
            "the snow solver integrates the drag",
        ),
        (
            "substeps",
            raw.substeps.is_some(),
            "the snow solver chooses its substeps",
        ),
    ] {
        if given {
            return Err(Issue::new(
                path.key(key),
                format!("wind.{key} is a key of flow scenes only: {what}"),
                format!("remove {key} from [wind]"),
            ));
        }
    }
    let drag = raw.drag.take().unwrap_or(Wind::DEFAULT_DRAG);
    let packed_density = raw
        .packed_density
        .take()
        .unwrap_or(Wind::DEFAULT_PACKED_DENSITY);
    let spindrift = raw.spindrift.take().map(resolve_spindrift);
    Ok(Some(Wind {
        field: resolve_field(raw, &path, domain)?,
        drag,
        packed_density,
        spindrift,
    }))
}

/// The `[wind.spindrift]` table, with the defaults of [`Spindrift`] for the
/// keys it leaves out.
fn resolve_spindrift(raw: RawSpindrift) -> Spindrift {
    let defaults = Spindrift::default();
    Spindrift {
        threshold_speed: raw.threshold_speed.unwrap_or(defaults.threshold_speed),
        loose_density: raw.loose_density.unwrap_or(defaults.loose_density),
        rate: raw.rate.unwrap_or(defaults.rate),
        fall_speed: raw.fall_speed.unwrap_or(defaults.fall_speed),
        settle: raw.settle.unwrap_or(defaults.settle),
    }
}

/// The field keys shared by `[flow]` and `[wind]` (at `path`), with the
/// defaults for `domain`; no emitters.
fn resolve_field(raw: RawFlow, path: &KeyPath, domain: &Domain) -> Result<FlowSettings, Issue> {
    // L defaults to a fifth of the domain, as in the seed's scene (L ≈ 20 in
    // 100 units), and M to L / 4 (see `FlowSettings::for_extent`).
    let defaults = FlowSettings::for_domain(domain);
    let length_scale = raw.length_scale.unwrap_or(defaults.length_scale);
    let noise_strength = raw
        .noise_strength
        .unwrap_or_else(|| FlowSettings::default_noise_strength(length_scale));

    let curl = match raw.curl.unwrap_or(RawCurl::Analytic) {
        RawCurl::Analytic => {
            if raw.curl_step.is_some() {
                return Err(Issue::new(
                    path.key("curl_step"),
                    format!("{path}.curl_step only applies when curl = \"finite-difference\""),
                    "remove curl_step, or set curl = \"finite-difference\"",
                ));
            }
            FlowCurl::Analytic
        }
        RawCurl::FiniteDifference => FlowCurl::FiniteDifference {
            step: raw
                .curl_step
                .unwrap_or_else(|| FlowSettings::default_curl_step(length_scale)),
        },
    };

    let mut obstacles = Vec::new();
    for (index, obstacle) in raw.obstacles.unwrap_or_default().into_iter().enumerate() {
        let at = path.key("obstacles").index(index);
        let radius = require(obstacle.radius, at.key("radius"), "the radius in metres")?;
        let center = vec3(require(obstacle.center, at.key("center"), "the centre")?);
        let mut resolved = FlowObstacle::new(center, radius);
        if let Some(influence) = obstacle.influence {
            resolved = resolved.influence(influence);
        }
        obstacles.push(resolved);
    }

    Ok(FlowSettings {
        noise_share: raw.noise_share.unwrap_or(defaults.noise_share),
        noise_strength,
        length_scale,
        background_direction: raw
            .background_direction
            .map_or(defaults.background_direction, unit_or_zero),
        background_strength: raw
            .background_strength
            .unwrap_or(defaults.background_strength),
        speed_scale: raw.speed_scale.unwrap_or(defaults.speed_scale),
        seed: raw.seed.unwrap_or(defaults.seed),
        offsets: raw.offsets.map(|offsets| offsets.map(vec3)),
        evolution_rate: raw.evolution_rate.unwrap_or(defaults.evolution_rate),
        curl,
        obstacles,
        ..defaults
    })
}

fn resolve_emitter(path: &KeyPath, raw: RawEmitter) -> Result<FlowEmitter, Issue> {
    let shape_kind = raw.shape.ok_or_else(|| {
        missing(path.key("shape"), "the region particles are born in")
            .with_hint("add shape = \"box\", \"sphere\" or \"disc\" with its dimensions")
    })?;
    let center = vec3(require(raw.center, path.key("center"), "the centre")?);
    let shape = match shape_kind {
        RawEmitterShape::Box => {
            let takes = "center and size";
            reject(&raw.radius, path.key("radius"), "box", takes)?;
            reject(&raw.normal, path.key("normal"), "box", takes)?;
            FlowEmitterShape::Box {
                center,
                size: vec3(require(raw.size, path.key("size"), "the edge lengths")?),
            }
        }
        RawEmitterShape::Sphere => {
            let takes = "center and radius";
            reject(&raw.size, path.key("size"), "sphere", takes)?;
            reject(&raw.normal, path.key("normal"), "sphere", takes)?;
            FlowEmitterShape::Sphere {
                center,
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
            }
        }
        RawEmitterShape::Disc => {
            reject(
                &raw.size,
                path.key("size"),
                "disc",
                "center, radius and normal",
            )?;
            FlowEmitterShape::Disc {
                center,
                radius: require(raw.radius, path.key("radius"), "the radius in metres")?,
                normal: unit_or_zero(raw.normal.unwrap_or([0.0, 1.0, 0.0])),
            }
        }
    };
    let emission = match (raw.rate, raw.count) {
        (Some(_), Some(_)) => {
            return Err(Issue::new(
                path.key("count"),
                format!("{path} has both rate and count"),
                "an emitter makes either `rate` particles per second or `count` particles at \
                 the start; remove one of the two",
            ));
        }
        (Some(rate), None) => FlowEmission::Rate(rate),
        (None, Some(count)) => FlowEmission::Count(count),
        (None, None) => {
            return Err(Issue::new(
                path.key("count"),
                format!("{path} needs `rate` or `count`"),
                "add count = 10000 (all born at the start) or rate = 1000.0 (particles per \
                 second)",
            )
            .pointing_at(path.clone()));
        }
    };
    if raw.lifetime.is_none() && raw.lifetime_spread.is_some() {
        return Err(Issue::new(
            path.key("lifetime_spread"),
            format!("{path}.lifetime_spread needs a lifetime"),
            "add lifetime = 8.0 (seconds), or remove lifetime_spread",
        ));
    }
    if raw.velocity.is_none() && raw.velocity_decay.is_some() {
        return Err(Issue::new(
            path.key("velocity_decay"),
            format!("{path}.velocity_decay only applies with a velocity"),
            "add velocity = [0.0, 5.0, 0.0], or remove velocity_decay",
        ));
    }
    let defaults = FlowEmitter::new(shape, emission);
    Ok(FlowEmitter {
        lifetime: raw.lifetime,
        lifetime_spread: raw.lifetime_spread.unwrap_or(defaults.lifetime_spread),
        velocity: raw.velocity.map_or(defaults.velocity, vec3),
        velocity_decay: raw.velocity_decay.unwrap_or(defaults.velocity_decay),
        ..defaults
    })
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

/// The rules of `[wind]` in a snow scene.
pub(super) fn check_wind(wind: &Wind) -> Check {
    let path = KeyPath::of("wind");
    check_field(&path, &wind.field)?;
    if !wind.field.emitters.is_empty() {
        return Err(Issue::new(
            path.key("emitters"),
            "a wind has no emitters: it carries the snow's own particles",
            "leave Wind::field.emitters empty",
        ));
    }
    not_negative(
        wind.drag,
        path.key("drag"),
        format!(
            "set the drag per exposed area per m/s, e.g. drag = {} kg/(m² s) (air on a rough \
             body at about 10 m/s; 0: no drag)",
            Wind::DEFAULT_DRAG
        ),
    )?;
    positive(
        wind.packed_density,
        path.key("packed_density"),
        format!(
            "set the density in kg/m³ above which snow is sheltered inside, e.g. \
             packed_density = {}",
            Wind::DEFAULT_PACKED_DENSITY
        ),
    )?;
    match &wind.spindrift {
        Some(spindrift) => check_spindrift(&path.key("spindrift"), spindrift),
        None => Ok(()),
    }
}

/// The rules of `[wind.spindrift]`, at `path`.
fn check_spindrift(path: &KeyPath, spindrift: &Spindrift) -> Check {
    not_negative(
        spindrift.threshold_speed,
        path.key("threshold_speed"),
        format!(
            "set the relative wind speed in m/s above which loose surface snow lifts, e.g. \
             threshold_speed = {}",
            Spindrift::DEFAULT_THRESHOLD_SPEED
        ),
    )?;
    positive(
        spindrift.loose_density,
        path.key("loose_density"),
        format!(
            "set the density in kg/m³ below which snow is loose enough to lift, e.g. \
             loose_density = {}",
            Spindrift::DEFAULT_LOOSE_DENSITY
        ),
    )?;
    not_negative(
        spindrift.rate,
        path.key("rate"),
        format!(
            "set the detachments per second of an exposed loose particle, e.g. rate = {} \
             (0: none lifts)",
            Spindrift::DEFAULT_RATE
        ),
    )?;
    not_negative(
        spindrift.fall_speed,
        path.key("fall_speed"),
        format!(
            "set the speed in m/s at which drift falls through still air, e.g. fall_speed = {}",
            Spindrift::DEFAULT_FALL_SPEED
        ),
    )
}

/// The field keys shared by `[flow]` and `[wind]`, at `path`.
fn check_field(path: &KeyPath, flow: &FlowSettings) -> Check {
    ensure(
        (0.0..=1.0).contains(&flow.noise_share),
        path.key("noise_share"),
        "in [0, 1]",
        Num::from(flow.noise_share),
        "set the share γ of turbulence, e.g. noise_share = 0.5 (0: background flow only, 1: \
         noise only)"
            .to_string(),
    )?;
    not_negative(
        flow.noise_strength,
        path.key("noise_strength"),
        "set the turbulence strength M, e.g. noise_strength = 5.0 (the rms speed is about 4.2 γ M / L)"
            .to_string(),
    )?;
    positive(
        flow.length_scale,
        path.key("length_scale"),
        "set the noise length scale L in metres, e.g. length_scale = 20.0 for a 100 m domain"
            .to_string(),
    )?;
    unit_vec(flow.background_direction, path.key("background_direction"))?;
    not_negative(
        flow.background_strength,
        path.key("background_strength"),
        "set the background speed M_f, e.g. background_strength = 1.0 (its direction is \
         background_direction)"
            .to_string(),
    )?;
    not_negative(
        flow.speed_scale,
        path.key("speed_scale"),
        "set the global speed factor, e.g. speed_scale = 1.0".to_string(),
    )?;
    if let Some(offsets) = flow.offsets {
        for (index, offset) in offsets.iter().enumerate() {
            finite_vec(*offset, path.key("offsets").index(index))?;
        }
    }
    not_negative(
        flow.evolution_rate,
        path.key("evolution_rate"),
        "set how many noise cells the turbulence drifts per second, e.g. evolution_rate = \
         0.05 (0: steady)"
            .to_string(),
    )?;
    if let FlowCurl::FiniteDifference { step } = flow.curl {
        positive(
            step,
            path.key("curl_step"),
            format!(
                "set the difference step in metres, e.g. curl_step = {} (L / 1000)",
                Num::from(flow.length_scale * 1e-3)
            ),
        )?;
        ensure(
            step <= 0.1 * flow.length_scale,
            path.key("curl_step"),
            &format!("at most a tenth of {path}.length_scale"),
            Num::from(step),
            format!(
                "a step that large blurs the noise; use curl_step = {} (L / 1000)",
                Num::from(flow.length_scale * 1e-3)
            ),
        )?;
    }
    for (index, obstacle) in flow.obstacles.iter().enumerate() {
        let at = path.key("obstacles").index(index);
        finite_vec(obstacle.center, at.key("center"))?;
        positive(
            obstacle.radius,
            at.key("radius"),
            "set the sphere's radius in metres, e.g. radius = 15.0".to_string(),
        )?;
        positive(
            obstacle.influence,
            at.key("influence"),
            "set the distance from the surface over which the flow turns to pass the sphere, \
             e.g. influence = 10.0"
                .to_string(),
        )?;
    }
    Ok(())
}

/// The emitters of a flow scene and the particle slots they need.
fn check_emitters(scene: &Scene, path: &KeyPath, flow: &FlowSettings) -> Check {
    if flow.emitters.is_empty() {
        return Err(Issue::new(
            path.key("emitters"),
            "the flow has no particles: there is no [[flow.emitters]] table",
            "add [[flow.emitters]] with shape = \"box\", center, size and count = 10000",
        )
        .pointing_at(path.clone()));
    }
    let mut slots: u64 = 0;
    for (index, emitter) in flow.emitters.iter().enumerate() {
        let at = path.key("emitters").index(index);
        check_emitter(scene, &at, emitter)?;
        slots = slots.saturating_add(emitter.slots(scene.time.duration));
        if slots > MAX_FLOW_PARTICLES {
            let key = match emitter.emission {
                FlowEmission::Rate(_) => "rate",
                FlowEmission::Count(_) => "count",
            };
            return Err(Issue::new(
                at.key(key),
                format!(
                    "the emitters up to {at} need {slots} particles; the limit is 2^26 = \
                     {MAX_FLOW_PARTICLES}"
                ),
                "lower count or rate, or shorten lifetime (a rate emitter keeps rate × \
                 lifetime particles alive)",
            ));
        }
    }
    Ok(())
}

fn emitter_shape_name(shape: &FlowEmitterShape) -> &'static str {
    match shape {
        FlowEmitterShape::Box { .. } => "box",
        FlowEmitterShape::Sphere { .. } => "sphere",
        FlowEmitterShape::Disc { .. } => "disc",
    }
}

fn check_emitter(scene: &Scene, path: &KeyPath, emitter: &FlowEmitter) -> Check {
    match emitter.shape {
        FlowEmitterShape::Box { center, size } => {
            finite_vec(center, path.key("center"))?;
            positive_vec(
                size,
                path.key("size"),
                "set the edge lengths in metres, e.g. size = [10.0, 10.0, 10.0]".to_string(),
            )?;
        }
        FlowEmitterShape::Sphere { center, radius } => {
            finite_vec(center, path.key("center"))?;
            positive(
                radius,
                path.key("radius"),
                "set the radius in metres, e.g. radius = 5.0".to_string(),
            )?;
        }
        FlowEmitterShape::Disc {
            center,
            radius,
            normal,
        } => {
            finite_vec(center, path.key("center"))?;
            positive(
                radius,
                path.key("radius"),
                "set the radius in metres, e.g. radius = 5.0".to_string(),
            )?;
            unit_vec(normal, path.key("normal"))?;
        }
    }
    match emitter.emission {
        FlowEmission::Rate(rate) => positive(
            rate,
            path.key("rate"),
            "set the particles born per second, e.g. rate = 1000.0".to_string(),
        )?,
        FlowEmission::Count(count) => ensure(
            count >= 1,
            path.key("count"),
            "at least 1",
            count,
            "set the number of particles, e.g. count = 10000".to_string(),
        )?,
    }
    if let Some(lifetime) = emitter.lifetime {
        positive(
            lifetime,
            path.key("lifetime"),
            "set how many seconds a particle lives, e.g. lifetime = 8.0".to_string(),
        )?;
    }
    ensure(
        (0.0..1.0).contains(&emitter.lifetime_spread),
        path.key("lifetime_spread"),
        "in [0, 1)",
        Num::from(emitter.lifetime_spread),
        "set the relative spread of lifetimes, e.g. lifetime_spread = 0.25".to_string(),
    )?;
    finite_vec(emitter.velocity, path.key("velocity"))?;
    positive(
        emitter.velocity_decay,
        path.key("velocity_decay"),
        "set the seconds over which the birth velocity fades, e.g. velocity_decay = 1.0"
            .to_string(),
    )?;

    check_inside_domain(
        path,
        emitter_shape_name(&emitter.shape),
        emitter.shape.bounds(),
        &scene.domain,
        "move or shrink the emitter so that it lies inside domain.min .. domain.max \
         (particles outside the domain are born again at once)",
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_emitters_keep_rate_times_lifetime_slots() {
        let emitter = FlowEmitter {
            shape: FlowEmitterShape::Sphere {
                center: glam::Vec3::ZERO,
                radius: 1.0,
            },
            emission: FlowEmission::Rate(100.0),
            lifetime: Some(2.5),
            lifetime_spread: 0.0,
            velocity: glam::Vec3::ZERO,
            velocity_decay: 1.0,
        };
        assert_eq!(emitter.slots(10.0), 250);
        let forever = FlowEmitter {
            lifetime: None,
            ..emitter
        };
        assert_eq!(forever.slots(10.0), 1001);
    }
}

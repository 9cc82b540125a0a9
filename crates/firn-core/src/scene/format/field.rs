//! Reads and checks the curl-noise field keys that `[flow]` and `[wind]` share.

use serde::Deserialize;

use super::emitters::RawEmitter;
use super::flow::RawIntegration;
use super::issue::{Check, Issue, KeyPath};
use super::values::{
    Num, ensure, finite_vec, not_negative, positive, require, unit_or_zero, unit_vec, vec3,
};
use super::wind::RawSpindrift;
use crate::scene::flow::{FlowCurl, FlowObstacle, FlowSettings};
use crate::scene::model::Domain;

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
    pub(super) integration: Option<RawIntegration>,
    pub(super) substeps: Option<u32>,
    obstacles: Option<Vec<RawObstacle>>,
    pub(super) emitters: Option<Vec<RawEmitter>>,
    pub(super) drag: Option<f32>,
    pub(super) packed_density: Option<f32>,
    pub(super) spindrift: Option<RawSpindrift>,
}

#[derive(Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum RawCurl {
    Analytic,
    FiniteDifference,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawObstacle {
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    influence: Option<f32>,
}

/// The field keys shared by `[flow]` and `[wind]` (at `path`), with the
/// defaults for `domain`; no emitters.
pub(super) fn resolve_field(
    raw: RawFlow,
    path: &KeyPath,
    domain: &Domain,
) -> Result<FlowSettings, Issue> {
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

/// The field keys shared by `[flow]` and `[wind]`, at `path`.
pub(super) fn check_field(path: &KeyPath, flow: &FlowSettings) -> Check {
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

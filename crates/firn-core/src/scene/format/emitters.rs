//! Reads and checks the `[[flow.emitters]]` tables of a flow scene: where particles are born.

use serde::Deserialize;

use super::MAX_FLOW_PARTICLES;
use super::issue::{Check, Issue, KeyPath};
use super::shapes::check_inside_domain;
use super::values::{
    Num, ensure, finite_vec, missing, positive, positive_vec, reject, require, unit_or_zero,
    unit_vec, vec3,
};
use crate::scene::flow::{FlowEmission, FlowEmitter, FlowEmitterShape, FlowSettings};
use crate::scene::model::Scene;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawEmitter {
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

pub(super) fn resolve_emitter(path: &KeyPath, raw: RawEmitter) -> Result<FlowEmitter, Issue> {
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

/// The emitters of a flow scene and the particle slots they need.
pub(super) fn check_emitters(scene: &Scene, path: &KeyPath, flow: &FlowSettings) -> Check {
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

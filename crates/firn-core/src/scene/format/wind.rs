//! Reads and checks the `[wind]` table of a snow scene and its `[wind.spindrift]`.

use serde::Deserialize;

use super::field::{RawFlow, check_field, resolve_field};
use super::issue::{Check, Issue, KeyPath};
use super::values::{not_negative, positive};
use crate::scene::model::Domain;
use crate::scene::wind::{Spindrift, Wind};

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

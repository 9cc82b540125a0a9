//! Reads and checks the `[render]` table: the pictures drawn of each frame.

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{ensure, first_duplicate, positive};
use crate::scene::render::{ColorBy, RenderSettings, RenderStyle};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawRender {
    enabled: Option<bool>,
    styles: Option<Vec<RenderStyle>>,
    size: Option<[u32; 2]>,
    color_by: Option<ColorBy>,
    legend: Option<bool>,
    point_radius: Option<f32>,
    trail_length: Option<u32>,
    smooth_trails: Option<bool>,
}

pub(super) fn resolve_render(raw: Option<RawRender>) -> RenderSettings {
    let defaults = RenderSettings::default();
    let Some(raw) = raw else {
        return defaults;
    };
    RenderSettings {
        enabled: raw.enabled.unwrap_or(defaults.enabled),
        styles: raw.styles.unwrap_or(defaults.styles),
        size: raw.size.unwrap_or(defaults.size),
        color_by: raw.color_by.unwrap_or(defaults.color_by),
        legend: raw.legend.unwrap_or(defaults.legend),
        point_radius: raw.point_radius,
        trail_length: raw.trail_length.unwrap_or(defaults.trail_length),
        smooth_trails: raw.smooth_trails.unwrap_or(defaults.smooth_trails),
    }
}

pub(super) fn check_render(render: &RenderSettings) -> Check {
    let path = KeyPath::of("render");
    let [width, height] = render.size;
    ensure(
        (16..=8192).contains(&width) && (16..=8192).contains(&height),
        path.key("size"),
        "between 16 and 8192 pixels on each side",
        format!("[{width}, {height}]"),
        "e.g. size = [960, 540]".to_string(),
    )?;
    if let Some(index) = first_duplicate(&render.styles) {
        let at = path.key("styles").index(index);
        return Err(Issue::new(
            at.clone(),
            format!("{at} lists a style twice"),
            "list each style once, e.g. styles = [\"points\", \"volume\"]",
        ));
    }
    if let Some(radius) = render.point_radius {
        positive(
            radius,
            path.key("point_radius"),
            "give the sprite radius in metres, e.g. point_radius = 0.005".to_string(),
        )?;
    }
    ensure(
        (2..=256).contains(&render.trail_length),
        path.key("trail_length"),
        "between 2 and 256 positions",
        render.trail_length,
        "e.g. trail_length = 16".to_string(),
    )
}

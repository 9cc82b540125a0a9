//! Reads and checks the `[camera]` table: a fixed, orbiting or keyed view of the scene.

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{Num, ensure, finite_vec, format_vec, require, vec3};
use crate::scene::render::{Camera, CameraKey, Orbit};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawCamera {
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
    fov: Option<f32>,
    orbit: Option<f32>,
    path: Option<Vec<RawCameraKey>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCameraKey {
    time: Option<f64>,
    position: Option<[f32; 3]>,
    look_at: Option<[f32; 3]>,
}

pub(super) fn resolve_camera(raw: Option<RawCamera>) -> Result<Camera, Issue> {
    let Some(raw) = raw else {
        return Ok(Camera::default());
    };
    let defaults = Camera::default();
    let mut path = Vec::new();
    for (index, key) in raw.path.unwrap_or_default().into_iter().enumerate() {
        let at = KeyPath::of("camera").key("path").index(index);
        path.push(CameraKey {
            time: require(key.time, at.key("time"), "the simulated time of this view")?,
            position: vec3(require(
                key.position,
                at.key("position"),
                "the eye position",
            )?),
            look_at: vec3(require(
                key.look_at,
                at.key("look_at"),
                "the point looked at",
            )?),
        });
    }
    Ok(Camera {
        position: raw.position.map(vec3),
        look_at: raw.look_at.map(vec3),
        fov_degrees: raw.fov.unwrap_or(defaults.fov_degrees),
        orbit: raw
            .orbit
            .map(|degrees_per_second| Orbit { degrees_per_second }),
        path,
    })
}

pub(super) fn check_camera(camera: &Camera) -> Check {
    let path = KeyPath::of("camera");
    if let Some(position) = camera.position {
        finite_vec(position, path.key("position"))?;
    }
    if let Some(look_at) = camera.look_at {
        finite_vec(look_at, path.key("look_at"))?;
    }
    if let (Some(position), Some(look_at)) = (camera.position, camera.look_at) {
        ensure(
            position.distance(look_at) > 0.0,
            path.key("look_at"),
            "away from camera.position",
            format_vec(look_at),
            "look at a point in front of the camera, e.g. the centre of the snow".to_string(),
        )?;
    }
    ensure(
        camera.fov_degrees > 1.0 && camera.fov_degrees < 170.0,
        path.key("fov"),
        "between 1 and 170 degrees",
        Num::from(camera.fov_degrees),
        "use a vertical field of view such as fov = 40".to_string(),
    )?;
    if let Some(orbit) = camera.orbit {
        ensure(
            orbit.degrees_per_second.is_finite(),
            path.key("orbit"),
            "a finite number of degrees per second",
            Num::from(orbit.degrees_per_second),
            "e.g. orbit = 30.0".to_string(),
        )?;
    }
    for (index, key) in camera.path.iter().enumerate() {
        let at = path.key("path").index(index);
        finite_vec(key.position, at.key("position"))?;
        finite_vec(key.look_at, at.key("look_at"))?;
        ensure(
            key.position.distance(key.look_at) > 0.0,
            at.key("look_at"),
            "away from the eye position",
            format_vec(key.look_at),
            "look at a point in front of the camera".to_string(),
        )?;
        if index > 0 {
            ensure(
                key.time > camera.path[index - 1].time,
                at.key("time"),
                "later than the previous key's time",
                Num::from(key.time),
                "list the camera path keys in increasing time".to_string(),
            )?;
        }
    }
    Ok(())
}

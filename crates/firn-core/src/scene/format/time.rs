//! Reads and checks the `[time]` table: duration, frame rate and the time step.

use serde::Deserialize;

use super::issue::{Check, Issue, KeyPath};
use super::values::{Num, ensure, positive, require};
use crate::scene::material::Material;
use crate::scene::model::{Scene, TimeSettings, TimeStep};

/// Most output frames a scene may have: frame numbers keep their five
/// digits in the cache and picture names, so the files sort.
pub const MAX_FRAMES: u32 = 99_999;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTime {
    duration: Option<f64>,
    fps: Option<f64>,
    pub(super) step: Option<RawStep>,
    pub(super) dt: Option<f32>,
    pub(super) cfl: Option<f32>,
    pub(super) max_substeps_per_frame: Option<u32>,
}

#[derive(Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RawStep {
    Adaptive,
    Fixed,
}

pub(super) fn resolve_time(raw: Option<RawTime>) -> Result<TimeSettings, Issue> {
    let path = KeyPath::of("time");
    let raw = raw.ok_or_else(|| {
        Issue::new(
            path.clone(),
            "the scene has no [time] table",
            "add a [time] table with the simulated duration, e.g. [time] duration = 2.0",
        )
    })?;
    let duration = require(
        raw.duration,
        path.key("duration"),
        "the simulated time in seconds",
    )?;
    let fps = raw.fps.unwrap_or(TimeSettings::DEFAULT_FPS);
    let step = match raw.step.unwrap_or(RawStep::Adaptive) {
        RawStep::Fixed => {
            if raw.cfl.is_some() {
                return Err(Issue::new(
                    path.key("cfl"),
                    "time.cfl only applies when step = \"adaptive\"",
                    "remove cfl, or set step = \"adaptive\"",
                ));
            }
            let dt = raw.dt.ok_or_else(|| {
                Issue::new(
                    path.key("dt"),
                    "time.step is \"fixed\" but time.dt is missing",
                    "add the step length in seconds, e.g. dt = 0.001, or use step = \"adaptive\"",
                )
                .pointing_at(path.key("step"))
            })?;
            TimeStep::Fixed { dt }
        }
        RawStep::Adaptive => TimeStep::Adaptive {
            cfl: raw.cfl.unwrap_or(TimeStep::DEFAULT_CFL),
            // The default bound never exceeds one frame.
            max_dt: raw.dt.unwrap_or_else(|| TimeStep::default_max_dt(fps)),
        },
    };
    Ok(TimeSettings {
        duration,
        fps,
        step,
        max_substeps_per_frame: raw
            .max_substeps_per_frame
            .unwrap_or(TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME),
    })
}

pub(super) fn check_time(time: &TimeSettings) -> Check {
    let path = KeyPath::of("time");
    positive(
        time.duration,
        path.key("duration"),
        "set the simulated time in seconds, e.g. duration = 2.0".to_string(),
    )?;
    positive(
        time.fps,
        path.key("fps"),
        "set the output frames per simulated second, e.g. fps = 30".to_string(),
    )?;
    check_frame_count(time)?;
    ensure(
        time.max_substeps_per_frame >= 1,
        path.key("max_substeps_per_frame"),
        "at least 1",
        time.max_substeps_per_frame,
        format!(
            "allow the frames some substeps, e.g. max_substeps_per_frame = {}",
            TimeSettings::DEFAULT_MAX_SUBSTEPS_PER_FRAME
        ),
    )?;
    let frame = 1.0 / time.fps;
    let (dt, what) = match time.step {
        TimeStep::Fixed { dt } => (dt, "the fixed step"),
        TimeStep::Adaptive { cfl, max_dt } => {
            ensure(
                cfl > 0.0 && cfl <= 1.0,
                path.key("cfl"),
                "in (0, 1]",
                Num::from(cfl),
                "set the CFL number, the fraction of a cell crossed per step, e.g. cfl = 0.4"
                    .to_string(),
            )?;
            (max_dt, "the largest adaptive step")
        }
    };
    positive(
        dt,
        path.key("dt"),
        format!("set {what} in seconds, e.g. dt = 0.001"),
    )?;
    if f64::from(dt) > frame * (1.0 + 1e-6) {
        return Err(Issue::new(
            path.key("dt"),
            format!(
                "time.dt must not exceed one frame (1/fps = {}), but it is {}; {what} would \
                 skip frames",
                Num(frame),
                Num::from(dt)
            ),
            format!("use dt = {} or less, or lower fps", Num(frame.min(1e-3))),
        ));
    }
    Ok(())
}

/// The duration and frame rate must make at most [`MAX_FRAMES`] frames.
fn check_frame_count(time: &TimeSettings) -> Check {
    let frames = (time.duration * time.fps - 1e-9).ceil();
    if frames <= f64::from(MAX_FRAMES) {
        return Ok(());
    }
    Err(Issue::new(
        KeyPath::of("time").key("duration"),
        format!(
            "time.duration = {} s at {} fps makes {} frames; the limit is {MAX_FRAMES} (frame \
             numbers keep five digits in file names)",
            Num(time.duration),
            Num(time.fps),
            Num(frames)
        ),
        format!(
            "simulate at most {} s at this frame rate, or lower fps",
            Num(f64::from(MAX_FRAMES) / time.fps)
        ),
    ))
}

/// The first substep must leave a frame at most
/// `time.max_substeps_per_frame` substeps; the error names what makes the
/// step short: the fixed or capped step, the fastest body, or the stiffest
/// material.
pub(super) fn check_first_step(scene: &Scene) -> Check {
    let time = &scene.time;
    let first = scene.first_step();
    let limit = time.max_substeps_per_frame;
    if first.substeps_per_frame <= f64::from(limit) {
        return Ok(());
    }
    let too_many = format!(
        "a frame (1/fps = {} s) would take {} substeps, more than time.max_substeps_per_frame \
         = {limit}",
        Num(1.0 / time.fps),
        Num(first.substeps_per_frame)
    );
    let raise = "or raise [time] max_substeps_per_frame if the frames really need that many \
                 substeps";
    let shortest = Num(time.shortest_dt());
    let dt_path = KeyPath::of("time").key("dt");
    let (cfl, max_dt) = match time.step {
        TimeStep::Fixed { dt } => {
            return Err(Issue::new(
                dt_path,
                format!("time.dt = {} s is too short: {too_many}", Num::from(dt)),
                format!("use dt = {shortest} or more, lower fps, {raise}"),
            ));
        }
        TimeStep::Adaptive { cfl, max_dt } => (cfl, max_dt),
    };
    if first.dt >= max_dt {
        return Err(Issue::new(
            dt_path,
            format!(
                "time.dt = {} s caps the adaptive step so low that {too_many}",
                Num::from(max_dt)
            ),
            format!("use dt = {shortest} or more, lower fps, {raise}"),
        ));
    }
    let h = scene.domain.cell_size;
    let step = format!(
        "the adaptive step starts at Δt = {} s (cfl {} × cell_size {} m / ({} m/s of the \
         fastest body + {} m/s of elastic waves)), so {too_many}",
        Num::from(first.dt),
        Num::from(cfl),
        Num::from(h),
        Num::from(first.speed),
        Num::from(first.wave_speed)
    );
    // Speeds at which a frame takes `limit` substeps, all told.
    let speed_budget = f64::from(cfl) * f64::from(h) / time.shortest_dt();
    if first.speed >= first.wave_speed {
        let (index, body) = scene
            .bodies
            .iter()
            .enumerate()
            .max_by(|a, b| {
                a.1.velocity
                    .length_squared()
                    .total_cmp(&b.1.velocity.length_squared())
            })
            .expect("a body is the fastest");
        let path = KeyPath::of("bodies").index(index).key("velocity");
        let slower = speed_budget - f64::from(first.wave_speed);
        let hint = if slower > 0.0 {
            format!(
                "give it at most {} m/s, use a larger cell_size, {raise}",
                Num(slower)
            )
        } else {
            format!("give it a lower speed and use a larger cell_size, {raise}")
        };
        return Err(Issue::new(
            path.clone(),
            format!(
                "{path} is {} m/s: {step}",
                Num(body.velocity.as_dvec3().length())
            ),
            hint,
        ));
    }
    let stiffest = scene
        .bodies
        .iter()
        .filter_map(|body| scene.materials.get(body.material))
        .max_by(|a, b| {
            let speed = |m: &Material| {
                let (mu, lambda) = m.lame();
                (lambda + 2.0 * mu) / m.density
            };
            speed(a).total_cmp(&speed(b))
        })
        .expect("a body's material is the stiffest");
    let path = KeyPath::of("materials").key(&stiffest.name);
    Err(Issue::new(
        path.key("youngs_modulus"),
        format!(
            "{path} carries elastic waves at {} m/s (E = {} Pa, density {} kg/m³): {step}",
            Num::from(first.wave_speed),
            Num::from(stiffest.youngs_modulus),
            Num::from(stiffest.density)
        ),
        format!(
            "use a softer material (lower youngs_modulus), integrator = \"semi-implicit\" in \
             [solver] (elastic waves do not limit its step), a larger cell_size, {raise}"
        ),
    ))
}

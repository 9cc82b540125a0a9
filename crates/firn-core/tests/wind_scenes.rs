//! `[wind]` in snow scenes: defaults, the field keys shared with `[flow]`,
//! and bad input located by line and key with a fix.

use firn_core::scene::{FlowCurl, Spindrift, Wind};
use firn_core::{Scene, SceneError};
use glam::Vec3;

/// A valid snow scene, 13 lines long; a [wind] table follows on line 14.
const SNOW: &str = "format = 1

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.05

[time]
duration = 0.5

[[bodies]]
shape = \"sphere\"
center = [0.5, 0.5, 0.5]
radius = 0.1
";

fn load(text: &str) -> Scene {
    Scene::from_toml_str(text, "scenes/windy.toml").unwrap_or_else(|err| panic!("{err}"))
}

fn error(text: &str) -> SceneError {
    match Scene::from_toml_str(text, "scenes/bad.toml") {
        Ok(_) => panic!("scene should not load:\n{text}"),
        Err(err) => err,
    }
}

/// Assert an error's line, key and that its message and hint mention
/// `says` and `hint`.
#[track_caller]
fn check(err: &SceneError, line: usize, key: &str, says: &str, hint: &str) {
    assert_eq!(err.line, Some(line), "wrong line:\n{err}");
    assert_eq!(err.key.as_deref(), Some(key), "wrong key:\n{err}");
    assert!(err.message.contains(says), "should say {says:?}:\n{err}");
    assert!(
        err.hint.contains(hint),
        "hint should mention {hint:?}:\n{err}"
    );
}

#[test]
fn a_scene_without_wind_has_none() {
    assert_eq!(load(SNOW).wind, None);
}

#[test]
fn an_empty_wind_table_takes_the_defaults() {
    let scene = load(&format!("{SNOW}\n[wind]\n"));
    let wind = scene.wind.expect("a wind");
    assert_eq!(wind.drag, Wind::DEFAULT_DRAG);
    assert_eq!(wind.packed_density, Wind::DEFAULT_PACKED_DENSITY);
    // The field's defaults are those of a flow over the same domain: L is a
    // fifth of the largest extent, the background blows along +x.
    assert_eq!(wind.field.length_scale, 0.2);
    assert_eq!(wind.field.background_direction, Vec3::X);
    assert!(wind.field.emitters.is_empty());
}

#[test]
fn every_wind_key_is_read() {
    let scene = load(&format!(
        "{SNOW}
[wind]
drag = 12.5
packed_density = 350.0
noise_share = 0.25
noise_strength = 0.4
length_scale = 0.3
background_direction = [0.0, 0.0, 2.0]
background_strength = 8.0
speed_scale = 1.5
seed = 9
evolution_rate = 0.75
curl = \"finite-difference\"
curl_step = 0.001

[[wind.obstacles]]
center = [0.5, 0.2, 0.5]
radius = 0.1
"
    ));
    let wind = scene.wind.expect("a wind");
    assert_eq!(wind.drag, 12.5);
    assert_eq!(wind.packed_density, 350.0);
    let field = &wind.field;
    assert_eq!(field.noise_share, 0.25);
    assert_eq!(field.noise_strength, 0.4);
    assert_eq!(field.length_scale, 0.3);
    assert_eq!(field.background_direction, Vec3::Z);
    assert_eq!(field.background_strength, 8.0);
    assert_eq!(field.speed_scale, 1.5);
    assert_eq!(field.seed, 9);
    assert_eq!(field.evolution_rate, 0.75);
    assert_eq!(field.curl, FlowCurl::FiniteDifference { step: 0.001 });
    assert_eq!(field.obstacles.len(), 1);
    assert_eq!(field.background_speed(), 0.75 * 8.0 * 1.5);
}

#[test]
fn bad_wind_values_are_located() {
    let err = error(&format!("{SNOW}\n[wind]\ndrag = -1.0\n"));
    check(
        &err,
        16,
        "wind.drag",
        "wind.drag must be 0 or more",
        "drag = 6",
    );
    let err = error(&format!("{SNOW}\n[wind]\npacked_density = 0.0\n"));
    check(
        &err,
        16,
        "wind.packed_density",
        "greater than 0",
        "packed_density = 400",
    );
    let err = error(&format!("{SNOW}\n[wind]\nnoise_share = 1.5\n"));
    check(
        &err,
        16,
        "wind.noise_share",
        "in [0, 1]",
        "noise_share = 0.5",
    );
    let err = error(&format!("{SNOW}\n[wind]\ncurl_step = 0.01\n"));
    check(
        &err,
        16,
        "wind.curl_step",
        "wind.curl_step only applies",
        "finite-difference",
    );
}

#[test]
fn flow_only_keys_are_refused_in_a_wind() {
    let err = error(&format!("{SNOW}\n[wind]\nsubsteps = 4\n"));
    check(
        &err,
        16,
        "wind.substeps",
        "a key of flow scenes only",
        "remove substeps",
    );
    let err = error(&format!(
        "{SNOW}\n[wind]\n[[wind.emitters]]\nshape = \"box\"\ncount = 3\n"
    ));
    check(
        &err,
        16,
        "wind.emitters",
        "a key of flow scenes only",
        "remove emitters",
    );
}

#[test]
fn wind_and_flow_keys_stay_in_their_scenes() {
    let flow = "format = 1
kind = \"flow\"

[domain]
max = [10.0, 10.0, 10.0]

[time]
duration = 1.0

[flow]
drag = 3.0

[[flow.emitters]]
shape = \"box\"
center = [5.0, 5.0, 5.0]
size = [1.0, 1.0, 1.0]
count = 10
";
    let err = error(flow);
    check(&err, 11, "flow.drag", "a key of [wind]", "remove drag");
    let windy_flow = flow.replace("drag = 3.0\n", "").replace(
        "[[flow.emitters]]",
        "[wind]\nbackground_strength = 2.0\n\n[[flow.emitters]]",
    );
    let err = error(&windy_flow);
    check(
        &err,
        12,
        "wind",
        "[wind] is for snow scenes",
        "remove [wind]",
    );
}

#[test]
fn a_wind_built_in_code_is_validated() {
    let mut wind = Wind::uniform(Vec3::X, 5.0);
    wind.drag = f32::NAN;
    let scene = Scene::builder("windy")
        .body(firn_core::scene::Body::sphere(Vec3::splat(0.5), 0.1))
        .wind(wind)
        .build();
    let err = scene.expect_err("a NaN drag is refused");
    assert_eq!(err.key.as_deref(), Some("wind.drag"), "{err}");
}

#[test]
fn spindrift_takes_its_defaults_and_reads_every_key() {
    assert_eq!(
        load(&format!("{SNOW}\n[wind]\n")).wind.unwrap().spindrift,
        None
    );
    let scene = load(&format!("{SNOW}\n[wind]\n[wind.spindrift]\n"));
    assert_eq!(scene.wind.unwrap().spindrift, Some(Spindrift::default()));
    let scene = load(&format!(
        "{SNOW}
[wind]
background_strength = 9.0

[wind.spindrift]
threshold_speed = 4.0
loose_density = 180.0
rate = 3.5
fall_speed = 0.8
settle = false
"
    ));
    assert_eq!(
        scene.wind.unwrap().spindrift,
        Some(Spindrift {
            threshold_speed: 4.0,
            loose_density: 180.0,
            rate: 3.5,
            fall_speed: 0.8,
            settle: false,
        })
    );
}

#[test]
fn bad_spindrift_values_are_located() {
    let table = format!("{SNOW}\n[wind]\n[wind.spindrift]\n");
    let err = error(&format!("{table}threshold_speed = -2.0\n"));
    check(
        &err,
        17,
        "wind.spindrift.threshold_speed",
        "0 or more",
        "threshold_speed = 5",
    );
    let err = error(&format!("{table}loose_density = 0.0\n"));
    check(
        &err,
        17,
        "wind.spindrift.loose_density",
        "greater than 0",
        "loose_density = 250",
    );
    let err = error(&format!("{table}rate = -1.0\n"));
    check(&err, 17, "wind.spindrift.rate", "0 or more", "rate = 2");
    let err = error(&format!("{table}fall_speed = -0.5\n"));
    check(
        &err,
        17,
        "wind.spindrift.fall_speed",
        "0 or more",
        "fall_speed = 0.5",
    );
    let err = error(&format!("{table}lift = 2.0\n"));
    assert_eq!(err.line, Some(17), "{err}");
    assert!(err.message.contains("lift"), "{err}");
}

#[test]
fn spindrift_is_a_key_of_the_wind_only() {
    let flow = "format = 1
kind = \"flow\"

[domain]
max = [10.0, 10.0, 10.0]

[time]
duration = 1.0

[flow.spindrift]
rate = 1.0

[[flow.emitters]]
shape = \"box\"
center = [5.0, 5.0, 5.0]
size = [1.0, 1.0, 1.0]
count = 10
";
    let err = error(flow);
    assert_eq!(err.key.as_deref(), Some("flow.spindrift"), "{err}");
    assert!(err.message.contains("a key of [wind]"), "{err}");
}

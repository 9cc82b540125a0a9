//! Colliders that turn, as scene files give them: `rotation`,
//! `angular_velocity`, keyed rotations (degrees or a quaternion), a
//! Catmull-Rom `path`, the cylinder; and the errors of bad ones.

use firn_core::scene::{ColliderGeometry, Motion, PathShape};
use firn_core::{Scene, SceneError};
use glam::{Quat, Vec3};

/// A valid scene head and a body; colliders follow from line 13.
const HEAD: &str = "format = 1

[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05

[time]
duration = 1.0

[[bodies]]
shape = \"sphere\"
center = [1.0, 1.0, 1.0]
radius = 0.2
";

/// The scene of [`HEAD`] with `colliders`, which must load.
fn load(colliders: &str) -> Scene {
    Scene::from_toml_str(&format!("{HEAD}{colliders}"), "scenes/wheel.toml").unwrap()
}

/// Why the scene of [`HEAD`] with `colliders` does not load.
fn error_of(colliders: &str) -> SceneError {
    match Scene::from_toml_str(&format!("{HEAD}{colliders}"), "scenes/wheel.toml") {
        Ok(_) => panic!("the scene should not load:\n{colliders}"),
        Err(error) => error,
    }
}

#[test]
fn a_rolling_wheel_and_a_keyed_turn_read_as_written() {
    let scene = load(
        "[[colliders]]
shape = \"cylinder\"
center = [0.5, 0.3, 1.0]
radius = 0.3
height = 0.2
rotation = [90.0, 0.0, 0.0]
velocity = [1.0, 0.0, 0.0]
angular_velocity = [0.0, 0.0, -3.3333]

[[colliders]]
shape = \"box\"
center = [1.0, 0.5, 1.0]
size = [0.6, 0.05, 0.2]
path = \"catmull-rom\"
keyframes = [
  { time = 0.0, position = [1.0, 0.5, 1.0] },
  { time = 0.5, position = [1.2, 0.6, 1.0], rotation = [0.0, 45.0, 0.0] },
  { time = 1.0, position = [1.4, 0.5, 1.0], quaternion = [0.0, 0.0, 0.0, 2.0] },
]
",
    );
    let wheel = &scene.colliders[0];
    assert_eq!(
        wheel.geometry,
        ColliderGeometry::Cylinder {
            center: Vec3::new(0.5, 0.3, 1.0),
            radius: 0.3,
            height: 0.2
        }
    );
    // The axis, y in the wheel's own frame, turned 90° about x, lies along z.
    assert!((wheel.rotation * Vec3::Y - Vec3::Z).length() < 1e-6);
    let pose = wheel.pose_at(0.5);
    assert!((pose.position - Vec3::new(1.0, 0.3, 1.0)).length() < 1e-6);
    assert_eq!(pose.angular_velocity, Vec3::new(0.0, 0.0, -3.3333));
    let Motion::Keyframed { keys, path } = &scene.colliders[1].motion else {
        panic!("keyframed");
    };
    assert_eq!(*path, PathShape::CatmullRom);
    assert_eq!(keys[0].rotation, Quat::IDENTITY);
    assert!(
        keys[1]
            .rotation
            .angle_between(Quat::from_rotation_y(45f32.to_radians()))
            < 1e-6
    );
    assert_eq!(keys[2].rotation, Quat::IDENTITY, "normalised");
}

/// Loads `colliders`, which must fail at `line` with `key`, its message
/// containing `says`.
#[track_caller]
fn refused(colliders: &str, line: usize, key: &str, says: &str) {
    let error = error_of(colliders);
    assert_eq!(error.file, "scenes/wheel.toml", "{error}");
    assert_eq!(error.line, Some(line), "{error}");
    assert_eq!(error.key.as_deref(), Some(key), "{error}");
    assert!(error.to_string().contains(says), "{error}");
    assert!(!error.hint.is_empty(), "{error}");
}

#[test]
fn bad_turns_are_refused_with_the_key_and_a_fix() {
    refused(
        "[[colliders]]
shape = \"box\"
center = [1.0, 0.5, 1.0]
size = [0.2, 0.2, 0.2]
keyframes = [
  { time = 0.0, position = [1.0, 0.5, 1.0] },
  { time = 1.0, position = [1.0, 0.5, 1.0], rotation = [0.0, nan, 0.0] },
]
",
        20,
        "colliders[0].keyframes[1].rotation",
        "finite",
    );
    refused(
        "[[colliders]]
shape = \"cylinder\"
center = [1.0, 0.5, 1.0]
radius = 0.5
height = 0.1
angular_velocity = [0.0, 1.0e6, 0.0]
",
        19,
        "colliders[0].angular_velocity",
        "max_substeps_per_frame",
    );
    refused(
        "[[colliders]]
shape = \"sphere\"
center = [1.0, 0.5, 1.0]
radius = 0.5
height = 0.1
",
        18,
        "colliders[0].height",
        "does not apply to a sphere",
    );
    refused(
        "[[colliders]]
shape = \"box\"
center = [1.0, 0.5, 1.0]
size = [0.2, 0.2, 0.2]
angular_velocity = [0.0, 1.0, 0.0]
keyframes = [
  { time = 0.0, position = [1.0, 0.5, 1.0] },
  { time = 1.0, position = [1.0, 0.5, 1.0] },
]
",
        19,
        "colliders[0].keyframes",
        "both angular_velocity and keyframes",
    );
}

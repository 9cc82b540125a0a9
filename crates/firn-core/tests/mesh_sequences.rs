//! Deforming mesh colliders in scene files (`sequence = "foot/frame_####.obj"`):
//! the files found and timed, and the located errors of bad sequences.

use std::fs;
use std::path::Path;

use firn_core::scene::{ColliderGeometry, SequenceInterval};
use firn_core::{Scene, SceneError};
use glam::Vec3;

/// A closed unit cube as an OBJ shifted by `dy`, faces wound outwards.
fn cube_obj(dy: f32) -> String {
    let mut text = String::new();
    for [x, y, z] in [
        [0, 0, 0],
        [1, 0, 0],
        [1, 1, 0],
        [0, 1, 0],
        [0, 0, 1],
        [1, 0, 1],
        [1, 1, 1],
        [0, 1, 1],
    ] {
        text += &format!("v {x} {} {z}\n", y as f32 + dy);
    }
    text + "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n"
}

/// A folder with `foot/frame_0001.obj` .. `frame_0004.obj`, the cube
/// dropping 0.1 per frame.
fn foot_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("foot")).unwrap();
    for k in 0..4 {
        let file = dir.path().join(format!("foot/frame_{:04}.obj", k + 1));
        fs::write(file, cube_obj(-0.1 * k as f32)).unwrap();
    }
    dir
}

/// Writes a scene whose collider has `keys` into `dir` and loads it; the
/// collider's table starts on line 15.
fn scene_with(dir: &Path, keys: &str) -> Result<Scene, Box<SceneError>> {
    let text = format!(
        "format = 1

[domain]
max = [2.0, 2.0, 2.0]
cell_size = 0.05

[time]
duration = 0.5

[[bodies]]
shape = \"sphere\"
center = [1.0, 0.3, 1.0]
radius = 0.1

[[colliders]]
shape = \"mesh\"
scale = 0.2
{keys}"
    );
    let path = dir.join("scene.toml");
    fs::write(&path, text).unwrap();
    Scene::load(&path).map_err(Box::new)
}

#[track_caller]
fn error_at(err: &SceneError, key: &str, says: &[&str]) {
    assert_eq!(err.key.as_deref(), Some(key), "{err}");
    assert!(err.line.is_some(), "{err}");
    for words in says {
        assert!(
            err.to_string().contains(words),
            "should say {words:?}:\n{err}"
        );
    }
}

#[test]
fn a_sequence_is_found_timed_and_placed() {
    let dir = foot_dir();
    let scene = scene_with(
        dir.path(),
        "sequence = \"foot/frame_####.obj\"\nframe_rate = 10\nstart = 0.1\ncenter = [1.0, 1.0, 1.0]\n",
    )
    .unwrap();
    let ColliderGeometry::MeshSequence(sequence) = &scene.colliders[0].geometry else {
        panic!("a mesh sequence");
    };
    assert_eq!((sequence.first_number, sequence.frame_count), (1, 4));
    // The first frame's box centre goes to `center`; later frames keep
    // their motion (0.2 × 0.1 down per frame).
    let first = sequence.mesh_of(0).bounds();
    assert!((0.5 * (first.0 + first.1)).distance(Vec3::ONE) < 1e-6);
    let last = sequence.mesh_of(3).bounds();
    assert!((last.0.y - (first.0.y - 0.06)).abs() < 1e-6, "{last:?}");
    // Held before the start and after the end; between frames a fraction.
    let at = |t| sequence.interval_at(t);
    assert_eq!(
        at(0.0),
        SequenceInterval {
            from: 0,
            to: 0,
            fraction: 0.0
        }
    );
    assert_eq!(
        at(0.5),
        SequenceInterval {
            from: 3,
            to: 3,
            fraction: 0.0
        }
    );
    let between = at(0.125);
    assert_eq!((between.from, between.to), (0, 1));
    assert!((between.fraction - 0.25).abs() < 1e-5);
    let velocities = sequence.vertex_velocities(between);
    assert!(
        velocities
            .iter()
            .all(|v| v.distance(Vec3::new(0.0, -0.2, 0.0)) < 1e-5)
    );
}

#[test]
fn bad_sequences_are_refused_with_the_file_the_frame_and_a_fix() {
    let dir = foot_dir();
    let sequence = "sequence = \"foot/frame_####.obj\"\n";

    let none = scene_with(dir.path(), "sequence = \"foot/step_####.obj\"\n").unwrap_err();
    error_at(
        &none,
        "colliders[0].sequence",
        &["no file", "step_####.obj", "#s"],
    );

    let no_hash = scene_with(dir.path(), "sequence = \"foot/frame_0001.obj\"\n").unwrap_err();
    error_at(&no_hash, "colliders[0].sequence", &["no #"]);

    let moving = scene_with(
        dir.path(),
        &format!("{sequence}velocity = [1.0, 0.0, 0.0]\n"),
    )
    .unwrap_err();
    error_at(&moving, "colliders[0].velocity", &["moves by its files"]);

    let rate = scene_with(dir.path(), &format!("{sequence}frame_rate = 0\n")).unwrap_err();
    error_at(&rate, "colliders[0].frame_rate", &["positive"]);

    // A triangle fewer in frame 3.
    let frame_3 = dir.path().join("foot/frame_0003.obj");
    let full = fs::read_to_string(&frame_3).unwrap();
    fs::write(&frame_3, full.replace("f 2 3 7 6\n", "")).unwrap();
    let topology = scene_with(dir.path(), sequence).unwrap_err();
    error_at(
        &topology,
        "colliders[0].sequence",
        &[
            "frame_0003.obj",
            "frame 3",
            "8 vertices and 10 triangles",
            "first frame has 8 and 12",
        ],
    );
    fs::write(&frame_3, full).unwrap();

    fs::remove_file(dir.path().join("foot/frame_0002.obj")).unwrap();
    let gap = scene_with(dir.path(), sequence).unwrap_err();
    error_at(
        &gap,
        "colliders[0].sequence",
        &["frame_0002.obj", "frame 2", "missing"],
    );
}

//! Mesh bodies and mesh colliders in scene files: placement, filling, the
//! signed distance of colliders, and located errors for bad meshes.

use std::fs;
use std::path::Path;

use firn_core::scene::sampling::sample_bodies;
use firn_core::scene::{ColliderGeometry, Shape};
use firn_core::{Scene, SceneError};
use glam::Vec3;

/// A closed unit cube as an OBJ, faces wound outwards.
const CUBE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n\
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 4 8 7 3\nf 1 5 8 4\nf 2 3 7 6\n";

/// Writes a scene file ending in `tail` into `dir` and loads it (the error
/// boxed: it is large, and only the failing cases look at it).
fn scene_with(dir: &Path, tail: &str) -> Result<Scene, Box<SceneError>> {
    let text = format!(
        "format = 1

[domain]
max = [1.0, 1.0, 1.0]
cell_size = 0.02

[time]
duration = 0.5
{tail}"
    );
    let path = dir.join("scene.toml");
    fs::write(&path, text).unwrap();
    Scene::load(&path).map_err(Box::new)
}

fn cube_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    fs::create_dir(dir.path().join("meshes")).unwrap();
    fs::write(dir.path().join("meshes/cube.obj"), CUBE_OBJ).unwrap();
    dir
}

#[test]
fn a_mesh_body_is_placed_by_scale_rotation_and_center_and_filled_to_its_volume() {
    let dir = cube_dir();
    let scene = scene_with(
        dir.path(),
        "[[bodies]]
shape = \"mesh\"
mesh = \"meshes/cube.obj\"
scale = [0.4, 0.2, 0.2]
rotation = [0.0, 0.0, 90.0]
center = [0.5, 0.4, 0.5]
",
    )
    .unwrap();
    let Shape::Mesh(mesh) = &scene.bodies[0].shape else {
        panic!("a mesh body")
    };
    // 0.4 along x turned a quarter about z stands 0.4 tall along y.
    let size = mesh.max - mesh.min;
    assert!(
        (size - Vec3::new(0.2, 0.4, 0.2)).abs().max_element() < 1e-5,
        "{size}"
    );
    assert!((0.5 * (mesh.min + mesh.max) - Vec3::new(0.5, 0.4, 0.5)).length() < 1e-5);

    let seeds = sample_bodies(&scene);
    let spacing = 0.02 / 2.0;
    let volume = seeds.len() as f32 * spacing * spacing * spacing;
    let expected = 0.2 * 0.4 * 0.2;
    assert!(
        (volume / expected - 1.0).abs() < 0.02,
        "filled {volume} m3 of {expected}"
    );
    assert!(seeds.positions.iter().all(|p| {
        (*p - Vec3::new(0.5, 0.4, 0.5))
            .abs()
            .cmple(Vec3::new(0.1, 0.2, 0.1))
            .all()
    }));
}

#[test]
fn a_mesh_collider_has_the_signed_distance_of_its_solid_and_moves_with_its_keys() {
    let dir = cube_dir();
    let scene = scene_with(
        dir.path(),
        "[[bodies]]
shape = \"sphere\"
center = [0.5, 0.8, 0.5]
radius = 0.05

[[colliders]]
shape = \"mesh\"
mesh = \"meshes/cube.obj\"
scale = 0.4
center = [0.5, 0.3, 0.5]
keyframes = [{ time = 0.0, position = [0.5, 0.3, 0.5] }, { time = 1.0, position = [0.5, 0.5, 0.5] }]
",
    )
    .unwrap();
    let collider = &scene.colliders[0];
    let ColliderGeometry::Mesh(mesh) = &collider.geometry else {
        panic!("a mesh collider")
    };
    assert_eq!(mesh.sdf_spacing, 0.01, "half the cell size by default");
    // The top face is at y = 0.5: 0.1 above it, 0.05 below it.
    let (above, normal) = collider.geometry.signed_distance(Vec3::new(0.5, 0.6, 0.5));
    assert!((above - 0.1).abs() < 0.005, "{above}");
    assert!(normal.dot(Vec3::Y) > 0.99, "{normal}");
    let (inside, _) = collider.geometry.signed_distance(Vec3::new(0.5, 0.45, 0.5));
    assert!((inside + 0.05).abs() < 0.005, "{inside}");
    // Half way through its keys the cube has risen by 0.1.
    let (position, _) = collider
        .motion
        .state_at(collider.geometry.reference_point(), 0.5);
    let moved = collider.geometry.moved_to(position);
    let (touching, _) = moved.signed_distance(Vec3::new(0.5, 0.6, 0.5));
    assert!(touching.abs() < 0.005, "{touching}");
}

#[test]
fn a_scene_read_back_from_json_rebuilds_its_meshes() {
    let dir = cube_dir();
    let scene = scene_with(
        dir.path(),
        "[[bodies]]
shape = \"mesh\"
mesh = \"meshes/cube.obj\"
scale = 0.3
center = [0.5, 0.5, 0.5]

[[colliders]]
shape = \"mesh\"
mesh = \"meshes/cube.obj\"
scale = 0.2
center = [0.5, 0.1, 0.5]
",
    )
    .unwrap();
    let json = serde_json::to_string(&scene).unwrap();
    let mut restored: Scene = serde_json::from_str(&json).unwrap();
    restored.load_meshes().unwrap();
    assert_eq!(restored, scene);
    let probe = Vec3::new(0.5, 0.25, 0.5);
    assert_eq!(
        restored.colliders[0].geometry.signed_distance(probe),
        scene.colliders[0].geometry.signed_distance(probe)
    );
    assert_eq!(sample_bodies(&restored), sample_bodies(&scene));
}

#[test]
fn the_bundled_bunny_fills_as_in_the_thesis() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/bunny.toml");
    let scene = Scene::load(&path).unwrap();
    let count = sample_bodies(&scene).len();
    assert!(
        (175_000..=190_000).contains(&count),
        "the thesis' bunny has 183,029 particles; this one {count}"
    );
    let warnings = scene.mesh_warnings();
    assert!(
        warnings.iter().any(|w| w.contains("boundary edges")),
        "the scan's holes are reported: {warnings:?}"
    );
}

#[track_caller]
fn error_at(err: &SceneError, line: usize, key: &str, says: &str) {
    assert_eq!(err.line, Some(line), "{err}");
    assert_eq!(err.key.as_deref(), Some(key), "{err}");
    assert!(
        err.to_string().contains(says),
        "should say {says:?}:\n{err}"
    );
}

#[test]
fn bad_meshes_are_reported_at_the_key_that_names_them() {
    let dir = cube_dir();
    let body =
        |keys: &str| format!("[[bodies]]\nshape = \"mesh\"\ncenter = [0.5, 0.5, 0.5]\n{keys}");

    let missing = scene_with(dir.path(), &body("scale = 0.2\n")).unwrap_err();
    error_at(&missing, 9, "bodies[0].mesh", "needs `mesh`");

    let absent = scene_with(dir.path(), &body("mesh = \"meshes/none.obj\"\n")).unwrap_err();
    error_at(&absent, 12, "bodies[0].mesh", "none.obj");

    fs::write(
        dir.path().join("meshes/broken.obj"),
        "v 0 0 0\nv 1 0 0\nf 1 2 7\n",
    )
    .unwrap();
    let broken = scene_with(dir.path(), &body("mesh = \"meshes/broken.obj\"\n")).unwrap_err();
    error_at(&broken, 12, "bodies[0].mesh", "broken.obj:3");

    let flat = scene_with(
        dir.path(),
        &body("mesh = \"meshes/cube.obj\"\nscale = [0.2, 0.0, 0.2]\n"),
    )
    .unwrap_err();
    error_at(&flat, 13, "bodies[0].scale", "greater than 0");

    let outside = scene_with(
        dir.path(),
        &body("mesh = \"meshes/cube.obj\"\nscale = 2.0\n"),
    )
    .unwrap_err();
    assert!(
        outside.to_string().contains("sticks out of the domain"),
        "{outside}"
    );

    let sphere_with_mesh = scene_with(
        dir.path(),
        "[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\nmesh = \"a.obj\"\n",
    )
    .unwrap_err();
    error_at(
        &sphere_with_mesh,
        13,
        "bodies[0].mesh",
        "does not apply to a sphere",
    );

    let coarse = scene_with(
        dir.path(),
        "[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\n\n\
[[colliders]]\nshape = \"mesh\"\nmesh = \"meshes/cube.obj\"\ncenter = [0.5, 0.1, 0.5]\nsdf_spacing = 1e-5\n",
    )
    .unwrap_err();
    error_at(&coarse, 18, "colliders[0].sdf_spacing", "raise sdf_spacing");
}

/// A scene read back from JSON (a run's manifest) whose mesh collider asks
/// for a field finer than an atom: loading its meshes is refused before the
/// field is sampled (it would take about 10^29 samples), and a spacing so
/// small that the count passes 2^64 does not overflow.
#[test]
fn a_json_scene_with_an_absurdly_fine_field_is_refused_before_sampling_it() {
    let dir = cube_dir();
    let scene = scene_with(
        dir.path(),
        "[[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\n\n\
[[colliders]]\nshape = \"mesh\"\nmesh = \"meshes/cube.obj\"\ncenter = [0.5, 0.1, 0.5]\nscale = 0.1\n",
    )
    .unwrap();
    for spacing in [1e-10, 1e-30] {
        let mut json = serde_json::to_value(&scene).unwrap();
        json["colliders"][0]["geometry"]["sdf_spacing"] = serde_json::json!(spacing);
        let mut read_back: Scene = serde_json::from_value(json).unwrap();
        let error = read_back.load_meshes().unwrap_err().to_string();
        assert!(
            error.contains("its signed distance field would take")
                && error.contains("more than 16777216"),
            "{error}"
        );
    }
}

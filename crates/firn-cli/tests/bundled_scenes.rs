//! Every scene bundled under `scenes/` passes `firn check` and runs its
//! first frame, pictures included, at a small picture size; the scenes'
//! README shows a still of each.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::firn;

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// The scene files directly under `scenes/` (the benchmark variants under
/// `scenes/bench/` are run by `firn bench`), sorted by name.
fn bundled_scenes() -> Vec<PathBuf> {
    let mut scenes: Vec<PathBuf> = fs::read_dir(scenes_dir())
        .expect("scenes/ is readable")
        .map(|entry| entry.unwrap().path())
        .filter(|path| path.extension().is_some_and(|ext| ext == "toml"))
        .collect();
    scenes.sort();
    scenes
}

fn report(output: &Output) -> String {
    format!(
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn the_thesis_scenes_are_all_bundled() {
    let names: Vec<String> = bundled_scenes()
        .iter()
        .map(|path| path.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for expected in [
        "snowball-drop",
        "snowball-wall-a",
        "snowball-wall-b",
        "snowball-wall-c",
        "snowball-wall-d",
        "snowball-wall-e",
        "bunny",
        "snow-on-bunny",
        "tower",
        "dry-vs-wet",
        "curl-noise-demo",
        "snowball-wall",
    ] {
        assert!(
            names.iter().any(|name| name == expected),
            "scenes/{expected}.toml is missing; found {names:?}"
        );
    }
}

#[test]
fn every_bundled_scene_passes_check() {
    for scene in bundled_scenes() {
        let output = firn(&["check", scene.to_str().unwrap()]);
        assert!(
            output.status.success(),
            "firn check {} failed\n{}",
            scene.display(),
            report(&output)
        );
    }
}

#[test]
fn every_bundled_scene_runs_its_first_frame_with_pictures() {
    let out_root = tempfile::tempdir().unwrap();
    for scene in bundled_scenes() {
        let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let out = out_root.path().join(&stem);
        let output = firn(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--frames",
            "1",
            "--size",
            "96x54",
            "--quiet",
        ]);
        assert!(
            output.status.success(),
            "firn run {} failed\n{}",
            scene.display(),
            report(&output)
        );
        let manifest: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
        let frames = manifest["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 2, "{stem}: frames 0 and 1");
        let images = frames[1]["images"].as_array().unwrap();
        assert!(!images.is_empty(), "{stem}: frame 1 has pictures");
        for image in images {
            let path = out.join(image.as_str().unwrap());
            let picture = image::open(&path).unwrap().to_rgb8();
            assert_eq!(picture.dimensions(), (96, 54), "{}", path.display());
        }
    }
}

#[test]
fn the_scenes_readme_shows_a_still_of_every_scene() {
    let readme = fs::read_to_string(scenes_dir().join("README.md")).unwrap();
    for scene in bundled_scenes() {
        let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
        let still = format!("images/{stem}.png");
        assert!(
            readme.contains(&format!("({still})")),
            "scenes/README.md does not show {still}"
        );
        assert!(
            scenes_dir().join(&still).is_file(),
            "scenes/{still} is missing"
        );
    }
}

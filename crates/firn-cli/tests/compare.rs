//! `firn compare` end to end: the grid picture and its numbers for two tiny
//! scenes, and exit codes with nothing written for bad input and blow-ups.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

mod common;
use common::{firn, stderr, tiny_ball_scene, write_scene};

const TIMES: &str = "0.02,0.05,0.1";

/// The two scenes of the grid's rows: balls in different places.
fn two_scenes(dir: &Path) -> [PathBuf; 2] {
    [
        write_scene(
            dir,
            "left.toml",
            &tiny_ball_scene("left-ball", "[0.14, 0.22, 0.2]", ""),
        ),
        write_scene(
            dir,
            "right.toml",
            &tiny_ball_scene(
                "right-ball",
                "[0.26, 0.16, 0.2]",
                "velocity = [0.0, 1.0, 0.0]\n",
            ),
        ),
    ]
}

fn path_text(path: &Path) -> &str {
    path.to_str().expect("utf-8 path")
}

/// `firn compare SCENES --times TIMES --size 64x48 --out OUT` plus `extra`.
fn compare(scenes: &[&Path], times: &str, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["compare"];
    args.extend(scenes.iter().map(|scene| path_text(scene)));
    args.extend(["--times", times, "--size", "64x48", "--out", path_text(out)]);
    args.extend_from_slice(extra);
    firn(&args)
}

/// A rectangle from the report's layout: (x, y, width, height).
fn rect(value: &serde_json::Value) -> (u32, u32, u32, u32) {
    let field = |name: &str| value[name].as_u64().expect("rectangle field") as u32;
    (field("x"), field("y"), field("width"), field("height"))
}

/// The pixels of `area` of `image`.
fn pixels(image: &image::RgbImage, area: (u32, u32, u32, u32)) -> Vec<[u8; 3]> {
    let (x, y, width, height) = area;
    (y..y + height)
        .flat_map(|row| (x..x + width).map(move |column| image.get_pixel(column, row).0))
        .collect()
}

/// How many pixels of `area` differ from its top-left pixel (the background).
fn marked_pixels(image: &image::RgbImage, area: (u32, u32, u32, u32)) -> usize {
    let inside = pixels(image, area);
    inside.iter().filter(|pixel| **pixel != inside[0]).count()
}

#[test]
fn two_scenes_at_three_times_make_a_labelled_grid_and_its_numbers() {
    let dir = tempfile::tempdir().expect("temp dir");
    let [left, right] = two_scenes(dir.path());
    let out = dir.path().join("figures/grid.png");
    let output = compare(&[&left, &right], TIMES, &out, &[]);
    let messages = stderr(&output);
    assert!(output.status.success(), "{messages}");
    assert_eq!(messages.matches("still ").count(), 6, "{messages}");
    assert!(
        messages.contains("right-ball at t = 0.1 s") && messages.contains("substeps so far"),
        "{messages}"
    );
    assert!(
        messages.contains("note: left-ball lasts 0.075 s; t = 0.1 s is past its end"),
        "{messages}"
    );

    let report: serde_json::Value = serde_json::from_str(
        &fs::read_to_string(dir.path().join("figures/grid.json")).expect("report"),
    )
    .expect("the report is JSON");
    let picture = image::open(&out).expect("a PNG").to_rgb8();
    let layout = &report["layout"];
    assert_eq!(
        picture.width() as u64,
        layout["width"].as_u64().expect("width")
    );
    assert_eq!(
        picture.height() as u64,
        layout["height"].as_u64().expect("height")
    );
    assert!(picture.width() > 3 * 64 && picture.height() > 2 * 48);

    let panels: Vec<Vec<(u32, u32, u32, u32)>> = layout["panels"]
        .as_array()
        .expect("rows")
        .iter()
        .map(|row| row.as_array().expect("columns").iter().map(rect).collect())
        .collect();
    assert_eq!(panels.len(), 2);
    for (row, rects) in panels.iter().enumerate() {
        assert_eq!(rects.len(), 3);
        for (column, &area) in rects.iter().enumerate() {
            assert_eq!((area.2, area.3), (64, 48), "panel size");
            assert!(
                marked_pixels(&picture, area) > 100,
                "panel {row},{column} is not a picture"
            );
        }
    }
    // Only the snow differs between the two rows (same box, same camera), so
    // pixels that differ are snow; and the snow moves from column to column.
    for (column, (&upper, &lower)) in panels[0].iter().zip(&panels[1]).enumerate() {
        let top = pixels(&picture, upper);
        let bottom = pixels(&picture, lower);
        let differing = top.iter().zip(&bottom).filter(|(a, b)| a != b).count();
        assert!(
            differing > 20,
            "column {column}: only {differing} pixels of snow"
        );
    }
    let first = pixels(&picture, panels[1][0]);
    let last = pixels(&picture, panels[1][2]);
    assert_ne!(first, last, "the right ball moves between the stills");

    for header in layout["headers"].as_array().expect("headers") {
        assert!(
            marked_pixels(&picture, rect(header)) > 20,
            "header {header} has no text"
        );
    }
    for label in layout["labels"].as_array().expect("labels") {
        assert!(
            marked_pixels(&picture, rect(label)) > 20,
            "label {label} has no text"
        );
    }

    let scenes = report["scenes"].as_array().expect("scenes");
    assert_eq!(scenes.len(), 2);
    assert_eq!(scenes[0]["label"], "left-ball");
    assert_eq!(scenes[1]["label"], "right-ball");
    for scene in scenes {
        let stills = scene["stills"].as_array().expect("stills");
        assert_eq!(stills.len(), 3);
        let times: Vec<f64> = stills
            .iter()
            .map(|s| s["time"].as_f64().expect("time"))
            .collect();
        assert_eq!(times, [0.02, 0.05, 0.1]);
        assert_eq!(stills[2]["past_duration"], true);
        for still in stills {
            assert!(still["particles"].as_u64().expect("count") > 50);
            assert!(still["wall_seconds"].as_f64().expect("wall time") >= 0.0);
            let centre = still["center_of_mass"].as_array().expect("centre");
            let (min, max) = (&still["bounds"]["min"], &still["bounds"]["max"]);
            for axis in 0..3 {
                let c = centre[axis].as_f64().expect("coordinate");
                assert!(
                    min[axis].as_f64().expect("min") <= c && c <= max[axis].as_f64().expect("max")
                );
            }
        }
        let substeps: Vec<u64> = stills
            .iter()
            .map(|s| s["substeps"].as_u64().expect("substeps"))
            .collect();
        assert!(
            substeps.windows(2).all(|pair| pair[0] < pair[1]),
            "{substeps:?}"
        );
    }
    // The dropped ball falls between the first and the last still.
    let height = |still: &serde_json::Value| still["center_of_mass"][1].as_f64().expect("height");
    let left_stills = &scenes[0]["stills"];
    assert!(height(&left_stills[2]) < height(&left_stills[0]));
}

/// Asserts exit code 2, the given fragments on stderr, and that neither the
/// picture nor its report was written.
fn assert_rejected(output: &Output, out: &Path, fragments: &[&str]) {
    let messages = stderr(output);
    assert_eq!(output.status.code(), Some(2), "{messages}");
    for fragment in fragments {
        assert!(
            messages.contains(fragment),
            "expected `{fragment}` in: {messages}"
        );
    }
    assert!(!out.exists(), "a picture was written");
    assert!(!out.with_extension("json").exists(), "a report was written");
}

#[test]
fn unsorted_times_are_rejected_before_anything_runs() {
    let dir = tempfile::tempdir().expect("temp dir");
    let [left, right] = two_scenes(dir.path());
    let out = dir.path().join("grid.png");
    let output = compare(&[&left, &right], "0.05,0.02,0.1", &out, &[]);
    assert_rejected(&output, &out, &["--times", "0.02 comes after 0.05", "fix:"]);
    let output = compare(&[&left], "-0.1,0.2", &out, &[]);
    assert_rejected(&output, &out, &["--times -0.1", "fix:"]);
}

#[test]
fn a_bad_scene_is_located_and_nothing_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let [left, _] = two_scenes(dir.path());
    let bad = write_scene(
        dir.path(),
        "bad.toml",
        &tiny_ball_scene("bad", "[0.2, 0.2, 0.2]", "").replace("radius = 0.08", "radus = 0.08"),
    );
    let out = dir.path().join("figures/grid.png");
    let output = compare(&[&left, &bad], TIMES, &out, &["--quiet"]);
    assert_rejected(&output, &out, &["bad.toml:", "radus", "fix:"]);
    assert!(
        !dir.path().join("figures").exists(),
        "the output folder was created"
    );
}

#[test]
fn a_missing_scene_file_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("missing.toml");
    let out = dir.path().join("grid.png");
    let output = compare(&[&missing], TIMES, &out, &[]);
    assert_rejected(&output, &out, &["missing.toml", "fix:"]);
}

#[test]
fn a_blow_up_names_the_scene_and_writes_no_picture() {
    let dir = tempfile::tempdir().expect("temp dir");
    let [left, _] = two_scenes(dir.path());
    let unstable = tiny_ball_scene("brittle", "[0.2, 0.2, 0.2]", "material = \"stiff\"\n")
        .replace("fps = 40", "fps = 40\nstep = \"fixed\"\ndt = 0.01")
        + "\n[materials.stiff]\nyoungs_modulus = 1e9\n";
    let unstable = write_scene(dir.path(), "unstable.toml", &unstable);
    let out = dir.path().join("grid.png");
    let output = compare(&[&left, &unstable], TIMES, &out, &["--quiet"]);
    let messages = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{messages}");
    assert!(
        messages.contains("brittle") && messages.contains("unstable.toml"),
        "{messages}"
    );
    assert!(!out.exists() && !out.with_extension("json").exists());
}

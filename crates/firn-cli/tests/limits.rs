//! Every piece of work firn starts is bounded before it starts (issue 25):
//! scenes past a documented limit or past the machine are refused by
//! `firn check` and `firn run` at once, with the numbers and a fix, exit
//! code 2 and nothing written; a run whose time step collapses stops with
//! the speed, the step and a fix; caches and checkpoints that lie are
//! refused with the file and the reason.

mod common;

use std::fs;
use std::path::Path;
use std::time::Duration;

use common::{firn_within, manifest, stderr, text, write_scene};

/// How long a refusal may take. The refusals themselves take milliseconds;
/// this leaves room for a loaded test machine, and is still far below what
/// the work they refuse would take (hours).
const AT_ONCE: Duration = Duration::from_secs(10);

/// A scene in a 1 m box with one body (`body`, TOML lines) and `extra`
/// top-level tables, writing to `out`.
fn scene(out: &Path, cell_size: f64, time: &str, body: &str, extra: &str) -> String {
    format!(
        "format = 1\nname = \"absurd\"\n\n[domain]\nmax = [1.0, 1.0, 1.0]\ncell_size = {cell_size}\n\n\
         [time]\n{time}\n\n[[bodies]]\n{body}\n\n{extra}\n[output]\ndirectory = \"{}\"\n\n\
         [render]\nsize = [64, 48]\n",
        out.display()
    )
}

/// `firn check` and `firn run` both refuse `scene` at once with exit code
/// 2 and an error containing every one of `expected`, and `firn run`
/// writes nothing.
fn refused_at_once(dir: &Path, contents: &str, expected: &[&str]) {
    let out = dir.join("out");
    let path = write_scene(dir, "absurd.toml", contents);
    let path = path.to_str().unwrap();
    for args in [vec!["check", path], vec!["run", path, "--no-render", "-q"]] {
        let output = firn_within(&args, &[], AT_ONCE);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "firn {args:?}: {message}");
        for part in expected.iter().chain(&["fix: "]) {
            assert!(message.contains(part), "`{part}` missing from: {message}");
        }
    }
    assert!(!out.exists(), "a refused run wrote {}", out.display());
}

/// My absurd case: a 1 mm thin rod laid along the box's diagonal at 1 mm
/// cells. It holds some 300,000 particles, but its bounding box is filled
/// from 5e10 lattice points: filling it (which `firn check` did) took hours.
#[test]
fn a_thin_rod_across_the_box_is_refused_by_its_lattice() {
    let dir = tempfile::tempdir().unwrap();
    let rod = "shape = \"cylinder\"\ncenter = [0.5, 0.5, 0.5]\naxis = [1.0, 1.0, 1.0]\n\
               radius = 0.001\nheight = 1.6\nparticles_per_cell = 64";
    let contents = scene(&dir.path().join("out"), 0.001, "duration = 1.0", rod, "");
    refused_at_once(
        dir.path(),
        &contents,
        &[
            "bodies[0] (cylinder) is filled from",
            "lattice points",
            "at most 2^30 = 1073741824",
            "a thin or slanted body is filled through its whole bounding box",
        ],
    );
}

/// Snow as stiff as nothing on Earth (E = 1e30 Pa): its elastic waves cross
/// a cell in 1e-16 s, so the explicit step would be that short.
#[test]
fn a_material_stiffer_than_anything_is_refused_by_its_first_step() {
    let dir = tempfile::tempdir().unwrap();
    let body = "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\nmaterial = \"adamant\"";
    let material = "[materials.adamant]\nyoungs_modulus = 1e30\n";
    let contents = scene(
        &dir.path().join("out"),
        0.05,
        "duration = 1.0",
        body,
        material,
    );
    refused_at_once(
        dir.path(),
        &contents,
        &[
            "materials.adamant carries elastic waves at",
            "the adaptive step starts at",
            "more than time.max_substeps_per_frame = 100000",
            "integrator = \"semi-implicit\"",
        ],
    );
}

/// A fixed step of a femtosecond: 3e13 substeps per frame.
#[test]
fn a_femtosecond_step_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let body = "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1";
    let time = "duration = 1.0\nstep = \"fixed\"\ndt = 1e-15";
    let contents = scene(&dir.path().join("out"), 0.05, time, body, "");
    refused_at_once(
        dir.path(),
        &contents,
        &[
            "time.dt = 1e-15 s is too short",
            "would take 3.33333e13 substeps",
            "use dt = 3.33333e-7 or more",
        ],
    );
}

/// A century of simulated time at 30 fps: ninety-five billion frames.
#[test]
fn a_century_of_frames_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let body = "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1";
    let contents = scene(
        &dir.path().join("out"),
        0.05,
        "duration = 3.156e9",
        body,
        "",
    );
    refused_at_once(
        dir.path(),
        &contents,
        &[
            "time.duration = 3.156e9 s at 30 fps makes 9.468e10 frames; the limit is 99999",
            "simulate at most 3333.3 s",
        ],
    );
}

/// A machine (here FIRN_MEMORY_LIMIT) with less memory than a small scene
/// needs: refused with both figures, before anything is written.
#[test]
fn a_scene_past_the_machine_memory_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let body = "shape = \"box\"\ncenter = [0.5, 0.5, 0.5]\nsize = [0.5, 0.5, 0.5]";
    let path = write_scene(
        dir.path(),
        "box.toml",
        &scene(&out, 0.05, "duration = 1.0", body, ""),
    );
    let path = path.to_str().unwrap();
    let small = [("FIRN_MEMORY_LIMIT", "2MiB")];
    for args in [vec!["check", path], vec!["run", path, "--no-render", "-q"]] {
        let output = firn_within(&args, &small, AT_ONCE);
        let message = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "firn {args:?}: {message}");
        assert!(
            message.contains(
                "for about 8000 particles; this machine allows 2.00 MiB (FIRN_MEMORY_LIMIT)"
            ),
            "{message}"
        );
        assert!(message.contains("fix: about 2"), "{message}");
    }
    assert!(!out.exists(), "a refused run wrote {}", out.display());
}

/// A planet some three hundred billion times heavier than the Earth: the
/// snow slams into the floor so hard that the adaptive step collapses
/// within the first frame. The run stops there with the speed, the wave
/// speed, the step and a fix for whichever of the two limits it (exit code
/// 1; at this gravity the snow crushed to ice, a little weaker and the fall
/// itself, and which one is a matter of round-off), the manifest says it
/// failed, and the frame it could not finish is not written.
#[test]
fn a_collapsing_time_step_stops_the_run_with_the_speed_and_a_fix() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let body = "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\nparticles_per_cell = 1";
    let gravity = "[solver]\ngravity = [0.0, -3e12, 0.0]\n";
    let path = write_scene(
        dir.path(),
        "heavy.toml",
        &scene(&out, 0.05, "duration = 0.1", body, gravity),
    );
    let output = firn_within(
        &["run", path.to_str().unwrap(), "--no-render", "-q"],
        &[],
        Duration::from_secs(60),
    );
    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(1), "{message}");
    for part in [
        "the simulation stopped in frame 1: at t = ",
        "the time step fell to Δt = ",
        "the fastest particle moves at ",
        " m/s and elastic waves at ",
        "more than time.max_substeps_per_frame = 100000",
        "use a larger cell_size, or raise [time] max_substeps_per_frame",
    ] {
        assert!(message.contains(part), "`{part}` missing from: {message}");
    }
    let fixes = [
        "fix: find what drives the snow this fast (gravity",
        "fix: the snow has hardened into stiff ice (lower hardening or youngs_modulus",
    ];
    assert!(
        fixes.iter().any(|fix| message.contains(fix)),
        "no fix for the speed or the stiffness in: {message}"
    );
    let manifest = manifest(&out);
    let status = &manifest["status"];
    assert_eq!(status["state"], "failed", "{manifest}");
    assert!(
        status["message"]
            .as_str()
            .unwrap()
            .contains("the time step fell to"),
        "{manifest}"
    );
    let frames = manifest["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 1, "only frame 0 is recorded: {manifest}");
    assert!(out.join("ply/frame_00000.ply").exists());
    assert!(!out.join("ply/frame_00001.ply").exists());
}

/// A tiny run of two frames with a checkpoint after each, in `out`.
fn tiny_run(dir: &Path, out: &Path) -> std::path::PathBuf {
    let body = "shape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.1\nparticles_per_cell = 1";
    let contents = scene(out, 0.05, "duration = 0.1\nfps = 20", body, "").replace(
        "[output]\n",
        "[output]\ncheckpoint_every = 1\nformats = [\"ply\"]\n",
    );
    let path = write_scene(dir, "tiny.toml", &contents);
    let output = firn_within(
        &["run", path.to_str().unwrap(), "--no-render", "-q"],
        &[],
        Duration::from_secs(60),
    );
    assert!(output.status.success(), "{}", stderr(&output));
    path
}

/// A particle cache with one flipped bit in its vertex data: `firn render`
/// refuses it with the file and the checksum, rather than picturing wrong
/// particles.
#[test]
fn a_bit_flipped_cache_is_refused_with_the_file_and_the_checksum() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    tiny_run(dir.path(), &out);
    let cache = out.join("ply/frame_00001.ply");
    let mut bytes = fs::read(&cache).unwrap();
    let last = bytes.len() - 3;
    bytes[last] ^= 0x20;
    fs::write(&cache, &bytes).unwrap();

    let output = firn_within(
        &["render", out.to_str().unwrap(), "--size", "64x48", "-q"],
        &[],
        Duration::from_secs(60),
    );

    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(message.contains(&cache.display().to_string()), "{message}");
    assert!(
        message.contains("checksum mismatch: the vertex data has CRC-32"),
        "{message}"
    );
}

/// Replaces the checkpoint's bytes by `change`, then makes its CRC-32
/// match again: a checkpoint that lies with a valid checksum.
fn rewrite_checkpoint(path: &Path, change: impl FnOnce(&mut Vec<u8>)) {
    let mut bytes = fs::read(path).unwrap();
    bytes.truncate(bytes.len() - 4);
    change(&mut bytes);
    let checksum = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&checksum.to_le_bytes());
    fs::write(path, &bytes).unwrap();
}

/// Where the raw bytes of checkpoint array `name` start.
fn array_offset(bytes: &[u8], name: &str) -> usize {
    let tag = [&(name.len() as u32).to_le_bytes()[..], name.as_bytes()].concat();
    let at = bytes
        .windows(tag.len())
        .position(|window| window == tag.as_slice())
        .expect("the array is in the checkpoint");
    at + tag.len() + 8
}

/// A checkpoint whose checksum holds but whose first particle sits at NaN:
/// `firn run --resume` refuses it with the file and the reason instead of
/// resuming into it.
#[test]
fn a_checkpoint_with_a_particle_at_nan_is_not_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scene = tiny_run(dir.path(), &out);
    let checkpoint = out.join("checkpoint.firnckpt");
    rewrite_checkpoint(&checkpoint, |bytes| {
        let at = array_offset(bytes, "position");
        bytes[at..at + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    });

    let output = firn_within(
        &[
            "run",
            scene.to_str().unwrap(),
            "--resume",
            "--no-render",
            "-q",
        ],
        &[],
        Duration::from_secs(60),
    );

    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains(&format!(
            "checkpoint {} holds a state no run of this scene reaches: particle 0 is at [NaN",
            checkpoint.display()
        )),
        "{message}"
    );
    assert!(message.contains("fix: run without --resume"), "{message}");
}

/// My absurd case: a checkpoint that claims to follow frame 7 of a scene of
/// two frames, its checksum made to match.
#[test]
fn a_checkpoint_past_the_last_frame_is_not_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let scene = tiny_run(dir.path(), &out);
    let checkpoint = out.join("checkpoint.firnckpt");
    rewrite_checkpoint(&checkpoint, |bytes| {
        let text = b"\"frame\":2";
        let at = bytes
            .windows(text.len())
            .position(|window| window == text)
            .expect("the frame counter is in the metadata");
        bytes[at + text.len() - 1] = b'7';
    });

    let output = firn_within(
        &[
            "run",
            scene.to_str().unwrap(),
            "--resume",
            "--no-render",
            "-q",
        ],
        &[],
        Duration::from_secs(60),
    );

    let message = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{message}");
    assert!(
        message.contains("it was taken after frame 7, but the scene has 2 frames"),
        "{message}"
    );
    assert!(text(&output.stdout).is_empty(), "{}", text(&output.stdout));
}

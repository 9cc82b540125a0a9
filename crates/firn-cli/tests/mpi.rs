//! `mpirun -np N firn run SCENE` (the `mpi` feature): the same PLY frames,
//! byte for byte, for 1 to 4 ranks and one process, both transfer schemes
//! and a curl-noise flow; a run stopped on one rank count resumes on
//! another with the same bytes, rigid bodies too, and on GPU ranks those of
//! one GPU process (lavapipe in CI); a failing rank stops the
//! run with its message; the semi-implicit integrator is refused. Skipped without
//! `mpirun` unless `FIRN_REQUIRE_MPI=1`.

#![cfg(feature = "mpi")]

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{firn, firn_binary};

/// The scene of the MPI tests: two snowballs crossing the slabs both ways
/// and a moving box.
fn crossing_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firn-mpi/tests/crossing.toml")
}

/// Whether `mpirun` is here; fails the test if it must be.
fn have_mpirun() -> bool {
    let found = Command::new("mpirun").arg("--version").output().is_ok();
    if !found && std::env::var_os("FIRN_REQUIRE_MPI").is_some_and(|v| v == "1") {
        panic!("FIRN_REQUIRE_MPI=1 but mpirun is not on PATH (install openmpi-bin)");
    }
    if !found {
        eprintln!("skipped: no mpirun (install openmpi-bin, or set FIRN_REQUIRE_MPI=1 to fail)");
    }
    found
}

/// `mpirun -np ranks firn args…`, oversubscribing the cores, one thread a
/// rank, quiet (the options of `firn run`).
fn mpirun(ranks: usize, args: &[&str]) -> Output {
    launch(ranks, &[args, &["--quiet"]].concat())
}

/// `mpirun -np ranks firn args… --threads 1`, oversubscribing the cores.
fn launch(ranks: usize, args: &[&str]) -> Output {
    Command::new("mpirun")
        .args(["--oversubscribe", "-np", &ranks.to_string()])
        .arg(firn_binary())
        .args(args)
        .args(["--threads", "1"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .output()
        .expect("mpirun starts")
}

fn assert_success(output: &Output, what: &str) {
    assert!(
        output.status.success(),
        "{what} failed: {}\n{}",
        output.status,
        String::from_utf8_lossy(&output.stderr)
    );
}

/// The PLY frames of a run directory, by name.
fn frames(run: &Path) -> Vec<(String, Vec<u8>)> {
    let mut frames: Vec<_> = fs::read_dir(run.join("ply"))
        .unwrap()
        .map(|entry| {
            let path = entry.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, fs::read(&path).unwrap())
        })
        .collect();
    frames.sort();
    frames
}

/// `firn run scene` to frame `frames` in one process of one thread, into
/// `out`.
fn run_alone(scene: &str, out: &Path, frames: u32) {
    let output = firn(&[
        "run",
        scene,
        "--out",
        out.to_str().unwrap(),
        "--frames",
        &frames.to_string(),
        "--threads",
        "1",
        "--quiet",
    ]);
    assert_success(&output, "one process");
}

/// `mpirun -np ranks firn run scene` to frame `frames` into `out`; its PLY
/// frames.
fn run_split(ranks: usize, scene: &str, out: &Path, frames: u32) -> Vec<(String, Vec<u8>)> {
    let output = mpirun(
        ranks,
        &[
            "run",
            scene,
            "--out",
            out.to_str().unwrap(),
            "--frames",
            &frames.to_string(),
        ],
    );
    assert_success(&output, &format!("{ranks} ranks"));
    self::frames(out)
}

/// `scene` run to frame `stop` on `first` ranks, then resumed to frame `end`
/// on `second` ranks, into `out`; its PLY frames.
fn stopped_and_resumed(
    scene: &str,
    out: &Path,
    (first, stop): (usize, u32),
    (second, end): (usize, u32),
) -> Vec<(String, Vec<u8>)> {
    run_split(first, scene, out, stop);
    let out_text = out.to_str().unwrap();
    let end_text = end.to_string();
    assert_success(
        &mpirun(
            second,
            &[
                "run", scene, "--out", out_text, "--frames", &end_text, "--resume",
            ],
        ),
        &format!("resumed on {second} ranks"),
    );
    frames(out)
}

/// The crossing scene with `transfer`, written into `dir`.
fn scene_with(dir: &Path, transfer: &str) -> PathBuf {
    let text = fs::read_to_string(crossing_scene()).unwrap().replace(
        "transfer = \"pic-flip\"",
        &format!("transfer = \"{transfer}\""),
    );
    let path = dir.join(format!("crossing-{transfer}.toml"));
    fs::write(&path, text).unwrap();
    path
}

#[test]
fn every_rank_count_writes_the_one_process_frames_byte_for_byte() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for transfer in ["pic-flip", "apic"] {
        let scene = scene_with(dir.path(), transfer);
        let scene = scene.to_str().unwrap();
        let alone = dir.path().join(format!("{transfer}-alone"));
        run_alone(scene, &alone, 3);
        let reference = frames(&alone);
        assert_eq!(reference.len(), 4, "frames 0 to 3");
        for ranks in 1..=4 {
            let out = dir.path().join(format!("{transfer}-{ranks}"));
            let split = run_split(ranks, scene, &out, 3);
            for ((name, whole), (_, parts)) in reference.iter().zip(&split) {
                assert!(
                    whole == parts,
                    "{transfer}: {name} differs with {ranks} ranks"
                );
            }
            assert_eq!(split.len(), reference.len());
        }
    }
}

/// The boot scene, coarse and without pictures, its sequence shifted so
/// that the boot is pressing into the snow from the first frame, written
/// into `dir`.
fn pressing_boot_scene(dir: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let boot = root.join("assets/meshes/boot/frame_####.ply");
    let text = fs::read_to_string(root.join("scenes/boot-print.toml"))
        .unwrap()
        .replace("cell_size = 0.015", "cell_size = 0.03")
        .replace(
            "sequence = \"../assets/meshes/boot/frame_####.ply\"",
            &format!("sequence = {:?}\nstart = -0.45", boot.to_str().unwrap()),
        )
        .replace("styles = [\"points\"]", "enabled = false");
    let path = dir.join("boot.toml");
    fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_deforming_collider_on_two_ranks_writes_the_one_process_frames() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = pressing_boot_scene(dir.path());
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    run_alone(scene, &alone, 3);
    let reference = frames(&alone);
    let split = run_split(2, scene, &dir.path().join("split"), 3);
    assert_eq!(split.len(), reference.len());
    for ((name, whole), (_, parts)) in reference.iter().zip(&split) {
        assert!(whole == parts, "{name} differs with 2 ranks");
    }
}

#[test]
fn a_run_stopped_on_two_ranks_resumes_on_three_with_the_same_bytes() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = crossing_scene();
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    run_alone(scene, &alone, 4);
    let split = dir.path().join("split");
    assert!(
        frames(&alone) == stopped_and_resumed(scene, &split, (2, 2), (3, 4)),
        "the resumed frames differ"
    );
}

/// The crossing scene with a free box that the right snowball hits,
/// written into `dir`.
fn crossing_with_a_box(dir: &Path) -> PathBuf {
    let text = fs::read_to_string(crossing_scene()).unwrap().replace(
        "[render]",
        "[[rigid_bodies]]\nshape = \"box\"\ncenter = [0.72, 0.3, 0.2]\nsize = [0.1, 0.1, 0.1]\ndensity = 400.0\n\n[render]",
    );
    let path = dir.join("crossing-with-a-box.toml");
    fs::write(&path, text).unwrap();
    path
}

/// Every frame's rigid body poses in a run's manifest, as JSON text.
fn body_poses(run: &Path) -> Vec<String> {
    let text = fs::read_to_string(run.join("manifest.json")).unwrap();
    let manifest: serde_json::Value = serde_json::from_str(&text).unwrap();
    manifest["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|frame| frame["rigid_bodies"].to_string())
        .collect()
}

#[test]
fn a_rigid_body_on_two_ranks_resumed_on_three_moves_as_in_one_process() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = crossing_with_a_box(dir.path());
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    run_alone(scene, &alone, 4);
    let split = dir.path().join("split");
    assert!(
        frames(&alone) == stopped_and_resumed(scene, &split, (2, 2), (3, 4)),
        "the snow differs"
    );
    let poses = body_poses(&alone);
    assert_eq!(poses.len(), 5, "frames 0 to 4");
    assert_ne!(poses[0], poses[4], "the box never moved");
    assert_eq!(body_poses(&split), poses, "the box differs");
}

/// Whether a GPU adapter (lavapipe in CI) is here; fails the test if it
/// must be.
fn have_gpu() -> bool {
    firn_gpu::context_for_tests().is_some()
}

#[test]
fn one_to_four_gpu_ranks_write_one_gpu_process_frames_and_resume_on_another_count() {
    if !have_mpirun() || !have_gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with(dir.path(), "apic");
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    let output = firn(&[
        "run",
        scene,
        "--out",
        alone.to_str().unwrap(),
        "--frames",
        "4",
        "--backend",
        "gpu",
        "--quiet",
    ]);
    assert_success(&output, "one GPU process");
    let split = dir.path().join("split");
    let out = split.to_str().unwrap();
    let gpu = ["--backend", "gpu"];
    let first = mpirun(
        2,
        &[&["run", scene, "--out", out, "--frames", "2"][..], &gpu].concat(),
    );
    assert_success(&first, "2 GPU ranks");
    let manifest = fs::read_to_string(split.join("manifest.json")).unwrap();
    assert!(manifest.contains("\"backend\": \"gpu\""), "{manifest}");
    let resumed = mpirun(
        3,
        &[
            &["run", scene, "--out", out, "--frames", "4", "--resume"][..],
            &gpu,
        ]
        .concat(),
    );
    assert_success(&resumed, "resumed on 3 GPU ranks");
    let reference = frames(&alone);
    assert_eq!(reference.len(), 5, "frames 0 to 4");
    assert!(
        reference == frames(&split),
        "the GPU ranks' frames differ from one GPU's"
    );
    for ranks in [1, 4] {
        let other = dir.path().join(format!("split-{ranks}"));
        let out = other.to_str().unwrap();
        let run = ["run", scene, "--out", out, "--frames", "2"];
        assert_success(
            &mpirun(ranks, &[&run[..], &gpu].concat()),
            &format!("{ranks} GPU ranks"),
        );
        assert!(
            reference[..3] == frames(&other)[..],
            "{ranks} GPU ranks' frames differ from one GPU's"
        );
    }
}

/// The flow scene of the MPI tests: a stream with rebirth, a sphere and
/// trails.
fn stream_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../firn-mpi/tests/stream.toml")
}

#[test]
fn a_flow_on_any_rank_count_writes_the_one_process_frames_and_resumes_on_another() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = stream_scene();
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    run_alone(scene, &alone, 4);
    let reference = frames(&alone);
    assert_eq!(reference.len(), 5, "frames 0 to 4");
    for ranks in 2..=4 {
        let out = dir.path().join(format!("ranks-{ranks}"));
        assert!(
            run_split(ranks, scene, &out, 4) == reference,
            "the flow's frames differ with {ranks} ranks"
        );
    }
    let resumed = dir.path().join("resumed");
    assert!(
        stopped_and_resumed(scene, &resumed, (3, 2), (2, 4)) == reference,
        "the resumed flow's frames differ"
    );
}

#[test]
fn a_rank_that_blows_up_stops_every_rank_with_its_message() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // A fixed step far past the elastic limit: the snow blows up at once.
    let text = fs::read_to_string(crossing_scene())
        .unwrap()
        .replace("step = \"adaptive\"", "step = \"fixed\"")
        .replace("cfl = 0.4\n", "")
        .replace("dt = 2e-3", "dt = 3e-2");
    let scene = dir.path().join("unstable.toml");
    fs::write(&scene, text).unwrap();
    let out = dir.path().join("run");
    let output = mpirun(
        3,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("likely cause"), "{stderr}");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "one rank reports: {stderr}"
    );
}

#[test]
fn the_flow_bench_runs_split_and_reports_every_rank() {
    if !have_mpirun() {
        return;
    }
    let output = launch(
        2,
        &[
            "bench",
            "--flow",
            "--particles",
            "5000",
            "--steps",
            "2",
            "--warmup",
            "1",
            "--simd",
            "portable",
        ],
    );
    assert_success(&output, "the split flow bench");
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("firn mpi flow ranks=2 threads=1 simd=portable particles=5000 steps=2"),
        "{stdout}"
    );
    // 5000 particles are chunks 0-4 of 1024: rank 0 moves 0, 2 and 4.
    assert!(
        stdout.contains("rank 0: particles=2952 bytes_sent_per_step=0"),
        "{stdout}"
    );
    // Rank 1's 2048 particles, 36 bytes each, and the message's two counts.
    assert!(
        stdout.contains("rank 1: particles=2048 bytes_sent_per_step=73744"),
        "{stdout}"
    );
}

#[test]
fn the_semi_implicit_integrator_is_refused_on_several_ranks() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let scene = crossing_scene();
    let output = mpirun(
        2,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--integrator",
            "semi-implicit",
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("semi-implicit"), "{stderr}");
    assert!(!out.join("manifest.json").exists(), "nothing is written");
}

/// The particle positions, as bits, of a frame's PLY cache, sorted.
fn ply_positions(path: &Path) -> Vec<[u32; 3]> {
    let cloud = firn_io::read_ply(path).unwrap();
    let mut positions: Vec<[u32; 3]> = cloud
        .positions()
        .unwrap()
        .iter()
        .map(|p| p.to_array().map(f32::to_bits))
        .collect();
    positions.sort_unstable();
    positions
}

/// The points of a VTK PolyData piece, as bits: its `Points` array,
/// base64 of a u64 byte count and the little-endian floats.
fn vtp_positions(path: &Path) -> Vec<[u32; 3]> {
    use base64::Engine;
    let text = fs::read_to_string(path).unwrap();
    let points = &text[text.find("<Points>").expect("a Points element")..];
    let start = points.find("format=\"binary\">").unwrap() + "format=\"binary\">".len();
    let end = points.find("</DataArray>").unwrap();
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(points[start..end].trim())
        .unwrap();
    let (count, data) = bytes.split_at(8);
    assert_eq!(
        u64::from_le_bytes(count.try_into().unwrap()) as usize,
        data.len()
    );
    data.chunks_exact(12)
        .map(|point| {
            std::array::from_fn(|axis| {
                u32::from_le_bytes(point[4 * axis..4 * axis + 4].try_into().unwrap())
            })
        })
        .collect()
}

/// The files of each frame of a run's PVD collection, by time in order:
/// (part, file) per piece.
fn collection(run: &Path) -> Vec<Vec<(u32, String)>> {
    let text = fs::read_to_string(run.join("particles.pvd")).unwrap();
    let attribute = |line: &str, name: &str| {
        let start = line.find(&format!("{name}=\"")).unwrap() + name.len() + 2;
        line[start..start + line[start..].find('"').unwrap()].to_string()
    };
    let mut frames: Vec<(String, Vec<(u32, String)>)> = Vec::new();
    for line in text.lines().filter(|line| line.contains("<DataSet")) {
        let time = attribute(line, "timestep");
        let piece = (
            attribute(line, "part").parse().unwrap(),
            attribute(line, "file"),
        );
        match frames.last_mut() {
            Some((last, pieces)) if *last == time => pieces.push(piece),
            _ => frames.push((time, vec![piece])),
        }
    }
    frames.into_iter().map(|(_, pieces)| pieces).collect()
}

#[test]
fn every_rank_writes_its_vtk_piece_and_the_pieces_hold_every_particle_once() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let text = fs::read_to_string(crossing_scene())
        .unwrap()
        .replace("formats = [\"ply\"]", "formats = [\"ply\", \"vtk\"]");
    let scene = dir.path().join("crossing-vtk.toml");
    fs::write(&scene, text).unwrap();
    let out = dir.path().join("split");
    let output = mpirun(
        3,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--frames",
            "2",
        ],
    );
    assert_success(&output, "3 ranks");
    let frames = collection(&out);
    assert_eq!(frames.len(), 3, "frames 0 to 2 in the collection");
    for (index, pieces) in frames.iter().enumerate() {
        let parts: Vec<u32> = pieces.iter().map(|(part, _)| *part).collect();
        assert_eq!(parts, [0, 1, 2], "frame {index}: one piece per rank");
        let mut together: Vec<[u32; 3]> = pieces
            .iter()
            .flat_map(|(_, file)| vtp_positions(&out.join(file)))
            .collect();
        together.sort_unstable();
        let merged = ply_positions(&out.join(format!("ply/frame_{index:05}.ply")));
        assert!(!merged.is_empty());
        assert!(
            together == merged,
            "frame {index}: the pieces hold {} particles, the frame {}",
            together.len(),
            merged.len()
        );
    }
}

#[test]
fn a_run_killed_on_two_ranks_resumes_on_three_with_the_one_process_bytes() {
    use std::os::unix::process::CommandExt;
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = crossing_scene();
    let scene = scene.to_str().unwrap();
    let alone = dir.path().join("alone");
    run_alone(scene, &alone, 4);
    let split = dir.path().join("split");
    let out = split.to_str().unwrap();
    let mut killed = Command::new("mpirun")
        .args(["--oversubscribe", "-np", "2"])
        .arg(firn_binary())
        .args(["run", scene, "--out", out, "--frames", "4"])
        .args(["--threads", "1", "--quiet"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .process_group(0)
        .spawn()
        .expect("mpirun starts");
    // The checkpoint is taken after frame 2 (checkpoint_every = 2): kill
    // the whole job while it simulates frame 4.
    let frame_3 = split.join("ply/frame_00003.ply");
    while !frame_3.exists() {
        assert!(
            killed.try_wait().unwrap().is_none(),
            "the run ended before frame 3"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let group = format!("-{}", killed.id());
    let kill = Command::new("kill")
        .args(["-KILL", "--", &group])
        .status()
        .unwrap();
    assert!(kill.success(), "kill -KILL {group}");
    let status = killed.wait().unwrap();
    assert!(!status.success(), "the run was killed");
    assert!(
        !split.join("ply/frame_00004.ply").exists(),
        "killed before frame 4"
    );
    assert_success(
        &mpirun(
            3,
            &["run", scene, "--out", out, "--frames", "4", "--resume"],
        ),
        "resumed on 3 ranks",
    );
    assert!(
        frames(&alone) == frames(&split),
        "the resumed frames differ"
    );
    let pieces = fs::read_to_string(split.join("checkpoint-pieces.json")).unwrap();
    assert!(pieces.contains("frame_00004_rank_0002"), "{pieces}");
}

#[test]
fn a_rank_that_cannot_write_its_piece_stops_every_rank_with_its_message() {
    if !have_mpirun() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let text = fs::read_to_string(crossing_scene())
        .unwrap()
        .replace("formats = [\"ply\"]", "formats = [\"ply\", \"vtk\"]");
    let scene = dir.path().join("crossing-vtk.toml");
    fs::write(&scene, text).unwrap();
    let out = dir.path().join("split");
    // A folder where rank 1's piece of frame 2 goes: its rename fails.
    fs::create_dir_all(out.join("vtk/frame_00002_part_0001.vtp/blocked")).unwrap();
    let output = mpirun(
        2,
        &[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--frames",
            "3",
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("rank 1 of 2"), "{stderr}");
    assert!(stderr.contains("frame_00002_part_0001.vtp"), "{stderr}");
    assert_eq!(
        stderr.matches("error:").count(),
        1,
        "one rank reports: {stderr}"
    );
    let listed = collection(&out);
    assert_eq!(listed.len(), 2, "frames 0 and 1 listed, not frame 2");
    assert!(
        !out.join("ply/frame_00002.ply").exists(),
        "frame 2 not written"
    );
}

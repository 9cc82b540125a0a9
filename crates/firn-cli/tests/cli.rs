//! The `firn` command end to end: outputs, determinism, resume, and a clear
//! error with exit code 2 and nothing written for every kind of bad input.

use std::fs;
use std::path::Path;
use std::process::Output;

mod common;
use common::{firn, manifest, text, write_scene};

const SMALL_SCENE: &str = r#"format = 1
name = "small"

[domain]
max = [0.5, 0.5, 0.5]
cell_size = 0.05

[time]
duration = 0.1
fps = 40

[[bodies]]
shape = "sphere"
center = [0.25, 0.2, 0.25]
radius = 0.08
velocity = [2.0, -1.0, 0.0]
"#;

/// `firn run SCENE --out OUT --quiet --backend cpu`.
fn run_into(scene: &Path, out: &Path) -> Output {
    firn(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--backend",
        "cpu",
    ])
}

fn run_small(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let scene = write_scene(dir, "small.toml", SMALL_SCENE);
    let out = dir.join(out);
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--backend",
        "cpu",
    ];
    args.extend_from_slice(extra);
    firn(&args)
}

#[test]
fn a_run_writes_caches_manifest_and_collection() {
    let dir = tempfile::tempdir().unwrap();
    let output = run_small(dir.path(), "run", &[]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let out = dir.path().join("run");
    for frame in 0..=4 {
        assert!(
            out.join(format!("ply/frame_{frame:05}.ply")).is_file(),
            "PLY of frame {frame}"
        );
        assert!(
            out.join(format!("vtk/frame_{frame:05}.vtp")).is_file(),
            "VTP of frame {frame}"
        );
    }
    let manifest = manifest(&out);
    assert_eq!(manifest["frames"].as_array().unwrap().len(), 5);
    assert_eq!(manifest["status"]["state"], "finished");
    assert!(
        manifest["frames"][2]["ns_per_particle_substep"]
            .as_f64()
            .unwrap()
            > 0.0
    );
    let pvd = fs::read_to_string(out.join("particles.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 5);
    let cloud = firn_io::read_ply(&out.join("ply/frame_00004.ply")).unwrap();
    let positions = cloud.positions().unwrap();
    assert!(!positions.is_empty());
    assert!(
        cloud
            .floats("density")
            .unwrap()
            .iter()
            .all(|d| d.is_finite() && *d > 0.0)
    );
    // No temporary files are left behind.
    for entry in fs::read_dir(out.join("ply")).unwrap() {
        let name = entry.unwrap().file_name();
        assert!(!name.to_string_lossy().contains(".tmp"), "{name:?}");
    }
}

#[test]
fn progress_goes_to_logs_as_a_line_per_frame_unless_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let out = dir.path().join("out");
    let output = firn(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(output.status.success());
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("frame 1/4") && stderr.contains("frame 4/4"),
        "{stderr}"
    );
    assert!(
        stderr.contains("substeps/s") && stderr.contains("ETA"),
        "{stderr}"
    );
    let start = stderr.lines().next().unwrap_or_default();
    assert!(
        start.starts_with("firn: small: ") && start.contains("frames 1 to 4, on the "),
        "the start line says what runs where: {stderr}"
    );
    let quiet = run_into(&scene, &dir.path().join("quiet"));
    assert!(text(&quiet.stderr).is_empty(), "{}", text(&quiet.stderr));
}

#[test]
fn thread_count_does_not_change_the_bits() {
    let dir = tempfile::tempdir().unwrap();
    assert!(
        run_small(dir.path(), "one", &["--threads", "1"])
            .status
            .success()
    );
    assert!(
        run_small(dir.path(), "two", &["--threads", "2"])
            .status
            .success()
    );
    let one = fs::read(dir.path().join("one/ply/frame_00004.ply")).unwrap();
    let two = fs::read(dir.path().join("two/ply/frame_00004.ply")).unwrap();
    assert!(one == two, "1 and 2 threads gave different frames");
}

#[test]
fn a_resumed_run_matches_an_uninterrupted_one() {
    let dir = tempfile::tempdir().unwrap();
    assert!(run_small(dir.path(), "straight", &[]).status.success());
    let first = run_small(dir.path(), "resumed", &["--frames", "2"]);
    assert!(first.status.success(), "{}", text(&first.stderr));
    assert!(!dir.path().join("resumed/ply/frame_00003.ply").exists());
    let second = run_small(dir.path(), "resumed", &["--resume"]);
    assert!(second.status.success(), "{}", text(&second.stderr));
    for frame in [3, 4] {
        let name = format!("ply/frame_{frame:05}.ply");
        let straight = fs::read(dir.path().join("straight").join(&name)).unwrap();
        let resumed = fs::read(dir.path().join("resumed").join(&name)).unwrap();
        assert!(straight == resumed, "frame {frame} differs after resume");
    }
    let manifest: serde_json::Value = serde_json::from_str(
        &fs::read_to_string(dir.path().join("resumed/manifest.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(manifest["frames"].as_array().unwrap().len(), 5);
}

#[test]
fn a_blow_up_stops_with_an_explanation_and_no_bad_frame() {
    let dir = tempfile::tempdir().unwrap();
    let unstable = SMALL_SCENE.replace("fps = 40", "fps = 10\nstep = \"fixed\"\ndt = 0.01")
        + "material = \"stiff\"\n\n[materials.stiff]\nyoungs_modulus = 1e9\n";
    let scene = write_scene(dir.path(), "unstable.toml", &unstable);
    let out = dir.path().join("out");
    let output = run_into(&scene, &out);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("in frame 1") && stderr.contains("set dt = "),
        "{stderr}"
    );
    assert!(
        !out.join("ply/frame_00001.ply").exists(),
        "a frame was written after the blow-up"
    );
    let manifest = manifest(&out);
    assert_eq!(manifest["status"]["state"], "failed");
}

/// Runs `firn run` on a bad scene; asserts exit code 2, the located message
/// and that no output directory was created.
fn assert_rejected(scene_text: &str, location: &str, fragments: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "bad.toml", scene_text);
    let out = dir.path().join("out");
    let output = run_into(&scene, &out);
    let stderr = text(&output.stderr);
    assert_eq!(output.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains(&format!("bad.toml:{location}")),
        "expected location {location} in: {stderr}"
    );
    assert!(stderr.contains("fix:"), "no fix in: {stderr}");
    for fragment in fragments {
        assert!(
            stderr.contains(fragment),
            "expected `{fragment}` in: {stderr}"
        );
    }
    assert!(!out.exists(), "output written for a bad scene");
}

#[test]
fn unknown_key_is_rejected_with_its_location() {
    assert_rejected(
        &SMALL_SCENE.replace("radius = 0.08", "radus = 0.08"),
        "15:1",
        &["radus"],
    );
}

#[test]
fn wrong_type_is_rejected_with_its_location() {
    assert_rejected(
        &SMALL_SCENE.replace("cell_size = 0.05", "cell_size = \"fine\""),
        "6:13",
        &["cell_size"],
    );
}

#[test]
fn non_positive_cell_size_is_rejected() {
    assert_rejected(
        &SMALL_SCENE.replace("cell_size = 0.05", "cell_size = -0.05"),
        "6:13",
        &["cell_size"],
    );
}

#[test]
fn incompressible_poisson_ratio_is_rejected() {
    let scene =
        format!("{SMALL_SCENE}material = \"soft\"\n\n[materials.soft]\npoisson_ratio = 0.5\n");
    assert_rejected(&scene, "20:17", &["poisson_ratio"]);
}

#[test]
fn body_outside_the_domain_is_rejected() {
    assert_rejected(
        &SMALL_SCENE.replace("[0.25, 0.2, 0.25]", "[0.25, 0.45, 0.25]"),
        "14:10",
        &["bodies[0]"],
    );
}

#[test]
fn a_scene_without_snow_is_rejected() {
    let scene = SMALL_SCENE.split("[[bodies]]").next().unwrap();
    assert_rejected(scene, "1:1", &["[[bodies]]"]);
}

#[test]
fn a_body_too_small_for_a_particle_is_rejected() {
    let scene = SMALL_SCENE
        .replace("radius = 0.08", "radius = 0.001")
        .replace("velocity", "particles_per_cell = 1\nvelocity");
    assert_rejected(&scene, "1", &["bodies[0]"]);
}

#[test]
fn an_unreadable_scene_file_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.toml");
    let output = firn(&["run", missing.to_str().unwrap(), "--quiet"]);
    assert_eq!(output.status.code(), Some(2));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("missing.toml") && stderr.contains("fix:"),
        "{stderr}"
    );
}

#[test]
fn an_unwritable_output_directory_is_rejected() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let blocker = dir.path().join("blocker");
    fs::write(&blocker, "a file, not a directory").unwrap();
    let out = blocker.join("out");
    let output = run_into(&scene, &out);
    assert_eq!(output.status.code(), Some(2));
    let stderr = text(&output.stderr);
    assert!(
        stderr.contains("blocker") && stderr.contains("fix:"),
        "{stderr}"
    );
}

#[test]
fn presets_lists_every_material() {
    let output = firn(&["presets"]);
    assert!(output.status.success());
    let stdout = text(&output.stdout);
    for name in firn_core::scene::material::PRESET_NAMES {
        assert!(stdout.contains(name), "{name} missing from: {stdout}");
    }
}

#[test]
fn check_reports_particles_grid_and_first_step() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let output = firn(&["check", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    for field in ["particles", "10 x 10 x 10 cells", "memory", "first step"] {
        assert!(stdout.contains(field), "`{field}` missing from: {stdout}");
    }
}

/// `firn check` says whether the GPU backend runs a scene and what it needs
/// there, without opening an adapter.
/// Whether `firn check` says the GPU runs the scene, or, on a machine
/// without an adapter (where CI, which sets FIRN_REQUIRE_GPU=1, never is),
/// that there is none.
fn gpu_runs(stdout: &str) -> bool {
    let required = std::env::var("FIRN_REQUIRE_GPU").is_ok_and(|value| value == "1");
    stdout.contains("the GPU backend runs this scene on")
        || (!required && stdout.contains("no GPU adapter was found"))
}

/// `firn check` estimates the GPU's sparse grid: a small ball in a
/// 1024³-cell domain needs the block table (4 bytes per 4³-node block,
/// 65.5 MiB) and a few blocks of nodes, not the 34 GiB of a dense grid.
#[test]
fn check_estimates_the_sparse_gpu_grid_of_a_big_domain() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(
        dir.path(),
        "big.toml",
        &SMALL_SCENE.replace("max = [0.5, 0.5, 0.5]", "max = [51.2, 51.2, 51.2]"),
    );
    let output = firn(&["check", scene.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    let mib: f64 = stdout
        .split(" MiB of GPU buffers")
        .next()
        .and_then(|before| before.rsplit(' ').next())
        .and_then(|figure| figure.parse().ok())
        .unwrap_or_else(|| panic!("no GPU figure in: {stdout}"));
    assert!((65.0..70.0).contains(&mib), "{mib} MiB: {stdout}");
    assert!(
        stdout.contains("of the domain's 17173512 blocks"),
        "{stdout}"
    );
}

#[test]
fn check_says_whether_the_gpu_backend_runs_the_scene() {
    let dir = tempfile::tempdir().unwrap();
    let explicit = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let output = firn(&["check", explicit.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(
        gpu_runs(&stdout) && stdout.contains("MiB of GPU buffers"),
        "{stdout}"
    );
    let implicit = write_scene(
        dir.path(),
        "implicit.toml",
        &SMALL_SCENE.replace(
            "[domain]",
            "[solver]\nintegrator = \"semi-implicit\"\n\n[domain]",
        ),
    );
    let output = firn(&["check", implicit.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    // The semi-implicit solve's stress differentials: 224 bytes per particle more.
    assert!(
        gpu_runs(&stdout) && stdout.contains("429 bytes per particle"),
        "{stdout}"
    );
    let obstacles: String = (0..9)
        .map(|i| {
            let x = 0.05 + 0.04 * f64::from(i);
            format!("\n[[wind.obstacles]]\ncenter = [{x:.2}, 0.4, 0.4]\nradius = 0.02\n")
        })
        .collect();
    let sheltered = write_scene(
        dir.path(),
        "sheltered.toml",
        &format!("{SMALL_SCENE}\n[wind]\nbackground_strength = 2.0\n{obstacles}"),
    );
    let output = firn(&["check", sheltered.to_str().unwrap()]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains("CPU only") && stdout.contains("9 spheres"),
        "{stdout}"
    );
}

#[test]
fn check_json_prints_the_resolved_scene() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let output = firn(&["check", scene.to_str().unwrap(), "--json"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let resolved: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    // Defaults filled in: the snow preset and the adaptive step.
    assert_eq!(resolved["materials"][0]["name"], "snow");
    assert_eq!(resolved["time"]["step"]["kind"], "adaptive");
    assert_eq!(resolved["domain"]["cell_size"], 0.05);
}

#[test]
fn the_bundled_default_scene_checks() {
    let output = firn(&["check"]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(stdout.contains("snowball-wall"), "{stdout}");
    assert!(
        stdout.contains("clumps of 0.05 m (contrast 0.2)"),
        "{stdout}"
    );
}

#[test]
fn bench_times_a_scene_file_with_either_integrator() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "small.toml", SMALL_SCENE);
    let json = dir.path().join("bench.json");
    let output = firn(&[
        "bench",
        "--scene",
        scene.to_str().unwrap(),
        "--duration",
        "0.02",
        "--integrator",
        "semi-implicit",
        "--dt",
        "2e-3",
        "--phases",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(stdout.contains("mean_iterations="), "{stdout}");
    assert!(stdout.contains("implicit_ns_per_node_product="), "{stdout}");
    assert!(
        stdout.contains("implicit_solve"),
        "the phase table: {stdout}"
    );
    let records: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    let record = &records[0];
    assert_eq!(record["integrator"], "semi-implicit");
    assert_eq!(record["substeps"], 10);
    assert!(record["mean_solver_iterations"].as_f64().is_some());
    assert!(record["implicit_ns_per_node_product"].as_f64().unwrap() > 0.0);
    let phases = record["phases_ns_per_particle_substep"].as_array().unwrap();
    let implicit = phases
        .iter()
        .find(|phase| phase["phase"] == "implicit_solve")
        .expect("the implicit phase is profiled");
    assert!(implicit["ns_per_particle_substep"].as_f64().unwrap() > 0.0);
    assert!(
        record["wall_seconds_per_simulated_second"]
            .as_f64()
            .unwrap()
            > 0.0
    );
}

#[test]
fn the_semi_implicit_integrator_records_its_solver_work_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    let output = run_small(
        dir.path(),
        "implicit",
        &["--integrator", "semi-implicit", "--no-render"],
    );
    assert!(output.status.success(), "{}", text(&output.stderr));
    let manifest = manifest(&dir.path().join("implicit"));
    assert_eq!(
        manifest["scene"]["solver"]["integrator"]["kind"],
        "semi-implicit"
    );
    let frames = manifest["frames"].as_array().unwrap();
    assert!(frames[0].get("solver").is_some_and(|s| s["solves"] == 0));
    for frame in &frames[1..] {
        let solver = &frame["solver"];
        assert!(solver["solves"].as_u64().unwrap() > 0, "{frame}");
        assert_eq!(solver["unconverged"], 0, "{frame}");
    }
    // In free flight v* already solves the system; the landing takes work.
    let iterations: u64 = frames
        .iter()
        .map(|frame| frame["solver"]["iterations"].as_u64().unwrap())
        .sum();
    assert!(iterations > 0);
}

#[test]
fn a_flow_scene_runs_resumes_and_writes_its_caches() {
    let dir = tempfile::tempdir().unwrap();
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/curl-noise-demo.toml"
    );
    let whole = dir.path().join("whole");
    let part = dir.path().join("part");
    let run = |out: &Path, frames: &str, resume: bool| {
        let mut args = vec!["run", scene, "--out", out.to_str().unwrap()];
        args.extend(["--frames", frames, "--no-render", "--quiet"]);
        if resume {
            args.push("--resume");
        }
        let output = firn(&args);
        assert!(output.status.success(), "{}", text(&output.stderr));
    };
    run(&whole, "4", false);
    run(&part, "2", false);
    run(&part, "4", true);
    let cache = "ply/frame_00004.ply";
    assert_eq!(
        fs::read(whole.join(cache)).unwrap(),
        fs::read(part.join(cache)).unwrap(),
        "a resumed flow matches an uninterrupted one bit for bit"
    );
    let header = fs::read(whole.join(cache)).unwrap();
    let header = String::from_utf8_lossy(&header[..400]);
    assert!(header.contains("property float age"), "{header}");
}

#[test]
fn check_summarises_a_flow_scene() {
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../scenes/curl-noise-demo.toml"
    );
    let output = firn(&["check", scene]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    assert!(stdout.contains("curl-noise flow"), "{stdout}");
    assert!(stdout.contains("obstacles   1"), "{stdout}");
}

/// `firn bench` on the CPU, a 2000-particle APIC snowball for 4 substeps
/// with `extra` arguments: its standard output and its JSON record.
fn small_bench(extra: &[&str]) -> (String, serde_json::Value) {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let mut args = vec![
        "bench",
        "--particles",
        "2000",
        "--grid",
        "32",
        "--transfer",
        "apic",
        "--steps",
        "4",
        "--warmup",
        "1",
        "--backend",
        "cpu",
        "--json",
        json.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    let output = firn(&args);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let records: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    (text(&output.stdout), records[0].clone())
}

#[test]
fn bench_phases_split_each_substep_into_the_steps_of_the_algorithm() {
    let (stdout, record) = small_bench(&["--phases"]);
    for phase in [
        "binning",
        "scatter",
        "colliders",
        "grid_update",
        "implicit_solve",
        "gather",
        "clear",
        "rigid_bodies",
    ] {
        assert!(stdout.contains(phase), "{phase} missing from\n{stdout}");
    }
    let phases = record["phases_ns_per_particle_substep"].as_array().unwrap();
    assert_eq!(phases.len(), 8);
    let share: f64 = phases.iter().map(|p| p["share"].as_f64().unwrap()).sum();
    assert!((share - 1.0).abs() < 1e-9, "shares sum to {share}");
    let phase_ns: f64 = phases
        .iter()
        .map(|p| p["ns_per_particle_substep"].as_f64().unwrap())
        .sum();
    let total_ns = record["ns_per_particle_substep"].as_f64().unwrap();
    assert!(
        phase_ns > 0.0 && phase_ns <= total_ns,
        "the phases ({phase_ns} ns) lie within the substeps ({total_ns} ns)"
    );
}

#[test]
fn bench_simd_choices_are_recorded_and_agree_to_the_bit() {
    let (stdout, portable) = small_bench(&["--simd", "portable"]);
    assert!(stdout.contains("simd=portable"), "{stdout}");
    assert_eq!(portable["simd"], "portable");
    assert_eq!(portable["backend"], "cpu");
    assert!(portable.get("adapter").is_none() && portable.get("gpu_memory").is_none());
    let (_, chosen) = small_bench(&["--simd", "auto"]);
    assert_eq!(
        portable["center_of_mass_y"], chosen["center_of_mass_y"],
        "{} and portable code must give the same bits",
        chosen["simd"]
    );
}

#[test]
fn bench_flow_with_a_simd_path_times_only_that_path() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let output = firn(&[
        "bench",
        "--flow",
        "--simd",
        "portable",
        "--particles",
        "2000",
        "--steps",
        "2",
        "--warmup",
        "1",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stdout = text(&output.stdout);
    let lines: Vec<&str> = stdout
        .lines()
        .filter(|line| line.starts_with("firn flow"))
        .collect();
    assert_eq!(lines.len(), 1, "{stdout}");
    assert!(lines[0].contains("curl=analytic simd=portable"), "{stdout}");
    let records: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(records.as_array().unwrap().len(), 1);
    assert_eq!(records[0]["simd"], "portable");
    assert_eq!(records[0]["curl"], "analytic");
    // The CPU it ran on, printed and recorded with the figure.
    let cpu = &records[0]["cpu"];
    assert!(
        cpu["model"].as_str().is_some_and(|model| !model.is_empty()),
        "{cpu}"
    );
    let flags = cpu["simd_flags"].as_array().expect("a list of SIMD flags");
    assert!(
        stdout.contains(&format!("cpu: {}", cpu["model"].as_str().unwrap())),
        "{stdout}"
    );
    if cfg!(target_arch = "x86_64") && std::arch::is_x86_feature_detected!("avx2") {
        assert!(flags.iter().any(|flag| flag == "avx2"), "{cpu}");
    }
}

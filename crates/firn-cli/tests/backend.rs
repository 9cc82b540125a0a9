//! The compute backend end to end: `firn info`, `--backend` and the scene's
//! `[compute]` table on `firn run` and `firn bench`, GPU runs against CPU
//! runs, and resuming across backends.
//!
//! GPU runs need an adapter; a software one (Mesa's lavapipe) will do. Tests
//! that need one get it from `context_for_tests`, which skips them when there
//! is none and fails them instead when FIRN_REQUIRE_GPU=1 (as CI sets).

use std::fs;
use std::path::Path;
use std::process::Output;

use firn_core::Scene;
use firn_gpu::{AdapterPolicy, GpuSnow};
use glam::DVec3;

mod common;
use common::{firn, firn_within, manifest, stderr, text, tiny_ball_scene, write_scene};

/// How far (m) the mean particle position of a GPU run may stray from the
/// CPU run's over the tiny scene's three frames: 1/500 of a grid cell.
/// Measured on lavapipe: under 1e-7 m.
const CENTRE_TOLERANCE: f64 = 1e-4;

/// The tiny snowball scene (134 particles, three frames) in `dir`.
fn tiny_scene(dir: &Path, extra: &str) -> std::path::PathBuf {
    let scene = format!("{}{extra}", tiny_ball_scene("tiny", "[0.2, 0.2, 0.2]", ""));
    write_scene(dir, "tiny.toml", &scene)
}

/// `firn run SCENE --out DIR --no-render --quiet` with `extra` arguments.
fn run(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-render",
        "--quiet",
    ];
    args.extend_from_slice(extra);
    firn(&args)
}

/// Asserts that `output` succeeded, showing its stderr if not.
#[track_caller]
fn assert_ok(output: &Output) {
    assert!(output.status.success(), "{}", stderr(output));
}

/// The mean particle position of each frame of the run in `out`.
fn centres(out: &Path) -> Vec<DVec3> {
    let frames = manifest(out)["frames"].as_array().unwrap().len();
    (0..frames)
        .map(|frame| {
            let path = out.join(format!("ply/frame_{frame:05}.ply"));
            let positions = firn_io::read_ply(&path).unwrap().positions().unwrap();
            let sum: DVec3 = positions.iter().map(|p| p.as_dvec3()).sum();
            sum / positions.len() as f64
        })
        .collect()
}

#[test]
fn info_lists_the_cpu_the_adapters_and_autos_choice() {
    let output = firn(&["info"]);
    assert_ok(&output);
    let stdout = text(&output.stdout);
    assert!(
        stdout.starts_with(&format!("firn {}\n", env!("CARGO_PKG_VERSION"))),
        "{stdout}"
    );
    for fragment in ["cpu: ", "SIMD", "gpu adapters: ", "--backend auto: the "] {
        assert!(
            stdout.contains(fragment),
            "{fragment} missing from\n{stdout}"
        );
    }
    // No noise from Vulkan layers probing for a display.
    assert!(stderr(&output).is_empty(), "{}", stderr(&output));
    if let Some(context) = firn_gpu::context_for_tests() {
        assert!(stdout.contains(&context.adapter.name), "{stdout}");
        assert!(stdout.contains("max storage binding"), "{stdout}");
    }
}

#[test]
fn a_gpu_run_writes_the_frames_of_the_cpu_run_and_agrees_with_it() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "");
    let (cpu, gpu) = (dir.path().join("cpu"), dir.path().join("gpu"));
    assert_ok(&run(&scene, &cpu, &["--backend", "cpu"]));
    assert_ok(&run(&scene, &gpu, &["--backend", "gpu"]));
    let record = manifest(&gpu);
    assert_eq!(record["backend"], "gpu");
    assert_eq!(record["adapter"], context.adapter.name.as_str());
    assert_eq!(record["status"]["state"], "finished");
    assert_eq!(manifest(&cpu)["backend"], "cpu");
    assert!(manifest(&cpu).get("adapter").is_none());
    let (on_cpu, on_gpu) = (centres(&cpu), centres(&gpu));
    assert_eq!(on_cpu.len(), 4, "frame 0 and three more");
    assert_eq!(on_cpu.len(), on_gpu.len());
    for (frame, (a, b)) in on_cpu.iter().zip(&on_gpu).enumerate() {
        let apart = (*a - *b).length();
        assert!(
            apart < CENTRE_TOLERANCE,
            "frame {frame}: centres {a} and {b} are {apart} m apart"
        );
    }
    let fall = on_gpu[0].y - on_gpu[3].y;
    assert!(fall > 0.02, "the snowball fell only {fall} m");
}

#[test]
fn auto_takes_a_hardware_gpu_and_never_a_software_adapter() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "");
    let out = dir.path().join("auto");
    let output = run(&scene, &out, &["--backend", "auto", "--frames", "1"]);
    assert_ok(&output);
    assert!(stderr(&output).is_empty(), "{}", stderr(&output));
    let hardware = firn_gpu::choose(AdapterPolicy::HardwareOnly);
    let expected = if hardware.is_some() { "gpu" } else { "cpu" };
    assert_eq!(manifest(&out)["backend"], expected);
}

/// A wind around nine obstacles: one more than the GPU backend takes.
fn sheltered_scene(dir: &Path) -> std::path::PathBuf {
    let obstacles: String = (0..9)
        .map(|i| {
            let x = 0.04 + 0.04 * f64::from(i);
            format!("\n[[wind.obstacles]]\ncenter = [{x:.2}, 0.35, 0.35]\nradius = 0.02\n")
        })
        .collect();
    tiny_scene(
        dir,
        &format!("\n[wind]\nbackground_strength = 2.0\n{obstacles}"),
    )
}

#[test]
fn auto_stays_on_the_cpu_for_a_scene_the_gpu_cannot_run() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sheltered_scene(dir.path());
    let out = dir.path().join("sheltered");
    let output = firn(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-render",
        "--frames",
        "1",
    ]);
    assert_ok(&output);
    assert_eq!(manifest(&out)["backend"], "cpu");
    let said = stderr(&output);
    let start = said.lines().next().unwrap_or_default();
    if firn_gpu::choose(AdapterPolicy::HardwareOnly).is_some() {
        assert!(
            start.starts_with(
                "firn: --backend auto stays on the CPU: the GPU backend cannot run this scene: "
            ),
            "{said}"
        );
    } else {
        assert!(!said.contains("stays on the CPU"), "{said}");
        assert!(start.contains("on the CPU ("), "{said}");
    }
}

/// `--backend gpu --integrator semi-implicit` runs the solve on the GPU and
/// reports it in the manifest, as on the CPU.
#[test]
fn the_gpu_runs_the_semi_implicit_integrator() {
    if firn_gpu::context_for_tests().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "");
    let out = dir.path().join("implicit");
    let output = run(
        &scene,
        &out,
        &[
            "--backend",
            "gpu",
            "--integrator",
            "semi-implicit",
            "--frames",
            "1",
        ],
    );
    assert_ok(&output);
    let manifest = manifest(&out);
    assert_eq!(manifest["backend"], "gpu");
    let frame = &manifest["frames"][1];
    assert!(frame["solver"]["solves"].as_u64() > Some(0), "{frame}");
    assert_eq!(frame["solver"]["unconverged"], 0, "{frame}");
}

#[test]
fn the_flag_overrides_the_scenes_backend() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "\n[compute]\nbackend = \"gpu\"\n");
    let out = dir.path().join("cpu");
    assert_ok(&run(&scene, &out, &["--backend", "cpu", "--frames", "1"]));
    let record = manifest(&out);
    assert_eq!(record["backend"], "cpu");
    assert_eq!(record["scene"]["compute"]["backend"], "cpu");
}

#[test]
fn a_bogus_backend_flag_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "");
    let out = dir.path().join("bogus");
    let commands = [
        vec!["run", scene.to_str().unwrap(), "--backend", "bogus"],
        vec!["bench", "--backend", "bogus"],
    ];
    for command in commands {
        let output = firn(&command);
        let said = stderr(&output);
        assert_eq!(output.status.code(), Some(2), "{command:?}: {said}");
        assert!(
            said.contains("'bogus'")
                && said.contains("--backend")
                && said.contains("auto, cpu, gpu"),
            "{command:?}: {said}"
        );
    }
    assert!(!out.exists());
}

#[test]
fn a_bogus_backend_key_is_a_located_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "\n[compute]\nbackend = \"bogus\"\n");
    let line = fs::read_to_string(&scene)
        .unwrap()
        .lines()
        .position(|line| line.starts_with("backend = "))
        .unwrap()
        + 1;
    let out = dir.path().join("bogus");
    let output = run(&scene, &out, &[]);
    let said = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{said}");
    assert!(
        said.contains(&format!(
            "tiny.toml:{line}:11: compute.backend has no option \"bogus\""
        )),
        "{said}"
    );
    assert!(
        said.contains("fix: compute.backend takes one of \"auto\", \"cpu\", \"gpu\""),
        "{said}"
    );
    assert!(!out.exists(), "nothing is written for bad input");
}

/// A snowball in a cube of `side` metres cut into cells of `cell_size`,
/// on `backend`.
fn wide_scene(dir: &Path, side: f64, cell_size: f64, backend: &str) -> std::path::PathBuf {
    let text = format!(
        "format = 1\nname = \"wide\"\n\n[compute]\nbackend = \"{backend}\"\n\n\
         [time]\nduration = 0.1\n\n[domain]\nmax = [{side}, {side}, {side}]\ncell_size = {cell_size}\n\n\
         [[bodies]]\nshape = \"sphere\"\ncenter = [0.5, 0.5, 0.5]\nradius = 0.05\n"
    );
    write_scene(dir, &format!("wide-{backend}.toml"), &text)
}

/// `firn check` on [`wide_scene`] with `cells` cells a side, whose ball's
/// particle matrices pass the storage-buffer `limit` of adapter `adapter`:
/// it does not fit (the buffer, the figures, a fix), and the scene that
/// asks for the GPU fails.
fn check_refuses_a_ball_past_the_limit(dir: &Path, adapter: &str, limit: u64, cells: f64) {
    let wide = wide_scene(dir, 1.0, 1.0 / cells, "auto");
    let output = firn(&["check", wide.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    let stdout = text(&output.stdout);
    assert!(
        stdout.contains("the scene does not fit the GPU: one matrix per particle")
            && stdout.contains(&format!("allows {limit} bytes per storage buffer"))
            && stdout.contains(adapter)
            && stdout.contains("fix: use fewer particles_per_cell"),
        "{stdout}"
    );
    assert!(!stdout.contains("runs this scene"), "{stdout}");
    let asked = wide_scene(dir, 1.0, 1.0 / cells, "gpu");
    let output = firn(&["check", asked.to_str().unwrap()]);
    assert_eq!(output.status.code(), Some(2), "{}", stderr(&output));
    assert!(stderr(&output).contains("asks for the GPU"));
}

/// `firn check` holds a scene to the adapter `--backend gpu` would take: a
/// snowball whose particle matrices pass the adapter's storage-buffer limit
/// does not fit (the buffer, the figures, a fix), and a scene that asks for
/// the GPU then fails (where a domain of at most 1024 cells a side holds
/// such a ball: lavapipe's 128 MiB limit, not a hardware GPU's gigabytes);
/// a software adapter's buffers, which live in host memory, are held to the
/// machine's memory too.
#[test]
fn check_holds_the_scene_to_the_adapters_limits_and_memory() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let limit = context.adapter.max_storage_binding;
    // 48 bytes of each particle matrix, 8 particles per cell, a ball of
    // radius 0.05 m: cells a side for a quarter more particles than fit.
    let ball_cells = 1.25 * (limit / 48) as f64 / 8.0 / (4.0 / 3.0 * std::f64::consts::PI);
    let cells = (ball_cells.cbrt() / 0.05).ceil();
    if cells <= 1024.0 {
        check_refuses_a_ball_past_the_limit(dir.path(), &context.adapter.name, limit, cells);
    }

    let roomy = wide_scene(dir.path(), 2.0, 0.01, "auto");
    let output = firn(&["check", roomy.to_str().unwrap()]);
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(text(&output.stdout).contains("the GPU backend runs this scene on"));
    if context.adapter.is_software {
        // 3.67 MiB on the CPU, 2.0 MiB more of GPU buffers.
        let limited = [("FIRN_MEMORY_LIMIT", "5MiB")];
        let args = ["check", roomy.to_str().unwrap()];
        let output = firn_within(&args, &limited, std::time::Duration::from_secs(60));
        assert!(output.status.success(), "{}", stderr(&output));
        let stdout = text(&output.stdout);
        assert!(
            stdout.contains("keeps its buffers in this machine's memory, which allows 5.00 MiB"),
            "{stdout}"
        );
    }
}

#[test]
fn gpu_on_a_scene_the_gpu_cannot_run_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let scene = sheltered_scene(dir.path());
    let parsed = Scene::load(&scene).unwrap();
    let Err(firn_gpu::GpuError::Unsupported { what, .. }) = GpuSnow::check_supported(&parsed)
    else {
        panic!("the GPU backend takes at most 8 wind obstacles");
    };
    let out = dir.path().join("sheltered");
    let output = run(&scene, &out, &["--backend", "gpu"]);
    let said = stderr(&output);
    assert_eq!(output.status.code(), Some(2), "{said}");
    assert!(
        said.starts_with("error: the GPU backend cannot run this scene: "),
        "{said}"
    );
    assert!(said.contains(&what) && said.contains("fix: "), "{said}");
    assert!(!out.exists(), "nothing is written for bad input");
}

#[test]
fn a_gpu_run_resumes_from_its_checkpoint_on_either_backend() {
    if firn_gpu::context_for_tests().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = tiny_scene(dir.path(), "");
    let out = dir.path().join("resumed");
    assert_ok(&run(&scene, &out, &["--backend", "gpu", "--frames", "1"]));
    assert_eq!(manifest(&out)["frames"].as_array().unwrap().len(), 2);
    assert_ok(&run(
        &scene,
        &out,
        &["--backend", "gpu", "--frames", "2", "--resume"],
    ));
    assert_eq!(manifest(&out)["frames"].as_array().unwrap().len(), 3);
    assert_eq!(manifest(&out)["status"]["state"], "running");
    assert_ok(&run(&scene, &out, &["--backend", "cpu", "--resume"]));
    let record = manifest(&out);
    assert_eq!(record["status"]["state"], "finished");
    assert_eq!(record["backend"], "cpu");
    let times: Vec<f64> = record["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|frame| frame["time"].as_f64().unwrap())
        .collect();
    assert_eq!(times.len(), 4);
    for (frame, time) in times.iter().enumerate() {
        assert!((time - frame as f64 / 40.0).abs() < 1e-9, "{times:?}");
    }
    let straight = dir.path().join("straight");
    assert_ok(&run(&scene, &straight, &["--backend", "cpu"]));
    let (resumed, uninterrupted) = (centres(&out), centres(&straight));
    let apart = (resumed[3] - uninterrupted[3]).length();
    assert!(apart < CENTRE_TOLERANCE, "{apart} m from the CPU run");
}

#[test]
fn bench_on_the_gpu_records_its_adapter_and_memory() {
    let Some(context) = firn_gpu::context_for_tests() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("bench.json");
    let output = firn(&[
        "bench",
        "--backend",
        "gpu",
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
        "--phases",
        "--memory-budget-gib",
        "4",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_ok(&output);
    let stdout = text(&output.stdout);
    for fragment in [
        "firn backend=gpu adapter=",
        "bytes per particle",
        "within 4 GiB",
        "2^20 particles on 256^3",
        "  scatter ",
        "  gather ",
    ] {
        assert!(
            stdout.contains(fragment),
            "{fragment} missing from\n{stdout}"
        );
    }
    let records: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&json).unwrap()).unwrap();
    let record = &records[0];
    assert_eq!(record["backend"], "gpu");
    assert_eq!(record["adapter"], context.adapter.name.as_str());
    assert!(record["simd"].is_null());
    assert!(record["ns_per_particle_substep"].as_f64().unwrap() > 0.0);
    assert!(record["steps"].as_u64().unwrap() >= 3);
    let phases = record["phases_ns_per_particle_substep"].as_array().unwrap();
    let names: Vec<&str> = phases
        .iter()
        .map(|p| p["phase"].as_str().unwrap())
        .collect();
    assert_eq!(
        names,
        firn_gpu::snow::stage_times::STAGE_NAMES,
        "the GPU's stages"
    );
    let memory = &record["gpu_memory"];
    let particles = record["particles"].as_u64().unwrap();
    let total = particles * memory["bytes_per_particle"].as_u64().unwrap()
        + memory["grid_bytes"].as_u64().unwrap();
    assert_eq!(memory["total_bytes"].as_u64().unwrap(), total);
    assert_eq!(memory["budget_gib"], 4.0);
    let on_256 = memory["max_particles_on_256_grid"].as_u64().unwrap();
    assert!(on_256 > 0 && on_256 < memory["max_particles_on_this_grid"].as_u64().unwrap());
    assert_eq!(
        memory["thesis_2_20_particles_on_256_fit"],
        memory["thesis_2_20_particles_on_256_bytes"]
            .as_u64()
            .unwrap()
            <= 4 << 30
    );
}

/// A small curl-noise flow: a box of 300 particles and a short-lived stream
/// past a sphere, four frames.
const TINY_FLOW: &str = r#"format = 1
name = "tiny-flow"
kind = "flow"

[domain]
max = [10.0, 10.0, 10.0]

[time]
duration = 0.2
fps = 20

[flow]
noise_share = 0.6
length_scale = 2.0

[[flow.obstacles]]
center = [5.0, 5.0, 5.0]
radius = 1.0

[[flow.emitters]]
shape = "box"
center = [3.0, 5.0, 5.0]
size = [2.0, 2.0, 2.0]
count = 300

[[flow.emitters]]
shape = "sphere"
center = [2.0, 5.0, 5.0]
radius = 0.5
rate = 100.0
lifetime = 0.15
"#;

#[test]
fn a_gpu_flow_resumed_halfway_agrees_with_the_cpu_flow() {
    if firn_gpu::context_for_tests().is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = write_scene(dir.path(), "flow.toml", TINY_FLOW);
    let (cpu, gpu) = (dir.path().join("cpu"), dir.path().join("gpu"));
    assert_ok(&run(&scene, &cpu, &["--backend", "cpu"]));
    assert_ok(&run(&scene, &gpu, &["--backend", "gpu", "--frames", "2"]));
    assert_ok(&run(&scene, &gpu, &["--backend", "gpu", "--resume"]));
    let record = manifest(&gpu);
    assert_eq!(record["backend"], "gpu");
    assert_eq!(record["status"]["state"], "finished");
    assert_eq!(record["particle_count"], manifest(&cpu)["particle_count"]);
    let (on_cpu, on_gpu) = (centres(&cpu), centres(&gpu));
    assert_eq!(on_cpu.len(), 5, "frame 0 and four more");
    assert_eq!(on_cpu.len(), on_gpu.len());
    for (frame, (a, b)) in on_cpu.iter().zip(&on_gpu).enumerate() {
        let apart = (*a - *b).length();
        assert!(
            apart < CENTRE_TOLERANCE,
            "frame {frame}: centres {a} and {b} are {apart} m apart"
        );
    }
}

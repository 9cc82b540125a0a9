"""The Python module against the physics and the command line."""

import json
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import firn

ROOT = pathlib.Path(__file__).resolve().parents[2]


def firn_binary() -> pathlib.Path:
    """The `firn` command built by cargo (FIRN_BIN, or the workspace's)."""
    if "FIRN_BIN" in os.environ:
        return pathlib.Path(os.environ["FIRN_BIN"])
    for profile in ("release", "debug"):
        candidate = ROOT / "target" / profile / "firn"
        if candidate.exists():
            return candidate
    pytest.fail("no firn binary: build it with `cargo build -p firn-cli` or set FIRN_BIN")


def small_snowball() -> firn.Scene:
    """The default scene, two frames long."""
    scene = firn.Scene.default()
    scene["time.duration"] = 2 / scene.fps
    return scene


def short_frames(frames: int) -> firn.Scene:
    """The default scene at 120 frames per second (a quarter of the substeps
    of a 30 fps frame), `frames` frames long."""
    scene = firn.Scene.default()
    scene["time.fps"] = 120
    scene["time.duration"] = frames / 120
    return scene


def ply_bytes(run: pathlib.Path) -> dict:
    """A run directory's PLY frames by name."""
    return {path.name: path.read_bytes() for path in sorted((run / "ply").iterdir())}


def ctrl_c_timer(delay: float = 0.0) -> threading.Timer:
    """A thread that sends this process SIGINT (Ctrl-C) `delay` s after it
    is started. Python's own Ctrl-C handler is installed first: a process
    started in the background by a shell inherits SIGINT ignored, and then
    Python never installs it."""
    signal.signal(signal.SIGINT, signal.default_int_handler)
    return threading.Timer(delay, os.kill, (os.getpid(), signal.SIGINT))


def test_stepping_the_snowball_conserves_mass_and_moves_it():
    sim = firn.Simulation(small_snowball(), backend="cpu", threads=2)
    mass_before = sim.masses.sum(dtype=np.float64)
    start = sim.positions.mean(axis=0)
    assert sim.advance_frames(2) == 2
    assert sim.frame == 2 and sim.substeps > 0
    assert sim.masses.sum(dtype=np.float64) == mass_before
    moved = sim.positions.mean(axis=0) - start
    assert moved[0] > 0.05, moved  # thrown along +x at 5 m/s
    assert np.isfinite(sim.elastic_deformation).all()
    assert sim.elastic_deformation.shape == (len(sim), 3, 3)
    assert (sim.density > 0).all()


def test_run_matches_the_command_line_byte_for_byte(tmp_path):
    scene_file = tmp_path / "snowball.toml"
    scene_file.write_text(small_snowball().to_toml())
    subprocess.run(
        [str(firn_binary()), "run", str(scene_file), "--out", str(tmp_path / "cli"), "--no-render", "-q"],
        check=True,
        env={**os.environ, "FIRN_BACKEND": "cpu"},
    )
    out = firn.run(firn.Scene.load(scene_file), out=tmp_path / "py", render=False, backend="cpu")
    cli_frames = sorted((tmp_path / "cli" / "ply").iterdir())
    py_frames = sorted((pathlib.Path(out) / "ply").iterdir())
    assert [p.name for p in cli_frames] == [p.name for p in py_frames]
    assert len(py_frames) == 3
    for cli, py in zip(cli_frames, py_frames):
        assert cli.read_bytes() == py.read_bytes(), cli.name


def test_a_bad_dict_raises_scene_error_with_the_key_and_value_given():
    values = small_snowball().to_dict()
    values["domain"]["cell_size"] = -0.02
    with pytest.raises(firn.SceneError) as raised:
        firn.Scene.from_dict(values)
    error = raised.value
    assert isinstance(error, ValueError)
    # No line of a file holds the key: the error says where the value came from.
    assert error.line is None
    assert "set from Python: domain.cell_size = -0.02" in str(error)
    assert "fix:" in str(error)
    assert error.key == "domain.cell_size"


def test_an_error_names_the_files_own_line_or_the_value_set_from_python():
    path = ROOT / "scenes" / "snowball-wall.toml"
    lines = path.read_text().splitlines()
    scene = firn.Scene.load(str(path))
    with pytest.raises(firn.SceneError) as raised:
        scene["bodies[0].radius"] = -1.0
    error = raised.value
    assert error.line is None, str(error)
    assert "set from Python: bodies[0].radius = -1.0" in str(error)
    # A key the file still holds as written: the file's own line, although
    # the scene has changed since (and its TOML text has other lines).
    scene["bodies[0].velocity"] = [1.0, 0.0, 0.0]
    with pytest.raises(firn.SceneError) as raised:
        scene["domain.max"] = [0.2, 0.2, 0.2]
    error = raised.value
    assert error.key == "bodies[0].center", str(error)
    center = next(n for n, line in enumerate(lines, 1) if line.startswith("center = [0.25"))
    assert error.line == center, str(error)
    assert str(error).startswith(f"error: {path}:{center}:")
    assert "set from Python" not in str(error)


def test_a_change_that_is_not_valid_is_refused_and_not_kept():
    scene = small_snowball()
    with pytest.raises(firn.SceneError):
        scene["time.fps"] = -5
    assert scene.fps == 30
    scene["bodies[0].velocity"] = [2.0, 0.0, 0.0]
    assert scene["bodies[0].velocity"] == [2.0, 0.0, 0.0]


def test_wrong_arrays_are_refused():
    sim = firn.Simulation(small_snowball(), backend="cpu")
    with pytest.raises(ValueError, match="shape"):
        sim.velocities = np.zeros((len(sim), 2))
    bad = np.zeros((len(sim), 3))
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="finite"):
        sim.velocities = bad
    sim.velocities = np.zeros((len(sim), 3))
    assert not sim.velocities.any()
    sim.positions = sim.positions + np.float32(0.01)  # float32 in, converted


def test_stepping_releases_the_gil():
    sim = firn.Simulation(small_snowball(), backend="cpu", threads=1)
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    counter = threading.Thread(target=count)
    counter.start()
    started = time.perf_counter()
    sim.step(200)
    finished = time.perf_counter()
    stop.set()
    counter.join()
    during = [t for t in ticks if started < t < finished]
    print(f"{len(during)} ticks of the other thread during {finished - started:.2f} s of stepping")
    assert len(during) > 10


def test_progress_reports_each_frame():
    sim = firn.Simulation(small_snowball(), backend="cpu")
    seen = []
    sim.advance_frames(2, progress=seen.append)
    assert [d["frame"] for d in seen] == [1, 2]
    assert seen[-1]["eta_seconds"] == 0.0 and seen[0]["substeps_per_second"] > 0


def test_flow_field_is_divergence_free():
    flow = firn.FlowSimulation(firn.Scene.load(ROOT / "scenes" / "curl-noise-demo.toml"))
    flow.advance_frames(1)
    assert flow.positions.shape == (len(flow), 3)
    points = np.random.default_rng(1).uniform(-0.5, 0.5, size=(64, 3))
    velocity = flow.velocity_at(points)
    assert velocity.shape == (64, 3) and np.abs(velocity).max() > 0.01
    divergence = flow.divergence_at(points)
    assert np.abs(divergence).max() < 1e-5 * np.abs(velocity).max() / 1e-2


def test_the_example_script_runs(tmp_path):
    out = tmp_path / "plot.png"
    subprocess.run(
        [sys.executable, str(ROOT / "python" / "examples" / "snowball_plot.py"), str(out), "--seconds", "0.1"],
        check=True,
    )
    assert out.stat().st_size > 10_000


def test_reprs_say_what_things_are():
    scene = small_snowball()
    assert "snowball-wall" in repr(scene) and "snow" in repr(scene)
    assert "5758 snow particles" in repr(firn.Simulation(scene))


def test_ctrl_c_stops_stepping_and_leaves_a_consistent_state():
    sim = firn.Simulation(small_snowball(), backend="cpu", threads=1)
    mass = sim.masses.sum(dtype=np.float64)
    timer = ctrl_c_timer(0.3)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        sim.step(1_000_000)  # hours, unless Ctrl-C stops it
    timer.join()
    taken = sim.substeps
    assert 0 < taken < 1_000_000
    assert np.isfinite(sim.positions).all() and np.isfinite(sim.elastic_deformation).all()
    assert sim.masses.sum(dtype=np.float64) == mass
    assert sim.step(3) == 3 and sim.substeps == taken + 3
    assert sim.masses.sum(dtype=np.float64) == mass


def test_ctrl_c_stops_a_run_which_resumes_to_the_same_bytes(tmp_path):
    scene = short_frames(3)
    whole = pathlib.Path(firn.run(scene, out=tmp_path / "whole", render=False, backend="cpu"))
    parts = tmp_path / "parts"
    timers = []

    def press_ctrl_c(info):
        # The signal reaches the run while it simulates frame 2 or, if it
        # is quick, before this callback returns; either way it stops there.
        if info["frame"] == 1:
            timers.append(ctrl_c_timer())
            timers[0].start()

    with pytest.raises(KeyboardInterrupt):
        firn.run(scene, out=parts, render=False, backend="cpu", progress=press_ctrl_c)
    timers[0].join()
    manifest = json.loads((parts / "manifest.json").read_text())
    assert manifest["status"]["state"] == "running"
    stopped_at = manifest["frames"][-1]["index"]
    assert stopped_at in (1, 2), stopped_at
    assert sorted(ply_bytes(parts)) == [f"frame_{i:05}.ply" for i in range(stopped_at + 1)]
    assert (parts / "checkpoint.firnckpt").is_file()

    firn.run(scene, out=parts, render=False, backend="cpu", resume=True)
    assert ply_bytes(parts) == ply_bytes(whole)
    assert json.loads((parts / "manifest.json").read_text())["status"]["state"] == "finished"


def test_an_exception_in_progress_stops_a_run_at_that_frame(tmp_path):
    def fail_at_frame_1(info):
        if info["frame"] == 1:
            raise ValueError("enough")

    with pytest.raises(ValueError, match="enough"):
        firn.run(short_frames(3), out=tmp_path, render=False, backend="cpu", progress=fail_at_frame_1)
    assert sorted(ply_bytes(tmp_path)) == ["frame_00000.ply", "frame_00001.ply"]


def test_the_gpu_backend_steps_the_snowball_like_the_cpu():
    scene = small_snowball()
    scene["bodies[0].radius"] = 0.05  # 517 particles: lavapipe is slow
    try:
        gpu = firn.Simulation(scene, backend="gpu")
    except firn.SimulationError as error:
        if os.environ.get("FIRN_REQUIRE_GPU") == "1":
            pytest.fail(f"FIRN_REQUIRE_GPU=1 but the GPU backend cannot start: {error}")
        pytest.skip(f"no GPU adapter (Mesa's lavapipe will do): {error}")
    assert gpu.backend == "gpu" and "on the gpu" in repr(gpu)
    mass = gpu.masses.sum(dtype=np.float64)
    start = gpu.positions.mean(axis=0)
    gpu.step(4)
    assert gpu.masses.sum(dtype=np.float64) == mass
    cpu = firn.Simulation(scene, backend="cpu")
    cpu.advance_to(gpu.time)
    assert gpu.positions.mean(axis=0)[0] > start[0]
    assert np.abs(gpu.positions.mean(axis=0) - cpu.positions.mean(axis=0)).max() < 1e-4


def test_a_rendered_frame_shows_the_snowball_where_it_is(tmp_path):
    import matplotlib.image

    scene = short_frames(1)
    scene["render.size"] = [192, 108]
    moved = firn.Scene.from_dict(scene.to_dict())
    moved["bodies[0].center"] = [0.7, 0.45, 0.3]
    here, there = firn.Simulation(scene), firn.Simulation(moved)
    image = here.render(style="points")
    assert image.shape == (108, 192, 3) and image.dtype == np.uint8
    changed = (image != there.render(style="points")).any(axis=2)

    # Pixels within the balls' projected outlines (plus a sprite's width).
    rows, columns = np.mgrid[0:108, 0:192] + 0.5
    inside = np.zeros_like(changed)
    for sim in (here, there):
        pixels = sim.project(sim.positions)
        centre = sim.project(sim.positions.mean(axis=0, keepdims=True))[0]
        radius = np.linalg.norm(pixels - centre, axis=1).max() + 2
        inside |= np.hypot(columns - centre[0], rows - centre[1]) <= radius
    print(f"changed: {changed[inside].mean():.3f} inside the balls, {changed[~inside].mean():.4f} elsewhere")
    assert changed[inside].mean() > 0.5, "the balls are drawn where they are"
    assert changed[~inside].mean() < 0.05, "and little changes elsewhere"

    # The same pixels as the PNG `firn run` writes for that frame.
    run = pathlib.Path(firn.run(scene, out=tmp_path, backend="cpu"))
    here.advance_frames(1)
    png = matplotlib.image.imread(run / "images" / "points" / "frame_00001.png")
    assert np.array_equal(np.rint(png[..., :3] * 255).astype(np.uint8), here.render())
    with pytest.raises(ValueError, match="style"):
        here.render(style="watercolour")
    with pytest.raises(ValueError, match="pixels"):
        here.render(width=8)

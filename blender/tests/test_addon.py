"""The Blender add-on, headless: bake_scene.py builds a shot from
primitives in Debian's Blender (`blender -b`), bakes it through the
add-on's operators and writes what it saw; these tests check it.

The add-on is found as an installed one (a user scripts folder holding
addons/firn_blender), and the firn module as the one this Python imports.
Skipped where `blender` is missing, unless FIRN_REQUIRE_BLENDER=1 (as
.ci/run sets it)."""

import json
import math
import os
import shutil
import subprocess
import tomllib
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent
ADDON = HERE.parent / "firn_blender"
FRAMES = 10


def blender_runs():
    """Whether `blender` runs; fails where it must and does not."""
    found = shutil.which("blender") is not None
    if not found and os.environ.get("FIRN_REQUIRE_BLENDER") == "1":
        pytest.fail("FIRN_REQUIRE_BLENDER=1 but blender is not on PATH")
    return found


@pytest.fixture(scope="module")
def baked(tmp_path_factory):
    """Runs bake_scene.py once; its output folder and facts."""
    if not blender_runs():
        pytest.skip("blender is not on PATH (apt-get install blender)")
    import firn

    root = tmp_path_factory.mktemp("blender")
    (root / "scripts" / "addons").mkdir(parents=True)
    (root / "scripts" / "addons" / "firn_blender").symlink_to(ADDON)
    (root / "modules").mkdir()
    (root / "modules" / "firn").symlink_to(Path(firn.__file__).parent)
    out = root / "out"
    env = dict(os.environ, BLENDER_USER_SCRIPTS=str(root / "scripts"), PYTHONPATH=str(root / "modules"))
    command = [
        "blender",
        "-b",
        "--factory-startup",
        "--python-exit-code",
        "1",
        "--addons",
        "firn_blender",
        "--python",
        str(HERE / "bake_scene.py"),
        "--",
        "--out",
        str(out),
    ]
    done = subprocess.run(command, check=False, env=env, capture_output=True, text=True, timeout=600)
    log = "\n".join(line for line in done.stdout.splitlines() if not line.startswith("Fra:"))
    assert done.returncode == 0, log + done.stderr
    with open(out / "facts.json", encoding="utf-8") as file:
        return out, json.load(file)


def to_firn(point):
    """Blender's (x, y, z) in firn's axes (unit scale 1)."""
    x, y, z = point
    return [x, z, -y]


def close(a, b, tolerance=1e-6):
    """Whether two vectors agree."""
    return all(abs(x - y) <= tolerance for x, y in zip(a, b, strict=True))


def test_bad_settings_are_blender_errors_naming_the_object_and_nothing_is_baked(baked):
    _, facts = baked
    assert "Snowball (snow body)" in facts["outside_error"]
    assert "sticks out of the domain" in facts["outside_error"]
    assert "Domain: Cell Size" in facts["cell_error"]
    assert facts["bad_runs"] == [False] * 5


def test_bad_rigid_bodies_are_blender_errors_naming_the_object_and_setting(baked):
    _, facts = baked
    assert "Crate (rigid body), Mass: the rigid body's mass must be greater than 0" in facts["mass_error"]
    assert "Crate (rigid body), Location: the rigid body starts inside Ground (collider)" in facts["inside_error"]
    assert "Sheet (rigid body), Mesh:" in facts["volume_error"] and "encloses no volume" in facts["volume_error"]


def test_scene_file_puts_bodies_and_colliders_where_the_objects_are_in_firn_axes(baked):
    out, facts = baked
    scene = tomllib.loads(facts["scene_toml"])
    objects = facts["objects"]
    assert close(scene["domain"]["min"], [-0.6, 0.0, -0.6]) and close(scene["domain"]["max"], [0.6, 0.8, 0.6])
    assert scene["domain"]["cell_size"] == 0.04
    assert scene["time"]["fps"] == 24 and math.ceil(scene["time"]["duration"] * 24) == FRAMES - 1
    body = scene["bodies"][0]
    assert close(body["center"], to_firn(objects["ball"]["location"]))
    assert close(body["velocity"], [1.5, -1.0, -0.5])
    vertices = [
        [float(v) for v in line.split()[1:]]
        for line in (out / "whole" / body["mesh"]).read_text().splitlines()
        if line.startswith("v ")
    ]
    radii = [math.dist(v, body["center"]) for v in vertices]
    assert 0.119 < min(radii) and max(radii) < 0.1201
    block, ground, paddle = scene["colliders"]
    assert ground["shape"] == "plane"
    assert close(ground["point"], [0.0, 0.02, 0.0]) and ground["normal"] == [0.0, 1.0, 0.0]
    assert block["shape"] == "mesh" and close(block["center"], to_firn(objects["block"]["location"]))
    keys = block["keyframes"]
    assert [round(key["time"] * 24, 6) for key in keys] == list(range(FRAMES))
    assert close(keys[0]["position"], block["center"]) and close(keys[-1]["position"], [0.3, 0.15, 0.05])
    # The block turns 30° about Blender's z, firn's y, by frame 10.
    assert "quaternion" not in keys[0]
    half = math.radians(15.0)
    assert close(keys[-1]["quaternion"], [0.0, math.sin(half), 0.0, math.cos(half)])


def test_scene_file_has_the_rigid_body_where_the_object_is_with_its_shape_and_mass(baked):
    _, facts = baked
    (body,) = tomllib.loads(facts["scene_toml"])["rigid_bodies"]
    x, y, z = facts["objects"]["crate"]["location"]
    assert body["shape"] == "box" and close(body["size"], [0.08, 0.05, 0.06])
    # The origin is on the bottom face: the box's centre is 2.5 cm above it.
    assert close(body["center"], to_firn([x, y, z + 0.025]))
    # Turned 30° about Blender's z, firn's y.
    half = math.radians(15.0)
    assert close(body["quaternion"], [0.0, math.sin(half), 0.0, math.cos(half)])
    assert body["mass"] == 0.2 and "density" not in body
    assert body["mode"] == "separate" and body["friction"] == 0.3 and body["restitution"] == 0.0


def rotate(quaternion, point):
    """`point` turned by the unit quaternion [x, y, z, w]."""
    x, y, z, w = quaternion
    u = [x, y, z]
    t = [
        2 * (u[1] * point[2] - u[2] * point[1]),
        2 * (u[2] * point[0] - u[0] * point[2]),
        2 * (u[0] * point[1] - u[1] * point[0]),
    ]
    cross = [u[1] * t[2] - u[2] * t[1], u[2] * t[0] - u[0] * t[2], u[0] * t[1] - u[1] * t[0]]
    return [p + w * a + b for p, a, b in zip(point, t, cross, strict=True)]


def test_a_mesh_body_lands_on_its_object_s_vertices_once_firn_places_it(baked):
    _, facts = baked
    rock = facts["rock"]
    body = rock["body"]
    assert body["shape"] == "mesh" and body["solid"] == "hull" and body["density"] == 500.0
    # firn turns the file's vertices by the rotation, then puts their
    # bounding box's centre at `center`.
    turned = [rotate(body["quaternion"], v) for v in rock["obj"]]
    middle = [(min(v[a] for v in turned) + max(v[a] for v in turned)) / 2 for a in range(3)]
    placed = [[p - m + c for p, m, c in zip(v, middle, body["center"], strict=True)] for v in turned]
    assert len(placed) == len(rock["world"]) == 12
    assert all(close(a, b, 1e-6) for a, b in zip(placed, rock["world"], strict=True))


def test_the_baked_rigid_body_falls_onto_the_ground_on_a_keyed_linked_copy(baked):
    _, facts = baked
    crate = facts["crate"]
    original = crate["crate"]
    assert original["display"] == "WIRE" and original["hide_render"]
    assert crate["copy"] == {"shares_mesh": True, "role": "NONE"}
    assert crate["keys"] == [FRAMES] * 7
    # At the first frame the copy is on the object.
    assert close(crate["location"][0], original["location"], 1e-6)
    assert close(crate["rotation"][0], original["rotation"], 1e-6)
    heights, bottom = [p[2] for p in crate["location"]], crate["bottom"]
    # Dropped 6 cm onto the ground plane (z = 0.02): it falls, lands by
    # frame 4 and rests there, never through the plane.
    assert heights[0] - heights[1] > 0.005 and heights[1] - heights[2] > 0.02
    assert all(abs(b - 0.02) < 0.001 for b in bottom[3:]), bottom
    assert max(heights[3:]) - min(heights[3:]) < 0.001 and min(bottom) > 0.019
    assert all(math.dist(p[:2], crate["location"][0][:2]) < 0.01 for p in crate["location"])


def test_a_deforming_collider_is_baked_as_one_mesh_file_per_frame(baked):
    out, facts = baked
    paddle = tomllib.loads(facts["scene_toml"])["colliders"][2]
    assert paddle["sequence"] == "meshes/Paddle/frame_####.obj" and paddle["frame_rate"] == 24
    assert "keyframes" not in paddle and "mesh" not in paddle
    files = sorted((out / "whole" / "meshes" / "Paddle").glob("frame_*.obj"))
    assert [f.name for f in files] == [f"frame_{n:04d}.obj" for n in range(1, FRAMES + 1)]

    def top(file):
        heights = [float(line.split()[2]) for line in file.read_text().splitlines() if line.startswith("v ")]
        return max(heights), len(heights)

    (first, count), (last, last_count) = top(files[0]), top(files[-1])
    # The shape key lowers the top 5 cm (Blender's z, firn's y).
    assert count == last_count and abs(first - 0.175) < 1e-5 and abs(last - 0.125) < 1e-5


def test_caches_hold_every_frame(baked):
    out, _ = baked
    run = out / "whole" / "run"
    for index in range(FRAMES):
        assert (run / "mesh" / f"frame_{index:05d}.ply").is_file()
        assert (run / "vdb" / f"frame_{index:05d}.vdb").is_file()


def test_surface_object_shows_the_mesh_of_each_frame(baked):
    _, facts = baked
    counts = facts["surface_vertices"]
    assert len(counts) == FRAMES and min(counts) > 500
    assert len(set(counts)) > 1, counts
    assert close(facts["surface_matrix"][1], [0, 0, -1, 0]) and close(facts["surface_matrix"][2], [0, 1, 0, 0])


def test_volume_object_reads_the_vdb_of_each_frame(baked):
    _, facts = baked
    assert facts["volume_files"] == [f"frame_{index:05d}.vdb" for index in range(FRAMES)]
    assert "density" in facts["volume_grids"]


def test_particles_come_back_as_points(baked):
    out, facts = baked
    with open(out / "whole" / "run" / "manifest.json", encoding="utf-8") as file:
        manifest = json.load(file)
    assert facts["particles"]["vertices"] == manifest["particle_count"] > 500
    assert facts["particles"]["modifiers"] == ["firn Points"]


def test_cycles_render_shows_snow_where_the_cache_projects_and_ground_elsewhere(baked):
    _, facts = baked
    render = facts["render"]
    assert render["mesh_frame"].endswith(".00007")
    luma = render["luma"]
    width, height = render["size"]
    snow = {tuple(p) for p in render["snow_pixels"]}
    assert len(snow) > 100
    # The ground is a dark green (luma about 0.26 in sRGB), lit snow white
    # (about 0.9); the ball's lower limb is in its own shade.
    bright = [luma[y][x] > 0.4 for x, y in snow]
    assert sum(bright) >= 0.85 * len(bright), sum(bright) / len(bright)
    near = {(x + dx, y + dy) for x, y in snow for dx in range(-4, 5) for dy in range(-4, 5)}
    ground = [luma[y][x] < 0.33 for y in range(height) for x in range(width) if (x, y) not in near]
    assert len(ground) > 0.5 * width * height
    assert sum(ground) >= 0.95 * len(ground), sum(ground) / len(ground)


def test_cancelled_bake_resumes_to_the_bytes_of_an_uncancelled_one(baked):
    _, facts = baked
    assert facts["cancel_error"] is None and facts["resume_error"] is None
    assert facts["cancelled_frames"] == [0, 1, 2, 3] and facts["cancelled_state"] == "running"
    assert "(resumed)" in facts["resume_status"]
    assert facts["resume_differs"] == []


def test_baking_again_replaces_the_rigid_body_s_keyed_copy(baked):
    _, facts = baked
    assert facts["copies"] == ["firn Crate"] and facts["copy_actions"] == ["firn Crate"]

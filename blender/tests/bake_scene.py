"""Builds a shot from primitives and bakes it through the add-on's
operators, under `blender -b` (run by test_addon.py):

    blender -b --factory-startup --addons firn_blender \\
        --python blender/tests/bake_scene.py -- --out DIR

A UV sphere of snow thrown at a cube that moves and turns (keyframed),
over a ground plane, in a box domain, and a small crate (a rigid body,
its origin on its bottom face) dropped 6 cm onto the ground beside them;
frames 1 to 10 at 24 fps. Writes DIR/facts.json with what test_addon.py
checks: the errors of bad settings, the scene file, a mesh body's export,
the caches of a bake and of a bake cancelled after frame 3 and baked
again, the imported objects' frames, the crate's keyed motion, and a
Cycles render of frame 8 with the pixels where the ball's cache projects."""

import json
import math
import os
import sys
import time

import bpy
from bpy_extras.object_utils import world_to_camera_view

from firn_blender import export
from firn_blender.rigid_bodies import BODY_KEY

OUT = sys.argv[sys.argv.index("--") + 2] if "--" in sys.argv else "/tmp/firn-addon"
SIZE = (96, 72)
RENDER_FRAME = 8


def clear():
    """An empty scene."""
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)


def shot(cell_size=0.04, voxel_size=0.02):
    """The scene's objects; returns them by name."""
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 10
    scene.render.fps, scene.render.fps_base = 24, 1.0
    bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0.0, 0.0, 0.4))
    domain = bpy.context.object
    domain.name = "Domain"
    domain.scale = (0.6, 0.6, 0.4)
    domain.display_type = "WIRE"
    domain.hide_render = True
    domain.firn.role = "DOMAIN"
    domain.firn.cell_size = cell_size
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.12, location=(-0.2, 0.05, 0.3), segments=24, ring_count=12)
    ball = bpy.context.object
    ball.name = "Snowball"
    ball.firn.role = "SNOW"
    ball.firn.velocity = (1.5, 0.5, -1.0)
    bpy.ops.mesh.primitive_plane_add(size=3.0, location=(0.0, 0.0, 0.02))
    ground = bpy.context.object
    ground.name = "Ground"
    ground.firn.role = "COLLIDER"
    ground.data.materials.append(ground_material())
    bpy.ops.mesh.primitive_cube_add(size=0.2, location=(0.25, 0.1, 0.15))
    block = bpy.context.object
    block.name = "Block"
    block.firn.role = "COLLIDER"
    block.hide_render = True
    block.keyframe_insert("location", frame=1)
    block.keyframe_insert("rotation_euler", frame=1)
    block.location = (0.3, -0.05, 0.15)
    block.rotation_euler = (0.0, 0.0, math.radians(30.0))
    block.keyframe_insert("location", frame=10)
    block.keyframe_insert("rotation_euler", frame=10)
    for curve in block.animation_data.action.fcurves:
        for key in curve.keyframe_points:
            key.interpolation = "LINEAR"
    scene.firn.voxel_size = voxel_size
    objects = {"domain": domain, "ball": ball, "ground": ground, "block": block, "paddle": squashed_paddle()}
    objects["crate"] = crate(ground.data.materials[0])
    return objects


def crate(material):
    """A rigid box 8 × 6 × 5 cm, turned 30° about z, its origin at the
    middle of its bottom face, 6 cm above the ground, dark as the ground."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(-0.4, 0.35, 0.08), rotation=(0.0, 0.0, math.radians(30.0)))
    box = bpy.context.object
    box.name = "Crate"
    box.scale = (0.08, 0.06, 0.05)
    for vertex in box.data.vertices:
        vertex.co.z += 0.5
    box.data.materials.append(material)
    box.firn.role = "RIGID_BODY"
    box.firn.body_shape = "BOX"
    box.firn.mass_from = "MASS"
    box.firn.mass = 0.2
    return box


def squashed_paddle():
    """A deforming collider away from the ball: a cube whose top a shape
    key lowers 5 cm from frame 1 to frame 10."""
    bpy.ops.mesh.primitive_cube_add(size=0.15, location=(-0.35, -0.35, 0.1))
    paddle = bpy.context.object
    paddle.name = "Paddle"
    paddle.firn.role = "COLLIDER"
    paddle.firn.motion = "DEFORMING"
    paddle.hide_render = True
    paddle.shape_key_add(name="Basis")
    squash = paddle.shape_key_add(name="Squash")
    for point in squash.data:
        if point.co.z > 0.0:
            point.co.z -= 0.05
    squash.value = 0.0
    squash.keyframe_insert("value", frame=1)
    squash.value = 1.0
    squash.keyframe_insert("value", frame=10)
    return paddle


def ground_material():
    """A dark green ground, far from the snow's white."""
    material = bpy.data.materials.new("Ground")
    material.use_nodes = True
    shader = material.node_tree.nodes["Principled BSDF"]
    shader.inputs["Base Color"].default_value = (0.01, 0.04, 0.01, 1.0)
    shader.inputs["Roughness"].default_value = 1.0
    return material


def bake(cache, **options):
    """Runs the bake operator into `cache`; the error message, if any."""
    bpy.context.scene.firn.cache_directory = cache
    try:
        bpy.ops.firn.bake(**options)
    except RuntimeError as error:
        return str(error)
    return None


def files_of(folder):
    """Every cache file under `folder`, relative path to bytes' length."""
    found = {}
    for root, _, names in os.walk(folder):
        for name in names:
            path = os.path.join(root, name)
            found[os.path.relpath(path, folder)] = path
    return found


def same_caches(first, second):
    """Cache files (mesh, vdb) that differ between two run folders."""
    differ = []
    a, b = files_of(first), files_of(second)
    for name in sorted(set(a) | set(b)):
        if not name.startswith(("mesh", "vdb")):
            continue
        if name not in a or name not in b:
            differ.append(name)
            continue
        with open(a[name], "rb") as one, open(b[name], "rb") as other:
            if one.read() != other.read():
                differ.append(name)
    return differ


def bad_settings(objects, facts):
    """A snow body outside the domain, a cell size of zero, a rigid body
    of no mass, one starting inside the ground, and a flat mesh body:
    errors, no bake."""
    ball, domain = objects["ball"], objects["domain"]
    ball.location.z = 1.5
    facts["outside_error"] = bake(os.path.join(OUT, "bad-outside"))
    ball.location.z = 0.3
    domain.firn.cell_size = 0.0
    facts["cell_error"] = bake(os.path.join(OUT, "bad-cell"))
    domain.firn.cell_size = 0.04
    crate = objects["crate"]
    crate.firn.mass = 0.0
    facts["mass_error"] = bake(os.path.join(OUT, "bad-mass"))
    crate.firn.mass = 0.2
    crate.location.z = 0.0
    facts["inside_error"] = bake(os.path.join(OUT, "bad-inside"))
    crate.location.z = 0.08
    bpy.ops.mesh.primitive_plane_add(size=0.1, location=(0.4, -0.4, 0.3))
    sheet = bpy.context.object
    sheet.name = "Sheet"
    sheet.firn.role = "RIGID_BODY"
    facts["volume_error"] = bake(os.path.join(OUT, "bad-volume"))
    bpy.data.objects.remove(sheet)
    folders = ("bad-outside", "bad-cell", "bad-mass", "bad-inside", "bad-volume")
    facts["bad_runs"] = [os.path.exists(os.path.join(OUT, name, "run")) for name in folders]


def mesh_body(facts):
    """A squashed, turned icosphere as a convex hull body: its table, its
    OBJ's vertices and its world vertices in firn's axes (not baked)."""
    bpy.ops.mesh.primitive_ico_sphere_add(
        subdivisions=1, radius=0.05, location=(0.4, -0.3, 0.4), rotation=(0.3, -0.5, 0.9)
    )
    rock = bpy.context.object
    rock.name = "Rock"
    rock.scale = (1.0, 0.6, 1.4)
    rock.firn.role = "RIGID_BODY"
    made = export.build(bpy.context.scene, bpy.context.evaluated_depsgraph_get, os.path.join(OUT, "rock"))
    index = next(i for i in range(len(made.scene["rigid_bodies"])) if made.origins[f"rigid_bodies[{i}]"][0] == "Rock")
    body = made.scene["rigid_bodies"][index]
    text = made.meshes[body["mesh"]].decode()
    facts["rock"] = {
        "body": body,
        "obj": [[float(v) for v in line.split()[1:]] for line in text.splitlines() if line.startswith("v ")],
        "world": [export.to_firn(rock.matrix_world @ v.co, 1.0) for v in rock.data.vertices],
    }
    bpy.data.objects.remove(rock)


def crate_motion(facts):
    """The crate's keyed copy at each frame: its origin, its rotation, its
    lowest corner, its keys; the crate object itself; what the copy shares
    with it."""
    scene = bpy.context.scene
    crate = bpy.data.objects["Crate"]
    copy = bpy.data.objects["firn Crate"]
    motion = {"location": [], "rotation": [], "bottom": []}
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        motion["location"].append(list(copy.matrix_world.to_translation()))
        motion["rotation"].append(list(copy.matrix_world.to_quaternion()))
        motion["bottom"].append(min((copy.matrix_world @ v.co).z for v in copy.data.vertices))
    motion["keys"] = [len(curve.keyframe_points) for curve in copy.animation_data.action.fcurves]
    motion["crate"] = {
        "location": list(crate.matrix_world.to_translation()),
        "rotation": list(crate.matrix_world.to_quaternion()),
        "display": crate.display_type,
        "hide_render": crate.hide_render,
    }
    motion["copy"] = {"shares_mesh": copy.data == crate.data, "role": copy.firn.role}
    facts["crate"] = motion


def copies(facts):
    """How many keyed copies and their actions there are."""
    facts["copies"] = sorted(obj.name for obj in bpy.data.objects if BODY_KEY in obj)
    facts["copy_actions"] = sorted(action.name for action in bpy.data.actions if action.name.startswith("firn"))


def sequences(facts):
    """The imported objects' frames."""
    scene = bpy.context.scene
    surface = bpy.data.objects["firn Snow Surface"]
    volume = bpy.data.objects["firn Snow Volume"]
    counts, files = [], []
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        counts.append(len(surface.data.vertices))
        volume.data.grids.load()
        files.append(os.path.basename(volume.data.grids.frame_filepath))
    facts["surface_vertices"] = counts
    facts["volume_files"] = files
    facts["volume_grids"] = [grid.name for grid in volume.data.grids]
    facts["surface_matrix"] = [list(row) for row in surface.matrix_world]
    particles = bpy.data.objects["firn Particles"]
    scene.frame_set(RENDER_FRAME)
    facts["particles"] = {
        "vertices": len(particles.data.vertices),
        "modifiers": [m.node_group.name for m in particles.modifiers if m.type == "NODES"],
    }
    particles.hide_render = True


def render(facts):
    """Cycles renders frame 8 from above; the pixels the ball's cache
    (frame 7, firn's axes) projects to, and the others."""
    scene = bpy.context.scene
    scene.frame_set(RENDER_FRAME)
    bpy.ops.object.camera_add(location=(0.0, -0.9, 1.3))
    camera = bpy.context.object
    camera.rotation_euler = (math.radians(35.0), 0.0, 0.0)
    scene.camera = camera
    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(20.0), 0.0, 0.0))
    bpy.context.object.data.energy = 4.0
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 16
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scene.view_settings.view_transform = "Standard"
    scene.render.resolution_x, scene.render.resolution_y = SIZE
    scene.render.resolution_percentage = 100
    scene.render.filepath = os.path.join(OUT, "frame_8.png")
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.world.use_nodes = False
    scene.world.color = (0.1, 0.1, 0.1)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(scene.render.filepath)
    pixels = list(image.pixels)
    surface = bpy.data.objects["firn Snow Surface"]
    projected = set()
    for vertex in surface.data.vertices:
        point = world_to_camera_view(scene, camera, surface.matrix_world @ vertex.co)
        x, y = int(point.x * SIZE[0]), int(point.y * SIZE[1])
        if 0 <= x < SIZE[0] and 0 <= y < SIZE[1]:
            projected.add((x, y))
    facts["render"] = {
        "size": SIZE,
        "luma": [
            [
                0.2126 * pixels[4 * (y * SIZE[0] + x)]
                + 0.7152 * pixels[4 * (y * SIZE[0] + x) + 1]
                + 0.0722 * pixels[4 * (y * SIZE[0] + x) + 2]
                for x in range(SIZE[0])
            ]
            for y in range(SIZE[1])
        ],
        "snow_pixels": sorted(projected),
        "mesh_frame": surface.data.name,
    }


def main():
    os.makedirs(OUT, exist_ok=True)
    clear()
    objects = shot()
    facts = {}
    bpy.context.scene.firn.import_particles = True
    bad_settings(objects, facts)
    mesh_body(facts)
    started = time.monotonic()
    facts["bake_error"] = bake(os.path.join(OUT, "whole"))
    facts["bake_seconds"] = time.monotonic() - started
    with open(os.path.join(OUT, "whole", "scene.toml"), encoding="utf-8") as file:
        facts["scene_toml"] = file.read()
    facts["objects"] = {
        name: {"location": list(obj.matrix_world.to_translation()), "dimensions": list(obj.dimensions)}
        for name, obj in objects.items()
    }
    facts["status"] = bpy.context.scene.firn.status
    sequences(facts)
    crate_motion(facts)
    render(facts)
    started = time.monotonic()
    facts["cancel_error"] = bake(os.path.join(OUT, "cancelled"), cancel_after_frame=3)
    with open(os.path.join(OUT, "cancelled", "run", "manifest.json"), encoding="utf-8") as file:
        manifest = json.load(file)
    facts["cancelled_frames"] = [record["index"] for record in manifest["frames"]]
    facts["cancelled_state"] = manifest["status"]["state"]
    facts["resume_error"] = bake(os.path.join(OUT, "cancelled"))
    facts["resume_status"] = bpy.context.scene.firn.status
    copies(facts)
    facts["resume_seconds"] = time.monotonic() - started
    facts["resume_differs"] = same_caches(os.path.join(OUT, "whole", "run"), os.path.join(OUT, "cancelled", "run"))
    with open(os.path.join(OUT, "facts.json"), "w", encoding="utf-8") as file:
        json.dump(facts, file)


if __name__ == "__main__":
    main()

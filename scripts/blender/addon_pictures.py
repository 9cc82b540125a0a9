# The add-on's pictures in docs/images: a shot baked through the add-on and
# rendered with Cycles (headless), and a screenshot of its panel with the
# crate (a rigid body) selected (Blender's interface under Xvfb; this bake
# runs on the background thread with the modal progress, as an artist's
# does, and is cancelled after the picture).
#
#   blender -b --factory-startup --addons firn_blender \
#       --python scripts/blender/addon_pictures.py -- render docs/images/blender-addon-shot.png
#   xvfb-run -a -s "-screen 0 1600x1000x24" blender --factory-startup --addons firn_blender \
#       --python scripts/blender/addon_pictures.py -- screenshot docs/images/blender-addon-panel.png
#
# The add-on and the firn module must be installed (scripts/blender/install-addon.sh).
# The shot is blender/tests/bake_scene.py's, at a finer grid and 30 frames,
# the ball thrown flat, and its crate set 1 cm above the cube's top, where the snow
# going over the cube pushes it off.

import importlib.util
import math
import os
import sys

import bpy
from mathutils import Vector

HERE = os.path.dirname(os.path.abspath(__file__))
MODE, OUT = sys.argv[sys.argv.index("--") + 1 :][:2]
CACHE = "/tmp/firn_addon_pictures"


def the_shot():
    """The test's shot at a finer grid, frames 1 to 30, the crate on the
    cube."""
    path = os.path.join(HERE, "..", "..", "blender", "tests", "bake_scene.py")
    spec = importlib.util.spec_from_file_location("bake_scene", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.clear()
    objects = module.shot(cell_size=0.02, voxel_size=0.01)
    scene = bpy.context.scene
    scene.frame_end = 30
    scene.firn.cache_directory = CACHE
    objects["ball"].firn.velocity = (4.0, 0.0, 0.0)
    crate = objects["crate"]
    crate.location = (0.25, 0.1, 0.26)
    crate.data.materials[0] = wood()
    return objects


def wood():
    """A brown material for the crate (its keyed copy shares its mesh)."""
    material = bpy.data.materials.new("Crate")
    material.use_nodes = True
    shader = material.node_tree.nodes["Principled BSDF"]
    shader.inputs["Base Color"].default_value = (0.35, 0.12, 0.03, 1.0)
    shader.inputs["Roughness"].default_value = 0.8
    return material


def camera_and_light(scene):
    """A camera low over the ground, side on to the ball's flight, a sun
    and a sky."""
    bpy.ops.object.camera_add(location=(0.3, -1.2, 0.5))
    camera = bpy.context.object
    aim = Vector((0.3, 0.08, 0.17)) - camera.location
    camera.rotation_euler = aim.to_track_quat("-Z", "Y").to_euler()
    scene.camera = camera
    bpy.ops.object.light_add(type="SUN", rotation=(math.radians(40.0), math.radians(10.0), math.radians(30.0)))
    bpy.context.object.data.energy = 3.5
    scene.world = scene.world or bpy.data.worlds.new("World")
    scene.world.use_nodes = False
    scene.world.color = (0.35, 0.42, 0.55)


def render(objects):
    """Bakes headless and renders frame 8: the crate falling off the
    cube's far side."""
    scene = bpy.context.scene
    objects["block"].hide_render = False
    bpy.ops.firn.bake()
    camera_and_light(scene)
    scene.frame_set(8)
    scene.render.engine = "CYCLES"
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.render.filepath = os.path.abspath(OUT)
    bpy.ops.render.render(write_still=True)


def screenshot(objects):
    """Starts the bake in the interface with the crate's firn panel (its
    rigid body settings) shown in the largest area, writes a screenshot of
    that area a third of the way, and cancels."""
    bpy.context.scene.firn.cache_directory = os.path.join(CACHE, "interface")
    bpy.context.preferences.view.show_splash = False
    window = bpy.context.window_manager.windows[0]
    properties = max(window.screen.areas, key=lambda a: a.width * a.height)
    properties.type = "PROPERTIES"
    crate = objects["crate"]
    bpy.context.view_layer.objects.active = crate
    crate.select_set(True)

    def start():
        properties.spaces[0].context = "PHYSICS"
        with bpy.context.temp_override(window=window, area=properties):
            bpy.ops.firn.bake("INVOKE_DEFAULT")
        bpy.app.timers.register(wait, first_interval=0.5)

    def wait():
        if bpy.context.scene.firn.progress < 0.3:
            properties.spaces[0].context = "PHYSICS"
            return 0.5
        with bpy.context.temp_override(window=window, area=properties):
            bpy.ops.screen.screenshot_area(filepath=os.path.abspath(OUT))
        print("firn: screenshot at", bpy.context.scene.firn.status, flush=True)
        bpy.ops.firn.cancel_bake()
        bpy.app.timers.register(stop, first_interval=0.5)
        return None

    def stop():
        if bpy.context.scene.firn.baking:
            return 0.5
        print("firn:", bpy.context.scene.firn.status, flush=True)
        bpy.ops.wm.quit_blender()
        return None

    bpy.app.timers.register(start, first_interval=1.0)


objects = the_shot()
if MODE == "render":
    render(objects)
else:
    screenshot(objects)

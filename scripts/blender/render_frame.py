# Loads one firn frame into Blender and renders it with Cycles.
#
#   blender -b --factory-startup --python scripts/blender/render_frame.py -- \
#       --vdb RUN/vdb/frame_00010.vdb --mesh RUN/mesh/frame_00010.ply \
#       --eye 1.6 0.9 2.1 --look-at 0.5 0.2 0.5 --fov 35 \
#       --size 480 270 --samples 32 --out frame.png
#
# The VDB becomes a volume object (its `density` grid, kg/m3, shaded with a
# Principled Volume), the PLY or OBJ surface a mesh object with smooth
# shading. Both stay in firn's coordinates (y up): nothing is rotated on
# import, and the camera is placed from firn's eye, look-at point and
# vertical field of view, so the picture frames the snow as firn's own.
# The background is transparent (alpha 0) where no snow is seen; --ground Y
# adds a grey floor at height Y. Prints one line per imported object.

import argparse
import math
import sys

import bpy
from mathutils import Matrix, Vector


def arguments():
    parser = argparse.ArgumentParser(description="Render a firn frame in Blender")
    parser.add_argument("--vdb", help="a frame's .vdb (the vdb format)")
    parser.add_argument("--mesh", help="a frame's .ply or .obj (the mesh format)")
    parser.add_argument("--eye", type=float, nargs=3, required=True)
    parser.add_argument("--look-at", type=float, nargs=3, required=True)
    parser.add_argument("--fov", type=float, required=True, help="vertical, degrees")
    parser.add_argument("--size", type=int, nargs=2, default=[160, 120])
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--ground", type=float, help="height of a floor plane")
    parser.add_argument("--out", required=True, help="the PNG to write")
    after = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    return parser.parse_args(after)


def node_of(material, kind):
    """The first node of `kind` (a node type such as BSDF_PRINCIPLED)."""
    material.use_nodes = True
    nodes = material.node_tree.nodes
    found = [node for node in nodes if node.type == kind]
    if found:
        return found[0]
    names = {"BSDF_PRINCIPLED": "ShaderNodeBsdfPrincipled",
             "OUTPUT_MATERIAL": "ShaderNodeOutputMaterial"}
    return nodes.new(names[kind])


def surface_material(name, color, roughness):
    material = bpy.data.materials.new(name)
    shader = node_of(material, "BSDF_PRINCIPLED")
    shader.inputs["Base Color"].default_value = color
    shader.inputs["Roughness"].default_value = roughness
    output = node_of(material, "OUTPUT_MATERIAL")
    material.node_tree.links.new(shader.outputs["BSDF"], output.inputs["Surface"])
    return material


def empty_scene():
    for thing in list(bpy.data.objects):
        bpy.data.objects.remove(thing, do_unlink=True)


def import_volume(path, rest_density):
    bpy.ops.object.volume_import(filepath=path, files=[{"name": path.split("/")[-1]}],
                                 directory=path.rsplit("/", 1)[0] + "/")
    volume = bpy.context.selected_objects[0]
    volume.data.grids.load()
    names = [grid.name for grid in volume.data.grids]
    material = bpy.data.materials.new("firn snow volume")
    output = node_of(material, "OUTPUT_MATERIAL")
    nodes = material.node_tree.nodes
    for node in [node for node in nodes if node.type == "BSDF_PRINCIPLED"]:
        nodes.remove(node)
    shader = nodes.new("ShaderNodeVolumePrincipled")
    shader.inputs["Color"].default_value = (0.9, 0.93, 1.0, 1.0)
    # The grid holds kg/m3; at rest density light goes about 2 cm into the
    # snow (an extinction of 50 per metre), so the volume shows its shape
    # and only a faint haze where the snow thins out past the surface.
    shader.inputs["Density"].default_value = 50.0 / rest_density
    shader.inputs["Density Attribute"].default_value = "density"
    material.node_tree.links.new(shader.outputs["Volume"], output.inputs["Volume"])
    volume.data.materials.append(material)
    print(f"firn: volume {volume.name} grids {names} bounds {list(volume.dimensions)}")
    return volume


def import_surface(path):
    if path.lower().endswith(".obj"):
        bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    else:
        bpy.ops.import_mesh.ply(filepath=path)
    surface = bpy.context.selected_objects[0]
    for polygon in surface.data.polygons:
        polygon.use_smooth = True
    material = surface_material("firn snow surface", (0.80, 0.84, 0.90, 1.0), 0.6)
    surface.data.materials.append(material)
    print(f"firn: mesh {surface.name} vertices {len(surface.data.vertices)} "
          f"faces {len(surface.data.polygons)}")
    return surface


def place_camera(eye, look_at, fov_degrees, size):
    camera = bpy.data.objects.new("firn camera", bpy.data.cameras.new("firn camera"))
    bpy.context.scene.collection.objects.link(camera)
    eye, look_at = Vector(eye), Vector(look_at)
    forward = (look_at - eye).normalized()
    right = forward.cross(Vector((0.0, 1.0, 0.0))).normalized()
    up = right.cross(forward)
    # A Blender camera looks along its -z with +y up.
    rotation = Matrix((right, up, -forward)).transposed().to_4x4()
    camera.matrix_world = Matrix.Translation(eye) @ rotation
    camera.data.sensor_fit = "VERTICAL"
    camera.data.angle = math.radians(fov_degrees)
    camera.data.clip_start = 0.01
    bpy.context.scene.camera = camera
    scene = bpy.context.scene
    scene.render.resolution_x, scene.render.resolution_y = size
    scene.render.resolution_percentage = 100


def light_the_scene():
    sun = bpy.data.objects.new("firn sun", bpy.data.lights.new("firn sun", "SUN"))
    bpy.context.scene.collection.objects.link(sun)
    towards_light = Vector((-0.35, 0.8, 0.5)).normalized()
    # A sun shines along its -z.
    sun.rotation_euler = towards_light.to_track_quat("Z", "Y").to_euler()
    sun.data.energy = 3.0
    world = bpy.data.worlds.new("firn sky")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.34, 0.42, 1.0)
    bpy.context.scene.world = world


def add_ground(height):
    bpy.ops.mesh.primitive_plane_add(size=20.0, location=(0.0, height, 0.0),
                                     rotation=(math.radians(-90.0), 0.0, 0.0))
    ground = bpy.context.selected_objects[0]
    ground.data.materials.append(surface_material("firn ground", (0.17, 0.17, 0.17, 1.0), 0.9))


def render(path, samples):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.film_transparent = True
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "RGBA"
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)
    print(f"firn: rendered {path}")


def main():
    args = arguments()
    empty_scene()
    if args.vdb:
        import_volume(args.vdb, 400.0)
    if args.mesh:
        import_surface(args.mesh)
    if args.ground is not None:
        add_ground(args.ground)
    place_camera(args.eye, args.look_at, args.fov, args.size)
    light_the_scene()
    render(args.out, args.samples)


main()

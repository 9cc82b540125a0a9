"""A baked run back into Blender: the snow's surface as a mesh object that
shows one mesh per frame (swapped on frame change), its density as a
volume object reading the VDB sequence, and optionally the particles and
the drift as point objects. All of them sit in the collection "firn",
placed by the transform from firn's axes to Blender's, with a keyed copy
of each rigid body object (`rigid_bodies`)."""

import json
import os
import struct
from array import array

import bpy
from bpy.app.handlers import persistent

from . import export, rigid_bodies
from .axes import blender_from_firn, unit_scale

COLLECTION = "firn"
SURFACE = "firn Snow Surface"
VOLUME = "firn Snow Volume"
PARTICLES = "firn Particles"
DRIFT = "firn Drift"
#: Custom properties of an object that shows a mesh per frame.
SEQUENCE_KEY = "firn_sequence"
START_KEY = "firn_frame_start"
COUNT_KEY = "firn_frame_count"

PLY_TYPES = {
    "char": "b",
    "uchar": "B",
    "short": "h",
    "ushort": "H",
    "int": "i",
    "uint": "I",
    "float": "f",
    "double": "d",
    "int8": "b",
    "uint8": "B",
    "int16": "h",
    "uint16": "H",
    "int32": "i",
    "uint32": "I",
    "float32": "f",
    "float64": "d",
}


def read_ply(path):
    """The vertices (flat x, y, z floats) and triangles (flat indices) of a
    binary little-endian PLY as firn writes it."""
    with open(path, "rb") as file:
        data = file.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    elements = ply_elements(data[:end].decode("ascii").splitlines())
    offset = end
    vertices, triangles = array("f"), array("i")
    for name, count, properties in elements:
        if name == "vertex":
            offset = read_vertices(data, offset, count, properties, vertices)
        elif name == "face":
            offset = read_faces(data, offset, count, properties, triangles)
    return vertices, triangles


def ply_elements(header):
    """(name, count, [(property, type or (count type, index type))])."""
    elements = []
    for line in header:
        words = line.split()
        if words[:1] == ["format"] and words[1] != "binary_little_endian":
            raise ValueError(f"only binary little-endian PLY is read, not {words[1]}")
        if words[:1] == ["element"]:
            elements.append((words[1], int(words[2]), []))
        elif words[:2] == ["property", "list"]:
            elements[-1][2].append((words[4], (PLY_TYPES[words[2]], PLY_TYPES[words[3]])))
        elif words[:1] == ["property"]:
            elements[-1][2].append((words[2], PLY_TYPES[words[1]]))
    return elements


def read_vertices(data, offset, count, properties, out):
    """Appends the x, y, z of `count` vertices to `out`; the next offset."""
    layout = "<" + "".join(kind for _, kind in properties)
    stride = struct.calcsize(layout)
    names = [name for name, _ in properties]
    if layout == "<fff" and names == ["x", "y", "z"]:
        out.frombytes(data[offset : offset + stride * count])
        return offset + stride * count
    axes = [names.index(axis) for axis in ("x", "y", "z")]
    for values in struct.iter_unpack(layout, data[offset : offset + stride * count]):
        out.extend(values[axis] for axis in axes)
    return offset + stride * count


def read_faces(data, offset, count, properties, out):
    """Appends `count` triangles to `out`; the next offset."""
    count_type, index_type = properties[0][1]
    if count_type == "B" and index_type == "i" and len(properties) == 1:
        stride = 1 + 12
        block = data[offset : offset + stride * count]
        out.frombytes(b"".join(block[i + 1 : i + stride] for i in range(0, len(block), stride)))
        return offset + stride * count
    raise ValueError("faces must be lists of uchar count and int indices")


def mesh_from_ply(name, path):
    """A mesh datablock `name` of the PLY's vertices and triangles."""
    vertices, triangles = read_ply(path)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(vertices) // 3)
    mesh.vertices.foreach_set("co", vertices)
    faces = len(triangles) // 3
    if faces:
        mesh.loops.add(len(triangles))
        mesh.loops.foreach_set("vertex_index", triangles)
        mesh.polygons.add(faces)
        mesh.polygons.foreach_set("loop_start", array("i", range(0, 3 * faces, 3)))
        mesh.polygons.foreach_set("loop_total", array("i", [3]) * faces)
        mesh.polygons.foreach_set("use_smooth", array("b", [1]) * faces)
    mesh.update()
    return mesh


def frame_mesh_name(prefix, index):
    """The name of a sequence's mesh of frame `index`."""
    return f"{prefix}.{index:05d}"


def the_collection(scene):
    """The collection "firn" of `scene`, made when missing."""
    collection = bpy.data.collections.get(COLLECTION)
    if collection is None:
        collection = bpy.data.collections.new(COLLECTION)
    if collection.name not in scene.collection.children:
        scene.collection.children.link(collection)
    return collection


def the_object(scene, name, data):
    """Object `name` in the "firn" collection with `data`, made or reused."""
    obj = bpy.data.objects.get(name)
    if obj is not None and obj.type != ("VOLUME" if isinstance(data, bpy.types.Volume) else "MESH"):
        bpy.data.objects.remove(obj)
        obj = None
    if obj is None:
        obj = bpy.data.objects.new(name, data)
        the_collection(scene).objects.link(obj)
    else:
        obj.data = data
    obj.matrix_world = blender_from_firn(unit_scale(scene))
    return obj


def remove_sequence_meshes(prefix):
    """Removes the meshes of a sequence imported before."""
    for mesh in [m for m in bpy.data.meshes if m.name.startswith(prefix + ".")]:
        bpy.data.meshes.remove(mesh)


def sequence_object(scene, name, folder, frame_start, frames, material):
    """An object showing `folder/frame_NNNNN.ply` at each frame, or None
    when the folder holds none of them."""
    paths = [os.path.join(folder, f"frame_{index:05d}.ply") for index in range(frames)]
    paths = [path for path in paths if os.path.exists(path)]
    if not paths:
        return None
    remove_sequence_meshes(name)
    meshes = [mesh_from_ply(frame_mesh_name(name, index), path) for index, path in enumerate(paths)]
    for mesh in meshes:
        mesh.materials.append(material)
    obj = the_object(scene, name, meshes[0])
    obj[SEQUENCE_KEY] = name
    obj[START_KEY] = frame_start
    obj[COUNT_KEY] = len(meshes)
    show_frame(obj, scene.frame_current)
    return obj


def show_frame(obj, frame):
    """Gives a sequence object the mesh of scene frame `frame` (the first
    before the bake's range, the last after it)."""
    index = min(max(frame - obj[START_KEY], 0), obj[COUNT_KEY] - 1)
    mesh = bpy.data.meshes.get(frame_mesh_name(obj[SEQUENCE_KEY], index))
    if mesh is not None and obj.data != mesh:
        obj.data = mesh


@persistent
def on_frame_change(scene, _depsgraph=None):
    """Swaps every sequence object's mesh to the scene's frame."""
    for obj in scene.objects:
        if SEQUENCE_KEY in obj and obj.type == "MESH":
            show_frame(obj, scene.frame_current)


def volume_object(scene, folder, frame_start, frames):
    """A volume object reading the VDB sequence, or None without one."""
    first = os.path.join(folder, "frame_00000.vdb")
    if not os.path.exists(first):
        return None
    old = bpy.data.objects.get(VOLUME)
    if old is not None:
        old_data = old.data
        bpy.data.objects.remove(old)
        if old_data.users == 0:
            bpy.data.volumes.remove(old_data)
    volume = bpy.data.volumes.new(VOLUME)
    volume.filepath = first
    volume.is_sequence = True
    volume.frame_start = frame_start
    volume.frame_duration = frames
    volume.frame_offset = -1
    volume.sequence_mode = "EXTEND"
    volume.materials.append(volume_material())
    return the_object(scene, VOLUME, volume)


def principled(material, kind):
    """The material's first node of `kind`, made when missing."""
    material.use_nodes = True
    nodes = material.node_tree.nodes
    for node in nodes:
        if node.bl_idname == kind:
            return node
    return nodes.new(kind)


def surface_material():
    """White, slightly translucent snow for the surface (Cycles and EEVEE)."""
    material = bpy.data.materials.get("firn Snow") or bpy.data.materials.new("firn Snow")
    shader = principled(material, "ShaderNodeBsdfPrincipled")
    shader.inputs["Base Color"].default_value = (0.9, 0.93, 0.97, 1.0)
    shader.inputs["Roughness"].default_value = 0.6
    shader.inputs["Subsurface"].default_value = 0.05
    shader.inputs["Subsurface Color"].default_value = (0.8, 0.88, 1.0, 1.0)
    output = principled(material, "ShaderNodeOutputMaterial")
    material.node_tree.links.new(shader.outputs["BSDF"], output.inputs["Surface"])
    return material


def volume_material():
    """A scattering white volume of firn's density (kg/m³)."""
    material = bpy.data.materials.get("firn Snow Volume") or bpy.data.materials.new("firn Snow Volume")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    for node in [n for n in nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"]:
        nodes.remove(node)
    shader = principled(material, "ShaderNodeVolumePrincipled")
    shader.inputs["Color"].default_value = (0.95, 0.97, 1.0, 1.0)
    shader.inputs["Density"].default_value = 0.25
    shader.inputs["Density Attribute"].default_value = "density"
    output = principled(material, "ShaderNodeOutputMaterial")
    material.node_tree.links.new(shader.outputs["Volume"], output.inputs["Volume"])
    return material


def points_group(material):
    """A geometry node group that turns a mesh's vertices into points of
    the "radius" input, with `material` (point clouds render in Cycles)."""
    group = bpy.data.node_groups.get("firn Points")
    if group is not None:
        return group
    group = bpy.data.node_groups.new("firn Points", "GeometryNodeTree")
    if hasattr(group, "interface"):
        group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:
        group.inputs.new("NodeSocketGeometry", "Geometry")
        group.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = group.nodes, group.links
    inputs, outputs = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    points = nodes.new("GeometryNodeMeshToPoints")
    points.name = "points"
    shade = nodes.new("GeometryNodeSetMaterial")
    shade.inputs["Material"].default_value = material
    links.new(inputs.outputs[0], points.inputs["Mesh"])
    links.new(points.outputs["Points"], shade.inputs["Geometry"])
    links.new(shade.outputs["Geometry"], outputs.inputs[0])
    return group


def as_points(obj, radius):
    """Renders `obj`'s vertices as spheres of `radius` (firn's metres)."""
    group = points_group(surface_material())
    group.nodes["points"].inputs["Radius"].default_value = radius
    modifier = obj.modifiers.get("firn Points") or obj.modifiers.new("firn Points", "NODES")
    modifier.node_group = group


def particle_radius(run_directory):
    """A third of the run's cell size, metres: about a particle's reach."""
    with open(os.path.join(run_directory, "manifest.json"), encoding="utf-8") as file:
        return json.load(file)["scene"]["domain"]["cell_size"] / 3.0


def load_run(scene, run_directory, frame_start, frames):
    """Imports the frames of `run_directory` that exist; the objects made."""
    settings = scene.firn
    made = []
    if settings.import_surface:
        made.append(
            sequence_object(
                scene, SURFACE, os.path.join(run_directory, "mesh"), frame_start, frames, surface_material()
            )
        )
    if settings.import_volume:
        volume = volume_object(scene, os.path.join(run_directory, "vdb"), frame_start, frames)
        if volume is not None and made and made[0] is not None:
            volume.hide_render = True
        made.append(volume)
    points = [DRIFT] + ([PARTICLES] if settings.import_particles else [])
    for name in points:
        folder = os.path.join(run_directory, "ply" if name == PARTICLES else "drift")
        obj = sequence_object(scene, name, folder, frame_start, frames, surface_material())
        if obj is not None:
            as_points(obj, particle_radius(run_directory))
        made.append(obj)
    bodies = export.role_objects(scene, "RIGID_BODY")
    made += rigid_bodies.load_bodies(scene, run_directory, frame_start, bodies, the_collection(scene))
    return [obj for obj in made if obj is not None]


def register():
    """Swaps sequence meshes on every frame change, renders included."""
    bpy.app.handlers.frame_change_pre.append(on_frame_change)


def unregister():
    """Removes the frame change handler."""
    if on_frame_change in bpy.app.handlers.frame_change_pre:
        bpy.app.handlers.frame_change_pre.remove(on_frame_change)

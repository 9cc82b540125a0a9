"""Rigid bodies back from a run. Each rigid body object gets a linked copy
("firn NAME", sharing its mesh, modifiers and materials) in the collection
"firn", keyed at every baked frame with the pose the manifest records; the
object itself keeps its start pose, shown as a wire and left out of
renders, as the snow bodies are: it stays what the next bake starts from.

The manifest gives each body's pose P_t (firn's axes, metres): where its
reference point is and how it is turned. Whatever that point is (the
shape's centre, a mesh's bounding box centre), the body moves by
P_t P_0⁻¹ since frame 0, so the copy's world matrix at frame t is
F P_t P_0⁻¹ F⁻¹ M_0, with F the transform from firn's world to Blender's
(`axes.blender_from_firn`) and M_0 the object's world matrix at the first
frame: the copy starts exactly on the object and moves as firn had it."""

import json
import os

import bpy
from mathutils import Matrix, Quaternion

from .axes import blender_from_firn, unit_scale

#: Custom property of a copy: the name of the rigid body object it shows.
BODY_KEY = "firn_rigid_body"
#: The transform channels a copy is keyed on, each with 3 or 4 values.
CHANNELS = (("location", 3), ("rotation_quaternion", 4))


def copy_name(name):
    """The name of the keyed copy of rigid body object `name`."""
    return f"firn {name}"


def firn_pose(pose):
    """A manifest pose as the 4×4 transform from the body's frame into
    firn's world: the translation to its position after its rotation."""
    x, y, z, w = pose["rotation"]
    return Matrix.Translation(pose["position"]) @ Quaternion((w, x, y, z)).to_matrix().to_4x4()


def tracks(run_directory, count):
    """Per body, (frame index, firn pose) of every frame of the run's
    manifest that records `count` bodies; empty lists without a manifest."""
    found = [[] for _ in range(count)]
    path = os.path.join(run_directory, "manifest.json")
    if not os.path.exists(path):
        return found
    with open(path, encoding="utf-8") as file:
        frames = json.load(file).get("frames", [])
    for record in frames:
        poses = record.get("rigid_bodies", [])
        if len(poses) != count:
            continue
        for track, pose in zip(found, poses, strict=True):
            track.append((record["index"], firn_pose(pose)))
    return found


def world_matrices(track, start, scale):
    """(frame index, Blender world matrix) of a body over `track`, whose
    world matrix at the first frame is `start`."""
    to_blender = blender_from_firn(scale)
    from_blender = to_blender.inverted()
    first = track[0][1].inverted()
    return [(index, to_blender @ pose @ first @ from_blender @ start) for index, pose in track]


def continuous(rotations):
    """The quaternions with their signs chosen so that each is on the
    same side as the one before: keys then turn the short way."""
    chosen = []
    for rotation in rotations:
        flip = bool(chosen) and chosen[-1].dot(rotation) < 0.0
        chosen.append(-rotation if flip else rotation)
    return chosen


def remove_copy(name):
    """Removes the keyed copy `name` and its action, when that has no
    other user (an object of that name that is no copy stays)."""
    obj = bpy.data.objects.get(name)
    if obj is None or BODY_KEY not in obj:
        return
    action = obj.animation_data.action if obj.animation_data else None
    bpy.data.objects.remove(obj)
    if action is not None and action.users == 0:
        bpy.data.actions.remove(action)


def fresh_copy(original, collection):
    """A linked copy of `original` in `collection`, unparented, without
    constraints, animation or firn role, its transform all in its own
    location, quaternion and scale; the copy of an earlier load replaced."""
    remove_copy(copy_name(original.name))
    copy = original.copy()
    copy.name = copy_name(original.name)
    copy[BODY_KEY] = original.name
    copy.firn.role = "NONE"
    copy.parent = None
    copy.matrix_parent_inverse = Matrix.Identity(4)
    copy.constraints.clear()
    copy.animation_data_clear()
    copy.delta_location = (0.0, 0.0, 0.0)
    copy.delta_rotation_euler = (0.0, 0.0, 0.0)
    copy.delta_rotation_quaternion = (1.0, 0.0, 0.0, 0.0)
    copy.delta_scale = (1.0, 1.0, 1.0)
    copy.rotation_mode = "QUATERNION"
    copy.display_type = "TEXTURED"
    copy.hide_render = False
    collection.objects.link(copy)
    return copy


def keyframe(copy, frames):
    """Keys the copy's location and rotation at every (scene frame, world
    matrix) of `frames`, linearly between them; its scale is the first's."""
    parts = [matrix.decompose() for _, matrix in frames]
    copy.scale = parts[0][2]
    values = {
        "location": [location for location, _, _ in parts],
        "rotation_quaternion": continuous([rotation for _, rotation, _ in parts]),
    }
    action = bpy.data.actions.new(copy.name)
    copy.animation_data_create().action = action
    numbers = [frame for frame, _ in frames]
    for path, size in CHANNELS:
        for index in range(size):
            curve = action.fcurves.new(path, index=index, action_group="Object Transforms")
            curve.keyframe_points.add(len(frames))
            points = [n for frame, value in zip(numbers, values[path], strict=True) for n in (frame, value[index])]
            curve.keyframe_points.foreach_set("co", points)
            for point in curve.keyframe_points:
                point.interpolation = "LINEAR"
            curve.update()


def start_matrices(scene, bodies, frame_start):
    """The world matrix of each of `bodies` at the scene frame `frame_start`."""
    current = scene.frame_current
    if current != frame_start:
        scene.frame_set(frame_start)
    starts = [obj.matrix_world.copy() for obj in bodies]
    if current != frame_start:
        scene.frame_set(current)
    return starts


def remove_stale_copies(scene, names):
    """Removes the keyed copies of objects that are no longer rigid bodies."""
    for obj in list(scene.objects):
        if BODY_KEY in obj and obj[BODY_KEY] not in names:
            remove_copy(obj.name)


def load_bodies(scene, run_directory, frame_start, bodies, collection):
    """Keys a copy of each of `bodies` (the rigid body objects, in the
    scene file's order) with its baked motion; the copies made."""
    remove_stale_copies(scene, {obj.name for obj in bodies})
    found = tracks(run_directory, len(bodies))
    if not bodies or not found[0]:
        return []
    scale = unit_scale(scene)
    made = []
    for obj, track, start in zip(bodies, found, start_matrices(scene, bodies, frame_start), strict=True):
        frames = [(frame_start + index, matrix) for index, matrix in world_matrices(track, start, scale)]
        copy = fresh_copy(obj, collection)
        keyframe(copy, frames)
        obj.display_type = "WIRE"
        obj.hide_render = True
        made.append(copy)
    scene.frame_set(scene.frame_current)
    return made

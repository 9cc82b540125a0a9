"""Blender objects to a firn scene: the scene's keys (a dict in firn's TOML
format), the meshes it refers to, and where each part came from, so that
firn's errors can name the Blender object and setting.

Everything is taken at the scene's first frame, in world space, and put
into firn's axes (y up, metres; see `axes`). A snow body is its evaluated
mesh, written as OBJ in firn's axes and placed at its own bounding box's
centre, so it lands exactly where the object is. A collider is a plane (a
flat mesh) or a mesh; when its transform changes over the frame range it
gets one keyframe per frame of its pose: where its reference point is and
how it is turned from the first frame (a quaternion in firn's axes). A
rigid body is its shape at the first frame: a sphere, box, cylinder or
capsule sized by the object's dimensions, or its evaluated mesh in its own
(scaled, unturned) axes, placed by the object's rotation and centred on
its world bounding box's centre, so that firn has it where Blender does."""

import math
import re
import struct
from dataclasses import dataclass, field

from mathutils import Quaternion, Vector

from .axes import to_firn, unit_scale

#: The folder, inside the cache, of the run's caches.
RUN_FOLDER = "run"
#: The folder, inside the cache, of the exported meshes.
MESH_FOLDER = "meshes"
#: Smallest rotation, in radians, that a collider's keys carry.
ROTATION_TOLERANCE = 1e-5
#: firn's shape of each primitive rigid body shape.
PRIMITIVE_SHAPES = {"SPHERE": "sphere", "BOX": "box", "CYLINDER": "cylinder", "CAPSULE": "capsule"}
#: firn's solid of each mesh rigid body shape.
MESH_SOLIDS = {"CONVEX_HULL": "hull", "CONVEX_DECOMPOSITION": "decomposition"}
#: The panel's name of a rigid body's firn key, for messages.
RIGID_BODY_SETTINGS = {
    "center": "Location",
    "radius": "Dimensions",
    "size": "Dimensions",
    "height": "Dimensions",
    "mesh": "Mesh",
    "sdf_spacing": "Mesh",
    "solid": "Shape",
    "shape": "Shape",
    "quaternion": "Rotation",
    "density": "Density",
    "mass": "Mass",
    "velocity": "Initial Velocity",
    "angular_velocity": "Initial Angular Velocity",
    "mode": "Snow Contact",
    "friction": "Friction",
    "restitution": "Bounciness",
}


class ExportError(Exception):
    """A Blender setting firn cannot take; names the object and setting."""

    def __init__(self, obj_name, setting, message):
        super().__init__(f"{obj_name}: {setting}: {message}")
        self.obj_name = obj_name
        self.setting = setting


@dataclass
class Motion:
    """An object's world transform sampled at each frame of the range."""

    times: list = field(default_factory=list)
    translations: list = field(default_factory=list)
    rotations: list = field(default_factory=list)

    def moves(self):
        """Whether the translation or the rotation changes over the range."""
        first = self.translations[0]
        moved = any(any(abs(a - b) > 1e-9 for a, b in zip(t, first, strict=True)) for t in self.translations)
        return moved or self.rotation_angle() > ROTATION_TOLERANCE

    def rotation_angle(self):
        """The largest rotation, radians, away from the first frame's."""
        first = self.rotations[0]
        return max(first.rotation_difference(r).angle for r in self.rotations)

    def keyframes(self, reference):
        """firn keyframes of a collider exported as it is at the first frame,
        whose reference point is `reference` (firn's axes): per frame the
        turn r = R R₀⁻¹ of the object's world rotation R since the first
        frame and the point c = o + r (c₀ − o₀) (o the object's origin), so
        that every point p of the exported mesh is at c + r (p − c₀), as
        Blender moves it. A key without a turn carries no quaternion."""
        origin = self.translations[0]
        first = self.rotations[0].inverted()
        arm = Vector([r - o for r, o in zip(reference, origin, strict=True)])
        keys = []
        for time, translation, rotation in zip(self.times, self.translations, self.rotations, strict=True):
            turn = firn_quaternion(rotation @ first)
            position = Vector(translation) + turn @ arm
            key = {"time": time, "position": list(position)}
            if turn.angle > ROTATION_TOLERANCE:
                key["quaternion"] = [turn.x, turn.y, turn.z, turn.w]
            keys.append(key)
        return keys


def firn_quaternion(turn):
    """A Blender world rotation as the same turn in firn's axes, where
    Blender's (x, y, z) is firn's (x, z, -y) (`axes.to_firn`)."""
    return Quaternion((turn.w, turn.x, turn.z, -turn.y))


@dataclass
class Export:
    """A firn scene made from Blender objects."""

    scene: dict
    meshes: dict
    origins: dict
    frame_start: int
    frame_count: int


def tidy(value):
    """A float as the shortest decimal with the same single-precision value
    (Blender's data is single precision), and -0.0 as 0.0; lists and dicts
    tidied through."""
    if isinstance(value, dict):
        return {key: tidy(item) for key, item in value.items()}
    if isinstance(value, list):
        return [tidy(item) for item in value]
    if not isinstance(value, float) or not math.isfinite(value):
        return value
    single = struct.unpack("f", struct.pack("f", value))[0]
    for digits in range(6, 10):
        short = float(f"{value:.{digits}g}")
        if struct.unpack("f", struct.pack("f", short))[0] == single:
            return short + 0.0
    return single + 0.0


def safe_name(name):
    """`name` with only letters, digits, `_` and `-` (for files and keys)."""
    return re.sub(r"[^A-Za-z0-9_-]", "_", name) or "object"


def frame_rate(scene):
    """Frames per second of `scene`."""
    return scene.render.fps / scene.render.fps_base


def duration_of(frames, fps):
    """Seconds of `frames` frames at `fps` such that firn makes exactly
    `frames` frames of it (ceil(duration × fps) == frames)."""
    duration = frames / fps
    while math.ceil(duration * fps) > frames:
        duration = math.nextafter(duration, 0.0)
    return duration


def role_objects(scene, role):
    """The scene's objects with firn role `role`, in name order."""
    return sorted((o for o in scene.objects if o.firn.role == role), key=lambda o: o.name)


def world_mesh(obj, depsgraph, scale):
    """`obj`'s evaluated mesh in firn's axes: vertices and triangles."""
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        matrix = evaluated.matrix_world
        vertices = [to_firn(matrix @ v.co, scale) for v in mesh.vertices]
        triangles = [tuple(t.vertices) for t in mesh.loop_triangles]
    finally:
        evaluated.to_mesh_clear()
    return vertices, triangles


def bounds(vertices):
    """The lower and upper corners of `vertices`."""
    lower = [min(v[axis] for v in vertices) for axis in range(3)]
    upper = [max(v[axis] for v in vertices) for axis in range(3)]
    return lower, upper


def centre(vertices):
    """The centre of `vertices`' bounding box."""
    lower, upper = bounds(vertices)
    return [(a + b) / 2 for a, b in zip(lower, upper, strict=True)]


def obj_text(vertices, triangles):
    """A Wavefront OBJ of the triangles, shortest round-trip decimals."""
    lines = [f"v {tidy(x)!r} {tidy(y)!r} {tidy(z)!r}" for x, y, z in vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in triangles]
    return ("\n".join(lines) + "\n").encode()


def flat_normal(vertices, triangles):
    """The unit normal, the way the faces point, of the plane all the
    vertices lie in; None when they do not lie in one."""
    lower, upper = bounds(vertices)
    extent = max(b - a for a, b in zip(lower, upper, strict=True))
    for a, b, c in triangles:
        normal = cross(difference(vertices[b], vertices[a]), difference(vertices[c], vertices[a]))
        length = math.sqrt(dot(normal, normal))
        if length > 1e-12 * extent * extent:
            normal = [n / length for n in normal]
            origin = vertices[a]
            flat = all(abs(dot(difference(v, origin), normal)) <= 1e-6 * extent for v in vertices)
            return normal if flat else None
    return None


def difference(a, b):
    """a - b."""
    return [x - y for x, y in zip(a, b, strict=True)]


def dot(a, b):
    """a · b."""
    return sum(x * y for x, y in zip(a, b, strict=True))


def cross(a, b):
    """a × b."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def sample_motions(scene, objects, scale):
    """The world transforms of `objects` at every frame of the range, in
    firn's axes (translation) and Blender's (rotation, a quaternion)."""
    motions = {obj.name: Motion() for obj in objects}
    if not objects:
        return motions
    fps = frame_rate(scene)
    current = scene.frame_current
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        for obj in objects:
            motion = motions[obj.name]
            matrix = obj.matrix_world
            motion.times.append((frame - scene.frame_start) / fps)
            motion.translations.append(to_firn(matrix.to_translation(), scale))
            motion.rotations.append(matrix.to_quaternion())
    scene.frame_set(current)
    return motions


def sample_deformations(scene, objects, depsgraph_of, scale):
    """The evaluated world meshes of deforming `objects` at every frame of
    the range, in firn's axes; an error when one changes its topology."""
    frames = {obj.name: [] for obj in objects}
    if not objects:
        return frames
    current = scene.frame_current
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        depsgraph = depsgraph_of()
        for obj in objects:
            vertices, triangles = checked_mesh(obj, depsgraph, scale)
            first = frames[obj.name][0] if frames[obj.name] else None
            if first is not None and (len(vertices) != len(first[0]) or triangles != first[1]):
                raise ExportError(
                    obj.name,
                    "Motion",
                    f"the mesh at frame {frame} has {len(vertices)} vertices and {len(triangles)} triangles, "
                    f"at frame {scene.frame_start} {len(first[0])} and {len(first[1])}: a deforming collider "
                    "must keep its topology (no remesh or decimate modifiers)",
                )
            frames[obj.name].append((vertices, triangles))
    scene.frame_set(current)
    return frames


def domain_keys(scene, domain, scale):
    """`[domain]` from the domain object's world bounding box."""
    corners = [to_firn(domain.matrix_world @ Vector(c), scale) for c in domain.bound_box]
    lower, upper = bounds(corners)
    settings = domain.firn
    if settings.cell_size <= 0.0:
        raise ExportError(domain.name, "Cell Size", f"must be greater than 0 (got {settings.cell_size:g})")
    return {
        "min": lower,
        "max": upper,
        "cell_size": settings.cell_size * scale,
        "walls": {"mode": settings.contact, "friction": settings.friction},
    }


def material_keys(settings):
    """A `[materials.NAME]` table of a body's custom parameters."""
    return {
        "preset": settings.preset,
        "youngs_modulus": settings.youngs_modulus,
        "poisson_ratio": settings.poisson_ratio,
        "hardening": settings.hardening,
        "critical_compression": settings.critical_compression,
        "critical_stretch": settings.critical_stretch,
        "density": settings.density,
    }


def body_keys(obj, vertices, mesh_file, scale, materials):
    """A `[[bodies]]` table of a snow object; adds its custom material."""
    settings = obj.firn
    body = {
        "shape": "mesh",
        "mesh": mesh_file,
        "center": centre(vertices),
        "velocity": to_firn(settings.velocity, scale),
        "particles_per_cell": settings.particles_per_cell,
        "material": settings.preset,
    }
    if settings.use_custom_material:
        name = safe_name(obj.name)
        materials[name] = material_keys(settings)
        body["material"] = name
    if settings.use_clumps:
        body["clumps"] = {"size": settings.clump_size * scale, "contrast": settings.clump_contrast}
    return body


def primitive_keys(shape, evaluated, matrix, scale):
    """The centre and size of a sphere, box, cylinder or capsule body:
    the object's local bounding box, scaled as the object is. The body's
    own axes are the object's local x, z, -y (Blender's to firn's, as for
    world axes), so a cylinder's or capsule's axis, firn's y, is the
    object's local z."""
    corners = [Vector(corner) for corner in evaluated.bound_box]
    lower, upper = bounds(corners)
    _, _, stretch = matrix.decompose()
    dx, dy, dz = ((b - a) * abs(s) * scale for a, b, s in zip(lower, upper, stretch, strict=True))
    keys = {"shape": PRIMITIVE_SHAPES[shape], "center": to_firn(matrix @ Vector(centre(corners)), scale)}
    if shape == "SPHERE":
        keys["radius"] = max(dx, dy, dz) / 2
    elif shape == "BOX":
        keys["size"] = [dx, dz, dy]
    else:
        keys["radius"] = max(dx, dy) / 2
        keys["height"] = dz
    return keys


def rigid_body_mesh(obj, depsgraph, rotation, scale):
    """A mesh body's vertices in its own axes (firn's, turned back by the
    body's `rotation`), its triangles, and where its world bounding box's
    centre is (firn's axes)."""
    vertices, triangles = checked_mesh(obj, depsgraph, scale)
    middle = centre(vertices)
    back = rotation.inverted()
    local = [list(back @ Vector(difference(v, middle))) for v in vertices]
    return local, triangles, middle


def rigid_body_keys(obj, depsgraph, scale, meshes):
    """A `[[rigid_bodies]]` table of a rigid body object at the current
    frame; adds a mesh body's OBJ to `meshes`."""
    settings = obj.firn
    if obj.type != "MESH":
        raise ExportError(obj.name, "Role", "only mesh objects can be firn rigid bodies")
    evaluated = obj.evaluated_get(depsgraph)
    matrix = evaluated.matrix_world
    rotation = firn_quaternion(matrix.decompose()[1])
    if settings.body_shape in PRIMITIVE_SHAPES:
        body = primitive_keys(settings.body_shape, evaluated, matrix, scale)
    else:
        local, triangles, middle = rigid_body_mesh(obj, depsgraph, rotation, scale)
        mesh_file = f"{MESH_FOLDER}/{safe_name(obj.name)}.obj"
        meshes[mesh_file] = obj_text(local, triangles)
        body = {"shape": "mesh", "mesh": mesh_file, "center": middle, "solid": MESH_SOLIDS[settings.body_shape]}
    body["quaternion"] = [rotation.x, rotation.y, rotation.z, rotation.w]
    if settings.mass_from == "MASS":
        body["mass"] = settings.mass
    else:
        body["density"] = settings.body_density
    body["velocity"] = to_firn(settings.velocity, scale)
    body["angular_velocity"] = to_firn(settings.angular_velocity, 1.0)
    body["mode"] = settings.contact
    body["friction"] = settings.body_friction
    body["restitution"] = settings.restitution
    return body


def rigid_body_tables(objects, depsgraph, scale, meshes, origins):
    """The `[[rigid_bodies]]` tables of `objects`, each named in `origins`."""
    tables = []
    for obj in objects:
        origins[f"rigid_bodies[{len(tables)}]"] = (obj.name, "rigid body")
        tables.append(rigid_body_keys(obj, depsgraph, scale, meshes))
    return tables


def sequence_keys(obj, pattern, fps):
    """A `[[colliders]]` table of a deforming mesh: its files per frame."""
    settings = obj.firn
    return {
        "shape": "mesh",
        "sequence": pattern,
        "frame_rate": fps,
        "start": 0.0,
        "mode": settings.contact,
        "friction": settings.friction,
    }


def collider_keys(obj, vertices, triangles, mesh_file, motion):
    """A `[[colliders]]` table: the shape, the contact and the motion."""
    settings = obj.firn
    normal = flat_normal(vertices, triangles) if settings.collider_shape != "MESH" else None
    if settings.collider_shape == "PLANE" and normal is None:
        raise ExportError(obj.name, "Shape", "a plane collider must be a flat mesh")
    if normal is not None:
        collider = {"shape": "plane", "point": centre(vertices), "normal": normal}
        reference = collider["point"]
    else:
        collider = {"shape": "mesh", "mesh": mesh_file, "center": centre(vertices)}
        reference = collider["center"]
    collider["mode"] = settings.contact
    collider["friction"] = settings.friction
    if settings.motion != "STATIC" and motion.moves():
        collider["keyframes"] = motion.keyframes(reference)
    return collider


def wind_keys(settings, scale):
    """`[wind]` (and `[wind.spindrift]`) from the scene's settings."""
    direction = to_firn(settings.wind_direction, 1.0)
    length = math.sqrt(sum(a * a for a in direction)) or 1.0
    wind = {
        "background_direction": [a / length for a in direction],
        "background_strength": settings.wind_strength,
        "noise_share": settings.wind_noise_share,
        "length_scale": settings.wind_length_scale * scale,
        "drag": settings.wind_drag,
    }
    if settings.use_spindrift:
        wind["spindrift"] = {
            "threshold_speed": settings.spindrift_threshold,
            "loose_density": settings.spindrift_loose_density,
            "rate": settings.spindrift_rate,
            "fall_speed": settings.spindrift_fall_speed,
            "settle": settings.spindrift_settle,
        }
    return wind


def output_keys(settings, run_directory, scale):
    """`[output]`: the caches the importer reads."""
    formats = []
    if settings.import_surface:
        formats.append("mesh")
    if settings.import_volume:
        formats.append("vdb")
    if settings.import_particles or (settings.use_wind and settings.use_spindrift):
        formats.append("ply")
    output = {"directory": run_directory, "formats": formats, "attributes": ["velocity"]}
    if settings.voxel_size > 0.0:
        voxel = settings.voxel_size * scale
        output["mesh"] = {"voxel_size": voxel}
        output["vdb"] = {"voxel_size": voxel}
    return output


def the_domain(scene):
    """The one domain object."""
    domains = role_objects(scene, "DOMAIN")
    if len(domains) != 1:
        names = ", ".join(o.name for o in domains) or "none"
        raise ExportError(scene.name, "Domain", f"mark exactly one object as the firn domain (found: {names})")
    return domains[0]


def build(scene, depsgraph_of, run_directory):
    """The firn scene of `scene`'s marked objects. `depsgraph_of()` gives
    the evaluated depsgraph at the current frame."""
    settings = scene.firn
    scale = unit_scale(scene)
    domain = the_domain(scene)
    snow = role_objects(scene, "SNOW")
    colliders = role_objects(scene, "COLLIDER")
    if not snow:
        raise ExportError(scene.name, "Snow", "mark at least one mesh object as firn snow")
    if scene.frame_end <= scene.frame_start:
        raise ExportError(scene.name, "Frame Range", "the scene's frame range must hold at least two frames")
    moving = [o for o in colliders if o.firn.motion in ("AUTO", "ANIMATED")]
    motions = sample_motions(scene, moving, scale)
    deforming = [o for o in colliders if o.firn.motion == "DEFORMING"]
    deformations = sample_deformations(scene, deforming, depsgraph_of, scale)
    current = scene.frame_current
    scene.frame_set(scene.frame_start)
    depsgraph = depsgraph_of()
    fps = frame_rate(scene)
    frames = scene.frame_end - scene.frame_start
    keys = {
        "format": 1,
        "name": safe_name(scene.name),
        "domain": domain_keys(scene, domain, scale),
        "time": {"duration": duration_of(frames, fps), "fps": fps},
        "solver": {"transfer": settings.transfer, "seed": settings.seed, "gravity": gravity(scene, scale)},
        "bodies": [],
        "colliders": [],
        "output": output_keys(settings, run_directory, scale),
        "render": {"enabled": False},
        "compute": {"backend": settings.backend},
    }
    meshes, origins, materials = {}, {"domain": (domain.name, "domain")}, {}
    for obj in snow:
        vertices, triangles = checked_mesh(obj, depsgraph, scale)
        mesh_file = f"{MESH_FOLDER}/{safe_name(obj.name)}.obj"
        meshes[mesh_file] = obj_text(vertices, triangles)
        origins[f"bodies[{len(keys['bodies'])}]"] = (obj.name, "snow body")
        keys["bodies"].append(body_keys(obj, vertices, mesh_file, scale, materials))
    for obj in colliders:
        if obj.name in deformations:
            folder = f"{MESH_FOLDER}/{safe_name(obj.name)}"
            for number, (vertices, triangles) in enumerate(deformations[obj.name], start=1):
                meshes[f"{folder}/frame_{number:04d}.obj"] = obj_text(vertices, triangles)
            origins[f"colliders[{len(keys['colliders'])}]"] = (obj.name, "collider")
            keys["colliders"].append(sequence_keys(obj, f"{folder}/frame_####.obj", fps))
            continue
        vertices, triangles = checked_mesh(obj, depsgraph, scale)
        motion = motions.get(obj.name, Motion())
        collider = collider_keys(obj, vertices, triangles, f"{MESH_FOLDER}/{safe_name(obj.name)}.obj", motion)
        if collider["shape"] == "mesh":
            meshes[collider["mesh"]] = obj_text(vertices, triangles)
        origins[f"colliders[{len(keys['colliders'])}]"] = (obj.name, "collider")
        keys["colliders"].append(collider)
    keys["rigid_bodies"] = rigid_body_tables(role_objects(scene, "RIGID_BODY"), depsgraph, scale, meshes, origins)
    scene.frame_set(current)
    if materials:
        keys["materials"] = materials
    for table in ("colliders", "rigid_bodies"):
        if not keys[table]:
            del keys[table]
    if settings.use_wind:
        keys["wind"] = wind_keys(settings, scale)
        origins["wind"] = (scene.name, "wind")
    keys = tidy(keys)
    keys["time"] = {"duration": duration_of(frames, fps), "fps": fps}
    return Export(keys, meshes, origins, scene.frame_start, frames)


def gravity(scene, scale):
    """The scene's gravity in firn's axes (m/s²), zero when it is off."""
    if not scene.use_gravity:
        return [0.0, 0.0, 0.0]
    return to_firn(scene.gravity, scale)


def checked_mesh(obj, depsgraph, scale):
    """`obj`'s world mesh in firn's axes; an error when it has no faces."""
    if obj.type != "MESH":
        raise ExportError(obj.name, "Role", "only mesh objects can be firn snow, colliders or rigid bodies")
    vertices, triangles = world_mesh(obj, depsgraph, scale)
    if not triangles:
        raise ExportError(obj.name, "Mesh", "the mesh has no faces to fill or to collide with")
    return vertices, triangles

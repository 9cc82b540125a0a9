"""Blender's axes and units against firn's.

Blender is z-up in Blender units; firn is y-up in metres. A point
(x, y, z) of Blender is (x, z, -y) × the unit scale in firn: a rotation by
-90° about x and a scale, so firn's output comes back into Blender by the
inverse, `blender_from_firn`, set as the imported object's transform."""

from mathutils import Matrix


def blender_from_firn(scale):
    """The 4×4 transform from firn's world (metres) to Blender's (units)."""
    inverse = 1.0 / scale
    return Matrix(((inverse, 0, 0, 0), (0, 0, -inverse, 0), (0, inverse, 0, 0), (0, 0, 0, 1)))


def to_firn(vector, scale):
    """A Blender point, direction or velocity (x, y, z) as firn's (x, z, -y) × scale."""
    x, y, z = vector
    return [x * scale, z * scale, -y * scale]


def unit_scale(scene):
    """Metres per Blender unit of `scene`."""
    settings = scene.unit_settings
    if settings.system == "NONE":
        return 1.0
    return settings.scale_length

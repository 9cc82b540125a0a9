"""The add-on's settings: `Object.firn` (what an object is to firn) and
`Scene.firn` (the bake: cache folder, wind, spindrift, what comes back).

Lengths are in Blender units and velocities in units per second; the
export multiplies them by the scene's unit scale to get metres."""

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

ROLES = [
    ("NONE", "None", "Not part of the firn simulation"),
    ("SNOW", "Snow", "A body of snow: the mesh is filled with particles"),
    ("COLLIDER", "Collider", "A rigid obstacle the snow hits"),
    ("DOMAIN", "Domain", "The box the simulation lives in: its bounds and cell size define the grid"),
    (
        "RIGID_BODY",
        "Rigid Body",
        "A solid that falls, tumbles and collides, pushed by the snow and pushing it; baked onto a linked copy",
    ),
]

PRESETS = [
    ("snow", "Snow", "Stomakhin et al. 2013's reference snow (E 1.4e5 Pa, 400 kg/m3)"),
    ("thesis", "Thesis", "The thesis' test snow (E 1e6 Pa)"),
    ("powder", "Powder", "Light, dry powder that breaks apart easily (200 kg/m3)"),
    ("wet", "Wet", "Dense wet snow that stays compact (550 kg/m3)"),
    ("icy", "Icy", "Stiff, strongly hardening snow (750 kg/m3)"),
    ("slush", "Slush", "Soft, heavy slush (850 kg/m3)"),
]

CONTACT_MODES = [
    ("separate", "Separate", "Snow moving into the surface stops; it may leave it"),
    ("slip", "Slip", "Snow slides along the surface but cannot leave it"),
    ("sticky", "Sticky", "Snow in contact moves with the collider"),
]

COLLIDER_SHAPES = [
    ("AUTO", "Auto", "A flat mesh becomes an infinite plane, any other mesh a mesh collider"),
    ("PLANE", "Plane", "The infinite plane through the object, solid below its normal"),
    ("MESH", "Mesh", "The object's mesh, as a signed distance field"),
]

BODY_SHAPES = [
    ("SPHERE", "Sphere", "A ball as wide as the object's largest dimension"),
    ("BOX", "Box", "A box of the object's dimensions, turned as the object is"),
    ("CYLINDER", "Cylinder", "A cylinder along the object's local z: its z dimension long, as wide as x or y"),
    ("CAPSULE", "Capsule", "A capsule along the object's local z: its z dimension end to end, as wide as x or y"),
    ("CONVEX_HULL", "Convex Hull", "The evaluated mesh; other solids meet its convex hull, the snow the mesh"),
    (
        "CONVEX_DECOMPOSITION",
        "Convex Decomposition",
        "The evaluated mesh; other solids meet it as convex pieces (for rings, bowls, chairs), the snow the mesh",
    ),
]

MASS_SOURCES = [
    ("DENSITY", "Density", "The mass follows from the shape's volume"),
    ("MASS", "Mass", "The mass in kg; the inertia is the shape's at a uniform density"),
]

MOTIONS = [
    ("AUTO", "Auto", "Animated when the object or a parent has an animation"),
    ("STATIC", "Static", "The collider stays where it is at the first frame"),
    ("ANIMATED", "Animated", "The object's transform is sampled every frame"),
    (
        "DEFORMING",
        "Deforming",
        "The evaluated mesh (armature, shape keys, modifiers) is exported every frame as a mesh sequence",
    ),
]


class FirnObjectSettings(bpy.types.PropertyGroup):
    """What an object is to firn, and its settings."""

    role: EnumProperty(name="Role", items=ROLES, default="NONE")

    # Snow bodies.
    preset: EnumProperty(name="Material", items=PRESETS, default="snow")
    use_custom_material: BoolProperty(
        name="Custom Parameters", description="Override the preset's parameters with the ones below"
    )
    youngs_modulus: FloatProperty(name="Young's Modulus (Pa)", default=1.4e5, min=1.0)
    poisson_ratio: FloatProperty(name="Poisson's Ratio", default=0.2, min=-0.99, max=0.49)
    hardening: FloatProperty(name="Hardening", default=10.0, min=0.0)
    critical_compression: FloatProperty(name="Critical Compression", default=0.025, min=0.0, max=0.999, precision=4)
    critical_stretch: FloatProperty(name="Critical Stretch", default=0.0075, min=0.0, precision=4)
    density: FloatProperty(name="Density (kg/m³)", default=400.0, min=0.001)
    particles_per_cell: IntProperty(name="Particles per Cell", default=8, min=1, max=64)
    velocity: FloatVectorProperty(name="Initial Velocity", subtype="VELOCITY", size=3)
    use_clumps: BoolProperty(name="Clumps", description="Pack the snow unevenly, in clumps")
    clump_size: FloatProperty(name="Clump Size", default=0.05, min=0.0, subtype="DISTANCE")
    clump_contrast: FloatProperty(name="Clump Contrast", default=0.15, min=0.0, max=0.5)

    # Colliders (and the domain's walls).
    collider_shape: EnumProperty(name="Shape", items=COLLIDER_SHAPES, default="AUTO")
    motion: EnumProperty(name="Motion", items=MOTIONS, default="AUTO")
    contact: EnumProperty(name="Contact", items=CONTACT_MODES, default="separate")
    friction: FloatProperty(name="Friction", default=0.2, min=0.0)

    # Rigid bodies (the contact mode above is theirs too).
    body_shape: EnumProperty(name="Shape", items=BODY_SHAPES, default="CONVEX_HULL")
    mass_from: EnumProperty(name="Mass From", items=MASS_SOURCES, default="DENSITY")
    body_density: FloatProperty(
        name="Density (kg/m³)", default=500.0, min=0.0, description="500 kg/m³ is wood; ice 900, stone 2600"
    )
    mass: FloatProperty(name="Mass (kg)", default=1.0, min=0.0)
    angular_velocity: FloatVectorProperty(
        name="Initial Angular Velocity",
        size=3,
        subtype="XYZ",
        description="rad/s in world axes: the direction is the axis (right-hand rule), the length the rate",
    )
    body_friction: FloatProperty(
        name="Friction",
        default=0.3,
        min=0.0,
        description="Coulomb friction against the snow and the other solids (0.3: wood on snow)",
    )
    restitution: FloatProperty(
        name="Bounciness",
        default=0.0,
        min=0.0,
        max=1.0,
        description="Share of the speed a collision with another solid gives back (the snow does not bounce)",
    )

    # The domain.
    cell_size: FloatProperty(
        name="Cell Size",
        default=0.05,
        min=0.0,
        subtype="DISTANCE",
        precision=4,
        description="Grid spacing: the finest detail is a few cells wide",
    )


class FirnSceneSettings(bpy.types.PropertyGroup):
    """The bake of a scene: where it goes, the air, and what comes back."""

    cache_directory: StringProperty(
        name="Cache",
        default="//firn_cache",
        subtype="DIR_PATH",
        description="Folder of the scene file, its meshes and the caches ('//' is the .blend's folder)",
    )
    transfer: EnumProperty(
        name="Transfer",
        items=[("pic-flip", "PIC/FLIP", "The thesis' transfer"), ("apic", "APIC", "Affine particle-in-cell")],
        default="pic-flip",
    )
    seed: IntProperty(name="Seed", default=1, min=0)
    voxel_size: FloatProperty(
        name="Voxel Size",
        default=0.0,
        min=0.0,
        subtype="DISTANCE",
        precision=4,
        description="Voxel edge of the surface mesh and the volume (0: the cell size)",
    )
    backend: EnumProperty(
        name="Backend",
        items=[("cpu", "CPU", ""), ("gpu", "GPU", ""), ("auto", "Auto", "A hardware GPU when present")],
        default="cpu",
    )

    use_wind: BoolProperty(name="Wind", description="Air blowing over the snow")
    wind_direction: FloatVectorProperty(name="Direction", size=3, default=(1.0, 0.0, 0.0), subtype="DIRECTION")
    wind_strength: FloatProperty(
        name="Background Strength",
        default=10.0,
        min=0.0,
        description="The steady wind blows at (1 - gusts) times this, m/s",
    )
    wind_noise_share: FloatProperty(name="Gusts", default=0.5, min=0.0, max=1.0)
    wind_length_scale: FloatProperty(name="Gust Size", default=0.5, min=0.001, subtype="DISTANCE")
    wind_drag: FloatProperty(name="Drag", default=6.0, min=0.0)
    use_spindrift: BoolProperty(name="Spindrift", description="Loose surface snow blown off as drift")
    spindrift_threshold: FloatProperty(name="Threshold Speed", default=5.0, min=0.0)
    spindrift_loose_density: FloatProperty(name="Loose Density", default=250.0, min=0.001)
    spindrift_rate: FloatProperty(name="Rate", default=2.0, min=0.0)
    spindrift_fall_speed: FloatProperty(name="Fall Speed", default=0.5, min=0.0)
    spindrift_settle: BoolProperty(name="Settle", default=True)

    import_surface: BoolProperty(name="Surface", default=True, description="The snow's surface mesh")
    import_volume: BoolProperty(name="Volume", default=True, description="The snow's density (VDB)")
    import_particles: BoolProperty(name="Particles", default=False, description="The particles as points")

    # Set while baking; shown by the panel.
    baking: BoolProperty(options={"SKIP_SAVE"})
    progress: FloatProperty(min=0.0, max=1.0, subtype="FACTOR", options={"SKIP_SAVE"})
    status: StringProperty(options={"SKIP_SAVE"})


CLASSES = (FirnObjectSettings, FirnSceneSettings)


def register():
    """Adds `Object.firn` and `Scene.firn`."""
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.Object.firn = PointerProperty(type=FirnObjectSettings)
    bpy.types.Scene.firn = PointerProperty(type=FirnSceneSettings)


def unregister():
    """Removes what `register` added."""
    del bpy.types.Scene.firn
    del bpy.types.Object.firn
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

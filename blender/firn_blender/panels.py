"""The add-on's interface: a "firn Snow" panel in the Physics properties
(what the active object is to firn, and its settings) and a "firn" tab in
the 3D view's sidebar (the bake: cache, wind, spindrift, what comes back,
and the bake buttons with their progress). The bake section is also shown
under the Physics panel."""

import bpy


def draw_object(layout, obj):
    """The settings of `obj`'s firn role."""
    settings = obj.firn
    layout.prop(settings, "role")
    if settings.role == "SNOW":
        layout.prop(settings, "preset")
        layout.prop(settings, "use_custom_material")
        column = layout.column(align=True)
        column.enabled = settings.use_custom_material
        for name in (
            "youngs_modulus",
            "poisson_ratio",
            "hardening",
            "critical_compression",
            "critical_stretch",
            "density",
        ):
            column.prop(settings, name)
        layout.prop(settings, "particles_per_cell")
        layout.prop(settings, "velocity")
        row = layout.row(align=True)
        row.prop(settings, "use_clumps")
        sub = row.row(align=True)
        sub.enabled = settings.use_clumps
        sub.prop(settings, "clump_size", text="Size")
        sub.prop(settings, "clump_contrast", text="Contrast")
    elif settings.role == "COLLIDER":
        layout.prop(settings, "collider_shape")
        layout.prop(settings, "motion")
        layout.prop(settings, "contact")
        layout.prop(settings, "friction")
    elif settings.role == "RIGID_BODY":
        draw_rigid_body(layout, settings)
    elif settings.role == "DOMAIN":
        layout.prop(settings, "cell_size")
        layout.label(text="Walls:")
        layout.prop(settings, "contact")
        layout.prop(settings, "friction")


def draw_rigid_body(layout, settings):
    """A rigid body's settings, grouped as Blender's Rigid Body panel."""
    layout.prop(settings, "body_shape")
    column = layout.column(heading="Settings")
    column.prop(settings, "mass_from")
    column.prop(settings, "body_density" if settings.mass_from == "DENSITY" else "mass")
    column.prop(settings, "velocity")
    column.prop(settings, "angular_velocity")
    column = layout.column(heading="Surface Response")
    column.prop(settings, "body_friction")
    column.prop(settings, "restitution")
    column.prop(settings, "contact", text="Snow Contact")


def draw_bake(layout, scene):
    """The bake's settings, buttons and progress."""
    settings = scene.firn
    layout.prop(settings, "cache_directory")
    fps = scene.render.fps / scene.render.fps_base
    layout.label(text=f"Frames {scene.frame_start} to {scene.frame_end} at {fps:g} fps (from the scene)")
    row = layout.row(align=True)
    row.prop(settings, "transfer")
    row.prop(settings, "backend", text="")
    layout.prop(settings, "voxel_size")
    layout.prop(settings, "use_wind")
    if settings.use_wind:
        box = layout.box()
        for name in ("wind_direction", "wind_strength", "wind_noise_share", "wind_length_scale", "wind_drag"):
            box.prop(settings, name)
        box.prop(settings, "use_spindrift")
        if settings.use_spindrift:
            for name in (
                "spindrift_threshold",
                "spindrift_loose_density",
                "spindrift_rate",
                "spindrift_fall_speed",
                "spindrift_settle",
            ):
                box.prop(settings, name)
    row = layout.row(align=True)
    row.label(text="Load:")
    row.prop(settings, "import_surface", toggle=True)
    row.prop(settings, "import_volume", toggle=True)
    row.prop(settings, "import_particles", toggle=True)
    row = layout.row(align=True)
    if settings.baking:
        row.operator("firn.cancel_bake", icon="CANCEL")
    else:
        row.operator("firn.bake", icon="PHYSICS")
        row.operator("firn.load_bake", text="", icon="IMPORT")
        row.operator("firn.free_bake", text="", icon="TRASH")
    if settings.baking:
        layout.prop(settings, "progress", text=settings.status, slider=True)
    elif settings.status:
        layout.label(text=settings.status)


class FIRN_PT_physics(bpy.types.Panel):
    """firn's settings of the active object."""

    bl_label = "firn Snow"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "physics"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        self.layout.use_property_split = True
        draw_object(self.layout, context.object)


class FIRN_PT_physics_bake(bpy.types.Panel):
    """The scene's bake, under the object's firn panel."""

    bl_label = "Bake"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "physics"
    bl_parent_id = "FIRN_PT_physics"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.firn.role != "NONE"

    def draw(self, context):
        self.layout.use_property_split = True
        draw_bake(self.layout, context.scene)


class FIRN_PT_sidebar(bpy.types.Panel):
    """The active object's role and the bake, in the 3D view's sidebar."""

    bl_label = "firn Snow"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "firn"

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        if context.object is not None and context.object.type == "MESH":
            draw_object(layout.box(), context.object)
        draw_bake(layout, context.scene)


CLASSES = (FIRN_PT_physics, FIRN_PT_physics_bake, FIRN_PT_sidebar)


def register():
    """Registers the panels."""
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    """Unregisters the panels."""
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)

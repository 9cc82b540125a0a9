"""firn inside Blender: mark objects as snow, colliders, rigid bodies and
the domain, bake them with firn's Python module, and get the snow back as
an animated surface mesh and volume, and the rigid bodies as keyed copies.
See the README's "Into Blender"."""

import bpy

from . import bake, importer, panels, properties

bl_info = {
    "name": "firn Snow",
    "author": "firn",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "Properties > Physics > firn Snow; 3D View > Sidebar > firn",
    "description": "Snow simulation (the Material Point Method) with firn: set up, bake and load back",
    "category": "Physics",
}


class FirnPreferences(bpy.types.AddonPreferences):
    """Where the firn module is when Blender's Python cannot import it."""

    bl_idname = __package__

    module_folder: bpy.props.StringProperty(
        name="firn Module Folder",
        subtype="DIR_PATH",
        description="Folder holding the 'firn' package (not needed when Blender's Python imports firn)",
    )

    def draw(self, context):
        self.layout.prop(self, "module_folder")


MODULES = (properties, bake, importer, panels)


def register():
    """Registers the add-on's settings, operators, panels and handler."""
    bpy.utils.register_class(FirnPreferences)
    for module in MODULES:
        module.register()


def unregister():
    """Undoes `register`."""
    for module in reversed(MODULES):
        module.unregister()
    bpy.utils.unregister_class(FirnPreferences)

"""hdeform in Blender: drag a mesh with harmonic guidance (Zayer et al. 2005) and as-rigid-as-possible
refinement, by moving Empties.

Paint the vertex groups hdeform_fixed (what stays) and hdeform_handle_1, _2, ... (what each handle
moves), optionally hdeform_roi; Bind (the 3D view's N panel, tab "hdeform"). Each handle gets an
Empty; G, R and S on it (axis locks, snapping, typed values, the gizmo) deform the mesh live into
the shape key "hdeform", and keyframed Empties deform it on every frame. The solver is the hdeform
Python module: it must be importable (its folder on PYTHONPATH, or in this add-on's preferences).
"""
import sys

import bpy
from bpy.props import StringProperty
from bpy.types import AddonPreferences

bl_info = {
    "name": "hdeform: harmonic guidance",
    "author": "the hdeform authors",
    "version": (1, 0, 0),
    "blender": (3, 4, 0),
    "location": "View3D > Sidebar (N) > hdeform",
    "description": "Detail-preserving deformation by handles: harmonic guidance and as-rigid-as-possible refinement",
    "category": "Mesh",
}


def add_module_path(path):
    if path and path not in sys.path:
        sys.path.append(path)


def module_path_changed(self, _context):
    add_module_path(bpy.path.abspath(self.module_path))


class HdeformPreferences(AddonPreferences):
    bl_idname = __package__

    module_path: StringProperty(name="hdeform module folder", subtype='DIR_PATH', update=module_path_changed,
                                description="The folder that holds the hdeform package (its install's site-packages); "
                                            "empty when it is on PYTHONPATH")

    def draw(self, _context):
        layout = self.layout
        layout.prop(self, "module_path")
        try:
            import hdeform
            layout.label(text="hdeform found: " + hdeform.__file__, icon='CHECKMARK')
        except ImportError:
            layout.label(text="hdeform is not importable: set the folder above, or PYTHONPATH", icon='ERROR')


from . import handlers, operators, panel, properties  # noqa: E402 - after bl_info, as Blender reads it

_parts = (properties, operators, panel, handlers)


def register():
    bpy.utils.register_class(HdeformPreferences)
    preferences = bpy.context.preferences.addons.get(__package__)
    if preferences is not None:
        add_module_path(bpy.path.abspath(preferences.preferences.module_path))
    for part in _parts:
        part.register()


def unregister():
    for part in reversed(_parts):
        part.unregister()
    bpy.utils.unregister_class(HdeformPreferences)

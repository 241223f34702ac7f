"""The N-panel tab "hdeform" in the 3D view: the groups, the buttons, the settings and the live
figures of the active mesh."""
import bpy
from bpy.types import Panel

from . import setup_jobs, solver


class VIEW3D_PT_hdeform(Panel):
    bl_label = "Harmonic guidance"
    bl_idname = "VIEW3D_PT_hdeform"
    bl_space_type = 'VIEW_3D'
    bl_region_type = 'UI'
    bl_category = "hdeform"

    def draw(self, context):
        layout = self.layout
        obj = context.active_object
        if obj is None or obj.type not in {'MESH', 'EMPTY'}:
            layout.label(text="Select a mesh (or a handle's Empty)")
            return
        if obj.type == 'EMPTY':
            owner = obj.parent if obj.parent is not None and obj.parent.type == 'MESH' else None
            layout.label(text=("Handle of " + owner.name) if owner is not None else "Not an hdeform handle", icon='EMPTY_ARROWS')
            if owner is None:
                return
            obj = owner
        settings = obj.hdeform

        groups = layout.box()
        groups.label(text="Vertex groups", icon='GROUP_VERTEX')
        fixed = obj.vertex_groups.get(solver.FIXED_GROUP)
        groups.label(text=solver.FIXED_GROUP + ("" if fixed is not None else ": missing"), icon='CHECKMARK' if fixed is not None else 'ERROR')
        handle_groups = solver.handle_groups(obj)
        for group in handle_groups:
            item = next((item for item in settings.handles if item.group == group.name), None)
            groups.label(text=group.name, icon='EMPTY_ARROWS')
            if item is not None:
                groups.prop(item, "empty", text="")
            else:
                groups.label(text="(its Empty comes with Bind)", icon='BLANK1')
        if not handle_groups:
            groups.label(text=solver.HANDLE_PREFIX + "1: missing", icon='ERROR')
        groups.prop_search(settings, "roi_group", obj, "vertex_groups", text="ROI")
        groups.operator("hdeform.add_handle", icon='ADD')

        row = layout.row(align=True)
        row.operator("hdeform.bind", text="Bind" if not settings.bound else "Bind again", icon='LINKED')
        row.operator("hdeform.update", icon='FILE_REFRESH')
        row = layout.row(align=True)
        row.operator("hdeform.apply", icon='CHECKMARK')
        row.operator("hdeform.reset", icon='LOOP_BACK')

        layout.prop(settings, "refine")
        sub = layout.row()
        sub.enabled = settings.refine
        sub.prop(settings, "refine_tolerance")
        layout.prop(settings, "backend")
        layout.prop(settings, "resolution")
        sub = layout.row()
        sub.enabled = settings.resolution != 'exact'
        sub.prop(settings, "base_vertices")

        status = layout.box()
        stage = setup_jobs.running(obj)
        error = settings.get("last_error")
        bound_object = solver.bound(obj)
        if stage is not None:
            for k, line in enumerate(wrap("Setting up: " + stage + "...", 28)):
                status.label(text=line, icon='SORTTIME' if k == 0 else 'BLANK1')
        elif error:
            for k, line in enumerate(wrap(error, 28)):
                status.label(text=line, icon='ERROR' if k == 0 else 'BLANK1')
        elif not settings.bound:
            for k, line in enumerate(wrap("Not bound: assign the groups, then Bind", 28)):
                status.label(text=line, icon='INFO' if k == 0 else 'BLANK1')
        elif bound_object is None:
            for k, line in enumerate(wrap("Bound; its solver is set up at the next move", 28)):
                status.label(text=line, icon='INFO' if k == 0 else 'BLANK1')
        else:
            if bound_object.solved_vertices < bound_object.vertices:
                site = "Solves on a base of %d of its %d vertices" % (bound_object.solved_vertices, bound_object.vertices)
            else:
                site = "Solves on all its %d vertices" % bound_object.vertices
            # Narrower than the other lines: the numbers are long words, and the lines have icons.
            for k, line in enumerate(wrap(site, 22)):
                status.label(text=line, icon='MESH_DATA' if k == 0 else 'BLANK1')
            for note in bound_object.warnings:
                for k, line in enumerate(wrap(note, 20)):
                    status.label(text=line, icon='ERROR' if k == 0 else 'BLANK1')
            status.label(text="Update: %.1f ms" % bound_object.update_ms)
            if settings.refine:
                status.label(text="%d iterations, %s" % (bound_object.iterations, "refining..." if bound_object.refining else "settled"))
                if bound_object.iterations > 0:
                    # Rounding leaves the rest pose's energy a hair below zero.
                    status.label(text="Energy %.4g" % max(bound_object.energy, 0.0))
                    status.label(text="(paper's %.4g)" % max(bound_object.unrefined_energy, 0.0))


def wrap(text, width):
    lines, line = [], ""
    for word in text.split():
        if line and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = word
        else:
            line = (line + " " + word).strip()
    return lines + ([line] if line else [])


def register():
    bpy.utils.register_class(VIEW3D_PT_hdeform)


def unregister():
    bpy.utils.unregister_class(VIEW3D_PT_hdeform)

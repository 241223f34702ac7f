"""The add-on's operators: Bind, Update, Add handle from selection, Apply and Reset. Each refuses a
set-up it cannot solve with an error report that says what to change, and changes nothing then."""
import bpy
import numpy as np
from bpy.props import BoolProperty
from bpy.types import Operator
from mathutils import Matrix

from . import setup_jobs, solver


def reporting_setup_errors(execute):
    """An operator's execute whose SetupError becomes Blender's error report (nothing changed)."""
    def reported(self, context):
        try:
            return execute(self, context)
        except solver.SetupError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
    return reported


def active_mesh(context):
    """The active mesh, or the mesh a handle's Empty (the active object) hangs from."""
    obj = context.active_object
    if obj is not None and obj.type == 'EMPTY' and obj.parent is not None and obj.parent.type == 'MESH':
        obj = obj.parent
    return obj if obj is not None and obj.type == 'MESH' else None


def new_handle_empty(context, obj, group_name, vertices, positions):
    """An Empty at the centroid of the handle's rest vertices, parented to the mesh object with no
    turn of its own (its axes are the mesh's), sized to a tenth of the mesh."""
    centroid = positions[vertices].mean(axis=0)
    size = 0.1 * float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
    empty = bpy.data.objects.new(group_name.replace(solver.HANDLE_PREFIX, "hdeform handle "), None)
    empty.empty_display_type = 'ARROWS'
    empty.empty_display_size = max(size, 1e-6)
    empty.parent = obj
    empty.matrix_parent_inverse = Matrix.Identity(4)
    empty.location = tuple(centroid)
    for collection in obj.users_collection:
        collection.objects.link(empty)
        break
    else:
        context.scene.collection.objects.link(empty)
    return empty


def record_bind(obj, item):
    """The Empty's frame now becomes the handle's rest frame."""
    empty = item.empty
    item.bind_frame = tuple(solver.empty_frame(obj, empty).ravel())
    item.bind_location = tuple(empty.location)
    item.bind_rotation = solver.rotation_values(empty)
    item.bind_rotation_mode = empty.rotation_mode
    item.bind_scale = tuple(empty.scale)
    item.recorded = True


def report_bound(operator, obj, setup, deformer):
    """The bind reported in Blender's way (the Info log lists it); with the solver's notes, as a warning."""
    count = len(setup.handles)
    message = f"Bound {obj.name}: {count} handle{'' if count == 1 else 's'}"
    notes = deformer.warnings
    if notes:
        operator.report({'WARNING'}, message + ". " + "; ".join(notes))
    else:
        operator.report({'INFO'}, message)


def finish_bind(context, obj, setup, deformer, record_all=False):
    """After the solver is built: the handles' Empties (made where missing), the rest frames of the
    handles that have none yet (or of all with `record_all`), the shape keys, and the result for
    the pose now."""
    settings = obj.hdeform
    by_group = {item.group: item for item in settings.handles}
    for name, vertices in zip(setup.handle_names, setup.handles):
        item = by_group.get(name)
        if item is None:
            item = settings.handles.add()
            item.group = name
        if item.empty is None or item.empty.name not in bpy.data.objects:
            item.empty = new_handle_empty(context, obj, name, vertices, setup.positions)
            item.recorded = False
    for index in reversed(range(len(settings.handles))):
        if settings.handles[index].group not in setup.handle_names:
            settings.handles.remove(index)
    for item in settings.handles:
        if record_all or not item.recorded:
            record_bind(obj, item)
    solver.ensure_shape_keys(obj)
    settings.bound = True
    solver.install(obj, solver.Bound(setup, deformer))
    # (None when the solver settings changed while it was set up: the next move sets it up again.)
    if solver.bound(obj) is not None:
        solver.update(obj, wait=not settings.refine or bpy.app.background, force=True)


class HDEFORM_OT_bind(Operator):
    """Read the hdeform vertex groups, make an Empty for each handle that has none, and set the solver up"""
    bl_idname = "hdeform.bind"
    bl_label = "Bind"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        return active_mesh(context) is not None and context.mode == 'OBJECT'

    @reporting_setup_errors
    def execute(self, context):
        obj = active_mesh(context)
        setup = solver.Setup(obj, obj.hdeform)
        deformer = solver.build(setup)
        finish_bind(context, obj, setup, deformer)
        report_bound(self, obj, setup, deformer)
        return {'FINISHED'}

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        obj = active_mesh(context)
        try:
            setup = solver.Setup(obj, obj.hdeform)
        except solver.SetupError as error:
            self.report({'ERROR'}, str(error))
            return {'CANCELLED'}
        self.job = setup_jobs.start(obj, setup)
        if self.job is None:
            self.report({'WARNING'}, obj.name + " is being set up already")
            return {'CANCELLED'}
        obj.hdeform.pop("last_error", None)
        self.timer = context.window_manager.event_timer_add(0.1, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {'RUNNING_MODAL'}

    def modal(self, context, event):
        """The interface goes on while the worker sets the solver up; then the bind is finished
        here, and reported in Blender's way."""
        if event.type != 'TIMER' or not self.job.done.is_set():
            return {'PASS_THROUGH'}
        context.window_manager.event_timer_remove(self.timer)
        setup_jobs.take(self.job)
        obj = bpy.data.objects.get(self.job.key[1])
        error = self.job.error
        if obj is not None and error is None:
            try:
                finish_bind(context, obj, self.job.setup, self.job.deformer)
            except solver.SetupError as failure:
                error = str(failure)
        if error is not None:
            if obj is not None:
                obj.hdeform["last_error"] = error
            self.report({'ERROR'}, error)
            return {'CANCELLED'}
        report_bound(self, obj, self.job.setup, self.job.deformer)
        return {'FINISHED'}


class HDEFORM_OT_update(Operator):
    """Bring the shape key "hdeform" up to date with the handles' Empties now"""
    bl_idname = "hdeform.update"
    bl_label = "Update"
    bl_options = {'REGISTER', 'UNDO'}

    wait: BoolProperty(name="Wait", default=False, description="Also wait until the refinement has settled")

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        return obj is not None and obj.hdeform.bound

    @reporting_setup_errors
    def execute(self, context):
        obj = active_mesh(context)
        if solver.bound(obj) is None:
            setup = solver.Setup(obj, obj.hdeform)
            solver.install(obj, solver.Bound(setup, solver.build(setup)))
        solver.update(obj, wait=self.wait)
        return {'FINISHED'}


class HDEFORM_OT_add_handle(Operator):
    """Make the selected vertices a new handle: a vertex group hdeform_handle_N and an Empty at their centroid"""
    bl_idname = "hdeform.add_handle"
    bl_label = "Add handle from selection"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        if obj is None or obj.mode != 'EDIT':
            cls.poll_message_set("Select the handle's vertices in Edit Mode")
            return False
        return True

    def execute(self, context):
        obj = active_mesh(context)
        obj.update_from_editmode()
        selected = np.zeros(len(obj.data.vertices), dtype=bool)
        obj.data.vertices.foreach_get("select", selected)
        vertices = np.flatnonzero(selected)
        if len(vertices) == 0:
            self.report({'ERROR'}, "no vertex is selected: select the handle's vertices in Edit Mode first")
            return {'CANCELLED'}
        numbers = [int(group.name[len(solver.HANDLE_PREFIX):]) for group in solver.handle_groups(obj)]
        name = solver.HANDLE_PREFIX + str(max(numbers, default=0) + 1)
        solver.forget(obj)  # set up again with the new handle at the next move
        bpy.ops.object.mode_set(mode='OBJECT')  # vertex groups and Empties are changed outside Edit Mode
        obj.vertex_groups.new(name=name).add(vertices.tolist(), 1.0, 'REPLACE')
        item = obj.hdeform.handles.add()
        item.group = name
        item.empty = new_handle_empty(context, obj, name, vertices, solver.rest_positions(obj))
        record_bind(obj, item)
        bpy.ops.object.mode_set(mode='EDIT')
        self.report({'INFO'}, "Added " + name + " (" + str(len(vertices)) + " vertices)" + ("" if obj.hdeform.bound else "; Bind to deform"))
        return {'FINISHED'}


class HDEFORM_OT_apply(Operator):
    """Make the result the new rest shape: the Basis takes the shape key, the handles stay where they are"""
    bl_idname = "hdeform.apply"
    bl_label = "Apply"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        return obj is not None and obj.hdeform.bound and obj.data.shape_keys is not None and context.mode == 'OBJECT'

    @reporting_setup_errors
    def execute(self, context):
        obj = active_mesh(context)
        result = solver.read_key(obj)
        # The solver for the new rest shape first: a failure leaves everything as it was.
        setup = solver.Setup(obj, obj.hdeform)
        setup.positions = result.astype(np.float64)
        deformer = solver.build(setup)
        obj.data.shape_keys.reference_key.data.foreach_set("co", result.ravel())
        obj.data.vertices.foreach_set("co", result.ravel())
        finish_bind(context, obj, setup, deformer, record_all=True)
        self.report({'INFO'}, "Applied: the result is the rest shape")
        return {'FINISHED'}


class HDEFORM_OT_reset(Operator):
    """Put every handle's Empty back where it was at bind"""
    bl_idname = "hdeform.reset"
    bl_label = "Reset"
    bl_options = {'REGISTER', 'UNDO'}

    @classmethod
    def poll(cls, context):
        obj = active_mesh(context)
        return obj is not None and obj.hdeform.bound

    def execute(self, context):
        obj = active_mesh(context)
        for item in obj.hdeform.handles:
            empty = item.empty
            if empty is None:
                continue
            empty.location = item.bind_location
            empty.rotation_mode = item.bind_rotation_mode
            if empty.rotation_mode == 'QUATERNION':
                empty.rotation_quaternion = item.bind_rotation
            elif empty.rotation_mode == 'AXIS_ANGLE':
                empty.rotation_axis_angle = item.bind_rotation
            else:
                empty.rotation_euler = item.bind_rotation[:3]
            empty.scale = item.bind_scale
        context.view_layer.update()
        return {'FINISHED'}


classes = (HDEFORM_OT_bind, HDEFORM_OT_update, HDEFORM_OT_add_handle, HDEFORM_OT_apply, HDEFORM_OT_reset)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

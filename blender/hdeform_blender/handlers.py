"""Moves and frames: after every change Blender makes (a G/R/S on an Empty, the gizmo, a typed
value, an undo), the shape key follows the handles; on every frame of an animation too, refined
to its stop before the frame is drawn or rendered."""
import bpy
from bpy.app.handlers import persistent

from . import setup_jobs, solver


def bound_meshes(scene):
    return [obj for obj in scene.objects if obj.type == 'MESH' and obj.hdeform.bound]


def ensure_solver(obj, wait):
    """The object's Deformer, set up again after the file was opened (from its groups and settings:
    the rest frames are in the file). With `wait` now, else on a worker (None until then)."""
    if solver.bound(obj) is not None:
        return solver.bound(obj)
    if setup_jobs.running(obj) is not None:
        return None
    setup = solver.Setup(obj, obj.hdeform)
    if wait:
        solver.install(obj, solver.Bound(setup, solver.build(setup)))
        return solver.bound(obj)

    def finish(obj, setup, deformer, error):
        if error is not None:
            obj.hdeform["last_error"] = error
            return
        solver.install(obj, solver.Bound(setup, deformer))
        if solver.bound(obj) is not None:
            solver.update(obj, wait=False)
        else:  # the solver settings changed while it was set up: again with the new ones
            ensure_solver(obj, wait=False)

    setup_jobs.start(obj, setup, finish)
    return None


def follow(scene, wait, depsgraph=None):
    for obj in bound_meshes(scene):
        try:
            if ensure_solver(obj, wait) is not None:
                solver.update(obj, wait=wait, depsgraph=depsgraph)
        except solver.SetupError as error:
            obj.hdeform["last_error"] = str(error)


@persistent
def on_depsgraph_update(scene, _depsgraph):
    # Without a window no timer runs the refinement: it runs now.
    follow(scene, wait=bpy.app.background)


@persistent
def on_frame_change(scene, depsgraph):
    # Playback and rendering: each frame's shape, refined, before it is drawn. A render animates
    # the Empties in its own depsgraph: their evaluated copies say where they are.
    follow(scene, wait=True, depsgraph=depsgraph)


@persistent
def on_load(_path):
    solver.forget_all()
    setup_jobs.forget_all()


HANDLERS = (
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update),
    (bpy.app.handlers.frame_change_post, on_frame_change),
    (bpy.app.handlers.load_post, on_load),
)


def register():
    for handlers, function in HANDLERS:
        if function not in handlers:
            handlers.append(function)


def unregister():
    for handlers, function in HANDLERS:
        if function in handlers:
            handlers.remove(function)

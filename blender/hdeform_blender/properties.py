"""What the add-on keeps per object, in the .blend file: the settings and, for each handle, its
Empty and that Empty's frame at bind (the handle's rest frame). The vertex groups and the Empties
are Blender's own data; nothing else is needed to deform again after reopening the file."""
import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, PointerProperty, StringProperty
from bpy.types import PropertyGroup

from . import solver

IDENTITY = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0)


def is_empty(_self, obj):
    return obj.type == 'EMPTY'


def settings_changed(self, _context):
    """A setting that changes the result: the shape key follows it (nothing to do until bound)."""
    obj = self.id_data  # (the settings' own object: a script may change one that is not active)
    if obj is not None and obj.type == 'MESH' and obj.hdeform.bound and solver.bound(obj) is not None:
        try:
            solver.update(obj, wait=False, force=True)
        except solver.SetupError:
            pass  # the panel shows the problem at the next bind or move


def solver_changed(self, _context):
    """Another backend or another place to solve: the next move sets the solver up again with it."""
    obj = self.id_data
    if obj is not None and obj.type == 'MESH':
        solver.forget(obj)


class HdeformHandle(PropertyGroup):
    group: StringProperty(name="Vertex group", description="The handle's vertex group (hdeform_handle_N)")
    empty: PointerProperty(name="Empty", type=bpy.types.Object, poll=is_empty,
                           description="Moving, turning or scaling it moves the handle")
    # The Empty's world matrix at bind in the mesh object's space, row by row, and its own
    # location, rotation and scale then (Reset puts them back).
    bind_frame: FloatVectorProperty(size=16, default=IDENTITY)
    bind_location: FloatVectorProperty(size=3)
    bind_rotation: FloatVectorProperty(size=4)
    bind_rotation_mode: StringProperty(default="XYZ")
    bind_scale: FloatVectorProperty(size=3, default=(1.0, 1.0, 1.0))
    recorded: BoolProperty(default=False, description="Its rest frame is recorded")


class HdeformSettings(PropertyGroup):
    bound: BoolProperty(default=False, description="Bound: the handles' rest frames are recorded")
    refine: BoolProperty(name="Refine (as rigid as possible)", default=True, update=settings_changed,
                         description="As-rigid-as-possible iterations after the paper's update: a drag bends instead of shearing")
    refine_tolerance: FloatProperty(name="Tolerance", default=1e-6, min=1e-12, max=0.5, precision=8, update=settings_changed,
                                    description="The refinement stops when an iteration lowers the energy by less than this fraction")
    roi_group: StringProperty(name="Region of interest", default="",
                              description="A vertex group: only it deforms, the rest stays (empty: the whole mesh)")
    backend: EnumProperty(name="Backend", default='tree', update=solver_changed,
                          items=[('tree', "tree", "hdeform's supernodal Cholesky on the elimination tree (the fastest)"),
                                 ('eigen', "eigen", "Eigen's simplicial Cholesky"),
                                 ('cholmod', "cholmod", "SuiteSparse CHOLMOD")])
    # Where the solves run, as hdeform's `resolution` and `base_vertices` (the editor's Solve on and
    # Base size): a scan of millions of vertices is dragged through a base mesh.
    resolution: EnumProperty(name="Solve on", default='auto', update=solver_changed,
                             items=[('auto', "Automatic", "A base mesh from 500,000 vertices on, every vertex below"),
                                    ('multiresolution', "A base mesh", "The update and the refinement solve on a simplified mesh, and the "
                                     "fine detail follows it in local frames (fixed and handle vertices stay exact)"),
                                    ('exact', "Every vertex", "Every vertex an unknown, however large the mesh: for a scan the set-up "
                                     "then takes many times longer and needs many times the memory")])
    base_vertices: IntProperty(name="Base size", default=150000, min=4, update=solver_changed,
                               description="The base mesh's vertices, where it solves on one (it may keep a few more to keep the "
                                           "mesh's topology)")
    handles: CollectionProperty(type=HdeformHandle)


classes = (HdeformHandle, HdeformSettings)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Object.hdeform = PointerProperty(type=HdeformSettings)


def unregister():
    del bpy.types.Object.hdeform
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)

"""Between Blender's data and the hdeform module: the set-up read from a mesh object's vertex groups,
the Deformer kept per object (one factorization for every move and every frame), the handles'
transforms from their Empties, and the result written to the shape key "hdeform".

Every refinement starts from the paper's result for its pose (hdeform's rule), so the shape key of
a pose is the same whatever moves came before it: live, after an undo, on any frame of an
animation, after reopening the file.
"""
import threading
import time
import uuid

import bpy
import numpy as np

from . import handle_frames

FIXED_GROUP = "hdeform_fixed"
HANDLE_PREFIX = "hdeform_handle_"
ROI_GROUP = "hdeform_roi"
SHAPE_KEY = "hdeform"
# On the object, beside the shape key (so an undo restores both together): the pose the key holds,
# and whether it is refined to its stop (else the refinement goes on from the paper's result).
POSE_PROPERTY = "hdeform_pose"
FINAL_PROPERTY = "hdeform_final"


class SetupError(Exception):
    """A set-up that cannot be solved; the message says what to change, in Blender's terms."""


def module():
    try:
        import hdeform
    except ImportError as error:
        raise SetupError("the hdeform Python module cannot be imported (" + str(error) + "): put the folder that holds it "
                         "(.../site-packages of hdeform's install) in the add-on's preferences, or on PYTHONPATH") from error
    return hdeform


def handle_groups(obj):
    """The object's handle groups, hdeform_handle_1, hdeform_handle_2, ... in number order."""
    found = []
    for group in obj.vertex_groups:
        number = group.name[len(HANDLE_PREFIX):]
        if group.name.startswith(HANDLE_PREFIX) and number.isdigit():
            found.append((int(number), group))
    return [group for _, group in sorted(found, key=lambda pair: pair[0])]


def rest_positions(obj):
    """The rest shape: the Basis key when the mesh has shape keys, else its vertices (float64 of
    Blender's float32 coordinates)."""
    mesh = obj.data
    coordinates = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    if mesh.shape_keys is not None:
        mesh.shape_keys.reference_key.data.foreach_get("co", coordinates)
    else:
        mesh.vertices.foreach_get("co", coordinates)
    return coordinates.reshape(-1, 3).astype(np.float64)


def triangles(obj, positions):
    """The faces as triangles, by hdeform's rule for every mesh reader (quads along the shorter
    diagonal, larger n-gons as fans): the same triangles the OBJ of this mesh gives."""
    mesh = obj.data
    sizes = np.empty(len(mesh.polygons), dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", sizes)
    corners = np.empty(len(mesh.loops), dtype=np.int32)
    mesh.loops.foreach_get("vertex_index", corners)
    if np.all(sizes == 3):
        return corners.reshape(-1, 3)  # triangles already (a scan, say): nothing to split
    # Polygons' loops are stored one polygon after another, in polygon order.
    return module().triangulate(positions, sizes, corners)


def group_members(obj, groups):
    """For each vertex group given, its vertices with a weight above 0 (sorted indices)."""
    wanted = {group.index: [] for group in groups}
    for vertex in obj.data.vertices:
        for element in vertex.groups:
            members = wanted.get(element.group)
            if members is not None and element.weight > 0.0:
                members.append(vertex.index)
    return [np.array(wanted[group.index], dtype=np.int64) for group in groups]


def solver_choice(settings):
    """The settings a Deformer is built with (the others apply to the one there is)."""
    return settings.backend, settings.resolution, settings.base_vertices


class Setup:
    """What a Deformer is built from, read on Blender's main thread."""

    def __init__(self, obj, settings):
        if obj.type != 'MESH':
            raise SetupError(obj.name + " is not a mesh")
        fixed_group = obj.vertex_groups.get(FIXED_GROUP)
        if fixed_group is None:
            raise SetupError("no vertex group '" + FIXED_GROUP + "' on " + obj.name + ": assign the vertices that stay where they "
                             "are (the sinks) to it")
        self.handle_groups = handle_groups(obj)
        if not self.handle_groups:
            raise SetupError("no vertex group '" + HANDLE_PREFIX + "1' on " + obj.name + ": assign a handle's vertices to it, or "
                             "select them and use Add handle from selection")
        roi_group = obj.vertex_groups.get(settings.roi_group) if settings.roi_group else None
        if settings.roi_group and roi_group is None:
            raise SetupError("no vertex group '" + settings.roi_group + "' for the region of interest on " + obj.name)
        groups = [fixed_group] + self.handle_groups + ([roi_group] if roi_group is not None else [])
        members = group_members(obj, groups)
        self.fixed = members[0]
        self.handles = members[1:1 + len(self.handle_groups)]
        self.roi = members[-1] if roi_group is not None else None
        if len(self.fixed) == 0:
            raise SetupError("vertex group '" + FIXED_GROUP + "' is empty: assign the vertices that stay where they are to it")
        for group, vertices in zip(self.handle_groups, self.handles):
            if len(vertices) == 0:
                raise SetupError("vertex group '" + group.name + "' is empty: assign its handle's vertices to it, or remove it")
        self.handle_names = [group.name for group in self.handle_groups]
        self.positions = rest_positions(obj)
        self.triangles = triangles(obj, self.positions)
        self.backend = settings.backend
        self.resolution = settings.resolution
        self.base_vertices = settings.base_vertices
        self.solver_choice = solver_choice(settings)
        self.tolerance = settings.refine_tolerance
        self.refine = settings.refine


def build(setup, progress=None):
    """The Deformer (factorization, field); on any thread (the module releases the GIL). Refuses
    what the add-on will not deform: loose vertices and non-manifold geometry, with the solver's
    own findings."""
    hdeform = module()
    try:
        # With refinement on, its set-up comes with the rest (else with its first iteration).
        deformer = hdeform.Deformer(setup.positions, setup.triangles, setup.fixed, setup.handles, roi=setup.roi, backend=setup.backend,
                                    refine="auto" if setup.refine else 0, refine_tolerance=setup.tolerance, progress=progress,
                                    resolution=setup.resolution, base_vertices=setup.base_vertices)
    except (ValueError, RuntimeError) as error:
        raise SetupError(str(error)) from error
    found = deformer.inspection
    refused = [f"{count} {one if count == 1 else many}" for count, one, many in (
        (found["nonmanifold_edges"], "non-manifold edge (shared by more than two faces)", "non-manifold edges (shared by more than two faces)"),
        (found["nonmanifold_vertices"], "non-manifold vertex (where separate fans of faces meet)",
         "non-manifold vertices (where separate fans of faces meet)"),
        (found["unreferenced_vertices"], "loose vertex (in no face)", "loose vertices (in no face)")) if count]
    if refused:
        raise SetupError("; ".join(refused) + ". In Edit Mode, Select > Select All by Trait > Non Manifold (or Loose "
                         "Geometry) selects them; Mesh > Clean Up > Delete Loose removes loose vertices")
    return deformer


class Bound:
    """An object's Deformer and where its refinement stands. The refinement runs on a worker
    thread, an iteration at a time under `lock` (the Deformer serves one caller at a time); a move
    stops it after the iteration in flight."""

    def __init__(self, setup, deformer):
        self.setup = setup
        self.deformer = deformer
        self.lock = threading.Lock()
        self.pose = None  # the signature of the pose last solved
        self.refining = False
        self.worker = None
        self.stop = threading.Event()
        self.latest = None  # (positions, finished) from the worker, not yet written to the key
        self.update_ms = 0.0
        self.iterations = 0
        self.energy = 0.0
        self.unrefined_energy = 0.0
        # Where it solves and what the solver noted (parts left in place, a base that cannot hold a
        # set, ...), for the panel: read once, as the worker may be inside the Deformer.
        self.solved_vertices = deformer.solved_vertex_count
        self.vertices = deformer.vertex_count
        self.warnings = list(deformer.warnings)
        self.key_buffer = None  # the shape key's coordinates as foreach_set takes them, kept between writes

    def key_coordinates(self, positions):
        """The positions as the flat float32 array foreach_set takes, in the memory of the last write:
        memory new to the process is slow to fill on a virtual machine (a 3.3M-triangle scan's 20 MB
        took 24-66 ms)."""
        if self.key_buffer is None or self.key_buffer.size != positions.size:
            self.key_buffer = np.empty(positions.size, dtype=np.float32)
        self.key_buffer.reshape(positions.shape)[...] = positions
        return self.key_buffer

    def stop_refinement(self):
        if self.worker is not None:
            self.stop.set()
            self.worker.join()
            self.worker = None
        self.refining = False
        self.latest = None

    def start_refinement(self):
        self.stop = threading.Event()
        self.refining = True
        self.worker = threading.Thread(target=self._refine, args=(self.stop,), daemon=True)
        self.worker.start()

    def _refine(self, stop):
        while not stop.is_set():
            with self.lock:
                positions = self.deformer.refine(1)
                status = self.deformer.refinement
                finished = status["converged"] or status["iterations"] >= MAX_ITERATIONS
                self.iterations, self.energy, self.unrefined_energy = status["iterations"], status["energy"], status["unrefined_energy"]
                self.latest = (positions, finished)
            if finished:
                return

    def take_latest(self):
        with self.lock:
            latest, self.latest = self.latest, None
        return latest


_bound = {}  # key(object): Bound


def key(obj, create=False):
    """The object's key in the add-on's caches: an id it keeps in its settings (an undo or a reload
    keeps it too), with its name (a copy has the same id but another name). Made when a solver is
    installed (`create`): drawing a panel may not write to the object."""
    settings = obj.hdeform
    if create and "uid" not in settings:
        settings["uid"] = uuid.uuid4().hex
    return settings.get("uid", ""), obj.name


def bound(obj):
    """The object's solver, or None, also when its set-up no longer fits the object (a handle group
    added or removed, vertices added, another backend or place to solve chosen while it was being
    set up): then it is forgotten, to be set up again."""
    bound_object = _bound.get(key(obj))
    if bound_object is None:
        return None
    if ([group.name for group in handle_groups(obj)] != bound_object.setup.handle_names or len(obj.data.vertices) != len(bound_object.setup.positions)
            or bound_object.setup.solver_choice != solver_choice(obj.hdeform)):
        forget(obj)
        return None
    return bound_object


def install(obj, bound_object):
    _bound[key(obj, create=True)] = bound_object


def forget_all():
    """After a file is loaded: every Deformer is built anew when needed."""
    for bound_object in _bound.values():
        bound_object.stop_refinement()
    _bound.clear()


def forget(obj):
    bound_object = _bound.pop(key(obj), None)
    if bound_object is not None:
        bound_object.stop_refinement()


# ---- handles -----------------------------------------------------------------------------------

def matrix(values):
    return np.array(values, dtype=np.float64).reshape(4, 4)


def parent_in_mesh_space(obj, empty):
    """The frame the Empty's own location, rotation and scale act in, in the mesh object's space:
    its parent inverse when it hangs from the mesh itself (exact, from its own values, with no
    scene update needed), else from the world matrices."""
    if empty.parent == obj and empty.parent_type == 'OBJECT':
        return np.array(empty.matrix_parent_inverse, dtype=np.float64)
    world = np.array(empty.matrix_world, dtype=np.float64) @ np.linalg.inv(np.array(empty.matrix_basis, dtype=np.float64))
    return handle_frames.frame_in_mesh_space(np.array(obj.matrix_world, dtype=np.float64), world)


def empty_frame(obj, empty):
    """The Empty's frame in the mesh object's space."""
    return parent_in_mesh_space(obj, empty) @ np.array(empty.matrix_basis, dtype=np.float64)


def rotation_values(empty):
    """The Empty's rotation as its own mode stores it, four numbers (Euler: x, y, z, 0)."""
    if empty.rotation_mode == 'QUATERNION':
        return tuple(empty.rotation_quaternion)
    if empty.rotation_mode == 'AXIS_ANGLE':
        return tuple(empty.rotation_axis_angle)
    return tuple(empty.rotation_euler) + (0.0,)


def turn_since_bind(obj, item, empty):
    """(axis in mesh space, angle) when the Empty turned about one rotation axis alone since bind, by
    any angle; else None (the frames' matrix says it, within half a turn)."""
    if empty.rotation_mode != item.bind_rotation_mode or empty.rotation_mode == 'QUATERNION':
        return None
    now, then = rotation_values(empty), tuple(item.bind_rotation)
    if empty.rotation_mode == 'AXIS_ANGLE':
        if tuple(now[1:]) != tuple(then[1:]) or now[0] == then[0]:
            return None
        axis, angle = np.array(now[1:], dtype=np.float64), float(now[0]) - float(then[0])
    else:
        changed = [k for k in range(3) if now[k] != then[k]]
        if len(changed) != 1:
            return None
        angle = float(now[changed[0]]) - float(then[changed[0]])
        axis = handle_frames.euler_turn_axis(empty.rotation_mode, [float(value) for value in then[:3]], changed[0])
    in_mesh = parent_in_mesh_space(obj, empty)[:3, :3] @ axis
    length = np.linalg.norm(in_mesh)
    return (in_mesh / length, angle) if length > 0.0 else None


def handle_items(obj):
    """The settings' handle items in the order of the handle groups, refusing a group without its
    Empty (bind again)."""
    settings = obj.hdeform
    by_group = {item.group: item for item in settings.handles}
    items = []
    for group in handle_groups(obj):
        item = by_group.get(group.name)
        if item is None or item.empty is None:
            raise SetupError("handle group '" + group.name + "' has no Empty: bind again")
        items.append(item)
    return items


def transforms(obj, depsgraph=None):
    """One hdeform.Transform per handle, and the pose's signature (the numbers it came from, and the
    solver settings it is solved with: a key solved on a base is not the pose's key once the mesh
    is to be solved on every vertex). With a depsgraph, the Empties as it evaluated them (a render's
    frame animates its own copies, not the file's objects)."""
    hdeform = module()
    result, signature = [], []
    for item in handle_items(obj):
        empty = item.empty if depsgraph is None else item.empty.evaluated_get(depsgraph)
        frame = empty_frame(obj, empty)
        turn = turn_since_bind(obj, item, empty)
        result.append(handle_frames.handle_transform(hdeform, matrix(item.bind_frame), frame, turn))
        signature.append(repr((frame.round(12).tolist(), rotation_values(empty), empty.rotation_mode)))
    signature.append(repr(solver_choice(obj.hdeform)))
    return result, "|".join(signature)


# ---- the result --------------------------------------------------------------------------------

def ensure_shape_keys(obj):
    """Basis (the rest shape) and "hdeform" (the result, at full value)."""
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(SHAPE_KEY)
    if key is None:
        key = obj.shape_key_add(name=SHAPE_KEY, from_mix=False)
    key.value = 1.0
    return key


def write(obj, bound_object, positions, signature, final):
    key = obj.data.shape_keys.key_blocks[SHAPE_KEY]
    key.data.foreach_set("co", bound_object.key_coordinates(positions))
    obj[POSE_PROPERTY] = signature
    obj[FINAL_PROPERTY] = final
    # The key changed, not the mesh: Mesh.update() would also have the mesh copied for evaluation
    # again (a move of a 3.3M-triangle scan took 466 ms in Blender's update against 352 this way).
    obj.data.shape_keys.update_tag()


def read_key(obj):
    key = obj.data.shape_keys.key_blocks[SHAPE_KEY]
    coordinates = np.empty(len(key.data) * 3, dtype=np.float32)
    key.data.foreach_get("co", coordinates)
    return coordinates.reshape(-1, 3)


MAX_ITERATIONS = 1000  # the cap of a refinement "until converged", as hdeform's


def update(obj, wait, force=False, depsgraph=None):
    """Brings the shape key up to date with the Empties now (as `depsgraph` evaluated them, when
    given). The paper's update at once; with refinement, the iterations until its stop, now
    (`wait`) or on a worker whose results a timer writes to the key. Nothing to do when the key
    already holds this pose, refined (after an undo, say), unless `force`."""
    bound_object = bound(obj)
    settings = obj.hdeform
    started = time.perf_counter()
    poses, signature = transforms(obj, depsgraph)
    holds = obj.get(POSE_PROPERTY) == signature
    if not force and holds and (obj.get(FINAL_PROPERTY, False) or not settings.refine):
        bound_object.pose = signature
        return False
    if not force and not wait and bound_object.pose == signature and bound_object.refining:
        return False  # the refinement of this pose is under way
    bound_object.stop_refinement()
    deformer = bound_object.deformer
    try:
        if deformer.refine_tolerance != settings.refine_tolerance:
            deformer.refine_tolerance = settings.refine_tolerance
        if settings.refine and wait:
            positions = deformer.deform(poses, refine="auto")
            status = deformer.refinement
            bound_object.iterations, bound_object.energy, bound_object.unrefined_energy = status["iterations"], status["energy"], status["unrefined_energy"]
        else:
            positions = deformer.deform(poses, refine=0)
            bound_object.iterations = 0
    except (ValueError, RuntimeError) as error:  # the module's InputError and SolveError among them
        raise SetupError(str(error)) from error
    final = not settings.refine or wait
    write(obj, bound_object, positions, signature, final)
    bound_object.pose = signature
    bound_object.update_ms = (time.perf_counter() - started) * 1000.0
    if not final:
        bound_object.start_refinement()
        if not bpy.app.timers.is_registered(show_refinement):
            bpy.app.timers.register(show_refinement, first_interval=REFINEMENT_FRAME)
    return True


# A refining shape is written to its key at most this often (seconds): each write redraws the mesh.
REFINEMENT_FRAME = 0.1


def show_refinement():
    """On Blender's timer: writes what the workers refined since the last call to the keys; the
    seconds until the next call, or None once every object has settled."""
    pending = False
    for obj in bpy.data.objects:
        bound_object = bound(obj) if obj.type == 'MESH' and obj.hdeform.bound else None
        if bound_object is None or not bound_object.refining:
            continue
        latest = bound_object.take_latest()
        if latest is not None:
            positions, finished = latest
            write(obj, bound_object, positions, bound_object.pose, finished)
            if finished:
                bound_object.refining = False
                bound_object.worker = None
        pending = pending or bound_object.refining
    redraw_panels()
    return REFINEMENT_FRAME if pending else None


def redraw_panels():
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == 'VIEW_3D':
                area.tag_redraw()

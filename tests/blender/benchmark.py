"""The add-on's speed on the Buddha (run by hand; a benchmark, not a test), against the module in
the same Blender and against Blender's own Laplacian Deform modifier on the same mesh, anchors and
drag:

    PYTHONPATH=build/python:blender blender -b --factory-startup --python tests/blender/benchmark.py -- \\
        ../shared/meshes/buddha [out.json [pictures-folder]] [--subdivide N]

- --subdivide N: the Buddha subdivided N times with relief, as `hdeform bench --subdivide N --relief
  0.001` makes it (N = 2: 3.3M triangles, solved on a base mesh); Laplacian Deform is left out
  there (its bind alone takes minutes), and the bind is measured twice instead of five times;

- bind: Bind (reading the groups, the solver's set-up, the Empty, the shape keys) against the
  module's set-up alone (hdeform.Deformer);
- move: from an Empty's move to the shape key written (the paper's update, as a drag shows it
  first: the add-on's handler, from reading the Empty to the key written), against the module's
  deform() of the same pose alone, over a drag of 20 steps; and Blender's whole update for the
  move (its depsgraph, the handler, the mesh evaluated with the key);
- Laplacian Deform: its bind, and one evaluation after the hook's Empty moved (the same drag);
- with a pictures folder: both results for the translation-only drag as OBJ files.
"""
import json
import statistics
import sys
import time
from pathlib import Path

import addon_utils
import bpy
import numpy as np
from mathutils import Matrix

import hdeform

arguments = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
levels = 0
if "--subdivide" in arguments:
    at = arguments.index("--subdivide")
    levels = int(arguments[at + 1])
    del arguments[at:at + 2]
folder = Path(arguments[0]) if arguments else Path("../shared/meshes/buddha")
out = Path(arguments[1]) if len(arguments) > 1 else None
pictures = Path(arguments[2]) if len(arguments) > 2 else None
STEPS = 20


def median_ms(samples):
    return round(statistics.median(samples) * 1000.0, 2)


def new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("hdeform_blender", default_set=True)


def buddha_object(V, F, fixed, handle):
    mesh = bpy.data.meshes.new("buddha")
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", V.astype(np.float32).ravel())
    mesh.loops.add(F.size)
    mesh.loops.foreach_set("vertex_index", F.astype(np.int32).ravel())
    mesh.polygons.add(len(F))
    mesh.polygons.foreach_set("loop_start", np.arange(0, F.size, 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(F), 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    obj = bpy.data.objects.new("buddha", mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    obj.vertex_groups.new(name="hdeform_fixed").add(fixed.tolist(), 1.0, 'REPLACE')
    obj.vertex_groups.new(name="hdeform_handle_1").add(handle.tolist(), 1.0, 'REPLACE')
    return obj


V, F = hdeform.read_mesh(str(folder / "buddha-206k.obj"))
fixed = np.loadtxt(folder / "buddha-206k-fixed.txt", dtype=np.int64)
handle = np.loadtxt(folder / "buddha-206k-handle.txt", dtype=np.int64)
translate = np.loadtxt(folder / "buddha-206k-translate.txt")
shift = translate[:, 3]
if levels > 0:
    V, F, (fixed, handle) = hdeform.subdivide(V, F, levels, [fixed, handle])
    V = hdeform.add_relief(V, F, 0.001)
report = {"mesh": str(folder / "buddha-206k.obj"), "subdivided": levels, "vertices": len(V), "triangles": len(F), "steps": STEPS,
          "blender": bpy.app.version_string}

# The add-on, without refinement (the paper's update is what a move shows first). A first bind
# on a fresh scene, five times, each followed by the module's set-up of the same mesh alone.
BINDS = 5 if levels == 0 else 2
bind_samples, setup_samples = [], []
for _ in range(BINDS):
    new_scene()
    obj = buddha_object(V, F, fixed, handle)
    obj.hdeform.refine = False
    started = time.perf_counter()
    bpy.ops.hdeform.bind()
    bind_samples.append(time.perf_counter() - started)
    positions = np.empty(len(V) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", positions)
    positions = positions.reshape(-1, 3).astype(np.float64)
    started = time.perf_counter()
    module = hdeform.Deformer(positions, F, fixed, [handle])  # as the add-on sets it up without refinement
    setup_samples.append(time.perf_counter() - started)
report["binds"] = BINDS
report["bind_ms"] = median_ms(bind_samples)
report["module_setup_ms"] = median_ms(setup_samples)
report["bind_ratio"] = round(statistics.median(bind_samples) / statistics.median(setup_samples), 2)

from hdeform_blender import solver  # noqa: E402 - enabled above

empty = obj.hdeform.handles[0].empty
start = np.array(empty.location)
move_samples, update_samples, module_samples = [], [], []
for step in range(1, STEPS + 1):
    empty.location = tuple(start + shift * step / STEPS)
    began = time.perf_counter()
    bpy.context.view_layer.update()  # the depsgraph, its handler (transform, deform, the key written)
    obj.evaluated_get(bpy.context.evaluated_depsgraph_get())  # ... and the mesh with the new key
    update_samples.append(time.perf_counter() - began)
    move_samples.append(solver.bound(obj).update_ms / 1000.0)
    pose = np.eye(4)[:3]
    pose[:, 3] = shift * step / STEPS
    began = time.perf_counter()
    module.deform(pose)
    module_samples.append(time.perf_counter() - began)
key = obj.data.shape_keys.key_blocks["hdeform"]
result = np.empty(len(V) * 3, dtype=np.float32)
key.data.foreach_get("co", result)
assert np.abs(result.reshape(-1, 3) - positions).max() > 1.0, "the drag moved nothing"
report["move_ms"] = median_ms(move_samples)
report["blender_update_ms"] = median_ms(update_samples)
report["module_deform_ms"] = median_ms(module_samples)
report["move_ratio"] = round(statistics.median(move_samples) / statistics.median(module_samples), 2)

# The same drag refined to its stop (what settles after the move).
obj.hdeform.refine = True
began = time.perf_counter()
bpy.ops.hdeform.update(wait=True)
report["refined_update_ms"] = round((time.perf_counter() - began) * 1000.0, 1)
key.data.foreach_get("co", result)
hdeform_refined = result.reshape(-1, 3).copy()


def laplacian_deform():
    """Blender's Laplacian Deform: anchors = fixed and handle vertices; a Hook moves the handle's. Its
    result after the drag."""
    new_scene()
    obj = buddha_object(V, F, fixed, handle)
    anchors = obj.vertex_groups.new(name="anchors")
    anchors.add(np.concatenate([fixed, handle]).tolist(), 1.0, 'REPLACE')
    hook_empty = bpy.data.objects.new("hook", None)
    bpy.context.scene.collection.objects.link(hook_empty)
    hook_empty.location = tuple(positions[handle].mean(axis=0))
    hook = obj.modifiers.new("Hook", 'HOOK')
    hook.object = hook_empty
    hook.vertex_group = "hdeform_handle_1"
    bpy.context.view_layer.update()
    hook.matrix_inverse = Matrix(np.linalg.inv(np.array(hook_empty.matrix_world)).tolist())
    laplacian = obj.modifiers.new("LaplacianDeform", 'LAPLACIANDEFORM')
    laplacian.vertex_group = "anchors"
    laplacian.iterations = 1
    started = time.perf_counter()
    with bpy.context.temp_override(object=obj, active_object=obj):
        bpy.ops.object.laplaciandeform_bind(modifier="LaplacianDeform")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    obj.evaluated_get(depsgraph)  # the bind happens at the next evaluation
    bpy.context.view_layer.update()
    report["laplacian_bind_ms"] = round((time.perf_counter() - started) * 1000.0, 1)
    hook_start = np.array(hook_empty.location)
    laplacian_samples = []
    for step in range(1, STEPS + 1):
        hook_empty.location = tuple(hook_start + shift * step / STEPS)
        began = time.perf_counter()
        bpy.context.view_layer.update()
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        evaluated.data.vertices[0].co  # noqa: B018 - the evaluated mesh, computed
        laplacian_samples.append(time.perf_counter() - began)
    report["laplacian_update_ms"] = median_ms(laplacian_samples)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).to_mesh()
    laplacian_result = np.empty(len(V) * 3, dtype=np.float32)
    evaluated.vertices.foreach_get("co", laplacian_result)
    laplacian_result = laplacian_result.reshape(-1, 3)
    report["laplacian_moved"] = float(np.abs(laplacian_result - positions).max())
    return laplacian_result


def edge_strain(result):
    edges = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    rest = np.linalg.norm(positions[edges[:, 0]] - positions[edges[:, 1]], axis=1)
    now = np.linalg.norm(result[edges[:, 0]].astype(np.float64) - result[edges[:, 1]].astype(np.float64), axis=1)
    return float(np.mean(np.abs(now / rest - 1.0)))


results = {"hdeform_refined": hdeform_refined}
if levels == 0:
    results["laplacian_deform"] = laplacian_deform()
report["mean_edge_strain"] = {name: edge_strain(result) for name, result in results.items()}

if pictures is not None:
    # The results as OBJ, for `hdeform render` (the README's pictures come from it).
    pictures.mkdir(parents=True, exist_ok=True)
    names = {"hdeform_refined": "hdeform", "laplacian_deform": "laplacian-deform"}
    for name, result in results.items():
        hdeform.write_mesh(str(pictures / f"blender-{names[name]}.obj"), result.astype(np.float64), F)

text = json.dumps(report, indent=2)
print(text)
if out is not None:
    out.write_text(text + "\n")

"""What the Blender tests share. They run inside Blender (blender -b --factory-startup
--python-exit-code 1 --python tests/blender/test_....py), with hdeform and the add-on importable
(ctest sets PYTHONPATH), and fail by raising: Blender then exits with 1."""
import atexit
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import addon_utils
import bpy
import numpy as np

import hdeform

EXECUTABLE = os.environ.get("HDEFORM_EXECUTABLE", "hdeform")
SHARED = Path(os.environ.get("HDEFORM_SHARED_MESHES", Path(__file__).resolve().parents[3] / "shared" / "meshes"))


def scratch_folder(prefix):
    """A new folder under the system's temporary one, removed when Blender exits (pass or fail):
    the tests write meshes of up to 10 MB there."""
    folder = Path(tempfile.mkdtemp(prefix=prefix))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def enable_addon():
    module = addon_utils.enable("hdeform_blender", default_set=True, handle_error=lambda error: (_ for _ in ()).throw(error))
    assert module is not None, "the add-on hdeform_blender did not enable"
    return module


def empty_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    enable_addon()


def mesh_object(name, positions, faces):
    """A mesh object from vertices and faces (lists of corner indices, any size), active and selected."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(np.asarray(positions).tolist(), [], [list(map(int, face)) for face in faces])
    mesh.update()
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


def bound_shape(name, resolution, refine=True, faces=None):
    """A fresh scene with hdeform's built-in shape `name` as a mesh object (`faces` instead of its
    triangles when given), its demo's sink and handle as the add-on's groups, bound."""
    empty_scene()
    shape = hdeform.shape(name, resolution)
    obj = mesh_object(name, shape["V"], shape["F"] if faces is None else faces)
    assign(obj, "hdeform_fixed", shape["fixed"])
    assign(obj, "hdeform_handle_1", shape["handles"][0])
    obj.hdeform.refine = refine
    assert bpy.ops.hdeform.bind() == {'FINISHED'}
    return obj, shape


def assign(obj, group_name, vertices):
    group = obj.vertex_groups.get(group_name) or obj.vertex_groups.new(name=group_name)
    group.add(list(map(int, vertices)), 1.0, 'REPLACE')
    return group


def shape_key(obj, name="hdeform"):
    key = obj.data.shape_keys.key_blocks[name]
    coordinates = np.empty(len(key.data) * 3, dtype=np.float32)
    key.data.foreach_get("co", coordinates)
    return coordinates.reshape(-1, 3)


def vertices(obj):
    coordinates = np.empty(len(obj.data.vertices) * 3, dtype=np.float32)
    obj.data.vertices.foreach_get("co", coordinates)
    return coordinates.reshape(-1, 3)


def rest_and_triangles(obj):
    """The mesh as the add-on hands it to the solver: Blender's float32 coordinates as float64, its
    faces triangulated by hdeform's rule."""
    positions = vertices(obj).astype(np.float64)
    sizes = np.array([len(polygon.vertices) for polygon in obj.data.polygons])
    corners = np.array([v for polygon in obj.data.polygons for v in polygon.vertices])
    return positions, hdeform.triangulate(positions, sizes, corners)


def handle_transform(obj, item):
    """Written out here, not taken from the add-on: the Empty's frame now (it hangs from the mesh:
    its parent inverse times its own location, rotation and scale) after its frame at bind, as a
    3x4 matrix."""
    assert item.empty.parent == obj, "the tests' Empties hang from their mesh"
    now = np.array(item.empty.matrix_parent_inverse, dtype=np.float64) @ np.array(item.empty.matrix_basis, dtype=np.float64)
    bind = np.array(item.bind_frame, dtype=np.float64).reshape(4, 4)
    return (now @ np.linalg.inv(bind))[:3, :4]


def cli_edit(obj, fixed, handles, matrices, refine, options=()):
    """`hdeform edit` on the mesh as Blender holds it (written as OBJ: %.17g of its float32 values),
    with more of its `options` when given."""
    folder = scratch_folder("hdeform-blender-")
    positions, triangles = rest_and_triangles(obj)
    hdeform.write_mesh(str(folder / "mesh.obj"), positions, triangles)
    arguments = [EXECUTABLE, "edit", "--mesh", str(folder / "mesh.obj"), "--fixed", str(folder / "fixed.txt"), "--out", str(folder / "out.obj"),
                 "--quiet", "--refine", "auto" if refine else "0", *options]
    np.savetxt(folder / "fixed.txt", fixed, fmt="%d")
    for k, (handle, matrix) in enumerate(zip(handles, matrices)):
        np.savetxt(folder / f"handle{k}.txt", handle, fmt="%d")
        np.savetxt(folder / f"transform{k}.txt", matrix, fmt="%.17g")
        arguments += ["--handle", str(folder / f"handle{k}.txt"), "--transform", str(folder / f"transform{k}.txt")]
    result = subprocess.run(arguments, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return hdeform.read_mesh(str(folder / "out.obj"))[0]


def expect_same_as_float32(actual, expected, what):
    """Blender stores coordinates in float32: the key must be the double result rounded, exactly."""
    difference = float(np.abs(actual.astype(np.float64) - np.asarray(expected, dtype=np.float32).astype(np.float64)).max())
    assert difference == 0.0, f"{what}: differs from the solver's result rounded to float32 by {difference}"


def expect_error(operator, expected_words, **arguments):
    """The operator refuses with an error report (Blender raises it as RuntimeError in background)."""
    try:
        result = operator(**arguments)
    except RuntimeError as error:
        message = str(error)
        for word in expected_words:
            assert word in message, f"the error does not say '{word}': {message}"
        return message
    raise AssertionError(f"no error report; the operator returned {result}")


def passed(name):
    print(f"PASSED {name}")
    sys.stdout.flush()

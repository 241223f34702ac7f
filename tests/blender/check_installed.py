"""Run by install_and_enable.cmake inside Blender: the add-on and the module both come from the
installed prefix, the add-on enables, binds the cactus and moves it."""
import os

import addon_utils
import bpy
import numpy as np

prefix = os.environ["HDEFORM_INSTALLED"]
module = addon_utils.enable("hdeform_blender", default_set=True)
assert module is not None and module.__file__.startswith(prefix), f"the add-on came from {getattr(module, '__file__', None)}, not {prefix}"
import hdeform  # noqa: E402 - after the add-on, from the same folder

assert hdeform.__file__.startswith(prefix), hdeform.__file__
cactus = hdeform.shape("cactus", 16)
mesh = bpy.data.meshes.new("cactus")
mesh.from_pydata(cactus["V"].tolist(), [], cactus["F"].tolist())
obj = bpy.data.objects.new("cactus", mesh)
bpy.context.scene.collection.objects.link(obj)
bpy.context.view_layer.objects.active = obj
obj.vertex_groups.new(name="hdeform_fixed").add(cactus["fixed"].tolist(), 1.0, 'REPLACE')
obj.vertex_groups.new(name="hdeform_handle_1").add(cactus["handles"][0].tolist(), 1.0, 'REPLACE')
assert bpy.ops.hdeform.bind() == {'FINISHED'}
obj.hdeform.handles[0].empty.location.x += 0.2
bpy.context.view_layer.update()
bpy.ops.hdeform.update(wait=True)
key = obj.data.shape_keys.key_blocks["hdeform"]
moved = np.empty(len(key.data) * 3, dtype=np.float32)
key.data.foreach_get("co", moved)
assert np.abs(moved.reshape(-1, 3) - cactus["V"]).max() > 0.05, "the installed add-on moved nothing"
print("PASSED the installed add-on, from " + prefix)

"""Reset puts the handles back (the key is the rest shape again); Apply makes the result the rest
shape (Basis and mesh), with the handles where they are; and `blender -b file.blend -a` renders
each frame's shape: a keyframed handle moves the cactus in the rendered pictures."""
import os
import subprocess
import sys

import numpy as np

import bpy
import hdeform

import support

obj, cactus = support.bound_shape("cactus", 16)
rest = support.vertices(obj).copy()
empty = obj.hdeform.handles[0].empty
empty.location.x += 0.2
empty.rotation_euler.z = 0.3
bpy.context.view_layer.update()
bpy.ops.hdeform.update(wait=True)
moved = support.shape_key(obj).copy()
assert np.abs(moved - rest).max() > 0.05

# With the Empty active, the operators act on the mesh it hangs from.
bpy.context.view_layer.objects.active = empty
assert bpy.ops.hdeform.reset() == {'FINISHED'}
bpy.ops.hdeform.update(wait=True)
assert tuple(empty.location) == tuple(obj.hdeform.handles[0].bind_location) and tuple(empty.rotation_euler) == (0.0, 0.0, 0.0)
assert np.abs(support.shape_key(obj) - rest).max() <= 1e-6, "after Reset the key is not the rest shape"
support.passed("Reset puts the handles back and the mesh at rest")

empty.location.x += 0.2
empty.rotation_euler.z = 0.3
bpy.context.view_layer.update()
bpy.ops.hdeform.update(wait=True)
assert np.array_equal(support.shape_key(obj), moved), "the same pose again gives another key"
bpy.context.view_layer.objects.active = obj
assert bpy.ops.hdeform.apply() == {'FINISHED'}
assert np.array_equal(support.vertices(obj), moved), "the mesh is not the result after Apply"
basis = np.empty(len(rest) * 3, dtype=np.float32)
obj.data.shape_keys.reference_key.data.foreach_get("co", basis)
assert np.array_equal(basis.reshape(-1, 3), moved), "the Basis is not the result after Apply"
bpy.ops.hdeform.update(wait=True)
assert np.abs(support.shape_key(obj) - moved).max() <= 1e-6, "after Apply the handles where they are should change nothing"
support.passed("Apply makes the result the rest shape, the handles staying where they are")

# Add handle from selection (Edit Mode): the group, its Empty at the selection's centroid, and the
# next move deforms with both handles.
bpy.ops.object.mode_set(mode='OBJECT')
chosen = [v.index for v in obj.data.vertices if v.co.z > 0.9 * max(u.co.z for u in obj.data.vertices)]  # the top
for vertex in obj.data.vertices:
    vertex.select = vertex.index in chosen
for element in list(obj.data.edges) + list(obj.data.polygons):
    element.select = False  # else Edit Mode selects the vertices of selected faces too
bpy.ops.object.mode_set(mode='EDIT')
assert bpy.ops.hdeform.add_handle() == {'FINISHED'}
bpy.ops.object.mode_set(mode='OBJECT')
group = obj.vertex_groups.get("hdeform_handle_2")
assert group is not None, "no group hdeform_handle_2"
members = sorted(v.index for v in obj.data.vertices if any(g.group == group.index for g in v.groups))
assert members == sorted(chosen), f"the group holds {len(members)} vertices, {len(chosen)} were selected"

second = next(item for item in obj.hdeform.handles if item.group == "hdeform_handle_2")
centroid = support.vertices(obj)[chosen].mean(axis=0)
assert np.allclose(np.array(second.empty.location), centroid, atol=1e-5), "the new Empty is not at the selection's centroid"
before = support.shape_key(obj).copy()
second.empty.location.z += 0.1
bpy.context.view_layer.update()
bpy.context.view_layer.objects.active = obj
assert bpy.ops.hdeform.update(wait=True) == {'FINISHED'}
after = support.shape_key(obj)
assert np.abs(after[chosen] - before[chosen] - np.array([0.0, 0.0, 0.1], dtype=np.float32)).max() < 1e-5, "the second handle did not move its vertices"
support.passed("Add handle from selection makes a handle that deforms")

# Rendering an animation from the command line: the add-on enabled, each frame's shape rendered.
obj, _ = support.bound_shape("cactus", 16, refine=False)
empty = obj.hdeform.handles[0].empty
start = tuple(empty.location)
empty.keyframe_insert("location", frame=1)
empty.location = (start[0], start[1] - 0.5, start[2] + 0.3)
empty.keyframe_insert("location", frame=2)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 2
camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(camera)
camera.location = (4.0, 0.0, 0.6)
camera.rotation_euler = (1.5708, 0.0, 1.5708)
scene.camera = camera
light = bpy.data.objects.new("light", bpy.data.lights.new("light", 'SUN'))
scene.collection.objects.link(light)
scene.render.engine = 'CYCLES'
scene.cycles.samples = 1
scene.cycles.use_denoising = False
scene.render.resolution_x = scene.render.resolution_y = 48
folder = support.scratch_folder("hdeform-render-")
scene.render.filepath = str(folder / "frame-")
scene.render.image_settings.file_format = 'PNG'
scene.frame_set(1)
bpy.ops.wm.save_as_mainfile(filepath=str(folder / "animation.blend"))
result = subprocess.run([bpy.app.binary_path, "-b", "--factory-startup", str(folder / "animation.blend"), "--python-expr",
                         "import addon_utils; addon_utils.enable('hdeform_blender', default_set=True)", "-a"],
                        capture_output=True, text=True, env=os.environ)
assert result.returncode == 0, result.stdout + result.stderr
frames = sorted(folder.glob("frame-*.png"))
assert len(frames) == 2, f"rendered {frames}: {result.stdout[-2000:]}"
images = [bpy.data.images.load(str(path)) for path in frames]
pixels = [np.array(image.pixels[:]) for image in images]
difference = float(np.abs(pixels[0] - pixels[1]).max())
assert difference > 0.2, f"frames 1 and 2 look alike ({difference}): the render did not see the moved handle"
support.passed("blender -b file.blend -a renders each frame's shape")

"""A keyframed 720-degree turn of the bar's handle Empty, frame by frame: two turns along the bar,
growing level by level. Then the file saved and opened again: moving the handle deforms as
before, without painting or binding again."""
import math

import numpy as np

import bpy
import hdeform

import support

obj, bar = support.bound_shape("bar", 24)
empty = obj.hdeform.handles[0].empty
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 9
for frame, angle in ((1, 0.0), (9, 4.0 * math.pi)):
    empty.rotation_euler.z = angle
    empty.keyframe_insert("rotation_euler", index=2, frame=frame)
for curve in empty.animation_data.action.fcurves:
    for point in curve.keyframe_points:
        point.interpolation = 'LINEAR'

rest = support.vertices(obj).astype(np.float64)
levels = np.unique(np.round(rest[:, 2], 9))


def turns_along_the_bar(positions):
    """The mean turn of each level about z, unwrapped from the bottom level up (radians)."""
    angles, previous = [], None
    for z in levels:
        at = (np.abs(rest[:, 2] - z) < 1e-9) & (np.hypot(rest[:, 0], rest[:, 1]) > 1e-6)  # not on the axis
        turn = np.exp(1j * (np.arctan2(positions[at, 1], positions[at, 0]) - np.arctan2(rest[at, 1], rest[at, 0])))
        raw = float(np.angle(turn.sum()))
        if previous is None:
            angles.append(raw)
        else:
            step = raw - previous
            angles.append(angles[-1] + step - 2.0 * math.pi * round(step / (2.0 * math.pi)))
        previous = raw
    return np.array(angles)


totals = []
for frame in range(1, 10):
    scene.frame_set(frame)
    turns = turns_along_the_bar(support.shape_key(obj).astype(np.float64))
    assert np.all(np.diff(turns) >= -1e-6), f"frame {frame}: the turn does not grow along the bar: {np.degrees(turns)}"
    totals.append(math.degrees(turns[-1] - turns[0]))
print("total turn per frame (degrees):", [round(t, 2) for t in totals])
assert abs(totals[-1] - 720.0) <= 5.0, f"the last frame turns {totals[-1]} degrees, not 720"
assert all(b >= a - 1e-6 for a, b in zip(totals, totals[1:])), "the turn does not grow frame by frame"
support.passed("a keyframed 720-degree turn gives two turns along the bar")

# Save, open again, move: the same key as moving without the reload.
scene.frame_set(5)
empty.animation_data_clear()
empty.rotation_euler.z = 0.0
empty.location.x += 0.2
bpy.context.view_layer.update()
bpy.ops.hdeform.update(wait=True)
expected = support.shape_key(obj).copy()
empty.location.x -= 0.2
bpy.context.view_layer.update()
bpy.ops.hdeform.update(wait=True)
path = support.scratch_folder("hdeform-blend-") / "bar.blend"
bpy.ops.wm.save_as_mainfile(filepath=str(path))
bpy.ops.wm.open_mainfile(filepath=str(path))
support.enable_addon()
obj = bpy.data.objects["bar"]
assert obj.hdeform.bound and len(obj.hdeform.handles) == 1, "the settings did not come back with the file"
empty = obj.hdeform.handles[0].empty
empty.location.x += 0.2
bpy.context.view_layer.update()
bpy.context.view_layer.objects.active = obj
bpy.ops.hdeform.update(wait=True)
assert np.array_equal(support.shape_key(obj), expected), "after reopening, the same move gives another key"
support.passed("after save and reload, a move deforms as before")

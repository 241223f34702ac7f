"""Each set-up the add-on cannot solve is refused with an error report that says why, and leaves
the mesh as it was: no fixed group, an empty handle group, a handle with no fixed vertex in its
part of the mesh, non-manifold edges, a loose vertex. One it can solve with a note binds, and the
note reaches the panel."""
import numpy as np

import bpy

import support


def grid(n=6):
    positions = [(x / n, y / n, 0.0) for y in range(n + 1) for x in range(n + 1)]
    faces = [(y * (n + 1) + x, y * (n + 1) + x + 1, (y + 1) * (n + 1) + x + 1, (y + 1) * (n + 1) + x) for y in range(n) for x in range(n)]
    return positions, faces


def refused(name, positions, faces, groups, words):
    support.empty_scene()
    obj = support.mesh_object(name, positions, faces)
    for group, members in groups.items():
        group_object = obj.vertex_groups.new(name=group)
        if len(members):
            group_object.add(list(members), 1.0, 'REPLACE')
    before = support.vertices(obj).copy()
    objects = len(bpy.data.objects)
    message = support.expect_error(bpy.ops.hdeform.bind, words)
    assert obj.data.shape_keys is None, f"{name}: shape keys were added"
    assert len(bpy.data.objects) == objects, f"{name}: objects were added"
    assert not obj.hdeform.bound, f"{name}: marked bound"
    assert np.array_equal(support.vertices(obj), before), f"{name}: the mesh changed"
    print(f"{name}: {message}")


positions, faces = grid()
top = [len(positions) - 1 - k for k in range(7)]
bottom = list(range(7))
refused("no fixed group", positions, faces, {"hdeform_handle_1": top}, ["hdeform_fixed"])
refused("an empty handle group", positions, faces, {"hdeform_fixed": bottom, "hdeform_handle_1": top, "hdeform_handle_2": []},
        ["hdeform_handle_2", "empty"])
# Two grids side by side, not joined: the second one's handle has no fixed vertex in its part.
second = [(x + 2.0, y, z) for x, y, z in positions]
offset = len(positions)
refused("a handle without a sink", positions + second, faces + [tuple(v + offset for v in f) for f in faces],
        {"hdeform_fixed": bottom, "hdeform_handle_1": top, "hdeform_handle_2": [v + offset for v in top]}, ["handle 2", "fixed vertex"])
# A fin: a third face on an inner edge of the grid (between vertices 8 and 9).
fin_positions = positions + [(1.5 / 6, 1.0 / 6, 0.3)]
refused("non-manifold", fin_positions, faces + [(8, 9, len(positions))], {"hdeform_fixed": bottom, "hdeform_handle_1": top},
        ["1 non-manifold edge (shared"])
refused("a loose vertex", positions + [(3.0, 3.0, 3.0)], faces, {"hdeform_fixed": bottom, "hdeform_handle_1": top},
        ["1 loose vertex (in no face)", "Loose"])
support.passed("every bad set-up is refused with its reason, nothing changed")

# Two grids side by side, the second in no group: bound, and the panel says it stays in place.
support.empty_scene()
obj = support.mesh_object("a part left alone", positions + second, faces + [tuple(v + offset for v in f) for f in faces])
support.assign(obj, "hdeform_fixed", bottom)
support.assign(obj, "hdeform_handle_1", top)
assert bpy.ops.hdeform.bind() == {'FINISHED'}
from hdeform_blender import solver  # noqa: E402 - the add-on is enabled by now
note = f"1 part of the mesh ({len(second)} vertices) has no fixed or handle vertex and stays in place"
assert note in solver.bound(obj).warnings, f"the panel's notes: {solver.bound(obj).warnings}"
obj.hdeform.handles[0].empty.location.z += 0.3
assert bpy.ops.hdeform.update(wait=True) == {'FINISHED'}
moved = support.shape_key(obj)
assert np.abs(moved[top, 2] - 0.3).max() < 1e-6, "the handle did not follow its Empty"
assert np.array_equal(moved[offset:], np.asarray(second, dtype=np.float32)), "the part in no group moved"
support.passed("a part in no group is noted and stays")

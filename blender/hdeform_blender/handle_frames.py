"""A handle's transform from its Empty, with no Blender in it (plain 4x4 float64 arrays).

The transform is the Empty's frame now after its frame at bind, both in the mesh object's space:
T = F_now @ inv(F_bind), as `hdeform edit --transform` takes it. A matrix can only say "less than
half a turn"; the Empty's rotation values say more: when the Empty has turned by more than half a
turn about one of its rotation axes alone since bind (a keyframed 720 degrees is two turns), the
handle gets that turn as a twist about the axis through the Empty's origin at bind
(hdeform.Transform.twist), as the paper's Figure 3 does.
"""
import math

import numpy as np

# A relative frame counts as a turn about the given axis when it is one to this much (its matrix
# entries, against the turn's; float32 frames carry about 1e-7).
TURN_TOLERANCE = 1e-5


def frame_in_mesh_space(mesh_world, empty_world):
    """The Empty's world matrix in the mesh object's space (both 4x4)."""
    return np.linalg.solve(np.asarray(mesh_world, dtype=np.float64), np.asarray(empty_world, dtype=np.float64))


def rotation_about(axis, angle):
    """The 3x3 rotation by `angle` radians about the unit `axis` (Rodrigues)."""
    x, y, z = axis
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array([[t * x * x + c, t * x * y - s * z, t * x * z + s * y],
                     [t * x * y + s * z, t * y * y + c, t * y * z - s * x],
                     [t * x * z - s * y, t * y * z + s * x, t * z * z + c]])


def euler_turn_axis(order, bind_euler, changed):
    """The axis, in the Empty's parent space, about which a change of Euler component `changed`
    (0, 1, 2 for x, y, z) turns it: the rotations applied after that component's (an order 'XYZ'
    applies x first), at their bind values, carry the component's own axis."""
    names = "XYZ"
    axis = np.eye(3)[changed]
    position = order.index(names[changed])
    for later in order[position + 1:]:
        component = names.index(later)
        axis = rotation_about(np.eye(3)[component], bind_euler[component]) @ axis
    return axis


def handle_transform(hdeform, bind_frame, frame, turn=None):
    """The hdeform.Transform taking the Empty's `bind_frame` to its `frame` (4x4, mesh space).

    `turn`: (unit axis in mesh space, angle in radians, any size) when the Empty's rotation values
    say it turned about that axis alone since bind; used beyond half a turn when the relative
    frame is that turn with a uniform scale, else the matrix decides."""
    bind_frame = np.asarray(bind_frame, dtype=np.float64)
    frame = np.asarray(frame, dtype=np.float64)
    relative = frame @ np.linalg.inv(bind_frame)
    if turn is not None and abs(turn[1]) > math.pi:
        axis, angle = turn
        axis = np.asarray(axis, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        linear = relative[:3, :3]
        determinant = np.linalg.det(linear)
        if determinant > 0.0:
            scale = determinant ** (1.0 / 3.0)
            if np.abs(linear - scale * rotation_about(axis, angle)).max() <= TURN_TOLERANCE * max(scale, 1.0):
                pivot = bind_frame[:3, 3]
                return hdeform.Transform.twist(axis=tuple(axis), point=tuple(pivot), degrees=math.degrees(angle), scale=scale,
                                               shift=tuple(frame[:3, 3] - pivot))
    return hdeform.Transform(relative[:3, :4])

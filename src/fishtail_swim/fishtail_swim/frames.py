"""The simulated fish's tf frames in plain numbers: odom -> base_link -> tail_mechanism.

``odom`` -> ``base_link`` (REP 105; the simulator's parameters name them) moves with the fish (C
at (X, Y, 0), turned by the yaw about z), while ``base_link`` -> ``tail_mechanism`` is fixed (O at
x = -l_O on the body axis, turned by pi about y). Plain Python, so that the transforms are tested
without ROS; the node turns them into messages. Conventions (tf2's, quaternions (x, y, z, w)):
docs/swimming-dynamics.md ("Frames and signs", "tf").

>>> tail_in_body(0.05).apply((0.1, 0.02, 0.0))
(-0.15000000000000002, 0.02, 0.0)
>>> yaw_quaternion(0.0)
(0.0, 0.0, 0.0, 1.0)
"""

from __future__ import annotations

import dataclasses
import math

from fishtail_common.interface import BODY_FRAME, ODOM_FRAME, TAIL_FRAME

Vector = tuple[float, float, float]
#: A unit quaternion (x, y, z, w).
Quaternion = tuple[float, float, float, float]

#: The tail frame's orientation in the body: a half turn about the body's y axis.
TAIL_IN_BODY_ROTATION: Quaternion = (0.0, 1.0, 0.0, 0.0)


@dataclasses.dataclass(frozen=True)
class FrameTransform:
    """The pose of frame ``child`` in frame ``parent``: rotate by ``rotation``, then translate."""

    parent: str
    child: str
    translation: Vector
    rotation: Quaternion

    def apply(self, point: Vector) -> Vector:
        """``point``, given in the child frame, in the parent frame."""
        qx, qy, qz, qw = self.rotation
        px, py, pz = point
        # v' = v + 2w (u x v) + 2 u x (u x v), u the quaternion's vector part: no matrix needed.
        cx, cy, cz = qy * pz - qz * py, qz * px - qx * pz, qx * py - qy * px
        dx, dy, dz = qy * cz - qz * cy, qz * cx - qx * cz, qx * cy - qy * cx
        tx, ty, tz = self.translation
        return (
            px + 2.0 * (qw * cx + dx) + tx,
            py + 2.0 * (qw * cy + dy) + ty,
            pz + 2.0 * (qw * cz + dz) + tz,
        )


def yaw_quaternion(psi: float) -> Quaternion:
    """The rotation by ``psi`` (rad, counter-clockwise) about z: (0, 0, sin ψ/2, cos ψ/2)."""
    half = 0.5 * psi
    return (0.0, 0.0, math.sin(half), math.cos(half))


def body_in_odom(
    x: float, y: float, psi: float, odom_frame: str = ODOM_FRAME, body_frame: str = BODY_FRAME
) -> FrameTransform:
    """``odom`` -> ``base_link`` of a fish with its centre of mass at (x, y) and yaw ``psi``."""
    return FrameTransform(odom_frame, body_frame, (x, y, 0.0), yaw_quaternion(psi))


def tail_in_body(tail_origin_offset_m: float, body_frame: str = BODY_FRAME) -> FrameTransform:
    """``base_link`` -> ``tail_mechanism``: O at x = -``tail_origin_offset_m``, π about y."""
    return FrameTransform(
        body_frame, TAIL_FRAME, (-tail_origin_offset_m, 0.0, 0.0), TAIL_IN_BODY_ROTATION
    )

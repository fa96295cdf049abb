"""Where every joint of a solved linkage is, in the frame at O (x back towards the tail, y left).

Pure numpy, for drawing (RViz markers, the animations): every point is an array of shape
``state_shape + (2,)`` of (x, y) in metres. The points also say which of them make the links and
the moving joints (``Tail.link_points``), so that drawing code does not depend on the mechanism.
Where the planet and the joints are: docs/kinematics.md ("The Cardan couple", and each
mechanism's section).

>>> import math
>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> points = tail.link_points(tail.solve(0.0))
>>> points.cardan.tolist(), points.planet_centre.round(4).tolist()
([0.0, 0.1], [-0.0, 0.05])
>>> points = tail.link_points(tail.solve(math.pi / 2))
>>> points.cardan.round(4).tolist(), points.planet_opposite.round(4).tolist()
([0.0, 0.0], [-0.1, 0.0])
>>> points.moving_joints().shape
(2, 2)
"""

from __future__ import annotations

from typing import NamedTuple, TypeAlias

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.geometry import (
    FloatArray,
    OscillatoryGeometry,
    OscillatoryState,
    Real,
    UndulatoryGeometry,
    UndulatoryState,
)


def _chain(*points: FloatArray) -> FloatArray:
    """Points in order along a polyline: shape ``(..., len(points), 2)``."""
    return np.stack(points, axis=-2)


class OscillatoryPoints(NamedTuple):
    """Joints of mechanism 1; each an array ``(..., 2)`` of (x, y) in metres."""

    origin: FloatArray  # O, ring-gear centre (fixed)
    planet_centre: FloatArray  # C, end of the carrier crank
    cardan: FloatArray  # P, on the y axis
    planet_opposite: FloatArray  # D = 2C - P, on the x axis
    joint_r: FloatArray  # R, joint of PR and RS
    pivot_s: FloatArray  # S, body pivot (fixed)
    tip: FloatArray  # T

    def drive_links(self) -> list[FloatArray]:
        """The links up to the tail link, as polylines ``(..., k, 2)``: P-R-S."""
        return [_chain(self.cardan, self.joint_r, self.pivot_s)]

    def tail_link(self) -> FloatArray:
        """The tail link, ``(..., 2, 2)``: S-T."""
        return _chain(self.pivot_s, self.tip)

    def moving_joints(self) -> FloatArray:
        """The joints that move, ``(..., k, 2)``: R, T."""
        return _chain(self.joint_r, self.tip)


class UndulatoryPoints(NamedTuple):
    """Joints of mechanism 2; each an array ``(..., 2)`` of (x, y) in metres."""

    origin: FloatArray
    planet_centre: FloatArray
    cardan: FloatArray
    planet_opposite: FloatArray
    joint_r: FloatArray
    pivot_s: FloatArray
    pin_u: FloatArray  # U, pin on SW riding in AV's slot
    slider_a: FloatArray  # A, slider on the body axis
    joint_v: FloatArray  # V, joint of AV and VT
    joint_w: FloatArray  # W, end of SW, hinge on VT
    tip: FloatArray  # T, end of VT

    def drive_links(self) -> list[FloatArray]:
        """The links up to the tail link, as polylines ``(..., k, 2)``: P-R-S-W and A-V."""
        return [
            _chain(self.cardan, self.joint_r, self.pivot_s, self.joint_w),
            _chain(self.slider_a, self.joint_v),
        ]

    def tail_link(self) -> FloatArray:
        """The tail (fin) link, ``(..., 2, 2)``: V-T."""
        return _chain(self.joint_v, self.tip)

    def moving_joints(self) -> FloatArray:
        """The joints that move, ``(..., k, 2)``: R, U, A, V, W, T."""
        return _chain(self.joint_r, self.pin_u, self.slider_a, self.joint_v, self.joint_w, self.tip)


LinkagePoints: TypeAlias = OscillatoryPoints | UndulatoryPoints


def _xy(x: npt.ArrayLike, y: npt.ArrayLike) -> FloatArray:
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    return np.stack((x, y), axis=-1)


def _polar(origin: FloatArray, length: float, angle: Real) -> FloatArray:
    angles = np.asarray(angle, float)
    return origin + length * np.stack((np.cos(angles), np.sin(angles)), axis=-1)


def oscillatory_points(
    geometry: OscillatoryGeometry | UndulatoryGeometry,
    state: OscillatoryState | UndulatoryState,
) -> OscillatoryPoints:
    """The Cardan couple and the drive of ``state`` (solved for ``geometry``), and its tip."""
    g = geometry
    phi = np.asarray(state.motor_angle, float)
    shape = phi.shape
    carrier = phi + g.phase_rad
    half = 0.5 * g.ring_radius_m
    sin_c, cos_c = np.sin(carrier), np.cos(carrier)
    zeros = np.zeros(shape)
    cardan = _xy(zeros, state.slider_position)
    theta1 = np.asarray(state.theta1, float)
    return OscillatoryPoints(
        origin=_xy(zeros, zeros),
        planet_centre=_xy(-half * sin_c, half * cos_c),
        cardan=cardan,
        planet_opposite=_xy(-g.ring_radius_m * sin_c, zeros),
        joint_r=cardan + g.crank_link_m * _xy(np.cos(theta1), -np.sin(theta1)),
        pivot_s=_xy(np.full(shape, g.pivot_offset_m), zeros),
        tip=_xy(state.tip_x, state.tip_y),
    )


def undulatory_points(
    geometry: UndulatoryGeometry, state: UndulatoryState, swing_bias_rad: float = 0.0
) -> UndulatoryPoints:
    """Every joint of mechanism 2 for ``state`` (solved for ``geometry``, S where it is).

    ``swing_bias_rad``: the tail's swing bias, so that SW lies at theta3 + bias from the body axis.
    """
    g = geometry
    drive = oscillatory_points(g, state)
    zeros = np.zeros(np.shape(state.motor_angle))
    slider_a = _xy(g.pivot_offset_m - np.asarray(state.slider_a_distance, float), zeros)
    arm_angle = state.theta3 if swing_bias_rad == 0.0 else state.theta3 + swing_bias_rad
    return UndulatoryPoints(
        *drive[:-1],
        pin_u=_polar(drive.pivot_s, g.pin_offset_m, arm_angle),
        slider_a=slider_a,
        joint_v=_polar(slider_a, g.slotted_link_m, state.theta4),
        joint_w=_polar(drive.pivot_s, g.swing_arm_m, arm_angle),
        tip=drive.tip,
    )

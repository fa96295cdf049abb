"""Where every joint of a solved linkage is, in the frame at O (x back towards the tail, y left).

Pure numpy, for drawing (RViz markers, the CLI's animation). Every point is an array of shape
``state_shape + (2,)`` holding (x, y) in metres: shape (2,) for a state of floats, (N, 2) for a
state solved over N carrier angles.

The Cardan couple. The ring (radius R) is fixed with its centre at O; the carrier turns about O
with the motor, carrying the planet (radius R/2, rolling inside the ring) on a crank of length R/2.
The Cardan point P is the point of the planet's rim that stays on the y axis,
P = (0, R cos c) with c = phi + psi. The planet centre C must lie at R/2 from O (carrier crank) and
at R/2 from P (P is on the rim), so C lies on the perpendicular bisector of OP, the line
y = (R/2) cos c, at x = +-(R/2) sin c. Taking

    C = (R/2) (-sin c, cos c) = (R/2) e(c + pi/2)

makes the carrier turn counter-clockwise with phi (its angle is c + pi/2). Then
P - C = (R/2) (sin c, cos c) = (R/2) e(pi/2 - c): the planet turns at -phi in the fixed frame, as a
planet of half the ring's radius rolling inside it must (turns of the planet = -(R/(R/2) - 1) x
turns of the carrier). The rim point diametrically opposite P, D = 2C - P = (-R sin c, 0), slides
along the x axis: the couple's second straight line. Drawing the diameter P-D shows the planet's
rotation.

Mechanism 1: joint R (``joint_r``) = P + PR (cos theta1, -sin theta1) = S + RS e(theta2);
tip T = S + ST e(fin angle), S = (OS + pivot shift, 0).
Mechanism 2: W = S + SW e(theta3 + b), pin U = S + SU e(theta3 + b) (on SW), slider
A = (S_x - AS, 0), V = A + AV e(theta4) (U lies on AV, in its slot), T = W + (VT - VW) e(theta5),
where b is the swing bias of a shifted pivot (SW's angle from the body axis is theta3 + b). The
geometry given is the one with S where it is (``Tail.shifted_geometry``).

Each tail gives the points of its states (``Tail.link_points``), and the points say which of them
make the links and the moving joints, so that drawing code does not depend on the mechanism.

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

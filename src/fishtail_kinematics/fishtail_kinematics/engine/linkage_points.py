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
tip T = S + ST e(theta3), S = (OS, 0).
Mechanism 2: W = S + SW e(theta3), pin U = S + SU e(theta3) (on SW), slider A = (OS - AS, 0),
V = A + AV e(theta4) (U lies on AV, in its slot), T = W + (VT - VW) e(theta5).

>>> import math
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryGeometry, OscillatoryTail
>>> geometry = OscillatoryGeometry()
>>> points = linkage_points(geometry, OscillatoryTail(geometry).solve(0.0))
>>> points.cardan.tolist(), points.planet_centre.round(4).tolist()
([0.0, 0.1], [-0.0, 0.05])
>>> points = linkage_points(geometry, OscillatoryTail(geometry).solve(math.pi / 2))
>>> points.cardan.round(4).tolist(), points.planet_opposite.round(4).tolist()
([0.0, 0.0], [-0.1, 0.0])
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from fishtail_kinematics.engine.mechanisms import (
    OscillatoryGeometry,
    OscillatoryState,
    UndulatoryGeometry,
    UndulatoryState,
)


class OscillatoryPoints(NamedTuple):
    """Joints of mechanism 1; each an array ``(..., 2)`` of (x, y) in metres."""

    origin: np.ndarray  # O, ring-gear centre (fixed)
    planet_centre: np.ndarray  # C, end of the carrier crank
    cardan: np.ndarray  # P, on the y axis
    planet_opposite: np.ndarray  # D = 2C - P, on the x axis
    joint_r: np.ndarray  # R, joint of PR and RS
    pivot_s: np.ndarray  # S, body pivot (fixed)
    tip: np.ndarray  # T


class UndulatoryPoints(NamedTuple):
    """Joints of mechanism 2; each an array ``(..., 2)`` of (x, y) in metres."""

    origin: np.ndarray
    planet_centre: np.ndarray
    cardan: np.ndarray
    planet_opposite: np.ndarray
    joint_r: np.ndarray
    pivot_s: np.ndarray
    pin_u: np.ndarray  # U, pin on SW riding in AV's slot
    slider_a: np.ndarray  # A, slider on the body axis
    joint_v: np.ndarray  # V, joint of AV and VT
    joint_w: np.ndarray  # W, end of SW, hinge on VT
    tip: np.ndarray  # T, end of VT


def _xy(x, y) -> np.ndarray:
    x, y = np.broadcast_arrays(np.asarray(x, float), np.asarray(y, float))
    return np.stack((x, y), axis=-1)


def _polar(origin: np.ndarray, length: float, angle) -> np.ndarray:
    angle = np.asarray(angle, float)
    return origin + length * np.stack((np.cos(angle), np.sin(angle)), axis=-1)


def linkage_points(
    geometry: OscillatoryGeometry | UndulatoryGeometry,
    state: OscillatoryState | UndulatoryState,
) -> OscillatoryPoints | UndulatoryPoints:
    """Every joint of ``state`` (solved by the engine for ``geometry``) in the frame at O."""
    g = geometry
    phi = np.asarray(state.motor_angle, float)
    shape = phi.shape
    carrier = phi + g.phase_rad
    half = 0.5 * g.ring_radius_m
    sin_c, cos_c = np.sin(carrier), np.cos(carrier)
    zeros = np.zeros(shape)
    origin = _xy(zeros, zeros)
    planet_centre = _xy(-half * sin_c, half * cos_c)
    cardan = _xy(zeros, state.slider_position)
    planet_opposite = _xy(-g.ring_radius_m * sin_c, zeros)
    theta1 = np.asarray(state.theta1, float)
    joint_r = cardan + g.crank_link_m * _xy(np.cos(theta1), -np.sin(theta1))
    pivot_s = _xy(np.full(shape, g.pivot_offset_m), zeros)
    tip = _xy(state.tip_x, state.tip_y)
    if isinstance(g, OscillatoryGeometry):
        return OscillatoryPoints(
            origin, planet_centre, cardan, planet_opposite, joint_r, pivot_s, tip
        )
    slider_a = _xy(g.pivot_offset_m - np.asarray(state.slider_a_distance, float), zeros)
    return UndulatoryPoints(
        origin,
        planet_centre,
        cardan,
        planet_opposite,
        joint_r,
        pivot_s,
        pin_u=_polar(pivot_s, g.pin_offset_m, state.theta3),
        slider_a=slider_a,
        joint_v=_polar(slider_a, g.slotted_link_m, state.theta4),
        joint_w=_polar(pivot_s, g.swing_arm_m, state.theta3),
        tip=tip,
    )

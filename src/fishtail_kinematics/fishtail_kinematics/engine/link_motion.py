"""How every moving body of a solved linkage moves and accelerates: second-order kinematics.

What the carrier's load needs of the linkage: for a state solved at carrier speed phi_dot, each
body's centre of mass velocity and acceleration and its angular rates (at 1 rad/s the velocity
ratios and their derivatives), analytic rather than differenced. :class:`PlaneMotion` is a body
in general plane motion, :class:`TurningMotion` one whose centre circles a fixed point at its own
angular speed; each gives its terms of the reduced inertia, and each tail the motion of its
bodies (``Tail.link_motion``), so that callers do not depend on the mechanism. The equations:
docs/motor-load.md ("The ratios' derivatives").

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> bodies = tail.link_motion(tail.solve(0.0, 1.0))
>>> [body.link for body in bodies]
['carrier', 'planet', 'crank_link', 'rocker_link', 'tail_link']
>>> [abs(float(body.angular_velocity)) for body in bodies]  # the stroke's end: the links stop
[1.0, 1.0, 0.0, 0.0, 0.0]
>>> energy, change = bodies[1].reduced_inertia_terms(0.1, 0.0)  # the planet: m (R/2)^2, constant
>>> round(float(energy), 12), abs(float(change))
(0.00025, 0.0)
"""

from __future__ import annotations

import math
from typing import NamedTuple, TypeAlias

import numpy as np

from fishtail_kinematics.engine.geometry import (
    OscillatoryGeometry,
    OscillatoryState,
    Real,
    UndulatoryGeometry,
    UndulatoryState,
)


class PlaneMotion(NamedTuple):
    """A body in general plane motion; floats or arrays shaped like the state's fields.

    ``link`` names it as :mod:`~fishtail_plant.linkage_load.link_inertia` does. Velocities [m/s]
    and accelerations [m/s^2] are those of its centre of mass, in the frame at O; the angular
    ones [rad/s, rad/s^2] are about z. A translating body has zero angular velocity.
    """

    link: str
    velocity_x: Real
    velocity_y: Real
    acceleration_x: Real
    acceleration_y: Real
    angular_velocity: Real
    angular_acceleration: Real

    def reduced_inertia_terms(self, mass_kg: float, inertia_kg_m2: float) -> tuple[Real, Real]:
        """Its m |v|^2 + I omega^2 and d/dt of it over phi_dot (m v.a + I omega alpha, twice)."""
        vx, vy, rate = self.velocity_x, self.velocity_y, self.angular_velocity
        energy = mass_kg * (vx * vx + vy * vy) + inertia_kg_m2 * (rate * rate)
        change = (2.0 * mass_kg) * (vx * self.acceleration_x + vy * self.acceleration_y) + (
            2.0 * inertia_kg_m2
        ) * (rate * self.angular_acceleration)
        return energy, change


class TurningMotion(NamedTuple):
    """A body whose centre of mass circles a fixed point at the body's own angular speed.

    A link turning about a fixed pivot (RS, ST, SW, the carrier about O), or the planet, whose
    centre circles O at phi_dot while it spins at -phi_dot: |v_G| = r |omega| and
    v_G . a_G = r^2 omega alpha, so its energy is (I + m r^2) omega^2 / 2 and no vector is needed.
    """

    link: str
    radius_m: float  # from the fixed point to the centre of mass
    angular_velocity: Real
    angular_acceleration: Real

    def reduced_inertia_terms(self, mass_kg: float, inertia_kg_m2: float) -> tuple[Real, Real]:
        """(I + m r^2) omega^2 and 2 (I + m r^2) omega alpha."""
        weight = inertia_kg_m2 + mass_kg * self.radius_m**2
        rate = self.angular_velocity
        return weight * (rate * rate), (2.0 * weight) * (rate * self.angular_acceleration)


#: The motion of one body of a solved state.
BodyMotion: TypeAlias = PlaneMotion | TurningMotion


def _turning_point(
    distance_m: float, rate: Real, rate_derivative: Real, cos: Real, sin: Real
) -> tuple[Real, Real, Real, Real]:
    """Velocity and acceleration (x, y, x, y) of a point turning about a point at rest.

    The point lies at ``distance_m`` along e(angle), the angle turning at ``rate``.
    """
    along = distance_m * rate * rate
    across = distance_m * rate_derivative
    return (
        -distance_m * rate * sin, distance_m * rate * cos,
        -across * sin - along * cos, across * cos - along * sin,
    )  # fmt: skip


class _Drive(NamedTuple):
    """The Cardan couple, PR and RS, and what the tail links need: theta2's rates."""

    bodies: tuple[BodyMotion, ...]
    theta2_rate: Real
    theta2_rate_derivative: Real


def _drive_motion(
    geometry: OscillatoryGeometry | UndulatoryGeometry,
    theta2_mid: float,
    state: OscillatoryState | UndulatoryState,
    cos3: Real,
    sin3: Real,
) -> _Drive:
    g = geometry
    speed = state.motor_velocity
    op, op_rate = state.slider_position, state.slider_velocity
    op_rate_derivative = -op * speed * speed
    theta1_rate, theta2_rate = state.theta1_dot, state.theta2_dot
    # theta2 = (the tail link's body-frame angle) + theta2_mid: the sum formulas instead of two
    # more sines and cosines of arrays.
    cos_mid, sin_mid = math.cos(theta2_mid), math.sin(theta2_mid)
    cos2 = cos3 * cos_mid - sin3 * sin_mid
    sin2 = sin3 * cos_mid + cos3 * sin_mid
    # Joint R seen from P: PR (cos th1, -sin th1) = S + RS e(th2) - P, no further trigonometry.
    cos1 = (g.pivot_offset_m + g.rocker_link_m * cos2) / g.crank_link_m
    sin1 = (op - g.rocker_link_m * sin2) / g.crank_link_m
    sin12 = sin1 * cos2 + cos1 * sin2
    crank_squared = g.crank_link_m * theta1_rate * theta1_rate
    rocker_squared = g.rocker_link_m * theta2_rate * theta2_rate
    a = rocker_squared * cos2 - crank_squared * cos1
    b = op_rate_derivative + crank_squared * sin1 + rocker_squared * sin2
    theta1_rate_derivative = (a * cos2 + b * sin2) / (g.crank_link_m * sin12)
    theta2_rate_derivative = (b * sin1 - a * cos1) / (g.rocker_link_m * sin12)
    # PR's middle is halfway between P = (0, OP) and R, which turns about S.
    r_vx, r_vy, r_ax, r_ay = _turning_point(
        g.rocker_link_m, theta2_rate, theta2_rate_derivative, cos2, sin2
    )
    crank = PlaneMotion(
        "crank_link",
        0.5 * r_vx, 0.5 * (op_rate + r_vy), 0.5 * r_ax, 0.5 * (op_rate_derivative + r_ay),
        -theta1_rate, -theta1_rate_derivative,
    )  # fmt: skip
    zero = 0.0 * speed
    quarter = 0.25 * g.ring_radius_m
    bodies = (
        TurningMotion("carrier", quarter, speed, zero),  # centre of mass C/2
        TurningMotion("planet", 2.0 * quarter, -speed, zero),  # centre C, spinning at -phi_dot
        crank,
        TurningMotion("rocker_link", 0.5 * g.rocker_link_m, theta2_rate, theta2_rate_derivative),
    )
    return _Drive(bodies, theta2_rate, theta2_rate_derivative)


def oscillatory_link_motion(
    geometry: OscillatoryGeometry, theta2_mid: float, state: OscillatoryState
) -> tuple[BodyMotion, ...]:
    """Carrier, planet, PR, RS and ST of mechanism 1 for ``state`` (solved for ``geometry``).

    ``geometry`` has S where it is (``Tail.shifted_geometry``); ``theta2_mid`` is theta2 at which
    the tail link lies along the body axis (``tail_mounting_rad``, the design's mid-swing), so
    that the tail link's angle from the body axis is theta2 - theta2_mid.
    """
    # The tail link's angle from the tip, T = S + ST e(angle): no trigonometry of arrays.
    cos3 = (state.tip_x - geometry.pivot_offset_m) / geometry.tail_link_m
    sin3 = state.tip_y / geometry.tail_link_m
    drive = _drive_motion(geometry, theta2_mid, state, cos3, sin3)
    tail = TurningMotion(
        "tail_link", 0.5 * geometry.tail_link_m, drive.theta2_rate, drive.theta2_rate_derivative
    )
    return (*drive.bodies, tail)


def undulatory_link_motion(
    geometry: UndulatoryGeometry,
    theta2_mid: float,
    state: UndulatoryState,
    swing_bias_rad: float = 0.0,
) -> tuple[BodyMotion, ...]:
    """The drive, SW, the slider A, AV and VT of mechanism 2 for ``state``.

    ``geometry`` and ``theta2_mid`` as for :func:`oscillatory_link_motion`; ``swing_bias_rad`` is
    the tail's swing bias (SW lies at theta3 + bias from the body axis).
    """
    g = geometry
    # SW's angle from the body axis, which the second loop and the drive's identities use.
    theta3 = np.asarray(state.theta3)
    if swing_bias_rad != 0.0:
        theta3 = theta3 + swing_bias_rad
    cos3, sin3 = np.cos(theta3), np.sin(theta3)
    drive = _drive_motion(g, theta2_mid, state, cos3, sin3)
    rate3, rate3_derivative = drive.theta2_rate, drive.theta2_rate_derivative
    u, u_rate = state.pin_u_distance, state.pin_u_distance_rate
    a_rate = state.slider_a_distance_rate
    rate4, rate5 = state.theta4_dot, state.theta5_dot
    # The loop's own directions: A->U (theta4) from U - A, V->W (theta5) from W - V.
    cos4 = (state.slider_a_distance + g.pin_offset_m * cos3) / u
    sin4 = g.pin_offset_m * sin3 / u
    av, vw = g.slotted_link_m, g.fin_joint_offset_m
    cos5 = (g.swing_arm_m * cos3 + state.slider_a_distance - av * cos4) / vw
    sin5 = (g.swing_arm_m * sin3 - av * sin4) / vw
    pin_along = g.pin_offset_m * rate3 * rate3
    pin_across = g.pin_offset_m * rate3_derivative
    arm_along = g.swing_arm_m * rate3 * rate3
    arm_across = g.swing_arm_m * rate3_derivative
    slot_squared = av * rate4 * rate4
    fin_joint_squared = vw * rate5 * rate5
    coriolis = 2.0 * u_rate * rate4
    u_squared = u * rate4 * rate4
    r1 = coriolis * sin4 + u_squared * cos4 - pin_across * sin3 - pin_along * cos3
    r2 = -coriolis * cos4 + u_squared * sin4 + pin_across * cos3 - pin_along * sin3
    r3 = arm_across * sin3 + arm_along * cos3 - slot_squared * cos4 - fin_joint_squared * cos5
    r4 = -arm_across * cos3 + arm_along * sin3 - slot_squared * sin4 - fin_joint_squared * sin5
    p = r2 * cos4 - r1 * sin4
    s = r3 * cos5 + r4 * sin5
    sin45 = sin4 * cos5 - cos4 * sin5
    cos45 = cos4 * cos5 + sin4 * sin5
    lever = av / u
    a_rate_derivative = (s - lever * sin45 * p) / (cos5 - lever * sin4 * sin45)
    rate4_derivative = (p - a_rate_derivative * sin4) / u
    rate5_derivative = (
        r3 * sin5 - r4 * cos5 - a_rate_derivative * sin5 - av * cos45 * rate4_derivative
    ) / vw

    arm = TurningMotion("swing_arm", 0.5 * g.swing_arm_m, rate3, rate3_derivative)
    zero = 0.0 * rate4
    # A = (OS - AS, 0): it moves against AS. V relative to A, and VT's middle relative to V.
    slider = PlaneMotion("slider", -a_rate, zero, -a_rate_derivative, zero, zero, zero)
    v_vx, v_vy, v_ax, v_ay = _turning_point(av, rate4, rate4_derivative, cos4, sin4)
    g_vx, g_vy, g_ax, g_ay = _turning_point(0.5 * g.fin_link_m, rate5, rate5_derivative, cos5, sin5)
    slotted = PlaneMotion(
        "slotted_link",
        0.5 * v_vx - a_rate, 0.5 * v_vy, 0.5 * v_ax - a_rate_derivative, 0.5 * v_ay,
        rate4, rate4_derivative,
    )  # fmt: skip
    fin_link = PlaneMotion(
        "fin_link",
        v_vx + g_vx - a_rate, v_vy + g_vy, v_ax + g_ax - a_rate_derivative, v_ay + g_ay,
        rate5, rate5_derivative,
    )  # fmt: skip
    return (*drive.bodies, arm, slider, slotted, fin_link)

"""An independent kinetic energy for the engine's load tests: from the drawn joints, by differences.

Each link's centre of mass is the middle of the two joints that define it and its angle the
direction from one to the other, both read off ``Tail.link_points`` (which the linkage-points
tests check against the loop equations). Velocities and accelerations are fourth-order central
differences of those points in the carrier angle: nothing here uses the engine's rates or its
second-order kinematics.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import NamedTuple

import numpy as np

#: Carrier-angle step of the differences: truncation ~ h^4 ~ 1e-12; rounding ~ 1e-16 / h ~ 1e-13
#: in first derivatives, ~ 1e-16 / h^2 ~ 1e-10 in second ones.
ANGLE_STEP_RAD = 1e-3


def bodies_from_points(points):
    """{link: (centre of mass, direction vector or None)}, each an array (..., 2)."""
    p = points
    bodies = {
        "carrier": (0.5 * (p.origin + p.planet_centre), p.planet_centre - p.origin),
        "planet": (p.planet_centre, p.cardan - p.planet_centre),  # P is a point of the rim
        "crank_link": (0.5 * (p.cardan + p.joint_r), p.joint_r - p.cardan),
        "rocker_link": (0.5 * (p.joint_r + p.pivot_s), p.joint_r - p.pivot_s),
    }
    if hasattr(p, "joint_w"):
        bodies.update(
            swing_arm=(0.5 * (p.pivot_s + p.joint_w), p.joint_w - p.pivot_s),
            slider=(p.slider_a, None),
            slotted_link=(0.5 * (p.slider_a + p.joint_v), p.joint_v - p.slider_a),
            fin_link=(0.5 * (p.joint_v + p.tip), p.tip - p.joint_v),
        )
    else:
        bodies["tail_link"] = (0.5 * (p.pivot_s + p.tip), p.tip - p.pivot_s)
    return bodies


#: Five-point central differences: offsets (in steps) and weights of d/dphi (over 12 h) and of
#: d2/dphi2 (over 12 h^2).
FIRST = ((-2, 1.0), (-1, -8.0), (1, 8.0), (2, -1.0))
SECOND = ((-2, -1.0), (-1, 16.0), (0, -30.0), (1, 16.0), (2, -1.0))


class Ratios(NamedTuple):
    """dG/dphi, d2G/dphi2 (arrays (..., 2)) and dtheta/dphi, d2theta/dphi2 of one body."""

    velocity: np.ndarray
    acceleration: np.ndarray
    rate: np.ndarray
    rate_derivative: np.ndarray


def ratios_from_points(tail, phi):
    """{link: Ratios} by differences of the drawn joints in the carrier angle."""
    phi = np.asarray(phi, dtype=float)
    h = ANGLE_STEP_RAD
    shifted = {
        k: bodies_from_points(tail.link_points(tail.solve(phi + k * h, 0.0)))
        for k in (-2, -1, 0, 1, 2)
    }
    result = {}
    for link, (_, direction) in shifted[0].items():
        velocity = sum(w * shifted[k][link][0] for k, w in FIRST) / (12 * h)
        acceleration = sum(w * shifted[k][link][0] for k, w in SECOND) / (12 * h * h)
        if direction is None:
            zero = np.zeros(phi.shape)
            result[link] = Ratios(velocity, acceleration, zero, zero)
            continue

        def unit(k, link=link):
            vector = shifted[k][link][1]
            return vector / np.linalg.norm(vector, axis=-1, keepdims=True)

        # e' = theta' e_perp and e'' = theta'' e_perp - theta'^2 e, so e x e' = theta' and
        # e x e'' = theta''.
        e = unit(0)
        first = sum(w * unit(k) for k, w in FIRST) / (12 * h)
        second = sum(w * unit(k) for k, w in SECOND) / (12 * h * h)
        result[link] = Ratios(
            velocity,
            acceleration,
            e[..., 0] * first[..., 1] - e[..., 1] * first[..., 0],
            e[..., 0] * second[..., 1] - e[..., 1] * second[..., 0],
        )
    return result


def reduced_inertia_from_points(tail, inertia, phi):
    """J(phi) = sum m |dG/dphi|^2 + I (dtheta/dphi)^2 from the drawn joints."""
    total = np.zeros(np.shape(phi))
    for link, ratios in ratios_from_points(tail, phi).items():
        mass, moment = inertia.mass_and_inertia(link)
        total = total + mass * np.sum(ratios.velocity**2, axis=-1) + moment * ratios.rate**2
    return total


def kinetic_energy_from_points(tail, inertia, phi, phi_dot):
    """T = ½ J(phi) phi_dot^2, with J from the drawn joints."""
    return 0.5 * reduced_inertia_from_points(tail, inertia, phi) * np.asarray(phi_dot) ** 2


#: The independent ratios, reduced inertia and kinetic energy, and the step they use.
FROM_POINTS = SimpleNamespace(
    ratios=ratios_from_points,
    reduced_inertia=reduced_inertia_from_points,
    kinetic_energy=kinetic_energy_from_points,
    step=ANGLE_STEP_RAD,
)

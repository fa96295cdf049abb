"""Inertia, added masses and yaw damping of a prolate-spheroid body, the defaults of the fish.

The fish's default hull is a neutrally buoyant prolate spheroid; its added masses come from
Lamb's k-coefficients, so that a different L, D or rho gives consistent values. Formulas and
references: docs/swimming-dynamics.md ("Parameters").

>>> round(lamb_coefficients(1.0, 1.0)[0], 6), round(lamb_coefficients(1.0, 1.0)[2], 6)  # sphere
(0.5, 0.0)
>>> [round(k, 3) for k in lamb_coefficients(10.0, 1.0)]  # Lamb's table, L/D = 10
[0.021, 0.96, 0.884]
>>> [round(k, 4) for k in lamb_coefficients(0.5, 0.2)]
[0.1563, 0.7619, 0.3652]
"""

from __future__ import annotations

import math
from typing import NamedTuple

from fishtail_plant.errors import SwimParameterError

# Below this eccentricity the closed forms lose digits to cancellation; the sphere's values
# (k1 = k2 = 1/2, k' = 0) are then within O(e²) < 1e-8 of them.
_SPHERE_ECCENTRICITY = 1e-4
# Cross-flow drag coefficient of a circular section (a cylinder moving sideways at Re ~ 1e4-1e5).
CROSSFLOW_DRAG_COEFFICIENT = 1.0


class SpheroidBody(NamedTuple):
    """Rigid-body and added inertia of a neutrally buoyant solid prolate spheroid."""

    mass_kg: float
    yaw_inertia_kg_m2: float
    added_mass_surge_kg: float
    added_mass_sway_kg: float
    added_yaw_inertia_kg_m2: float


def lamb_coefficients(length_m: float, diameter_m: float) -> tuple[float, float, float]:
    """Lamb's (k1, k2, k') of a prolate spheroid of length L and diameter D (L >= D > 0).

    Raises:
        SwimParameterError: a length that is not finite and > 0, or a diameter not in (0, L].
    """
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise SwimParameterError("body_length_m", length_m, 0.0, math.inf, "m")
    if not (math.isfinite(diameter_m) and 0.0 < diameter_m <= length_m):
        raise SwimParameterError("body_diameter_m", diameter_m, 0.0, length_m, "m")
    e = math.sqrt(1.0 - (diameter_m / length_m) ** 2)
    if e < _SPHERE_ECCENTRICITY:
        return 0.5, 0.5, 0.0
    log_term = math.log((1.0 + e) / (1.0 - e))
    alpha0 = 2.0 * (1.0 - e * e) / e**3 * (0.5 * log_term - e)
    beta0 = 1.0 / (e * e) - (1.0 - e * e) / (2.0 * e**3) * log_term
    k1 = alpha0 / (2.0 - alpha0)
    k2 = beta0 / (2.0 - beta0)
    difference = beta0 - alpha0
    k_yaw = e**4 * difference / ((2.0 - e * e) * (2.0 * e * e - (2.0 - e * e) * difference))
    return k1, k2, k_yaw


def prolate_spheroid(length_m: float, diameter_m: float, density_kg_m3: float) -> SpheroidBody:
    """Mass, yaw inertia and added masses of a neutrally buoyant spheroid (uniform density).

    -X_udot = k1 m_f, -Y_vdot = k2 m_f and -N_rdot = k' I_f, with m_f and I_f = m_f (a² + b²)/5 the
    displaced water's mass and moment of inertia about the vertical axis through C.

    >>> body = prolate_spheroid(0.5, 0.2, 1000.0)
    >>> round(body.mass_kg, 3), round(body.added_mass_sway_kg, 3)
    (10.472, 7.978)

    Raises:
        SwimParameterError: as :func:`lamb_coefficients`.
    """
    k1, k2, k_yaw = lamb_coefficients(length_m, diameter_m)
    a, b = 0.5 * length_m, 0.5 * diameter_m
    mass = 4.0 / 3.0 * math.pi * density_kg_m3 * a * b * b
    inertia = mass * (a * a + b * b) / 5.0
    return SpheroidBody(mass, inertia, k1 * mass, k2 * mass, k_yaw * inertia)


def crossflow_yaw_damping(length_m: float, diameter_m: float, density_kg_m3: float) -> float:
    """K_D of M = -K_D r|r| from cross-flow drag on the spheroid's sections, turning about C.

    A section at x of diameter D sqrt(1 - (2x/L)²) moving sideways at r x feels
    ½ ρ C_dc D(x) (r x)|r x|; its moment integrates to ρ C_dc D L⁴ / 120 · r|r|.

    >>> round(crossflow_yaw_damping(0.5, 0.2, 1000.0), 5)
    0.10417
    """
    return density_kg_m3 * CROSSFLOW_DRAG_COEFFICIENT * diameter_m * length_m**4 / 120.0

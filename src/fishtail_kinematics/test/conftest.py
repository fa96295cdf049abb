"""Independent reference solutions (oracles) shared by the kinematics tests.

Nothing here re-uses the engine's formulas. Mechanism 1 is solved as the intersection of the circle
of radius PR about P with the circle of radius RS about S, keeping the point left of P->S; mechanism
2 is solved with scipy's ``fsolve`` on the four loop equations of the spec, continued from the
straight pose. Tests get them through the session-scoped ``oracle`` fixture.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import fsolve, minimize_scalar

#: The report geometry (spec tables), metres.
REPORT = SimpleNamespace(R=0.1, PR=0.1, OS=0.2, ST=0.15, SW=0.16, AV=0.24, VT=0.2, VW=0.06, SU=0.08)


def joint_r(op, pr, rs, os_):
    """Joint R for Cardan-point positions ``op``: circle (P, PR) meets circle (S, RS), left of P->S.

    Returns (x, y) arrays; NaN where the circles do not meet.
    """
    op = np.asarray(op, float)
    dx, dy = os_ - 0.0, 0.0 - op  # S - P
    d = np.hypot(dx, dy)
    ux, uy = dx / d, dy / d
    along = (pr * pr - rs * rs + d * d) / (2.0 * d)
    with np.errstate(invalid="ignore"):
        across = np.sqrt(pr * pr - along * along)
    # (-uy, ux) is u turned counter-clockwise: the left side of P->S.
    return along * ux - across * uy, op + along * uy + across * ux


def theta12(op, pr, rs, os_):
    """(theta1, theta2) of mechanism 1 from the joint position (spec angle conventions).

    theta2 is given in [-pi/2, 3 pi/2): R sits above S's horizontal through most of the stroke,
    so that range keeps theta2 continuous where it crosses pi.
    """
    x, y = joint_r(op, pr, rs, os_)
    theta2 = np.remainder(np.arctan2(y, x - os_) + 0.5 * math.pi, 2.0 * math.pi) - 0.5 * math.pi
    theta1 = np.arctan2(-(y - np.asarray(op, float)), x)
    return theta1, theta2


def theta2_extremes(ring, pr, rs, os_, samples=200001):
    """(min, max, op_at_min, op_at_max) of theta2 over |OP| <= R: dense sweep, then Brent polish."""
    ops = np.linspace(-ring, ring, samples)
    values = np.unwrap(theta12(ops, pr, rs, os_)[1])
    step = ops[1] - ops[0]
    found = []
    for sign, index in ((1.0, int(np.argmin(values))), (-1.0, int(np.argmax(values)))):
        best_op, best = ops[index], values[index]
        low, high = max(-ring, best_op - step), min(ring, best_op + step)
        if high > low:
            reference = values[index]

            def objective(op, sign=sign, reference=reference):
                value = float(theta12(op, pr, rs, os_)[1])
                value = reference + math.remainder(value - reference, 2.0 * math.pi)
                return sign * value

            result = minimize_scalar(
                objective, bounds=(low, high), method="bounded", options={"xatol": 1e-13}
            )
            if sign * result.fun < sign * best:
                best_op, best = float(result.x), sign * float(result.fun)
        found.append((best, best_op))
    (low_value, low_op), (high_value, high_op) = found
    return low_value, high_value, low_op, high_op


def loop_residuals(theta3, theta4, au, as_, theta5, g):
    """The four loop equations of mechanism 2 (spec), as residuals in metres."""
    return (
        au * np.cos(theta4) - g.SU * np.cos(theta3) - as_,
        au * np.sin(theta4) - g.SU * np.sin(theta3),
        as_ + g.SW * np.cos(theta3) - g.AV * np.cos(theta4) - g.VW * np.cos(theta5),
        g.SW * np.sin(theta3) - g.AV * np.sin(theta4) - g.VW * np.sin(theta5),
    )


def _jacobian(x, theta3, g):
    theta4, au, _, theta5 = x
    s4, c4, s5, c5 = math.sin(theta4), math.cos(theta4), math.sin(theta5), math.cos(theta5)
    return np.array(
        [
            [-au * s4, c4, -1.0, 0.0],
            [au * c4, s4, 0.0, 0.0],
            [g.AV * s4, 0.0, 1.0, g.VW * s5],
            [-g.AV * c4, 0.0, 0.0, -g.VW * c5],
        ]
    )


def _solve_one(theta3, seed, g):
    def equations(x):
        return np.array(loop_residuals(theta3, *x, g))

    x = fsolve(equations, seed, fprime=lambda x: _jacobian(x, theta3, g), xtol=1e-12)
    for _ in range(2):  # Newton polish to rounding level
        x = x - np.linalg.solve(_jacobian(x, theta3, g), equations(x))
    assert np.abs(equations(x)).max() < 1e-14, "oracle did not converge"
    return x


def solve_undulatory(theta3_values, g, ramp_steps=64):
    """(theta4, AU, AS, theta5) arrays for a sequence of theta3, by continuation from straight.

    The first sample is reached from theta3 = 0 (theta4 = theta5 = 0, AS = AV + VW - SW,
    AU = SU + AS) in ``ramp_steps`` steps; each later sample is seeded with the one before.
    """
    as0 = g.AV + g.VW - g.SW
    x = np.array([0.0, g.SU + as0, as0, 0.0])
    theta3_values = np.asarray(theta3_values, float)
    for theta3 in np.linspace(0.0, theta3_values.flat[0], ramp_steps):
        x = _solve_one(float(theta3), x, g)
    out = np.empty((theta3_values.size, 4))
    for index, theta3 in enumerate(theta3_values.flat):
        x = _solve_one(float(theta3), x, g)
        out[index] = x
    return tuple(out[:, column].reshape(theta3_values.shape) for column in range(4))


@pytest.fixture(scope="session")
def oracle():
    """The independent reference solutions and the report geometry."""
    return SimpleNamespace(
        REPORT=REPORT,
        joint_r=joint_r,
        theta12=theta12,
        theta2_extremes=theta2_extremes,
        loop_residuals=loop_residuals,
        solve_undulatory=solve_undulatory,
    )

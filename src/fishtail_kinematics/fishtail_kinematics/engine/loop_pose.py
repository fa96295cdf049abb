"""Mechanism 2's second loop A-U-V-W at one arm angle: the engine's formulas, written once.

:class:`~fishtail_kinematics.engine.undulatory_tail.UndulatoryTail` calls them, and so do the
synthesis' population solve and its compiled cycle kernel (numba compiles them as they stand:
plain arithmetic and ``math``), so that every path closes the loop by the same Newton step to
the same tolerance. The loop is written relative to S with a = AS: A = (-a, 0), U = SU e(theta3),
theta4 = direction A->U, V = A + AV e(theta4), and W = SW e(theta3) must lie at VW from V
(docs/kinematics.md, "Mechanism 2"). theta3 here is SW's angle to the body axis.
"""

from __future__ import annotations

import math
from typing import TypeAlias

import numpy as np

from fishtail_kinematics.engine.geometry import Real

#: Newton steps the loop may take from its seed before the solve counts as failed.
LOOP_NEWTON_STEPS = 8
#: How far W may sit off its circle about V [m]: each sample stops at it on its own.
CLOSURE_TOLERANCE_M = 1e-13

#: :func:`loop_closure`'s result: AS, AU, cos and sin theta4, W - V (x, y), the residual and
#: the slope at the final AS, and whether the loop closed within :data:`LOOP_NEWTON_STEPS`.
LoopClosure: TypeAlias = tuple[float, float, float, float, float, float, float, float, bool]


def residual_tolerance(fin_joint_offset_m: Real) -> Real:
    """The tolerance of the squared residual: |W - V|² - VW² ~ 2 VW x the distance error."""
    return 2.0 * fin_joint_offset_m * CLOSURE_TOLERANCE_M


def loop_closure(
    a: float,
    su_cos3: float,
    su_sin3: float,
    sw_cos3: float,
    sw_sin3: float,
    slotted_link_m: float,
    vw_squared: float,
    tolerance: float,
) -> LoopClosure:
    """Newton's method on the loop's equation in AS from the seed ``a``, at one arm angle.

    Takes SU and SW times cos and sin theta3, AV, VW² and the squared residual's tolerance; at
    least one step, then until the residual is within the tolerance. Not checked: the caller
    raises (or marks the sample) where the result says the loop did not close.
    """
    av = slotted_link_m
    slope = residual = au = cos4 = sin4 = ex = ey = 0.0
    closed = False
    for step in range(LOOP_NEWTON_STEPS + 1):
        if step:
            a -= residual / slope
        dx = a + su_cos3
        au = math.hypot(dx, su_sin3)
        cos4 = dx / au
        sin4 = su_sin3 / au
        ex = sw_cos3 + a - av * cos4
        ey = sw_sin3 - av * sin4
        residual = ex * ex + ey * ey - vw_squared
        # d(cos4)/da = sin4^2/AU, d(sin4)/da = -cos4 sin4/AU.
        lever = av * sin4 / au
        slope = 2.0 * (ex * (1.0 - lever * sin4) + ey * lever * cos4)
        if step and abs(residual) < tolerance:
            closed = True
            break
    return a, au, cos4, sin4, ex, ey, residual, slope, closed


def loop_residual_and_slope(
    a: Real, cos3: Real, sin3: Real, pin_offset_m: Real, swing_arm_m: Real,
    slotted_link_m: Real, fin_joint_offset_m: Real,
) -> tuple[Real, Real]:  # fmt: skip
    """The loop's residual |W - V|² - VW² and its slope in AS, for floats or arrays."""
    dx = a + pin_offset_m * cos3
    dy = pin_offset_m * sin3
    # np.hypot is ~15x slower than this and the operands are far from overflow.
    au = np.sqrt(dx * dx + dy * dy) if isinstance(dx, np.ndarray) else math.hypot(dx, dy)
    cos4 = dx / au
    sin4 = dy / au
    ex = swing_arm_m * cos3 + a - slotted_link_m * cos4
    ey = swing_arm_m * sin3 - slotted_link_m * sin4
    residual = ex * ex + ey * ey - fin_joint_offset_m * fin_joint_offset_m
    slope = 2.0 * (
        ex * (1.0 - slotted_link_m * sin4 * sin4 / au) + ey * slotted_link_m * cos4 * sin4 / au
    )
    return residual, slope


def loop_rates(
    theta3_dot: Real, cos3: Real, sin3: Real, cos4: Real, sin4: Real, cos5: Real, sin5: Real,
    au: Real, pin_offset_m: Real, swing_arm_m: Real, slotted_link_m: Real,
    fin_joint_offset_m: Real,
) -> tuple[Real, Real, Real, Real]:  # fmt: skip
    """theta4', AU', AS' and theta5' from the loop's four equations differentiated in time.

    In closed form (docs/kinematics.md); floats or arrays:
      AS' [cos5 - (AV/AU) sin4 sin(t4-t5)] = t3' [SW sin(t3-t5) - (AV SU/AU) sin(t4-t5) cos(t3-t4)]
      t4' = (SU t3' cos(t3-t4) - AS' sin4) / AU
      AU' = AS' cos4 - SU t3' sin(t3-t4)
      t5' = (SW t3' cos(t3-t5) - AV t4' cos(t4-t5) - AS' sin5) / VW
    """
    sin34 = sin3 * cos4 - cos3 * sin4
    cos34 = cos3 * cos4 + sin3 * sin4
    sin35 = sin3 * cos5 - cos3 * sin5
    cos35 = cos3 * cos5 + sin3 * sin5
    sin45 = sin4 * cos5 - cos4 * sin5
    cos45 = cos4 * cos5 + sin4 * sin5
    lever = slotted_link_m / au
    slider_rate = (
        theta3_dot
        * (swing_arm_m * sin35 - lever * pin_offset_m * sin45 * cos34)
        / (cos5 - lever * sin4 * sin45)
    )
    theta4_dot = (pin_offset_m * theta3_dot * cos34 - slider_rate * sin4) / au
    au_rate = slider_rate * cos4 - pin_offset_m * theta3_dot * sin34
    theta5_dot = (
        swing_arm_m * theta3_dot * cos35 - slotted_link_m * theta4_dot * cos45 - slider_rate * sin5
    ) / fin_joint_offset_m
    return theta4_dot, au_rate, slider_rate, theta5_dot


def loop_tip(
    pivot_offset_m: Real, swing_arm_m: Real, fin_tail_m: Real, cos3: Real, sin3: Real,
    cos5: Real, sin5: Real, theta3_dot: Real, theta5_dot: Real,
) -> tuple[Real, Real, Real, Real]:  # fmt: skip
    """The tip T = S + SW e(theta3) + WT e(theta5) and its velocity (``fin_tail_m``: WT)."""
    tip_x = pivot_offset_m + swing_arm_m * cos3 + fin_tail_m * cos5
    tip_y = swing_arm_m * sin3 + fin_tail_m * sin5
    tip_x_dot = -swing_arm_m * sin3 * theta3_dot - fin_tail_m * sin5 * theta5_dot
    tip_y_dot = swing_arm_m * cos3 * theta3_dot + fin_tail_m * cos5 * theta5_dot
    return tip_x, tip_y, tip_x_dot, tip_y_dot

"""Mechanism 2's loop formulas: the closure, its slope, its rates and the tip, floats and arrays."""

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import UndulatoryGeometry
from fishtail_kinematics.engine.loop_pose import (
    CLOSURE_TOLERANCE_M,
    loop_closure,
    loop_rates,
    loop_residual_and_slope,
    loop_tip,
    residual_tolerance,
)
from fishtail_kinematics.engine.undulatory_tail import UndulatoryTail

G = UndulatoryGeometry()
SU, SW, AV, VW = G.pin_offset_m, G.swing_arm_m, G.slotted_link_m, G.fin_joint_offset_m


def _close(theta3: float, seed: float):
    c, s = math.cos(theta3), math.sin(theta3)
    return loop_closure(seed, SU * c, SU * s, SW * c, SW * s, AV, VW * VW, residual_tolerance(VW))


def test_the_closure_puts_w_at_vw_from_v_from_a_nearby_seed():
    for theta3 in (-0.4, 0.0, 0.3):
        a, au, cos4, sin4, ex, ey, residual, slope, closed = _close(theta3, 0.13)
        assert closed and abs(residual) < residual_tolerance(VW)
        v = np.array([-a, 0.0]) + AV * np.array([cos4, sin4])
        w = SW * np.array([math.cos(theta3), math.sin(theta3)])
        assert np.linalg.norm(w - v) == pytest.approx(VW, abs=2 * CLOSURE_TOLERANCE_M)
        assert au == pytest.approx(math.hypot(a + SU * math.cos(theta3), SU * math.sin(theta3)))
        assert (ex, ey) == pytest.approx(tuple(w - v), abs=1e-15)
        assert slope == pytest.approx(loop_residual_and_slope(a, math.cos(theta3),
                                      math.sin(theta3), SU, SW, AV, VW)[1], rel=1e-9)  # fmt: skip


def test_a_loop_that_cannot_close_says_so():
    # W on SW further from any V than AV + VW can reach: no root near the seed.
    c, s = math.cos(0.2), math.sin(0.2)
    *_, closed = loop_closure(0.14, SU * c, SU * s, 2.0 * c, 2.0 * s, AV, VW * VW, 1e-20)
    assert not closed


def test_the_slope_is_the_residual_s_derivative_and_arrays_match_floats():
    a = np.linspace(0.12, 0.16, 9)
    theta3 = np.linspace(-0.4, 0.4, 9)
    residual, slope = loop_residual_and_slope(a, np.cos(theta3), np.sin(theta3), SU, SW, AV, VW)
    h = 1e-7
    ahead, _ = loop_residual_and_slope(a + h, np.cos(theta3), np.sin(theta3), SU, SW, AV, VW)
    behind, _ = loop_residual_and_slope(a - h, np.cos(theta3), np.sin(theta3), SU, SW, AV, VW)
    np.testing.assert_allclose(slope, (ahead - behind) / (2 * h), rtol=1e-6)
    for index in range(a.size):
        one = loop_residual_and_slope(float(a[index]), math.cos(theta3[index]),
                                      math.sin(theta3[index]), SU, SW, AV, VW)  # fmt: skip
        assert one == pytest.approx((residual[index], slope[index]), rel=1e-13, abs=1e-17)


def test_the_rates_are_the_closure_s_derivatives_in_theta3():
    theta3, h = 0.25, 1e-6
    ahead, here, behind = (_close(theta3 + d, 0.14) for d in (h, 0.0, -h))
    a, au, cos4, sin4, ex, ey = here[:6]
    rates = loop_rates(1.0, math.cos(theta3), math.sin(theta3), cos4, sin4, ex / VW, ey / VW, au,
                       SU, SW, AV, VW)  # fmt: skip
    theta4 = [math.atan2(c[3], c[2]) for c in (ahead, behind)]
    theta5 = [math.atan2(c[5], c[4]) for c in (ahead, behind)]
    expected = ((theta4[0] - theta4[1]) / (2 * h), (ahead[1] - behind[1]) / (2 * h),
                (ahead[0] - behind[0]) / (2 * h), (theta5[0] - theta5[1]) / (2 * h))  # fmt: skip
    assert rates == pytest.approx(expected, rel=1e-6)


def test_the_tip_is_the_engine_s():
    tail = UndulatoryTail(G)
    state = tail.solve(np.linspace(0.0, 2.0 * math.pi, 17), 3.0)
    tip = loop_tip(G.pivot_offset_m, SW, G.fin_link_m - VW, np.cos(state.theta3),
                   np.sin(state.theta3), np.cos(state.theta5), np.sin(state.theta5),
                   state.theta3_dot, state.theta5_dot)  # fmt: skip
    for got, want in zip(tip, (state.tip_x, state.tip_y, state.tip_x_dot, state.tip_y_dot),
                         strict=True):  # fmt: skip
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)

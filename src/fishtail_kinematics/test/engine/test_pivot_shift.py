"""The pivot shift: S moved along the body axis, the tail link keeping its mounting on the rocker.

Expected values come from the spec's formulas written out here (the atan2 form of theta2, the
circle-intersection and fsolve oracles of conftest.py) and from invariants (link lengths, loop
closure, differences), not from the engine's own output.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from fishtail_kinematics.engine.errors import FishtailKinematicsError, PivotShiftError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

TWO_PI = 2.0 * math.pi
CYCLE = np.linspace(0.0, TWO_PI, 4001)
SHIFTS = (-0.04, -0.012, 0.007, 0.03)
#: A second loop whose branch folds (no pose) at SW = 0.536 rad: it, not the drive, bounds shifts.
FOLDING = {"pin_offset_m": 0.02}


def wrap(angle):
    """Angle difference wrapped into [-pi, pi]."""
    return np.remainder(np.asarray(angle) + math.pi, TWO_PI) - math.pi


def theta2_spec(op, ring, pr, rs, os_):
    """theta2 = atan2(OS, OP) + asin K, the spec's branch, written out independently."""
    k = (op**2 + rs**2 + os_**2 - pr**2) / (2.0 * rs * math.hypot(op, os_))
    return math.atan2(os_, op) + math.asin(k)


def monotone_mid(ring, pr, rs, os_):
    """Mid-swing when theta2 is monotone: its extremes are at OP = -R and R."""
    return 0.5 * (theta2_spec(ring, ring, pr, rs, os_) + theta2_spec(-ring, ring, pr, rs, os_))


def tails():
    return [OscillatoryTail(OscillatoryGeometry()), UndulatoryTail(UndulatoryGeometry())]


@pytest.fixture(scope="module", params=["oscillatory", "undulatory"])
def tail(request):
    return tails()[0 if request.param == "oscillatory" else 1]


# --- unshifted: nothing changes ---


def test_an_unshifted_tail_has_no_shift_and_no_bias(tail):
    assert tail.pivot_shift_m == 0.0 and tail.swing_bias_rad == 0.0
    assert tail.with_pivot_shift(0.0) is tail
    assert tail.with_pivot_shift(0.02).with_pivot_shift(0.0) is tail
    assert tail.shifted_geometry is tail.geometry
    assert tail.fin_angle_field() == "fin_angle"


def test_unshifted_fin_angle_is_the_last_links_angle_with_no_new_array(tail):
    state = tail.solve(CYCLE, 3.0)
    last = "theta5" if isinstance(tail, UndulatoryTail) else "theta3"
    assert state.fin_angle is getattr(state, last)
    assert state.fin_angle_dot is getattr(state, f"{last}_dot")
    scalar = tail.solve(1.3, 3.0)
    assert scalar.fin_angle == getattr(scalar, last)
    assert scalar.fin_angle_dot == getattr(scalar, f"{last}_dot")


# --- the drive: bias, mid-line, symmetry ---


@pytest.mark.parametrize("shift", [-0.06, *SHIFTS, 0.1])
def test_swing_bias_is_the_change_of_the_monotone_mid_swing(shift):
    """b(s) = mid(OS + s) - mid(OS), mid = [theta2(R) + theta2(-R)]/2 (theta2 monotone here)."""
    g = OscillatoryGeometry()
    ring, pr, rs, os_ = g.ring_radius_m, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m
    # theta2 is stationary only at OP* = sqrt(RS^2 - (OS' - PR)^2); outside the stroke here.
    assert rs**2 - (os_ + shift - pr) ** 2 >= ring**2
    expected = monotone_mid(ring, pr, rs, os_ + shift) - monotone_mid(ring, pr, rs, os_)
    shifted = OscillatoryTail(g).with_pivot_shift(shift)
    assert shifted.pivot_shift_m == shift
    assert shifted.swing_bias_rad == pytest.approx(expected, abs=1e-13)
    assert UndulatoryTail(UndulatoryGeometry()).with_pivot_shift(shift).swing_bias_rad == (
        pytest.approx(expected, abs=1e-13)
    )


def test_swing_bias_where_theta2_is_not_monotone(oracle):
    """With short PR the shifted swing has an inner extreme: the oracle's dense sweep finds it."""
    lengths = {"ring_radius_m": 0.1, "crank_link_m": 0.15, "rocker_link_m": 0.1}
    tail = OscillatoryTail(OscillatoryGeometry(pivot_offset_m=0.2, **lengths))
    for shift in (-0.02, 0.015):
        shifted = tail.with_pivot_shift(shift)
        assert not shifted.drive.monotone
        low, high, _, _ = oracle.theta2_extremes(0.1, 0.15, 0.1, 0.2 + shift)
        base_low, base_high, _, _ = oracle.theta2_extremes(0.1, 0.15, 0.1, 0.2)
        expected = 0.5 * (low + high) - 0.5 * (base_low + base_high)
        assert shifted.swing_bias_rad == pytest.approx(expected, abs=1e-9)


@pytest.mark.parametrize("shift", SHIFTS)
def test_theta3_swings_plus_minus_half_the_range_about_the_current_mid_line(shift, oracle):
    """theta3 = theta2 - mid(OS + s): its extremes are +-half the shifted range.

    Each extreme sits at OP = -R or R (carrier angle pi or 0), which the cycle's samples contain.
    """
    g = OscillatoryGeometry()
    shifted = OscillatoryTail(g).with_pivot_shift(shift)
    state = shifted.solve(CYCLE, 1.0)
    low, high, _, _ = oracle.theta2_extremes(0.1, 0.1, g.rocker_link_m, 0.2 + shift)
    half = 0.5 * (high - low)
    assert shifted.drive.swing_range_rad == pytest.approx(high - low, abs=1e-9)
    assert state.theta3.max() == pytest.approx(half, abs=1e-12)
    assert state.theta3.min() == pytest.approx(-half, abs=1e-12)
    # The closed-form range where theta2 is monotone: 2 atan(R / OS') whatever PR and RS.
    assert shifted.drive.swing_range_rad == pytest.approx(2 * math.atan(0.1 / (0.2 + shift)))


def test_a_shift_makes_the_symmetric_design_swing_unevenly_in_time():
    """The symmetric design swings evenly; a shifted one does not.

    The design has theta3 = 0 at mid-stroke (OP = 0). A shift breaks
    RS^2 = PR^2 + OS sqrt(OS^2 + R^2), so mid-stroke lands off the mid-line: by
    theta2(0) - mid(OS') (a few tenths of a degree per 5 mm here).
    """
    g = OscillatoryGeometry()
    ring, pr, rs, os_ = g.ring_radius_m, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m
    tail = OscillatoryTail(g)
    assert tail.solve(math.pi / 2).theta3 == pytest.approx(0.0, abs=1e-14)
    for shift in (-0.005, 0.005, 0.02):
        shifted_os = os_ + shift
        expected = theta2_spec(0.0, ring, pr, rs, shifted_os) - monotone_mid(
            ring, pr, rs, shifted_os
        )
        asymmetry = tail.with_pivot_shift(shift).solve(math.pi / 2).theta3
        assert asymmetry == pytest.approx(expected, abs=1e-13)
        assert 0.001 < abs(asymmetry) < math.radians(1.1)
        assert math.copysign(1.0, asymmetry) == -math.copysign(1.0, shift)


# --- poses with S shifted ---


@pytest.mark.parametrize("shift", SHIFTS)
def test_the_drive_closes_its_loop_about_the_shifted_pivot(shift, oracle):
    """theta1 and theta2 are the circle intersection of PR about P and RS about S' = (OS + s, 0)."""
    g = OscillatoryGeometry(phase_rad=0.4)
    state = OscillatoryTail(g).with_pivot_shift(shift).solve(CYCLE, 2.0)
    op = 0.1 * np.cos(CYCLE + 0.4)
    theta1, theta2 = oracle.theta12(op, 0.1, g.rocker_link_m, 0.2 + shift)
    assert np.abs(wrap(state.theta1 - theta1)).max() < 1e-12
    assert np.abs(wrap(state.theta2 - theta2)).max() < 1e-12


@pytest.mark.parametrize("shift", SHIFTS)
def test_the_tip_lies_at_st_from_the_shifted_pivot_along_the_fin_angle(shift):
    g = OscillatoryGeometry()
    tail = OscillatoryTail(g)
    shifted = tail.with_pivot_shift(shift)
    state = shifted.solve(CYCLE, 2.0)
    arm = (state.tip_x - (0.2 + shift)) + 1j * state.tip_y
    np.testing.assert_allclose(np.abs(arm), g.tail_link_m, rtol=0, atol=1e-14)
    assert np.abs(wrap(np.angle(arm) - state.fin_angle)).max() < 1e-13
    # The tail link keeps its mounting: its body-frame angle is theta2 - mid(OS).
    assert np.abs(wrap(state.fin_angle - (state.theta2 - tail.theta2_mid))).max() < 1e-14
    assert np.abs(state.fin_angle - (state.theta3 + shifted.swing_bias_rad)).max() < 1e-14
    np.testing.assert_array_equal(state.fin_angle_dot, state.theta2_dot)


@pytest.mark.parametrize("shift", SHIFTS)
def test_mechanism_2_closes_both_loops_about_the_shifted_pivot(shift, oracle):
    """Both loops close with S shifted, SW at theta3 + b from the body axis.

    A stays on the body axis; the four loop equations hold, and theta4, AU, AS, theta5 are the
    fsolve oracle's for SW's body-frame angle.
    """
    g = UndulatoryGeometry()
    shifted = UndulatoryTail(g).with_pivot_shift(shift)
    state = shifted.solve(CYCLE[::8], 2.0)
    arm = state.theta3 + shifted.swing_bias_rad
    residuals = oracle.loop_residuals(
        arm, state.theta4, state.pin_u_distance, state.slider_a_distance, state.theta5,
        oracle.REPORT,
    )  # fmt: skip
    assert max(np.abs(r).max() for r in residuals) < 1e-12
    expected = oracle.solve_undulatory(arm, oracle.REPORT)
    for got, want in zip(
        (state.theta4, state.pin_u_distance, state.slider_a_distance, state.theta5),
        expected,
        strict=True,
    ):
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-11)
    s_x = 0.2 + shift
    tip = s_x + 0.16 * np.exp(1j * arm) + 0.14 * np.exp(1j * state.theta5)
    assert np.abs(state.tip_x + 1j * state.tip_y - tip).max() < 1e-13
    np.testing.assert_array_equal(state.fin_angle, state.theta5)


def assert_rates_match_differences(tail, fields, speed=3.0, step=1e-6):
    phi = np.linspace(0.05, TWO_PI, 181)
    state = tail.solve(phi, speed)
    plus, minus = tail.solve(phi + step), tail.solve(phi - step)
    for field in fields:
        difference = np.asarray(getattr(plus, field)) - np.asarray(getattr(minus, field))
        if field.startswith(("theta", "fin")):
            difference = wrap(difference)
        expected = speed * difference / (2.0 * step)
        rate = "tip_x_dot" if field == "tip_x" else "tip_y_dot" if field == "tip_y" else (
            {"pin_u_distance": "pin_u_distance_rate",
             "slider_a_distance": "slider_a_distance_rate"}.get(field, f"{field}_dot")
        )  # fmt: skip
        error = np.abs(np.asarray(getattr(state, rate)) - expected).max()
        assert error < 1e-6 * speed, (field, error)


@pytest.mark.parametrize("shift", [-0.03, 0.05])
def test_rates_of_a_shifted_tail_match_finite_differences(shift):
    drive_fields = ("theta1", "theta2", "theta3", "tip_x", "tip_y", "fin_angle")
    oscillatory, undulatory = (tail.with_pivot_shift(shift) for tail in tails())
    assert_rates_match_differences(oscillatory, drive_fields)
    assert_rates_match_differences(
        undulatory,
        (*drive_fields, "theta4", "pin_u_distance", "slider_a_distance", "theta5"),
    )


@pytest.mark.parametrize("shift", [-0.05, 0.02, 0.09])
def test_scalar_and_array_paths_agree_when_shifted(tail, shift):
    shifted = tail.with_pivot_shift(shift)
    phis = np.linspace(-2.0, 8.0, 41)
    arrays = shifted.solve(phis, 5.0)
    out = shifted.solve(phis, 5.0, out=shifted.empty_state(phis.shape))
    for index, phi in enumerate(phis.tolist()):
        scalar = shifted.solve(phi, 5.0)
        for field, value in zip(scalar._fields, scalar, strict=True):
            expected = float(getattr(arrays, field)[index])
            assert value == pytest.approx(expected, abs=1e-12), field
            assert float(getattr(out, field)[index]) == expected, field


# --- feasible shifts ---


def test_the_oscillatory_range_is_the_assembly_conditions_with_os_plus_s():
    g = OscillatoryGeometry(rocker_link_m=0.25, crank_link_m=0.12, ring_radius_m=0.08)
    low = abs(0.25 - 0.12) - 0.2
    high = math.sqrt((0.25 + 0.12) ** 2 - 0.08**2) - 0.2
    tail = OscillatoryTail(g)
    assert tail.pivot_shift_range() == pytest.approx((low, high), abs=1e-15)
    for inside in (low + 1e-9, high - 1e-9):
        tail.with_pivot_shift(inside).solve(CYCLE)
    for outside in (low, low - 0.01, high, high + 1e-6):
        with pytest.raises(PivotShiftError, match=re.escape(f"{low:.6f} m < shift < {high:.6f} m")):
            tail.with_pivot_shift(outside)


def test_the_default_undulatory_range_is_the_drives():
    """The report's second loop follows SW wherever the drive can take it."""
    oscillatory, undulatory = tails()
    assert undulatory.pivot_shift_range() == oscillatory.pivot_shift_range()


def independent_loop_residual(arm, slider_a, g):
    """|W - V|^2 - VW^2 for SW at ``arm`` from the body axis and AS = ``slider_a`` (from S)."""
    u = g.pin_offset_m * np.exp(1j * arm)
    a = -slider_a
    v = a + g.slotted_link_m * (u - a) / np.abs(u - a)
    w = g.swing_arm_m * np.exp(1j * arm)
    return np.abs(w - v) ** 2 - g.fin_joint_offset_m**2


def test_where_the_second_loop_folds_it_bounds_the_shifts(oracle):
    g = UndulatoryGeometry(**FOLDING)
    tail = UndulatoryTail(g)
    drive_low, drive_high = tail.drive.pivot_shift_range()
    low, high = tail.pivot_shift_range()
    assert drive_low < low < 0.0 < high <= drive_high
    assert high - low > 0.05
    # Just inside: both loops close over the stroke (fsolve agrees at the extremes).
    shifted = tail.with_pivot_shift(low + 1e-6)
    state = shifted.solve(CYCLE[::4])
    arm = state.theta3 + shifted.swing_bias_rad
    lengths = oracle.REPORT.__class__(**{**vars(oracle.REPORT), "SU": 0.02})
    expected = oracle.solve_undulatory(arm, lengths)
    np.testing.assert_allclose(state.slider_a_distance, expected[2], rtol=0, atol=1e-11)
    # Just outside: SW would have to swing a little further, to an angle where the loop has no
    # pose at all: |W - V| = VW for no slider position between S and beyond the slot's length.
    with pytest.raises(PivotShiftError, match="second loop") as refused:
        tail.with_pivot_shift(low - 1e-3)
    assert f"{low:.6f} m < shift < {high:.6f} m" in str(refused.value)
    drive = tail.drive.with_pivot_shift(low - 1e-3)
    farthest = drive.theta2_max - tail.drive.theta2_mid
    assert farthest > float(np.max(arm))
    sliders = np.linspace(1e-4, 0.3, 300001)
    assert np.all(independent_loop_residual(farthest, sliders, g) > 0.0)
    # Where the shift is feasible the loop does have poses at SW's farthest angle.
    assert np.any(independent_loop_residual(float(np.max(arm)), sliders, g) < 0.0)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_non_finite_shift_is_refused_naming_the_range(tail, bad):
    low, high = tail.pivot_shift_range()
    with pytest.raises(PivotShiftError, match="finite") as refused:
        tail.with_pivot_shift(bad)
    assert f"{low:.6f} m < shift < {high:.6f} m" in str(refused.value)
    assert isinstance(refused.value, FishtailKinematicsError)


def test_shifts_are_measured_from_the_design():
    tail = OscillatoryTail(OscillatoryGeometry())
    once = tail.with_pivot_shift(0.01)
    again = once.with_pivot_shift(0.03)
    direct = tail.with_pivot_shift(0.03)
    assert again.pivot_shift_m == 0.03
    assert again.swing_bias_rad == direct.swing_bias_rad
    assert again.shifted_geometry.pivot_offset_m == pytest.approx(0.23, abs=1e-15)
    assert again.geometry is tail.geometry  # the design's lengths, S unshifted

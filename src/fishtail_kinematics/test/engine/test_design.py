"""Tests of the design helpers against the spec's conditions and independent oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.design import (
    FinRatioFit,
    assembly_interval,
    design_summary,
    fit_fin_ratio,
    pivot_shift_effect,
    swing_range_vs_pivot_offset,
    symmetric_rocker_link,
)
from fishtail_kinematics.engine.errors import DesignError, PivotShiftError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

REPORT_RS = math.sqrt(0.1**2 + 0.2 * math.hypot(0.2, 0.1))
# The symmetric RS of this drive leaves theta2 non-monotone (stationary inside the stroke).
NON_MONOTONE_SYMMETRIC = {"ring_radius_m": 0.3, "crank_link_m": 0.2, "pivot_offset_m": 0.1}


def closes_over_stroke(ring, pr, rs, os_, samples=2001):
    """Whether circle (P, PR) meets circle (S, RS) at two distinct points for every |OP| <= R."""
    if not os_ > 0.0:
        return False
    distance = np.hypot(np.linspace(-ring, ring, samples), os_)
    return bool(np.all((abs(pr - rs) < distance) & (distance < pr + rs)))


@pytest.mark.parametrize(
    ("ring", "pr", "rs"), [(0.1, 0.1, REPORT_RS), (0.1, 0.3, 0.12), (0.05, 0.2, 0.25)]
)
def test_assembly_interval_ends(ring, pr, rs):
    """Just inside both ends the loop closes over the stroke; just outside it does not."""
    low, high = assembly_interval(ring, pr, rs)
    assert 0.0 <= low < high
    for inside in (low * (1 + 1e-9) + 1e-12, 0.5 * (low + high), high * (1 - 1e-9)):
        assert closes_over_stroke(ring, pr, rs, inside)
    for outside in (low * (1 - 1e-9), high * (1 + 1e-9)):
        assert not closes_over_stroke(ring, pr, rs, outside)


def test_assembly_interval_report():
    """The report's drive assembles for 0.133926 < OS < 0.318601."""
    low, high = assembly_interval(0.1, 0.1, REPORT_RS)
    assert low == pytest.approx(REPORT_RS - 0.1, abs=1e-15)
    assert high**2 + 0.1**2 == pytest.approx((REPORT_RS + 0.1) ** 2, abs=1e-15)
    assert (round(low, 6), round(high, 6)) == (0.133926, 0.318601)


@pytest.mark.parametrize(("ring", "pr", "rs"), [(0.5, 0.1, 0.1), (0.35, 0.1, 0.3), (0.2, 0.1, 0.1)])
def test_assembly_interval_empty(ring, pr, rs):
    """No OS closes the loop: DesignError naming both bounds."""
    for os_ in np.linspace(0.001, 1.0, 1000):
        assert not closes_over_stroke(ring, pr, rs, os_)
    with pytest.raises(DesignError, match=r"\|RS - PR\|.*< OS <"):
        assembly_interval(ring, pr, rs)


def test_swing_range_nan_exactly_outside_interval(oracle):
    """NaN exactly where the loop cannot close, else the true range (2 atan(R/OS) if monotone)."""
    geometry = OscillatoryGeometry()
    ring, pr, rs = 0.1, 0.1, REPORT_RS
    low, high = REPORT_RS - 0.1, math.sqrt((REPORT_RS + 0.1) ** 2 - 0.01)
    offsets = np.concatenate(
        [np.linspace(-0.1, 0.5, 61), [low, high, low * (1 + 1e-9), high * (1 - 1e-9),
                                      low * (1 - 1e-9), high * (1 + 1e-9)]]
    )  # fmt: skip
    ranges = swing_range_vs_pivot_offset(geometry, offsets)
    assert ranges.shape == offsets.shape
    for os_, value in zip(offsets, ranges, strict=True):
        inside = low < os_ < high
        assert np.isnan(value) != inside, os_
        assert inside == closes_over_stroke(ring, pr, rs, os_) or abs(os_ - low) < 1e-6, os_
        if not inside:
            continue
        lowest, highest, _, _ = oracle.theta2_extremes(ring, pr, rs, os_, samples=20001)
        assert value == pytest.approx(highest - lowest, abs=1e-9), os_
        if rs**2 > (os_ - pr) ** 2 + ring**2:  # monotone
            assert value == pytest.approx(2.0 * math.atan(ring / os_), abs=1e-12), os_


def test_swing_range_with_rederived_rocker():
    """With the symmetric RS per OS the range is 2 atan(R/OS); NaN where that RS is refused."""
    offsets = np.array([-0.05, 0.0, 0.05, 0.1, 0.2, 0.4])
    ranges = swing_range_vs_pivot_offset(OscillatoryGeometry(), offsets, rederive_rocker=True)
    assert np.isnan(ranges[:2]).all()
    assert ranges[2:] == pytest.approx(2.0 * np.arctan(0.1 / offsets[2:]), abs=1e-12)
    geometry = OscillatoryGeometry(ring_radius_m=0.3, crank_link_m=0.2, rocker_link_m=0.27)
    ranges = swing_range_vs_pivot_offset(geometry, np.array([0.1]), rederive_rocker=True)
    assert np.isnan(ranges).all()


def test_symmetric_rocker_link_non_monotone_raises(oracle):
    """Where the closed-form RS leaves theta2 non-monotone it is not symmetric, and is refused."""
    ring, pr, os_ = 0.3, 0.2, 0.1
    rs = math.sqrt(pr**2 + os_ * math.hypot(os_, ring))
    lowest, highest, _, _ = oracle.theta2_extremes(ring, pr, rs, os_)
    middle = float(oracle.theta12(0.0, pr, rs, os_)[1])
    assert abs((highest - middle) - (middle - lowest)) > 1e-3  # really asymmetric
    with pytest.raises(DesignError, match="non-monotone"):
        symmetric_rocker_link(ring, pr, os_)


def test_symmetric_rocker_link_not_assembling_raises():
    """A symmetric RS that cannot assemble is a DesignError, not a silent value."""
    with pytest.raises(DesignError, match="does not assemble"):
        symmetric_rocker_link(0.1, 0.005, 0.2)


def own_fin_fit(geometry, samples, oracle):
    """mu, rms and max deviation, local ratios: theta3 from circles, theta5 from fsolve."""
    phi = np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)
    op = geometry.ring_radius_m * np.cos(phi + geometry.phase_rad)
    args = (geometry.crank_link_m, geometry.rocker_link_m, geometry.pivot_offset_m)
    _, ends = oracle.theta12(np.array([-geometry.ring_radius_m, geometry.ring_radius_m]), *args)
    theta3 = oracle.theta12(op, *args)[1] - ends.mean()
    g = oracle.REPORT.__class__(
        SU=geometry.pin_offset_m, SW=geometry.swing_arm_m, AV=geometry.slotted_link_m,
        VW=geometry.fin_joint_offset_m,
    )  # fmt: skip
    theta5 = oracle.solve_undulatory(theta3, g)[3]
    mu = float(np.sum(theta3 * theta5) / np.sum(theta3 * theta3))
    deviation = theta5 - mu * theta3
    outer = np.abs(theta3) > 0.5 * np.abs(theta3).max()
    ratio = theta5[outer] / theta3[outer]
    return mu, np.sqrt(np.mean(deviation**2)), np.abs(deviation).max(), ratio.min(), ratio.max()


@pytest.mark.parametrize("pin", [0.08, 0.03])
def test_fit_fin_ratio_matches_own_fit(pin, oracle):
    """The fitted mu is in (0, 3), its deviation small but non-zero, as computed independently."""
    geometry = UndulatoryGeometry(pin_offset_m=pin)
    fit = fit_fin_ratio(geometry, samples=720)
    assert isinstance(fit, FinRatioFit)
    mu, rms, worst, ratio_min, ratio_max = own_fin_fit(geometry, 720, oracle)
    assert fit.mu == pytest.approx(mu, abs=1e-9)
    assert fit.rms_deviation_rad == pytest.approx(rms, abs=1e-9)
    assert fit.max_deviation_rad == pytest.approx(worst, abs=1e-9)
    assert fit.local_ratio_min == pytest.approx(ratio_min, abs=1e-9)
    assert fit.local_ratio_max == pytest.approx(ratio_max, abs=1e-9)
    assert 0.0 < fit.mu < 3.0
    assert 1e-5 < fit.rms_deviation_rad <= fit.max_deviation_rad < 0.1
    assert fit.local_ratio_min <= fit.mu <= fit.local_ratio_max


def test_fin_ratio_depends_on_pin_not_fin_length():
    """The fitted mu changes with SU and not with VT."""
    base = fit_fin_ratio(UndulatoryGeometry(), samples=360).mu
    longer_fin = fit_fin_ratio(UndulatoryGeometry(fin_link_m=0.35), samples=360).mu
    other_pin = fit_fin_ratio(UndulatoryGeometry(pin_offset_m=0.05), samples=360).mu
    assert longer_fin == pytest.approx(base, abs=1e-12)
    assert abs(other_pin - base) > 0.05


COMMON_KEYS = {
    "symmetric_rocker_link_m", "rocker_link_m", "swing_range_rad", "swing_range_deg",
    "theta2_min_rad", "theta2_max_rad", "theta2_monotone", "swing_asymmetry_rad",
    "assembly_pivot_offset_min_m", "assembly_pivot_offset_max_m",
}  # fmt: skip
FIN_KEYS = {
    "fin_ratio_mu", "fin_ratio_rms_deviation_rad", "fin_ratio_max_deviation_rad",
    "fin_ratio_local_min", "fin_ratio_local_max",
}  # fmt: skip


def test_design_summary_oscillatory(oracle):
    """Keys of mechanism 1, and values against the oracle for RS = 0.234."""
    summary = design_summary(OscillatoryGeometry(rocker_link_m=0.234))
    assert set(summary) == COMMON_KEYS
    _, (low, middle, high) = oracle.theta12(np.array([0.1, 0.0, -0.1]), 0.1, 0.234, 0.2)
    assert summary["theta2_min_rad"] == pytest.approx(low, abs=1e-12)
    assert summary["theta2_max_rad"] == pytest.approx(high, abs=1e-12)
    assert summary["swing_range_deg"] == pytest.approx(53.130102354, abs=1e-8)
    asymmetry = (high - middle) - (middle - low)
    assert summary["swing_asymmetry_rad"] == pytest.approx(asymmetry, abs=1e-12)
    assert 1e-5 < abs(asymmetry) < 1e-3
    assert summary["theta2_monotone"] is True
    assert summary["symmetric_rocker_link_m"] == pytest.approx(REPORT_RS, abs=1e-15)
    assert summary["assembly_pivot_offset_min_m"] == pytest.approx(0.134, abs=1e-12)


def test_design_summary_undulatory():
    """Mechanism 2 adds the fin-ratio figures; the default drive is exactly symmetric."""
    summary = design_summary(UndulatoryGeometry())
    assert set(summary) == COMMON_KEYS | FIN_KEYS
    assert summary["swing_asymmetry_rad"] == pytest.approx(0.0, abs=1e-12)
    assert 0.0 < summary["fin_ratio_mu"] < 3.0


def test_design_summary_without_symmetric_rocker():
    """Where no symmetric RS exists the summary says why instead of failing."""
    rs = math.sqrt(0.2**2 + 0.1 * math.hypot(0.1, 0.3))
    summary = design_summary(OscillatoryGeometry(**NON_MONOTONE_SYMMETRIC, rocker_link_m=rs))
    assert str(summary["symmetric_rocker_link_m"]).startswith("none (")
    assert summary["theta2_monotone"] is False


def test_pivot_shift_effect_of_the_report_drive():
    """The fin's extremes are the bias -+ half the range, exactly.

    Where theta2 is monotone its extremes sit at OP = -R and R, which a revolution of samples
    starting at phi = 0 contains.
    """
    tail = OscillatoryTail(OscillatoryGeometry())
    unshifted = pivot_shift_effect(tail, 0.0)
    assert unshifted.swing_bias_rad == 0.0
    assert unshifted.mid_stroke_theta3_rad == pytest.approx(0.0, abs=1e-12)  # symmetric design
    assert unshifted.swing_range_rad == pytest.approx(2 * math.atan(0.5), abs=1e-12)
    shifted = pivot_shift_effect(tail, 0.02)
    half = math.atan(0.1 / 0.22)
    assert shifted.swing_range_rad == pytest.approx(2 * half, abs=1e-12)
    assert shifted.swing_bias_rad == tail.with_pivot_shift(0.02).swing_bias_rad
    assert shifted.fin_max_rad == pytest.approx(shifted.swing_bias_rad + half, abs=1e-12)
    assert shifted.fin_min_rad == pytest.approx(shifted.swing_bias_rad - half, abs=1e-12)
    assert shifted.fin_min_rad < shifted.fin_mean_rad < shifted.fin_max_rad
    with pytest.raises(PivotShiftError):
        pivot_shift_effect(tail, -0.1)


def test_pivot_shift_effect_of_mechanism_2_takes_the_fin_link():
    tail = UndulatoryTail(UndulatoryGeometry())
    effect = pivot_shift_effect(tail, -0.03, samples=720)
    fin = tail.with_pivot_shift(-0.03).solve(np.linspace(0.0, 2 * math.pi, 720, endpoint=False))
    assert effect.fin_max_rad == float(fin.theta5.max())
    assert effect.fin_mean_rad == pytest.approx(float(fin.theta5.mean()), abs=1e-15)
    assert (
        effect.swing_bias_rad
        == pivot_shift_effect(OscillatoryTail(OscillatoryGeometry()), -0.03).swing_bias_rad
    )

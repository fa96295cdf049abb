"""Pure-logic tests of the tail linkages, checked against independent oracles (see conftest.py)."""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from fishtail_kinematics.engine.design import symmetric_rocker_link
from fishtail_kinematics.engine.errors import (
    AssemblyError,
    InvalidInputError,
    InvalidLengthError,
    PinOffsetError,
)
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

TWO_PI = 2.0 * math.pi
CYCLE = np.linspace(0.0, TWO_PI, 4001)
REPORT_RS = math.sqrt(0.1**2 + 0.2 * math.hypot(0.2, 0.1))
NON_MONOTONE = {"ring_radius_m": 0.1, "crank_link_m": 0.15, "pivot_offset_m": 0.2,
                "rocker_link_m": 0.1}  # fmt: skip
OSCILLATORY_FIELDS = ("theta1", "theta2", "theta3", "tip_x", "tip_y")
UNDULATORY_FIELDS = (
    *OSCILLATORY_FIELDS, "theta4", "pin_u_distance", "slider_a_distance", "theta5"
)  # fmt: skip
RATE_OF = {
    "theta1": "theta1_dot", "theta2": "theta2_dot", "theta3": "theta3_dot",
    "tip_x": "tip_x_dot", "tip_y": "tip_y_dot", "theta4": "theta4_dot",
    "pin_u_distance": "pin_u_distance_rate", "slider_a_distance": "slider_a_distance_rate",
    "theta5": "theta5_dot",
}  # fmt: skip


def wrap(angle):
    """Angle difference wrapped into [-pi, pi]."""
    return np.remainder(np.asarray(angle) + math.pi, TWO_PI) - math.pi


def oscillatory(**lengths):
    """Mechanism 1 with the report geometry, some lengths replaced."""
    return OscillatoryTail(OscillatoryGeometry(**lengths))


def closure(state, g):
    """Loop-closure residuals of mechanism 1 (spec equations) from a solved state."""
    os_, pr, rs = g.pivot_offset_m, g.crank_link_m, g.rocker_link_m
    op = g.ring_radius_m * np.cos(np.asarray(state.motor_angle) + g.phase_rad)
    first = pr * np.cos(state.theta1) - rs * np.cos(state.theta2) - os_
    second = pr * np.sin(state.theta1) + rs * np.sin(state.theta2) - op
    return np.maximum(np.abs(first), np.abs(second)), op


def branch_cross(state, g):
    """(S - P) x (Rj - P) with Rj = S + RS e(theta2)."""
    os_, rs = g.pivot_offset_m, g.rocker_link_m
    op = g.ring_radius_m * np.cos(np.asarray(state.motor_angle) + g.phase_rad)
    rx, ry = os_ + rs * np.cos(state.theta2), rs * np.sin(state.theta2)
    return os_ * (ry - op) - (-op) * rx


# --- mechanism 1: closure, branch, agreement with the circle-intersection oracle ---


@pytest.mark.parametrize(
    "lengths",
    [{}, {"rocker_link_m": 0.234}, NON_MONOTONE, {"phase_rad": 1.3},
     {"ring_radius_m": 0.05, "crank_link_m": 0.3, "rocker_link_m": 0.12, "pivot_offset_m": 0.25}],
)  # fmt: skip
def test_oscillatory_loop_closure_and_branch(lengths, oracle):
    """Returned theta1, theta2 close the loop to 1e-12 m on the branch left of P->S."""
    tail = oscillatory(**lengths)
    g = tail.geometry
    state = tail.solve(np.linspace(-3.0, 9.0, 20001), 2.0)
    residual, op = closure(state, g)
    assert residual.max() < 1e-12
    assert branch_cross(state, g).min() > 0.0
    theta1, theta2 = oracle.theta12(op, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m)
    assert np.abs(wrap(state.theta2 - theta2)).max() < 1e-12
    assert np.abs(wrap(state.theta1 - theta1)).max() < 1e-12


def test_oscillatory_report_values(oracle):
    """Report geometry: 53.13 deg swing, tip at the documented pose at phi = 0."""
    tail = oscillatory()
    assert math.degrees(tail.swing_range_rad) == pytest.approx(53.130102354, abs=1e-8)
    assert tail.swing_range_rad == pytest.approx(2.0 * math.atan(0.1 / 0.2), abs=1e-12)
    state = tail.solve(0.0, 4.0)
    # phi = 0: OP = R, theta2 is at its minimum, theta3 = -swing / 2.
    assert state.theta3 == pytest.approx(-math.atan(0.5), abs=1e-12)
    assert state.tip_x == pytest.approx(0.2 + 0.15 * math.cos(math.atan(0.5)), abs=1e-12)
    assert state.tip_y == pytest.approx(-0.15 * math.sin(math.atan(0.5)), abs=1e-12)
    assert state.theta2_dot == 0.0  # OP_dot = -R phi_dot sin(0)


@pytest.mark.parametrize("ring", [0.05, 0.1, 0.15])
@pytest.mark.parametrize(
    "crank_rocker", [(0.1, REPORT_RS), (0.08, 0.25), (0.2, 0.3), (0.3, 0.45), (0.25, 0.2)]
)
def test_swing_range_independent_of_links_when_monotone(ring, crank_rocker, oracle):
    """Monotone theta2: range = 2 atan(R/OS), whatever PR and RS; extremes at OP = -R, R."""
    pr, rs = crank_rocker
    os_ = 0.2
    assert rs**2 > (os_ - pr) ** 2 + ring**2  # monotone by the spec's criterion
    tail = oscillatory(ring_radius_m=ring, crank_link_m=pr, rocker_link_m=rs, pivot_offset_m=os_)
    assert tail.monotone
    _, ends = oracle.theta12(np.array([-ring, ring]), pr, rs, os_)
    assert abs(wrap(ends[0] - ends[1])) == pytest.approx(2.0 * math.atan(ring / os_), abs=1e-12)
    assert tail.swing_range_rad == pytest.approx(2.0 * math.atan(ring / os_), abs=1e-12)
    state = tail.solve(CYCLE)
    assert state.theta3.max() == pytest.approx(-state.theta3.min(), abs=1e-12)
    assert state.theta3.max() == pytest.approx(math.atan(ring / os_), abs=1e-12)


def test_theta3_symmetric_non_monotone(oracle):
    """Non-monotone drive: max theta3 = -min theta3 over a cycle, at the true extremes."""
    tail = oscillatory(**NON_MONOTONE)
    state = tail.solve(np.linspace(0.0, TWO_PI, 200001))
    assert state.theta3.max() == pytest.approx(-state.theta3.min(), abs=1e-9)


# --- symmetric rocker ---


def test_symmetric_rocker_link_report(oracle):
    """RS = sqrt(PR^2 + OS sqrt(OS^2 + R^2)) = 0.233926 makes theta2(OP=0) the exact mid-swing."""
    rs = symmetric_rocker_link(0.1, 0.1, 0.2)
    assert rs == pytest.approx(math.sqrt(0.01 + 0.2 * math.sqrt(0.05)), rel=1e-15)
    assert abs(rs - 0.233926) < 5e-7
    _, (theta_low, theta_mid, theta_high) = oracle.theta12(np.array([0.1, 0.0, -0.1]), 0.1, rs, 0.2)
    assert (theta_high - theta_mid) - (theta_mid - theta_low) == pytest.approx(0.0, abs=1e-12)
    tail = oscillatory(rocker_link_m=rs)
    assert tail.solve(math.pi / 2.0).theta3 == pytest.approx(0.0, abs=1e-12)
    assert tail.theta2_mid == pytest.approx(theta_mid, abs=1e-12)


def test_report_rocker_0234_is_off_by_about_0005_deg(oracle):
    """RS = 0.234 (the report's rounding) puts mid-stroke about 0.005 deg off mid-swing."""
    _, (theta_low, theta_mid, theta_high) = oracle.theta12(
        np.array([0.1, 0.0, -0.1]), 0.1, 0.234, 0.2
    )
    offset = math.degrees(theta_mid - 0.5 * (theta_low + theta_high))
    assert 1e-3 < abs(offset) < 1e-2
    state = oscillatory(rocker_link_m=0.234).solve(math.pi / 2.0)  # OP = 0
    assert math.degrees(state.theta3) == pytest.approx(offset, abs=1e-10)


# --- feasibility ---

EPS = 1e-9


@pytest.mark.parametrize(
    ("lengths", "outside", "condition"),
    [
        # RS - PR = OS
        ({"crank_link_m": 0.1, "pivot_offset_m": 0.2}, {"rocker_link_m": 0.3}, "|RS - PR| < OS"),
        # PR - RS = OS
        ({"rocker_link_m": 0.1, "pivot_offset_m": 0.2}, {"crank_link_m": 0.3}, "|RS - PR| < OS"),
        # RS + PR = sqrt(OS^2 + R^2)
        ({"crank_link_m": 0.1, "pivot_offset_m": 0.2},
         {"rocker_link_m": math.sqrt(0.05) - 0.1}, "OS^2 + R^2 < (RS + PR)^2"),
    ],
)  # fmt: skip
def test_feasibility_boundaries(lengths, outside, condition, oracle):
    """Just inside each boundary the loop closes; just outside it raises naming the condition."""
    ((name, boundary),) = outside.items()
    # Which way is inside: RS (or PR) shorter for the first two, longer for the third.
    inward = -1.0 if condition == "|RS - PR| < OS" else 1.0
    tail = oscillatory(**lengths, **{name: boundary + inward * EPS})
    state = tail.solve(np.linspace(0.0, TWO_PI, 721))
    assert np.all(np.isfinite(state.theta2))
    assert closure(state, tail.geometry)[0].max() < 1e-9
    with pytest.raises(AssemblyError, match=re.escape(condition)):
        oscillatory(**lengths, **{name: boundary - inward * EPS})


def test_both_conditions_named():
    """A geometry failing both conditions names both."""
    with pytest.raises(AssemblyError) as info:
        oscillatory(ring_radius_m=1.0, crank_link_m=0.5, rocker_link_m=0.1, pivot_offset_m=0.3)
    assert "|RS - PR| < OS" in str(info.value)
    assert "OS^2 + R^2 < (RS + PR)^2" in str(info.value)


@pytest.mark.parametrize(
    "name", ["ring_radius_m", "crank_link_m", "rocker_link_m", "tail_link_m", "pivot_offset_m"]
)
@pytest.mark.parametrize("value", [0.0, -0.1, math.nan, math.inf, -math.inf])
def test_invalid_lengths(name, value):
    """Non-positive, NaN and infinite lengths raise InvalidLengthError naming the length."""
    with pytest.raises(InvalidLengthError, match=name):
        OscillatoryGeometry(**{name: value})
    with pytest.raises(InvalidLengthError, match=name if name != "tail_link_m" else "swing"):
        UndulatoryGeometry(**{name if name != "tail_link_m" else "swing_arm_m": value})


@pytest.mark.parametrize("value", [math.nan, math.inf])
def test_invalid_phase(value):
    """The phase may be negative but not NaN or infinite."""
    assert OscillatoryGeometry(phase_rad=-2.0).phase_rad == -2.0
    with pytest.raises(InvalidLengthError, match="phase_rad"):
        OscillatoryGeometry(phase_rad=value)


# --- non-monotone drive ---


def test_non_monotone_extremes_are_exact(oracle):
    """Non-monotone theta2: the engine's extremes are the true ones, not those at OP = -R, R."""
    tail = oscillatory(**NON_MONOTONE)
    assert not tail.monotone
    ring, pr, rs, os_ = 0.1, 0.15, 0.1, 0.2
    ops = np.linspace(-ring, ring, 2_000_001)
    theta2 = np.unwrap(oracle.theta12(ops, pr, rs, os_)[1])
    shift = tail.theta2_at(0.0) - theta2[len(ops) // 2]
    assert abs(wrap(shift)) < 1e-12
    theta2 = theta2 + shift
    assert theta2.max() - 1e-15 <= tail.theta2_max <= theta2.max() + 1e-9
    assert theta2.min() - 1e-9 <= tail.theta2_min <= theta2.min() + 1e-15
    # At least one extreme is interior and clearly beyond the end values.
    ends = theta2[[0, -1]]
    assert tail.theta2_min < ends.min() - 1e-3 or tail.theta2_max > ends.max() + 1e-3
    interior = [ops[np.argmin(theta2)], ops[np.argmax(theta2)]]
    assert max(ring - abs(op) for op in interior) > 1e-3
    # Bounded Brent on the oracle (plus the two ends, which Brent never evaluates) agrees.
    for sign, extreme in ((1.0, tail.theta2_min), (-1.0, tail.theta2_max)):

        def objective(op, sign=sign):
            return sign * (float(oracle.theta12(op, pr, rs, os_)[1]) + shift)

        result = minimize_scalar(
            objective, bounds=(-ring, ring), method="bounded", options={"xatol": 1e-12}
        )
        best = min(result.fun, objective(-ring), objective(ring))
        assert sign * best == pytest.approx(extreme, abs=1e-10)
        assert best >= sign * extreme - 1e-12  # nothing beyond the engine's extreme


def test_stationary_slider_positions_are_stationary(oracle):
    """Each reported stationary OP has d(theta2)/d(OP) = 0 on the assembly branch.

    There sin(theta1) = 0 with theta1 = 0 (theta1 = pi needs RS > OS + PR, which cannot
    assemble), so R = (PR, OP), and (S - P) x (R - P) = PR OP > 0 puts it at OP > 0 only.
    """
    tail = oscillatory(**NON_MONOTONE)
    assert tail.stationary_slider_positions, "expected an interior stationary point"
    step = 1e-6
    for op in tail.stationary_slider_positions:
        _, (before, after) = oracle.theta12(np.array([op - step, op + step]), 0.15, 0.1, 0.2)
        assert abs(after - before) / (2.0 * step) < 1e-6, op


def test_non_monotone_swing_range_exceeds_closed_form():
    """Where theta2 is not monotone the range is not 2 atan(R/OS)."""
    tail = oscillatory(**NON_MONOTONE)
    assert abs(tail.swing_range_rad - 2.0 * math.atan(0.1 / 0.2)) > 1e-3


# --- rates against central differences ---

PHASES = (0.0, 1.1, -2.5)
SPEEDS = (-3.0, 2.0 * math.pi * 4.0, 0.5)


def check_rates(tail, fields, phi, speed, step, tolerance):
    """Every rate field equals speed * d(position)/d(phi) by a central difference."""
    state = tail.solve(phi, speed)
    plus, minus = tail.solve(phi + step), tail.solve(phi - step)
    for field in fields:
        difference = np.asarray(getattr(plus, field)) - np.asarray(getattr(minus, field))
        if field.startswith("theta"):
            difference = wrap(difference)
        expected = speed * difference / (2.0 * step)
        actual = np.asarray(getattr(state, RATE_OF[field]))
        error = np.abs(actual - expected).max()
        assert error < tolerance * max(1.0, abs(speed)), (field, error)


@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("speed", SPEEDS)
@pytest.mark.parametrize("lengths", [{}, NON_MONOTONE])
def test_oscillatory_rates_match_finite_differences(lengths, phase, speed):
    """theta1, theta2, theta3 and tip rates of mechanism 1 vs central differences."""
    tail = oscillatory(**lengths, phase_rad=phase)
    check_rates(tail, OSCILLATORY_FIELDS, np.linspace(0.0, TWO_PI, 257), speed, 1e-5, 1e-7)


@pytest.mark.parametrize("phase", PHASES)
@pytest.mark.parametrize("speed", SPEEDS)
def test_undulatory_rates_match_finite_differences(phase, speed):
    """All rates of mechanism 2 (theta4, AU, AS, theta5, tip...) vs central differences."""
    tail = UndulatoryTail(UndulatoryGeometry(phase_rad=phase))
    check_rates(tail, UNDULATORY_FIELDS, np.linspace(0.0, TWO_PI, 257), speed, 1e-4, 1e-6)


def test_undulatory_rates_scalar_path():
    """The scalar path's rates also match central differences."""
    tail = UndulatoryTail(UndulatoryGeometry(pin_offset_m=0.05))
    for phi in (0.3, 1.7, 4.0):
        check_rates(tail, UNDULATORY_FIELDS, phi, 7.0, 1e-4, 1e-6)


# --- mechanism 2 ---


def undulatory_points(state, g):
    """A, V, W, T as complex numbers from a solved mechanism-2 state."""
    a = (g.pivot_offset_m - np.asarray(state.slider_a_distance)) + 0j
    v = a + g.slotted_link_m * np.exp(1j * np.asarray(state.theta4))
    w = g.pivot_offset_m + g.swing_arm_m * np.exp(1j * np.asarray(state.theta3))
    t = np.asarray(state.tip_x) + 1j * np.asarray(state.tip_y)
    return a, v, w, t


@pytest.mark.parametrize("pin", [0.02, 0.08, 0.099])
def test_undulatory_loop_equations_and_tip(pin, oracle):
    """Four loop equations < 1e-12 m; V, W, T collinear with W between; T = S + SW e3 + WT e5."""
    g = UndulatoryGeometry(pin_offset_m=pin)
    state = UndulatoryTail(g).solve(np.linspace(0.0, TWO_PI, 5001), 3.0)
    lengths = oracle.REPORT.__class__(**{**vars(oracle.REPORT), "SU": pin})
    residuals = oracle.loop_residuals(
        state.theta3, state.theta4, state.pin_u_distance, state.slider_a_distance, state.theta5,
        lengths,
    )  # fmt: skip
    assert max(np.abs(r).max() for r in residuals) < 1e-12
    _, v, w, t = undulatory_points(state, g)
    assert np.abs(np.abs(w - v) - 0.06).max() < 1e-12
    assert np.abs(np.abs(t - w) - 0.14).max() < 1e-12
    assert np.abs(np.abs(t - v) - 0.2).max() < 1e-12
    expected = 0.2 + 0.16 * np.exp(1j * state.theta3) + 0.14 * np.exp(1j * state.theta5)
    assert np.abs(t - expected).max() < 1e-12
    # U = S + SU e(theta3) lies on AV at AU from A, inside the slot.
    a, v, _, _ = undulatory_points(state, g)
    u = 0.2 + pin * np.exp(1j * state.theta3)
    assert np.abs(a + state.pin_u_distance * np.exp(1j * state.theta4) - u).max() < 1e-12
    assert 0.0 < state.pin_u_distance.min() and state.pin_u_distance.max() < 0.24


def test_undulatory_straight_pose():
    """At theta3 = 0 the solution is the straight pose: theta4 = theta5 = 0, AS = AV + VW - SW."""
    state = UndulatoryTail(UndulatoryGeometry()).solve(math.pi / 2.0)  # OP = 0, mid-swing
    assert state.theta3 == pytest.approx(0.0, abs=1e-12)
    assert state.theta4 == pytest.approx(0.0, abs=1e-9)
    assert state.theta5 == pytest.approx(0.0, abs=1e-9)
    assert state.slider_a_distance == pytest.approx(0.24 + 0.06 - 0.16, abs=1e-9)
    assert state.pin_u_distance == pytest.approx(0.08 + 0.14, abs=1e-9)
    assert state.tip_x == pytest.approx(0.2 + 0.2 - 0.06 + 0.16, abs=1e-9)
    assert state.tip_y == pytest.approx(0.0, abs=1e-9)


def test_undulatory_continuous_over_cycle():
    """No jumps over a dense cycle: no step is more than a few times the typical step."""
    state = UndulatoryTail(UndulatoryGeometry()).solve(np.linspace(0.0, 2.0 * TWO_PI, 40001))
    for field in ("theta4", "pin_u_distance", "slider_a_distance", "theta5", "tip_x", "tip_y"):
        steps = np.abs(np.diff(getattr(state, field)))
        assert steps.max() < 4.0 * steps.mean() + 1e-12, field


@pytest.mark.parametrize("lengths", [{}, {"pin_offset_m": 0.03, "phase_rad": 0.4}])
def test_undulatory_agrees_with_fsolve(lengths, oracle):
    """Per-sample fsolve of the four equations, continued from the straight pose, agrees to 1e-9."""
    g = UndulatoryGeometry(**lengths)
    state = UndulatoryTail(g).solve(np.linspace(0.0, TWO_PI, 721))
    # theta3 itself from the circle-intersection oracle (monotone drive: extremes at OP = -R, R).
    _, ends = oracle.theta12(np.array([-0.1, 0.1]), 0.1, g.rocker_link_m, 0.2)
    op = 0.1 * np.cos(np.asarray(state.motor_angle) + g.phase_rad)
    theta3 = oracle.theta12(op, 0.1, g.rocker_link_m, 0.2)[1] - ends.mean()
    assert np.abs(state.theta3 - theta3).max() < 1e-12
    lengths = oracle.REPORT.__class__(**{**vars(oracle.REPORT), "SU": g.pin_offset_m})
    theta4, au, as_, theta5 = oracle.solve_undulatory(theta3, lengths)
    for field, expected in zip(
        ("theta4", "pin_u_distance", "slider_a_distance", "theta5"),
        (theta4, au, as_, theta5),
        strict=True,
    ):
        assert np.abs(getattr(state, field) - expected).max() < 1e-9, field


def test_undulatory_stays_on_the_straight_pose_s_branch_for_random_designs(oracle):
    """Random lengths, RS off the symmetric value: the oracle's branch at every angle, both paths.

    Lengths within 30 % of the report's; the oracle continues the loop from the straight pose.
    """
    rng = np.random.default_rng(20261203)
    base = UndulatoryGeometry()
    names = ("ring_radius_m", "crank_link_m", "rocker_link_m", "pivot_offset_m", "pin_offset_m",
             "swing_arm_m", "slotted_link_m", "fin_joint_offset_m", "fin_link_m")  # fmt: skip
    checked = 0
    while checked < 8:
        lengths = {name: getattr(base, name) * rng.uniform(0.7, 1.3) for name in names}
        try:
            tail = UndulatoryTail(UndulatoryGeometry(**lengths))
        except (AssemblyError, InvalidLengthError, PinOffsetError):
            continue
        checked += 1
        state = tail.solve(np.linspace(0.0, TWO_PI, 361))
        g = SimpleNamespace(
            SU=lengths["pin_offset_m"], SW=lengths["swing_arm_m"],
            AV=lengths["slotted_link_m"], VW=lengths["fin_joint_offset_m"],
        )  # fmt: skip
        # theta3 moves continuously round the revolution: the oracle follows it from straight.
        _, _, slider, theta5 = oracle.solve_undulatory(np.asarray(state.theta3), g)
        assert np.abs(np.asarray(state.slider_a_distance) - slider).max() < 1e-9, lengths
        assert np.abs(np.asarray(state.theta5) - theta5).max() < 1e-8, lengths
        for angle in (0.3, 2.0, 4.5):
            one = tail.solve(angle)
            assert one.slider_a_distance == pytest.approx(
                float(np.asarray(tail.solve(np.array([angle])).slider_a_distance)[0]), abs=1e-15
            )


def test_pin_offset_limits():
    """SU at or beyond SW - VW raises PinOffsetError; SU <= 0 is refused as a length."""
    for pin in (0.1, 0.1 + 1e-9, 0.15, 0.2):
        with pytest.raises(PinOffsetError, match=re.escape("0 < SU < SW - VW")):
            UndulatoryTail(UndulatoryGeometry(pin_offset_m=pin))
    for pin in (0.0, -0.01):
        with pytest.raises((PinOffsetError, InvalidLengthError), match="pin_offset_m|SU"):
            UndulatoryTail(UndulatoryGeometry(pin_offset_m=pin))


def test_pin_near_limit_makes_theta5_follow_theta3():
    """As SU -> SW - VW, U -> V and theta5 -> theta3."""
    deviations = []
    for gap in (1e-3, 1e-4, 1e-6):
        state = UndulatoryTail(UndulatoryGeometry(pin_offset_m=0.1 - gap)).solve(CYCLE)
        deviations.append(np.abs(state.theta5 - state.theta3).max())
    assert deviations[-1] < 1e-4
    assert deviations[0] > deviations[1] > deviations[2]
    far = UndulatoryTail(UndulatoryGeometry(pin_offset_m=0.05)).solve(CYCLE)
    assert np.abs(far.theta5 - far.theta3).max() > 1e-2


# --- scalar and array paths, shapes ---


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_scalar_and_array_paths_agree(mechanism):
    """Python floats take the scalar path; it agrees with the array path to 1e-12, every field."""
    if mechanism == "oscillatory":
        tail = OscillatoryTail(OscillatoryGeometry(phase_rad=0.3))
    else:
        tail = UndulatoryTail(UndulatoryGeometry(phase_rad=0.3, pin_offset_m=0.07))
    phis = np.linspace(-4.0, 10.0, 97)
    speeds = np.linspace(-30.0, 30.0, 97)
    arrays = tail.solve(phis, speeds)
    for index, (phi, speed) in enumerate(zip(phis.tolist(), speeds.tolist(), strict=True)):
        scalar = tail.solve(phi, speed)
        for field, value in zip(scalar._fields, scalar, strict=True):
            assert isinstance(value, float), field
            expected = float(getattr(arrays, field)[index])
            assert abs(value - expected) <= 1e-12 * max(1.0, abs(expected)), (field, phi)
    assert isinstance(tail.solve(1, 2).theta3, float)


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_two_dimensional_arrays_broadcast_with_speeds(mechanism):
    """A (3, 4) angle array and a (4,) speed array broadcast to (3, 4) in every field."""
    tail = oscillatory() if mechanism == "oscillatory" else UndulatoryTail(UndulatoryGeometry())
    phis = np.linspace(0.0, 6.0, 12).reshape(3, 4)
    speeds = np.array([1.0, -2.0, 3.0, 0.0])
    state = tail.solve(phis, speeds)
    for field, value in zip(state._fields, state, strict=True):
        assert np.shape(value) == (3, 4), field
    for row in range(3):
        for column in range(4):
            single = tail.solve(float(phis[row, column]), float(speeds[column]))
            for field, value in zip(single._fields, single, strict=True):
                assert getattr(state, field)[row, column] == pytest.approx(value, abs=1e-12)
    speed_column = tail.solve(1.0, np.array([[1.0], [2.0]]))
    assert np.shape(speed_column.theta2_dot) == (2, 1)
    assert speed_column.theta2_dot[1, 0] == pytest.approx(2.0 * speed_column.theta2_dot[0, 0])


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_zero_dimensional_arrays(mechanism):
    """0-d arrays (np.array(1.0)) are arrays too and give the scalar path's values."""
    tail = oscillatory() if mechanism == "oscillatory" else UndulatoryTail(UndulatoryGeometry())
    expected = tail.solve(1.0, 2.0)
    for phi, speed in ((np.array(1.0), np.array(2.0)), (np.array(1.0), 2.0)):
        state = tail.solve(phi, speed)
        for field, value in zip(expected._fields, expected, strict=True):
            assert np.shape(getattr(state, field)) == (), field
            assert float(getattr(state, field)) == pytest.approx(value, abs=1e-12), field


def test_empty_array():
    """An empty batch gives empty fields."""
    state = UndulatoryTail(UndulatoryGeometry()).solve(np.array([]), 1.0)
    assert all(np.shape(value) == (0,) for value in state)


# --- property tests over random geometries ---

lengths_m = st.floats(min_value=0.01, max_value=0.5)


@st.composite
def feasible_geometries(draw):
    """R, PR, RS, and OS inside the assembly interval with a margin on both ends."""
    ring = draw(st.floats(min_value=0.01, max_value=0.3))
    pr, rs = draw(lengths_m), draw(lengths_m)
    low = abs(rs - pr)
    reach_sq = (rs + pr) ** 2 - ring**2
    assume(reach_sq > 0.0)
    high = math.sqrt(reach_sq)
    margin = 0.02 * (rs + pr)
    assume(high - low > 3.0 * margin)
    os_ = draw(st.floats(min_value=low + margin, max_value=high - margin))
    phase = draw(st.floats(min_value=-math.pi, max_value=math.pi))
    return OscillatoryGeometry(
        ring_radius_m=ring, crank_link_m=pr, rocker_link_m=rs, pivot_offset_m=os_, phase_rad=phase
    )


PROPERTY_SETTINGS = settings(
    max_examples=50,
    deadline=None,
    database=None,
    suppress_health_check=[HealthCheck.filter_too_much],
)


@PROPERTY_SETTINGS
@given(feasible_geometries())
def test_property_loop_closure_and_branch(g):
    """Loop closes and stays on the left branch for random feasible geometries."""
    state = OscillatoryTail(g).solve(np.linspace(0.0, TWO_PI, 1001), 1.0)
    residual, _ = closure(state, g)
    assert residual.max() < 1e-12
    assert branch_cross(state, g).min() > 0.0


@PROPERTY_SETTINGS
@given(g=feasible_geometries())
def test_property_range_and_extremes(oracle, g):
    """Range 2 atan(R/OS) where monotone; extremes bracket and reach every sampled theta2."""
    tail = OscillatoryTail(g)
    ring, pr, rs, os_ = g.ring_radius_m, g.crank_link_m, g.rocker_link_m, g.pivot_offset_m
    # At RS^2 = (OS - PR)^2 + R^2 exactly, theta2 is stationary at OP = R, an end: still monotone.
    upper = (os_ - pr) ** 2 + ring**2
    monotone = not (os_ - pr) ** 2 <= rs**2 < upper
    if abs(rs**2 - upper) > 1e-12:
        assert tail.monotone == monotone
    if monotone:
        assert tail.swing_range_rad == pytest.approx(2.0 * math.atan(ring / os_), abs=1e-12)
    ops = np.linspace(-ring, ring, 20001)
    theta2 = np.unwrap(oracle.theta12(ops, pr, rs, os_)[1])
    theta2 += wrap(tail.theta2_at(0.0) - theta2[10000])
    assert tail.theta2_min <= theta2.min() + 1e-12
    assert tail.theta2_max >= theta2.max() - 1e-12
    assert tail.theta2_min > theta2.min() - 1e-5
    assert tail.theta2_max < theta2.max() + 1e-5


@PROPERTY_SETTINGS
@given(feasible_geometries())
def test_property_theta3_zero_at_mid_swing(g):
    """theta3 is centred: its max over a cycle is minus its min, and 0 at the mid-swing."""
    tail = OscillatoryTail(g)
    state = tail.solve(np.linspace(0.0, TWO_PI, 20001) - g.phase_rad)  # hits OP = R and -R
    tolerance = 1e-12 if tail.monotone else 1e-6
    assert state.theta3.max() == pytest.approx(-state.theta3.min(), abs=tolerance)
    assert state.theta3.max() == pytest.approx(tail.swing_range_rad / 2.0, abs=tolerance)


@st.composite
def infeasible_geometries(draw):
    """R, PR, RS and an OS outside the assembly interval (or no interval at all)."""
    ring = draw(st.floats(min_value=0.01, max_value=0.5))
    pr, rs = draw(lengths_m), draw(lengths_m)
    low = abs(rs - pr)
    reach_sq = (rs + pr) ** 2 - ring**2
    high = math.sqrt(reach_sq) if reach_sq > 0.0 else 0.0
    choices = [st.floats(min_value=max(high, low) * 1.001 + 1e-6, max_value=2.0)]
    if low > 1e-3:
        choices.append(st.floats(min_value=1e-4, max_value=low * 0.999))
    os_ = draw(st.one_of(choices))
    return ring, pr, rs, os_


@PROPERTY_SETTINGS
@given(infeasible_geometries())
def test_property_infeasible_raises(lengths):
    """Random geometries outside the assembly conditions always raise, naming a failed condition."""
    ring, pr, rs, os_ = lengths
    g = OscillatoryGeometry(
        ring_radius_m=ring, crank_link_m=pr, rocker_link_m=rs, pivot_offset_m=os_
    )
    with pytest.raises(AssemblyError) as info:
        OscillatoryTail(g)
    message = str(info.value)
    if not abs(rs - pr) < os_:
        assert "|RS - PR| < OS" in message
    if not os_**2 + ring**2 < (rs + pr) ** 2:
        assert "OS^2 + R^2 < (RS + PR)^2" in message


def test_undulatory_geometry_that_cannot_straighten():
    """AV + VW <= SW puts A at or past S in the straight pose; VW >= VT leaves no WT."""
    with pytest.raises(AssemblyError, match=re.escape("AV + VW > SW")):
        UndulatoryTail(UndulatoryGeometry(slotted_link_m=0.09))
    with pytest.raises(InvalidLengthError, match=re.escape("VW < VT")):
        UndulatoryTail(UndulatoryGeometry(fin_link_m=0.06))


@pytest.mark.parametrize("make", [OscillatoryTail, UndulatoryTail], ids=["osc", "und"])
@pytest.mark.parametrize(
    ("angle", "speed"),
    [(math.nan, 4.0), (0.3, math.inf), (np.array([0.1, math.nan, 0.3]), 4.0),
     (np.array([0.1, 0.2]), np.array([4.0, -math.inf])), (np.array(math.nan), 4.0)],
)  # fmt: skip
def test_non_finite_input_is_refused_not_turned_into_nan(make, angle, speed):
    geometry = OscillatoryGeometry() if make is OscillatoryTail else UndulatoryGeometry()
    with pytest.raises(InvalidInputError, match="finite"):
        make(geometry).solve(angle, speed)

"""The pivot actuator model: constant speed towards the target, the stroke, refused commands."""

from __future__ import annotations

import doctest
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fishtail_plant import pivot_actuator
from fishtail_plant.pivot_actuator import PivotActuator, PivotLimits

LIMITS = PivotLimits(stroke_m=0.03, speed_m_s=0.01)


def test_doctests():
    result = doctest.testmod(pivot_actuator)
    assert result.failed == 0 and result.attempted >= 6


def test_it_reaches_the_target_in_distance_over_speed_and_stops_there():
    pivot = PivotActuator(LIMITS)
    pivot.command(-0.025, now_s=1.0)
    assert pivot.arrival_s() == pytest.approx(1.0 + 0.025 / 0.01)
    assert pivot.state(3.49)[0] == pytest.approx(-0.0249)
    assert pivot.state(3.49)[1] == -0.01
    assert pivot.state(3.5) == (pytest.approx(-0.025), 0.0)
    assert pivot.state(100.0) == (pytest.approx(-0.025), 0.0)


def test_the_full_stroke_takes_its_time():
    pivot = PivotActuator(LIMITS, position_m=-0.03)
    pivot.command(0.03, now_s=0.0)
    assert LIMITS.full_stroke_time_s == pytest.approx(6.0)
    assert pivot.arrival_s() == pytest.approx(6.0)
    assert pivot.state(3.0)[0] == pytest.approx(0.0)


def test_a_new_command_starts_from_where_the_actuator_is():
    pivot = PivotActuator(LIMITS)
    pivot.command(0.02, now_s=0.0)
    pivot.command(-0.01, now_s=1.0)  # at +0.01 m, heading up: turns round at once
    assert pivot.state(1.0) == (pytest.approx(0.01), -0.01)
    assert pivot.arrival_s() == pytest.approx(3.0)
    assert pivot.state(4.0) == (pytest.approx(-0.01), 0.0)


@given(
    st.lists(
        st.tuples(st.floats(-0.1, 0.1), st.floats(0.0, 3.0)), min_size=1, max_size=8
    ),  # (target, time until the next command)
    st.floats(0.001, 0.05),
)
def test_never_faster_than_the_screw_nor_beyond_the_stroke(commands, dt):
    pivot = PivotActuator(LIMITS)
    now, position = 0.0, 0.0
    for target, hold in commands:
        pivot.command(target, now)
        end = now + hold
        while now < end:
            now = min(now + dt, end)
            new_position, velocity = pivot.state(now)
            assert abs(new_position - position) <= LIMITS.speed_m_s * dt + 1e-12
            assert abs(new_position) <= LIMITS.stroke_m + 1e-12
            assert abs(velocity) in (0.0, LIMITS.speed_m_s)
            position = new_position


def test_beyond_the_stroke_it_goes_to_the_end_and_says_so():
    pivot = PivotActuator(LIMITS)
    outcome = pivot.command(-0.05, now_s=0.0)
    assert outcome.accepted and outcome.clipped and outcome.target_m == -0.03
    assert "beyond the stroke of +-0.03 m: achievable -0.0300 m" in outcome.reason
    assert pivot.state(10.0) == (pytest.approx(-0.03), 0.0)
    within = pivot.command(0.03, now_s=10.0)  # the end itself is within
    assert within.accepted and not within.clipped and within.reason == ""


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_a_command_that_is_not_a_number_is_refused_and_the_move_goes_on(bad):
    pivot = PivotActuator(LIMITS)
    pivot.command(0.02, now_s=0.0)
    outcome = pivot.command(bad, now_s=1.0)
    assert not outcome.accepted and not outcome.clipped and outcome.target_m == 0.02
    assert "not a finite number" in outcome.reason
    assert pivot.state(1.5) == (pytest.approx(0.015), 0.01)  # the same move, undisturbed
    assert pivot.arrival_s() == pytest.approx(2.0)


def test_limits_and_start_are_checked():
    with pytest.raises(ValueError, match="speed_m_s must be finite and > 0"):
        PivotLimits(0.03, 0.0)
    with pytest.raises(ValueError, match="stroke_m must be finite and > 0"):
        PivotLimits(math.nan, 0.01)
    with pytest.raises(ValueError, match="outside the stroke"):
        PivotActuator(LIMITS, position_m=0.04)

"""The motor board's numbers: integer wrapping and the units of its speed loop."""

from __future__ import annotations

import doctest
import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fishtail_plant.motor import board_units
from fishtail_plant.motor.board_units import (
    INT16_MAX,
    INT16_MIN,
    INT32_MAX,
    INT32_MIN,
    Scale,
    wrap_int16,
    wrap_int32,
)


def test_doctests():
    """The examples in the module documentation hold."""
    result = doctest.testmod(board_units)
    assert result.failed == 0 and result.attempted >= 4


def test_pid_frame_is_integer_milliseconds():
    """1000/30 in integer maths: 33 ms, 30.30 Hz, not 30 Hz."""
    scale = Scale(2048)
    assert scale.frame_ms == 33
    assert scale.frame_rate_hz == pytest.approx(30.303, abs=1e-3)
    assert Scale(2048, pid_rate_hz=50).frame_ms == 20
    assert Scale(2048, pid_rate_hz=7).frame_ms == 142


def test_ticks_per_frame_uses_counts_gear_and_frame():
    """One carrier turn per second = counts x gear x frame ticks per frame."""
    scale = Scale(counts_per_revolution=1000, gear_ratio=30.0, pid_rate_hz=30)
    exact = 1000 * 30.0 * 0.033
    assert scale.ticks_per_frame_exact(2 * math.pi) == pytest.approx(exact)
    assert scale.ticks_per_frame(2 * math.pi) == (990, False)
    assert scale.speed_from_ticks(990) == pytest.approx(2 * math.pi)
    assert scale.angle_from_counts(30000) == pytest.approx(2 * math.pi)


def test_ticks_are_clamped_to_the_avr_int_range():
    """Speeds beyond 32767 ticks per frame are clamped and flagged, never wrapped."""
    scale = Scale(counts_per_revolution=100000, gear_ratio=100.0)
    assert scale.ticks_per_frame(1000.0) == (INT16_MAX, True)
    assert scale.ticks_per_frame(-1000.0) == (INT16_MIN, True)
    with pytest.raises(ValueError, match="finite"):
        scale.ticks_per_frame(math.nan)


@given(st.floats(-1e4, 1e4), st.integers(1, 100000), st.floats(0.01, 1000.0), st.integers(1, 1000))
def test_ticks_round_to_nearest_and_stay_in_range(speed, counts, gear, rate):
    """The sent value is the nearest integer (or the clamp) and always a valid AVR int."""
    scale = Scale(counts, gear, rate)
    ticks, clamped = scale.ticks_per_frame(speed)
    assert INT16_MIN <= ticks <= INT16_MAX
    exact = scale.ticks_per_frame_exact(speed)
    if not clamped:
        assert abs(ticks - exact) <= 0.5 + 1e-9


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"counts_per_revolution": 0}, "counts_per_revolution"),
        ({"counts_per_revolution": 10, "gear_ratio": 0.0}, "gear_ratio"),
        ({"counts_per_revolution": 10, "pid_rate_hz": 0}, "PID_RATE"),
        ({"counts_per_revolution": 10, "pid_rate_hz": 30.0}, "PID_RATE"),
    ],
)
def test_scale_rejects_meaningless_values(kwargs, words):
    """Bad unit parameters fail at construction with the reason."""
    with pytest.raises(ValueError, match=words):
        Scale(**kwargs)


# --- wrapping and unwrapping --------------------------------------------------------------------


def test_wrap_helpers():
    """Two's complement wrap of the board's integer types."""
    assert wrap_int32(INT32_MAX + 1) == INT32_MIN
    assert wrap_int16(40000) == -25536

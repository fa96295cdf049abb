"""The carrier-jump rule of CarrierGuard: a step the motor cannot turn is held, then re-based."""

from __future__ import annotations

import math

import pytest

from fishtail_kinematics.engine.carrier_profile import DEFAULT_TOP_SPEED_RAD_S
from fishtail_kinematics.engine.input_guard import (
    BACKWARDS,
    CARRIER_JUMP,
    JUMP_SPEED_MARGIN,
    MAX_CARRIER_SPEED,
    CarrierGuard,
    plausible_advance_rad,
)

NOW = 1_000 * 10**9  # the node's clock [ns]
MS = 1_000_000
SPEED_RAD_S = 8.0


def steady(samples: int = 20) -> CarrierGuard:
    """A guard with the driver's limit that has accepted ``samples`` samples at 8 rad/s, 5 ms."""
    guard = CarrierGuard(max_speed_rad_s=DEFAULT_TOP_SPEED_RAD_S)
    for k in range(samples):
        assert guard.check(k * 5 * MS, SPEED_RAD_S * k * 0.005, 0.0, NOW) is None
    return guard


def angle(k: int) -> float:
    return SPEED_RAD_S * k * 0.005


JUMPS = [(10.0, 100_000), (10.0, 5 * MS), (1e3, 5 * MS), (1e6, 5 * MS)]


@pytest.mark.parametrize(("jump_rad", "after_ns"), JUMPS)
def test_a_jump_is_dropped_and_the_next_good_sample_passes(jump_rad, after_ns):
    guard = steady()
    assert guard.check(19 * 5 * MS + after_ns, angle(19) + jump_rad, 0.0, NOW) == CARRIER_JUMP
    advance, elapsed = guard.jump
    assert advance == pytest.approx(jump_rad) and elapsed == pytest.approx(after_ns * 1e-9)
    assert guard.check(20 * 5 * MS + after_ns, angle(20), 0.0, NOW) is None
    assert guard.rebased_from is None


def test_a_one_sample_spike_costs_one_sample_and_nothing_after():
    guard = steady()
    assert guard.check(20 * 5 * MS, angle(20) + 1e3, 0.0, NOW) == CARRIER_JUMP
    # The spike never became the reference: what follows is neither backwards nor a jump.
    for k in range(21, 40):
        assert guard.check(k * 5 * MS, angle(k), 0.0, NOW) is None
        assert guard.rebased_from is None


def test_a_step_that_persists_re_bases_on_the_jumped_sample():
    """An encoder re-zeroed 1e6 rad ahead: one sample held, then the stream follows from it."""
    guard = steady()
    assert guard.check(20 * 5 * MS, angle(20) + 1e6, 0.0, NOW) == CARRIER_JUMP
    assert guard.check(21 * 5 * MS, angle(21) + 1e6, 0.0, NOW) is None
    assert guard.rebased_from == (20 * 5 * MS, angle(20) + 1e6)
    for k in range(22, 30):
        assert guard.check(k * 5 * MS, angle(k) + 1e6, 0.0, NOW) is None
        assert guard.rebased_from is None
    assert guard.check(30 * 5 * MS, angle(30), 0.0, NOW) == BACKWARDS


def test_a_stream_too_fast_for_the_motor_never_passes():
    """Three times the limit, sample after sample: every one a jump (the fish must not swim)."""
    guard = steady(1)
    speed = 3 * DEFAULT_TOP_SPEED_RAD_S
    for k in range(1, 20):
        assert guard.check(k * 5 * MS, speed * k * 0.005, 0.0, NOW) == CARRIER_JUMP


def test_within_the_margin_passes_and_without_a_limit_nothing_is_a_jump():
    guard = steady(1)
    speed = 0.95 * JUMP_SPEED_MARGIN * DEFAULT_TOP_SPEED_RAD_S
    for k in range(1, 20):
        assert guard.check(k * 5 * MS, speed * k * 0.005, 0.0, NOW) is None
    unlimited = CarrierGuard()
    assert unlimited.max_speed_rad_s == math.inf
    assert unlimited.check(1, 0.0, 0.0, NOW) is None
    assert unlimited.check(2, 1e6, 0.0, NOW) is None


def test_the_limit_is_a_parameter_with_the_drivers_default():
    guard = CarrierGuard()
    guard.apply_parameters({MAX_CARRIER_SPEED.name: 5.0})
    assert guard.max_speed_rad_s == 5.0
    assert MAX_CARRIER_SPEED.default == DEFAULT_TOP_SPEED_RAD_S
    assert MAX_CARRIER_SPEED.unit == "rad/s"
    assert plausible_advance_rad(0.005, 20.0) == pytest.approx(0.16)

"""Plausibility rules of the carrier-angle streams: hand-made cases, one rule at a time."""

from __future__ import annotations

import math
import subprocess
import sys

import pytest

from fishtail_common.stream_timing import StreamTiming
from fishtail_kinematics.engine.input_guard import (
    ANGLE_OUT_OF_RANGE,
    BACKWARDS,
    GUARD_REASONS,
    MAX_ABS_CARRIER_ANGLE_RAD,
    NON_FINITE,
    STAMP_IN_FUTURE,
    STAMP_NOT_INCREASING,
    CarrierGuard,
    DropCounts,
    input_status,
)

NOW = 1_000 * 10**9  # the node's clock [ns]
MS = 1_000_000


def accepted(guard: CarrierGuard, stamp_ns: int, angle: float, now_ns: int = NOW) -> bool:
    return guard.check(stamp_ns, angle, 0.0, now_ns) is None


def test_a_steady_forward_stream_passes():
    guard = CarrierGuard()
    assert all(accepted(guard, NOW - 10**9 + k * MS, 0.004 * k) for k in range(1000))


@pytest.mark.parametrize("angle", [math.nan, math.inf, -math.inf])
def test_non_finite_angle(angle):
    assert CarrierGuard().check(NOW, angle, 0.0, NOW) == NON_FINITE


@pytest.mark.parametrize("others", [math.nan, math.inf, math.inf - math.inf])
def test_non_finite_other_value(others):
    assert CarrierGuard().check(NOW, 0.5, others, NOW) == NON_FINITE


def test_angle_bound():
    guard = CarrierGuard()
    assert guard.check(NOW - 2, 1e12, 0.0, NOW) == ANGLE_OUT_OF_RANGE
    assert guard.check(NOW - 2, -1e12, 0.0, NOW) == ANGLE_OUT_OF_RANGE
    assert accepted(guard, NOW - 1, MAX_ABS_CARRIER_ANGLE_RAD)
    # Up to the bound a double resolves the angle far below an encoder count (3e-3 rad).
    assert math.ulp(MAX_ABS_CARRIER_ANGLE_RAD) < 1e-6


def test_backwards_beyond_the_tolerance_is_dropped_within_it_passes():
    guard = CarrierGuard(backwards_tolerance_rad=0.01)
    assert accepted(guard, 1, 5.0)
    assert accepted(guard, 2, 4.995)  # encoder jitter
    assert guard.check(3, 4.98, 0.0, NOW) == BACKWARDS
    assert accepted(guard, 4, 5.02)


def test_slow_backwards_creep_is_caught():
    # Each step back is within the tolerance, the sum is not: the reference is the highest angle.
    guard = CarrierGuard(backwards_tolerance_rad=0.01)
    results = [guard.check(k + 1, 5.0 - 0.004 * k, 0.0, NOW) for k in range(6)]
    assert results == [None, None, None, BACKWARDS, BACKWARDS, BACKWARDS]


def test_stamp_must_increase():
    guard = CarrierGuard()
    assert accepted(guard, 100, 0.0)
    assert guard.check(100, 0.1, 0.0, NOW) == STAMP_NOT_INCREASING
    assert guard.check(99, 0.1, 0.0, NOW) == STAMP_NOT_INCREASING
    assert accepted(guard, 101, 0.1)


def test_stamp_far_ahead_of_the_clock():
    guard = CarrierGuard(future_tolerance_ns=10**9)
    assert guard.check(NOW + 3600 * 10**9, 0.0, 0.0, NOW) == STAMP_IN_FUTURE
    assert guard.check(NOW + 10**9 + 1, 0.0, 0.0, NOW) == STAMP_IN_FUTURE
    assert accepted(guard, NOW + 10**9, 0.0)
    # A dropped sample does not move the reference: the next normal one passes.
    assert accepted(guard, NOW + 10**9 + 1, 0.01, now_ns=NOW + 5 * MS)


def test_no_clock_yet_skips_the_future_check():
    assert CarrierGuard().check(NOW, 0.0, 0.0, now_ns=0) is None


def test_restart_after_a_pause_without_accepted_samples():
    # A restarted driver counts from 0 again: refused as backwards until nothing has been
    # accepted for restart_after_ns, then followed.
    guard = CarrierGuard(restart_after_ns=2 * 10**9)
    assert accepted(guard, NOW, 500.0, now_ns=NOW)
    assert guard.check(NOW + 1, 0.0, 0.0, NOW + 10**9) == BACKWARDS
    assert guard.check(NOW + 2, 0.004, 0.0, NOW + 2 * 10**9) == BACKWARDS
    assert accepted(guard, NOW + 3, 0.008, now_ns=NOW + 2 * 10**9 + 1)
    assert accepted(guard, NOW + 4, 0.012, now_ns=NOW + 2 * 10**9 + 2)
    assert guard.check(NOW + 5, 0.0, 0.0, NOW + 2 * 10**9 + 3) == BACKWARDS


def test_drop_counts_per_reason_and_period():
    counts = DropCounts((*GUARD_REASONS, "no_carrier_joint"))
    for reason in (BACKWARDS, BACKWARDS, NON_FINITE, "no_carrier_joint"):
        counts.count(reason)
    assert counts.take_period() == {BACKWARDS: 2, NON_FINITE: 1, "no_carrier_joint": 1}
    assert counts.take_period() == {}
    counts.count(STAMP_IN_FUTURE)
    values = counts.values()
    assert values["dropped"] == "5"
    assert values["dropped_backwards"] == "2" and values["dropped_angle_out_of_range"] == "0"
    assert set(values) == {"dropped", *(f"dropped_{r}" for r in counts.total)}


def test_input_status_names_each_problem():
    drops = DropCounts(GUARD_REASONS)
    timing = StreamTiming()
    for k in range(100):
        timing.observe(0.005 * k)
    level, text, values = input_status("tail/state", drops, timing.take_period(), 1.0)
    assert level == 0 and text.startswith("tail/state at 200.0 Hz"), text
    drops.count(BACKWARDS)
    timing.observe(0.5 + 0.066)
    level, text, values = input_status("tail/state", drops, timing.take_period(), 1.0)
    assert level == 1
    assert text.startswith("dropped 1 tail/state samples in 1 s: 1 backwards; 1 gap(s)"), text
    assert "longest 71 ms" in text, text
    assert values["dropped_backwards"] == "1" and values["longest_gap_ms"] == "71.0"


def test_the_rules_do_not_import_rclpy():
    code = (
        "import sys, fishtail_kinematics.engine.input_guard, "
        "fishtail_common.stream_timing; "
        "print('rclpy' in sys.modules)"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.stdout.strip() == "False", result.stderr

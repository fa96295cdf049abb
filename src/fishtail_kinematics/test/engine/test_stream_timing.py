"""Usual interval, gaps and rate of a stamped stream, from hand-made stamp sequences."""

from __future__ import annotations

import math
import random

import pytest

from fishtail_kinematics.engine.stream_timing import GAP_FACTOR, GAP_FLOOR_S, WINDOW, StreamTiming


def feed(timing: StreamTiming, stamps) -> list[bool]:
    return [timing.observe(float(t)) for t in stamps]


def test_regular_stream_has_no_gap_and_its_own_rate():
    timing = StreamTiming()
    assert not any(feed(timing, [0.001 * k for k in range(1001)]))
    period = timing.take_period()
    assert period.samples == 1001 and period.gaps == 0 and period.healthy
    assert period.rate_hz == pytest.approx(1000.0)
    assert period.usual_interval_s == pytest.approx(0.001)
    assert period.gap_threshold_s == GAP_FLOOR_S  # 4 ms is under the floor
    assert period.longest_interval_s == pytest.approx(0.001)


def test_gap_is_relative_to_the_usual_interval_above_the_floor():
    timing = StreamTiming()
    feed(timing, [0.01 * k for k in range(50)])  # 100 Hz: gaps are over 40 ms
    assert timing.gap_threshold_s == pytest.approx(GAP_FACTOR * 0.01)
    last = 0.49
    assert not timing.observe(last + 0.039)
    assert timing.observe(last + 0.039 + 0.041)


def test_jitter_under_the_floor_is_not_a_gap():
    # 1 kHz with the stamps of a loaded machine: up to 11 ms late, never a gap.
    jitter = random.Random(3)
    stamps, t = [], 0.0
    for _ in range(3000):
        t += 0.001 if jitter.random() < 0.99 else jitter.uniform(0.002, 0.011)
        stamps.append(t)
    timing = StreamTiming()
    assert not any(feed(timing, stamps))


def test_lost_runs_are_gaps_and_the_median_ignores_them():
    # The soak: about 1 % lost in runs of up to 66 ms at 1 kHz.
    timing = StreamTiming()
    stamps = [0.001 * k for k in range(5000) if not (1000 <= k % 2000 < 1066)]
    flags = feed(timing, stamps)
    assert sum(flags) == 2
    period = timing.take_period()
    assert period.gaps == 2 and not period.healthy
    assert period.longest_interval_s == pytest.approx(0.067)
    assert period.usual_interval_s == pytest.approx(0.001)
    assert "2 gap(s) in tail/state, longest 67 ms" in period.describe("tail/state")


def test_evenly_spread_loss_is_a_low_rate():
    # Every fifth sample lost: no interval is a gap (2 ms < 20 ms), but the rate is 80 %.
    timing = StreamTiming()
    feed(timing, [0.001 * k for k in range(2001) if k % 5 != 4])
    period = timing.take_period()
    assert period.gaps == 0
    assert period.rate_hz == pytest.approx(800.0, rel=1e-3)
    assert period.rate_low and not period.healthy
    assert "at 800.0 Hz, below the 1000.0 Hz of its usual interval" in period.describe("x")


def test_follows_a_changed_rate_within_a_window():
    timing = StreamTiming()
    stamps = [0.001 * k for k in range(200)]
    stamps += [stamps[-1] + 0.1 * (k + 1) for k in range(WINDOW)]  # 1 kHz -> 10 Hz
    flags = feed(timing, stamps)
    assert timing.usual_interval_s == pytest.approx(0.1)
    # Until half the window has the new interval, the new intervals are gaps; then none are.
    assert sum(flags) == WINDOW // 2 + 1
    assert not timing.observe(stamps[-1] + 0.1)


def test_periods_restart_and_an_empty_period_is_not_judged():
    timing = StreamTiming()
    feed(timing, [0.005 * k for k in range(10)])
    timing.take_period()
    empty = timing.take_period()
    assert empty.samples == 0 and empty.rate_hz == 0.0 and empty.healthy
    first = StreamTiming().take_period()
    assert math.isnan(first.usual_interval_s) and first.gap_threshold_s == math.inf


def test_stamp_going_back_restarts_from_it():
    timing = StreamTiming()
    feed(timing, [10.0 + 0.005 * k for k in range(20)])
    assert not timing.observe(1.0)  # a restarted stream: no interval, no gap
    assert not timing.observe(1.005)
    assert timing.take_period().longest_interval_s == pytest.approx(0.005)

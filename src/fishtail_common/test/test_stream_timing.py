"""Rate and gaps of a sample stream, learned from its stamps and against a promised rate.

From hand-made stamp sequences (pure, no ROS).
"""

from __future__ import annotations

import math
import random

import pytest

from fishtail_common.stream_timing import GAP_FACTOR, GAP_FLOOR_S, WINDOW, RateCheck, StreamTiming


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


# ---- against a promised rate


def stream(check: RateCheck, start: float, rate_hz: float, seconds: float) -> float:
    """Record samples at ``rate_hz`` from ``start`` for ``seconds``; returns the last time."""
    count = round(rate_hz * seconds)
    for k in range(1, count + 1):
        check.record(start + k / rate_hz)
    return start + count / rate_hz


def test_a_steady_stream_at_the_promised_rate_is_fine():
    """100 Hz promised and delivered: rate 100, gaps 10 ms, no shortfall."""
    check = RateCheck(0.0, window_s=1.0)
    end = stream(check, 0.0, 100.0, 3.0)
    report = check.report(end, 100.0)
    assert report.rate_hz == pytest.approx(100.0)
    assert report.longest_gap_s == pytest.approx(0.01)
    assert report.shortfall is None


def test_a_slow_stream_falls_short():
    """12.5 Hz against 100 promised: below 80 % (and gaps of 80 ms stay under 100 ms)."""
    check = RateCheck(0.0, window_s=1.0)
    end = stream(check, 0.0, 12.5, 3.0)
    report = check.report(end, 100.0)
    assert report.rate_hz == pytest.approx(12.5, abs=1.0)  # one sample more or less in 1 s
    assert report.shortfall == "rate below 80% of the promised 100 Hz"


def test_a_gap_falls_short_even_at_a_good_average_rate():
    """A 300 ms hole in a 200 Hz stream: the rate stays above 80 % of 200, the gap does not."""
    check = RateCheck(0.0, window_s=2.0)
    end = stream(check, 0.0, 200.0, 1.0)
    end = stream(check, end + 0.3 - 0.005, 200.0, 0.7)
    report = check.report(end, 200.0)
    assert report.rate_hz > 160.0
    assert report.longest_gap_s == pytest.approx(0.3)
    assert report.shortfall == "a gap longer than 100 ms"


def test_the_open_gap_counts_and_a_gap_across_the_window_start_counts_whole():
    """Samples stopped 2 s ago: the gap up to now is 2 s, though the window is 1 s."""
    check = RateCheck(0.0, window_s=1.0)
    end = stream(check, 0.0, 100.0, 1.0)
    report = check.report(end + 2.0, 100.0)
    assert report.rate_hz == 0.0 and report.longest_gap_s == pytest.approx(2.0)
    assert report.shortfall == "rate below 80% of the promised 100 Hz; a gap longer than 100 ms"


def test_slow_promised_rates_have_gaps_by_design():
    """At 1 Hz promised, a 1 s gap is normal (the gap limit is at least 3 periods)."""
    check = RateCheck(0.0, window_s=5.0)
    end = stream(check, 0.0, 1.0, 10.0)
    assert check.report(end, 1.0).shortfall is None


def test_no_rate_verdict_before_a_few_periods():
    """Right after the start the window is too short for a rate; the start is not a gap."""
    check = RateCheck(100.0, window_s=1.0)
    check.record(100.005)
    report = check.report(100.01, 100.0)
    assert report.shortfall is None
    assert report.longest_gap_s == pytest.approx(0.005)


def test_checks_can_be_disabled_and_restarted():
    """0 disables a check; restart forgets the old samples."""
    check = RateCheck(0.0, window_s=1.0, min_rate_fraction=0.0, max_gap_s=0.0)
    end = stream(check, 0.0, 1.0, 3.0)
    assert check.report(end, 100.0).shortfall is None
    check = RateCheck(0.0, window_s=1.0)
    end = stream(check, 0.0, 10.0, 3.0)
    check.restart(end)
    end = stream(check, end, 100.0, 1.0)
    assert check.report(end, 100.0).shortfall is None


def test_bad_settings_are_refused():
    """Window, fraction, gap and promised rate out of range: ValueError."""
    for kwargs in ({"window_s": 0.0}, {"window_s": 1.0, "min_rate_fraction": 1.5},
                   {"window_s": 1.0, "max_gap_s": -1.0}):  # fmt: skip
        with pytest.raises(ValueError):
            RateCheck(0.0, **kwargs)
    with pytest.raises(ValueError):
        RateCheck(0.0, window_s=1.0).report(1.0, 0.0)

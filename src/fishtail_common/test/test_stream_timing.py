"""Rate and gaps of a sample stream, learned from its stamps and against a promised rate.

From hand-made stamp sequences (pure, no ROS).
"""

from __future__ import annotations

import math
import random

import pytest

from fishtail_common.stream_timing import (
    CLEAR_AFTER_S,
    GAP_FACTOR,
    GAP_FLOOR_S,
    STATUS_GAP_CEILING_S,
    STATUS_GAP_FLOOR_S,
    WARN_AFTER_S,
    WINDOW,
    PersistentStatus,
    RateCheck,
    StreamTiming,
)


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
    # 15 of every 25 samples lost in runs: no interval is a gap (16 ms < 20 ms), the rate is 40 %.
    timing = StreamTiming()
    feed(timing, [0.001 * k for k in range(5000) if k % 25 < 10])
    period = timing.take_period()
    assert period.gaps == 0 and period.usual_interval_s == pytest.approx(0.001)
    assert period.rate_hz == pytest.approx(400.0, rel=0.01)
    assert period.rate_low and not period.healthy
    assert "at 401.1 Hz, below the 1000.0 Hz of its usual interval" in period.describe("x")


def test_a_loaded_publisher_that_skips_ticks_is_not_a_low_rate():
    # Every fourth tick skipped (150 of 200 Hz): a loaded computer, not a fault of the stream.
    timing = StreamTiming()
    feed(timing, [0.005 * k for k in range(801) if k % 4 != 3])
    assert timing.take_period().healthy


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


# ---- the status's gaps and its hysteresis


def jittery_stream(seconds: float, seed: int, late_every_s: float = 1.0) -> list[float]:
    """200 Hz stamps of a loaded computer: +-1 ms jitter, now and then a 20-24 ms interval."""
    rng = random.Random(seed)
    stamps, t, next_late = [], 0.0, late_every_s
    while t < seconds:
        if t >= next_late:
            t += rng.uniform(0.020, 0.024)
            next_late += late_every_s * rng.uniform(0.5, 1.5)
        else:
            t += 0.005 + rng.uniform(-0.001, 0.001)
        stamps.append(t)
    return stamps


def statuses(timing: StreamTiming, status: PersistentStatus, stamps, period_s=1.0) -> list[bool]:
    """The WARN state after each period of ``period_s`` of ``stamps``."""
    warnings, end = [], period_s
    for t in stamps:
        while t > end:
            period = timing.take_period()
            problem = None if period.healthy else period.describe("x")
            lasted = period.longest_interval_s if period.status_gaps else 0.0
            warnings.append(status.update(period_s, problem, lasted))
            end += period_s
        timing.observe(t)
    return warnings


def test_occasional_24_ms_intervals_at_200_hz_are_no_status_gap_and_never_warn():
    for seed in range(5):
        timing, status = StreamTiming(), PersistentStatus()
        warnings = statuses(timing, status, jittery_stream(120.0, seed))
        assert timing.gaps_total > 0  # holes for the beats ...
        assert not any(warnings) and status.transitions == 0  # ... but nothing to warn of
        assert timing.status_gap_threshold_s == STATUS_GAP_FLOOR_S


def test_heavy_jitter_raises_the_status_threshold_up_to_its_ceiling():
    # 5 % of the intervals 30-40 ms late: the learned margin takes them in.
    rng = random.Random(7)
    timing = StreamTiming()
    t = 0.0
    for _ in range(2000):
        t += rng.uniform(0.030, 0.040) if rng.random() < 0.05 else 0.005
        assert not timing.observe(t) or timing.gap_threshold_s < 0.03
    assert STATUS_GAP_FLOOR_S < timing.status_gap_threshold_s <= 2.5 * 0.040
    assert timing.take_period().healthy
    # A stream that stalls all the time does not learn to ignore its stalls beyond the ceiling.
    for k in range(2000):
        t += 0.3 if k % 20 == 0 else 0.005
        timing.observe(t)
    assert timing.usual_interval_s == pytest.approx(0.005)
    assert timing.status_gap_threshold_s == STATUS_GAP_CEILING_S
    assert timing.take_period().status_gaps == 100


def test_a_real_outage_warns_once_and_clears_once():
    stamps = [0.005 * k for k in range(2000)]  # 10 s at 200 Hz
    resume = stamps[-1] + 4.0  # a 4 s outage
    stamps += [resume + 0.005 * k for k in range(4000)]  # 20 s more
    timing, status = StreamTiming(), PersistentStatus()
    warnings = statuses(timing, status, stamps)
    assert status.transitions == 2
    first = warnings.index(True)
    assert first == 13  # the period in which the outage ended: 4 s >= WARN_AFTER_S at once
    assert all(warnings[first : first + int(CLEAR_AFTER_S)])
    assert not any(warnings[first + int(CLEAR_AFTER_S) :])


def test_a_shortfall_must_persist_and_a_warning_must_clear():
    status = PersistentStatus()
    pattern = ["short", None] * 10  # flapping every period: never long enough
    assert not any(status.update(1.0, problem) for problem in pattern)
    assert [status.update(1.0, "short") for _ in range(3)] == [False, False, True]
    # Clear for less than CLEAR_AFTER_S, then short again: stays WARN throughout.
    assert all(status.update(1.0, None) for _ in range(int(CLEAR_AFTER_S) - 1))
    assert status.update(1.0, "short")
    assert [status.update(1.0, None) for _ in range(int(CLEAR_AFTER_S))][-1] is False
    assert status.transitions == 2 and status.last_problem == "short"
    assert WARN_AFTER_S == 3.0


def test_garbage_is_handled():
    status = PersistentStatus()
    for bad in (math.nan, math.inf, -1.0, 0.0):
        assert not status.update(bad, "short")  # no time passes
    assert not status.update(1.0, "short", math.nan)
    assert status.update(1.0, "short", 5.0)  # a 5 s gap counts whole
    with pytest.raises(ValueError):
        PersistentStatus(warn_after_s=math.nan)
    with pytest.raises(ValueError):
        PersistentStatus(clear_after_s=-1.0)
    timing = StreamTiming()
    for t in (0.0, 0.005, math.nan, math.inf, 0.010, 0.015, -math.inf, 0.020):
        assert not timing.observe(t)
    period = timing.take_period()
    assert period.status_gaps == 0 and math.isfinite(period.longest_interval_s)


def test_a_rate_that_hovers_at_its_limit_warns_once_and_does_not_flip():
    # The driver's 200 Hz delivered at 76-84 % under load: below 80 % now and then.
    rng = random.Random(11)
    check, status, t, warnings = RateCheck(0.0, window_s=1.0), PersistentStatus(), 0.0, []
    for second in range(60):
        share = 0.76 if second < 5 else rng.uniform(0.76, 0.84)
        for _ in range(round(200 * share)):
            t += 1.0 / (200 * share)
            check.record(t)
        report = check.report(t, 200.0, status.warning)
        warnings.append(status.update(1.0, report.shortfall, report.longest_gap_s))
    assert status.transitions == 1 and warnings[-1], warnings

"""Rate and longest gap of a sample stream against the promised rate (pure, no ROS)."""

from __future__ import annotations

import pytest

from fishtail_driver.rate_check import RateCheck


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

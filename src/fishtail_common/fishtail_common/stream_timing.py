"""How regular a stream of samples is: its rate and its gaps, two ways.

A consumer does not know the rate its upstream publishes at, so :class:`StreamTiming` learns it
from the stream's stamps (the kinematics node, the monitor); a producer knows what its parameters
promise, so :class:`RateCheck` measures against that promise (the driver). Both are plain Python
and cheap per sample. The rules and their thresholds: docs/kinematics.md ("Gaps and rate") and
docs/serial.md ("Rate and gaps").

>>> timing = StreamTiming()
>>> flags = [timing.observe(0.005 * k) for k in range(40)]
>>> timing.observe(0.005 * 39 + 0.315), round(timing.usual_interval_s, 6)
(True, 0.005)
"""

from __future__ import annotations

import collections
import dataclasses
import math
from array import array
from bisect import bisect_left, insort

#: Intervals in the running median.
WINDOW = 31
#: An interval longer than this many usual intervals is a gap ...
GAP_FACTOR = 4.0
#: ... and longer than this [s].
GAP_FLOOR_S = 0.02
#: The rate over a period is low below this share of 1 / usual interval.
RATE_WARN_SHARE = 0.9


@dataclasses.dataclass(frozen=True)
class PeriodTiming:
    """The stream over one diagnostics period (intervals that ended in it)."""

    samples: int
    rate_hz: float  # intervals / their total duration; 0 without an interval
    usual_interval_s: float  # median interval at the end of the period; NaN before the first
    gap_threshold_s: float  # longer intervals are gaps; inf before the first interval
    longest_interval_s: float  # 0 without an interval
    gaps: int

    @property
    def rate_low(self) -> bool:
        """The rate is below RATE_WARN_SHARE of what the usual interval promises."""
        return self.rate_hz * self.usual_interval_s < RATE_WARN_SHARE

    @property
    def healthy(self) -> bool:
        """No gap and no low rate (True for a period without intervals: nothing to judge)."""
        return self.gaps == 0 and (self.samples < 2 or not self.rate_low)

    def describe(self, topic: str) -> str:
        """One line: the gaps and the rate, e.g. for a diagnostics WARN."""
        parts = []
        if self.gaps:
            parts.append(
                f"{self.gaps} gap(s) in {topic}, longest {self.longest_interval_s * 1e3:.0f} ms "
                f"(gaps are over {self.gap_threshold_s * 1e3:.0f} ms, the usual interval "
                f"{self.usual_interval_s * 1e3:.2f} ms)"
            )
        if self.samples >= 2 and self.rate_low:
            parts.append(
                f"{topic} at {self.rate_hz:.1f} Hz, below the "
                f"{1.0 / self.usual_interval_s:.1f} Hz of its usual interval"
            )
        if not parts:
            parts.append(
                f"{topic} at {self.rate_hz:.1f} Hz, longest interval "
                f"{self.longest_interval_s * 1e3:.1f} ms"
            )
        return "; ".join(parts)

    def values(self) -> dict[str, str]:
        """Diagnostic values."""
        return {
            "input_rate_hz": f"{self.rate_hz:.2f}",
            "sample_interval_ms": f"{self.usual_interval_s * 1e3:.3f}",
            "longest_gap_ms": f"{self.longest_interval_s * 1e3:.1f}",
            "gap_threshold_ms": f"{self.gap_threshold_s * 1e3:.1f}",
            "gaps": str(self.gaps),
        }


class StreamTiming:
    """Running median interval, gap detection and per-period statistics of one stream.

    :meth:`observe` does a few float operations, a bisect and an in-place insertion into a list
    of :data:`WINDOW` floats: nothing grows.
    """

    def __init__(self) -> None:
        """No sample seen yet."""
        self._last_s: float | None = None
        self._ring = array("d", bytes(8 * WINDOW))
        self._next = 0
        self._sorted: list[float] = []
        self.gap_threshold_s = math.inf
        self.gaps_total = 0
        self._start_period()

    def _start_period(self) -> None:
        self._samples = 0
        self._intervals = 0
        self._span_s = 0.0
        self._longest_s = 0.0
        self._gaps = 0

    @property
    def usual_interval_s(self) -> float:
        """The median of the recent intervals (the lower one of an even count); NaN before any."""
        ordered = self._sorted
        return ordered[(len(ordered) - 1) // 2] if ordered else math.nan

    def observe(self, stamp_s: float) -> bool:
        """Add a sample's stamp; True if the interval since the previous sample is a gap.

        A stamp not after the previous one starts over from it (the caller drops such samples;
        this only happens when its guard restarts).
        """
        self._samples += 1
        last = self._last_s
        self._last_s = stamp_s
        if last is None or not stamp_s > last:
            return False
        interval = stamp_s - last
        gap = interval > self.gap_threshold_s
        self._intervals += 1
        self._span_s += interval
        if interval > self._longest_s:
            self._longest_s = interval
        if gap:
            self._gaps += 1
            self.gaps_total += 1
        self._add_interval(interval)
        return gap

    def _add_interval(self, interval: float) -> None:
        ordered = self._sorted
        if len(ordered) == WINDOW:
            del ordered[bisect_left(ordered, self._ring[self._next])]
        self._ring[self._next] = interval
        self._next = (self._next + 1) % WINDOW
        insort(ordered, interval)
        self.gap_threshold_s = max(GAP_FACTOR * ordered[(len(ordered) - 1) // 2], GAP_FLOOR_S)

    def take_period(self) -> PeriodTiming:
        """The statistics since the last call; a new period starts."""
        span = self._span_s
        period = PeriodTiming(
            samples=self._samples,
            rate_hz=self._intervals / span if span > 0.0 else 0.0,
            usual_interval_s=self.usual_interval_s,
            gap_threshold_s=self.gap_threshold_s,
            longest_interval_s=self._longest_s,
            gaps=self._gaps,
        )
        self._start_period()
        return period


# ---- against a promised rate


#: A gap is never a shortfall below this many promised periods.
GAP_PERIODS = 3.0


@dataclasses.dataclass(frozen=True)
class RateReport:
    """What :meth:`RateCheck.report` found."""

    #: Samples per second over the window (0 when none).
    rate_hz: float
    #: The rate the parameters promise.
    expected_rate_hz: float
    #: The longest time without a sample in the window, the open gap up to now included [s].
    longest_gap_s: float
    #: Why the stream falls short of the promise, or None.
    shortfall: str | None


class RateCheck:
    """Records sample times; reports the rate and the longest gap against a promised rate."""

    def __init__(
        self,
        start_s: float,
        window_s: float,
        min_rate_fraction: float = 0.8,
        max_gap_s: float = 0.1,
    ) -> None:
        """Start measuring at ``start_s`` (samples are expected from then on).

        Reports cover the last ``window_s``; ``min_rate_fraction`` 0 or ``max_gap_s`` 0 disables
        that check.

        Raises:
            ValueError: ``window_s`` not > 0, ``min_rate_fraction`` outside [0, 1], or
                ``max_gap_s`` negative.
        """
        if not window_s > 0.0:
            raise ValueError(f"window_s must be > 0, got {window_s}")
        if not 0.0 <= min_rate_fraction <= 1.0:
            raise ValueError(f"min_rate_fraction must be in [0, 1], got {min_rate_fraction}")
        if not max_gap_s >= 0.0:
            raise ValueError(f"max_gap_s must be >= 0, got {max_gap_s}")
        self.start_s = start_s
        self.window_s = window_s
        self.min_rate_fraction = min_rate_fraction
        self.max_gap_s = max_gap_s
        self._times: collections.deque[float] = collections.deque()

    def restart(self, start_s: float) -> None:
        """Forget the samples; measure from ``start_s`` (e.g. after the promise changed)."""
        self._times.clear()
        self.start_s = start_s

    def record(self, when_s: float) -> None:
        """One sample, read at ``when_s`` (samples arrive in time order)."""
        self._times.append(when_s)
        # Keep the window's samples plus the one before them (its gap crosses the window's
        # start).
        times = self._times
        while len(times) > 2 and times[1] < when_s - self.window_s:
            times.popleft()

    def report(self, now_s: float, expected_rate_hz: float) -> RateReport:
        """Rate and longest gap over the ``window_s`` up to ``now_s`` (not before the start).

        Raises:
            ValueError: ``expected_rate_hz`` not > 0.
        """
        if not expected_rate_hz > 0.0:
            raise ValueError(f"expected_rate_hz must be > 0, got {expected_rate_hz}")
        begin = max(now_s - self.window_s, self.start_s)
        span = now_s - begin
        inside = [t for t in self._times if begin < t <= now_s]
        before = [t for t in self._times if t <= begin]
        # A gap that began before the window counts whole: it ended (or goes on) inside it.
        edges = [before[-1] if before else begin, *inside, now_s]
        longest = max((b - a for a, b in zip(edges, edges[1:], strict=False)), default=0.0)
        rate = len(inside) / span if span > 0.0 else 0.0
        period = 1.0 / expected_rate_hz
        # The reasons name the limits, not the figures (those are in the report), so that a
        # status message stays the same while the shortfall lasts.
        reasons = []
        # Judge the rate only over a window that holds a few promised samples.
        if self.min_rate_fraction > 0.0 and span >= GAP_PERIODS * period:
            if rate < self.min_rate_fraction * expected_rate_hz:
                reasons.append(
                    f"rate below {self.min_rate_fraction:.0%} of the promised "
                    f"{expected_rate_hz:g} Hz"
                )
        max_gap = max(self.max_gap_s, GAP_PERIODS * period)
        if self.max_gap_s > 0.0 and longest > max_gap:
            reasons.append(f"a gap longer than {max_gap * 1e3:.0f} ms")
        shortfall = "; ".join(reasons) if reasons else None
        return RateReport(rate, expected_rate_hz, longest, shortfall)

"""Sample intervals of a stamped stream: its usual interval, its gaps and its rate (no rclpy).

The nodes do not know the rate their upstream publishes at (the driver's ``publish_rate_hz``),
so they learn it from the stream: the usual interval is the median of the last
:data:`WINDOW` intervals between sample stamps (robust to lost samples as long as fewer than
half of those intervals are stretched, and following a changed rate within :data:`WINDOW`
samples). An interval is a **gap** when it is longer than ``max(GAP_FACTOR x usual interval,
GAP_FLOOR_S)``. The floor keeps a fast stream's scheduling jitter (a few ms at 1 kHz) from
counting: for the report's geometry a 20 ms hole moves a sampled peak of theta3 by less than the
monitor's warning tolerance even at the driver's top speed of 20 rad/s.

Per period (the nodes' diagnostics period) :meth:`StreamTiming.take_period` returns the measured
rate (intervals over the stamp time they span), the longest interval and the number of gaps. The
rate is low when it is below :data:`RATE_WARN_SHARE` of what the usual interval promises: that
catches loss spread evenly (every fifth sample lost), which stretches no interval enough to be a
gap. Loss of every other sample looks like half the rate and is not detectable from the stream.

>>> timing = StreamTiming()
>>> flags = [timing.observe(0.005 * k) for k in range(40)]
>>> timing.observe(0.005 * 39 + 0.315), round(timing.usual_interval_s, 6)
(True, 0.005)
"""

from __future__ import annotations

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

"""How regular a stream of samples is: its rate and its gaps, two ways, and when that is news.

A consumer does not know the rate its upstream publishes at, so :class:`StreamTiming` learns it
from the stream's stamps (the kinematics node, the monitor); a producer knows what its parameters
promise, so :class:`RateCheck` measures against that promise (the driver). A shortfall becomes a
WARN only once it persists, and an OK only once it has cleared for a while
(:class:`PersistentStatus`), so that a loaded machine's jitter does not flip a status every
period. All plain Python (no rclpy) and cheap per sample. The rules and their constants:
docs/kinematics.md ("Gaps and rate") and docs/serial.md ("Rate and gaps").

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
#: The rate over a period is low below this share of 1 / usual interval: fewer than half the
#: samples arrived. A loaded computer's publisher skips ticks (130-175 Hz of a 200 Hz stream at
#: load 6-16 on two cores), which a consumer cannot tell from evenly spread loss; the holes either
#: leaves are the beats' business, and the driver, which knows its promise, reports its own rate.
RATE_WARN_SHARE = 0.5
#: A low rate clears only once the rate is this share of the promise above its limit (a rate that
#: hovers at a limit must not flip the status: the driver's at 75-85 % of its 200 Hz under load).
RATE_CLEAR_MARGIN = 0.1
#: Intervals whose spread (the high quantile below) sets the status's gap threshold: 2 s at 200 Hz.
JITTER_WINDOW = 400
#: The quantile of those intervals that measures the stream's own jitter (a loss pattern that
#: stretches 1 % of the intervals, as 65 ms holes twice a second at 200 Hz, stays above it) ...
JITTER_QUANTILE = 0.98
#: ... an interval longer than this many times it is a gap for the status ...
JITTER_FACTOR = 2.5
#: ... and only if longer than this [s] (10 intervals at 200 Hz: a scheduling hiccup of a loaded
#: computer is not a fault of the stream), and than GAP_FACTOR usual intervals.
STATUS_GAP_FLOOR_S = 0.05
#: The jitter never raises the status's gap threshold above this [s] (a stream that keeps
#: stalling must not teach the status to ignore its stalls).
STATUS_GAP_CEILING_S = 0.25


@dataclasses.dataclass(frozen=True)
class PeriodTiming:
    """The stream over one diagnostics period (intervals that ended in it)."""

    samples: int
    rate_hz: float  # intervals / their total duration; 0 without an interval
    usual_interval_s: float  # median interval at the end of the period; NaN before the first
    gap_threshold_s: float  # longer intervals are gaps; inf before the first interval
    longest_interval_s: float  # 0 without an interval
    gaps: int  # intervals over gap_threshold_s (holes in the data, for the beats)
    #: Longer intervals are gaps for the status (learned from the jitter); inf before the first.
    status_gap_threshold_s: float = math.inf
    #: Intervals over status_gap_threshold_s.
    status_gaps: int = 0
    #: The JITTER_QUANTILE of the recent intervals; NaN before the first.
    jitter_interval_s: float = math.nan

    @property
    def rate_low(self) -> bool:
        """The rate is below RATE_WARN_SHARE of what the usual interval promises."""
        return self.rate_below(RATE_WARN_SHARE)

    def rate_below(self, share: float) -> bool:
        """The rate is below ``share`` of what the usual interval promises."""
        return self.rate_hz * self.usual_interval_s < share

    def healthy_for(self, warning: bool) -> bool:
        """:attr:`healthy`, with the rate's limit RATE_CLEAR_MARGIN higher while ``warning``."""
        share = RATE_WARN_SHARE + (RATE_CLEAR_MARGIN if warning else 0.0)
        return self.status_gaps == 0 and (self.samples < 2 or not self.rate_below(share))

    @property
    def healthy(self) -> bool:
        """No status gap and no low rate (True for a period without intervals: nothing to judge).

        Gaps under the status threshold (a loaded machine's jitter) are holes in the data, which
        the beats account for, not a fault of the stream.
        """
        return self.status_gaps == 0 and (self.samples < 2 or not self.rate_low)

    def describe(self, topic: str) -> str:
        """One line: the gaps and the rate, e.g. for a diagnostics WARN."""
        parts = []
        if self.status_gaps:
            parts.append(
                f"{self.status_gaps} gap(s) in {topic}, longest "
                f"{self.longest_interval_s * 1e3:.0f} ms (gaps are over "
                f"{self.status_gap_threshold_s * 1e3:.0f} ms, the usual interval "
                f"{self.usual_interval_s * 1e3:.2f} ms, the {JITTER_QUANTILE:.0%} interval "
                f"{self.jitter_interval_s * 1e3:.1f} ms)"
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
            "jitter_interval_ms": f"{self.jitter_interval_s * 1e3:.1f}",
            "status_gap_threshold_ms": f"{self.status_gap_threshold_s * 1e3:.1f}",
            "status_gaps": str(self.status_gaps),
        }


class StreamTiming:
    """Running median interval, gap detection and per-period statistics of one stream.

    Two thresholds: :attr:`gap_threshold_s` marks the holes in the data (the beats'
    business: max(GAP_FLOOR_S, GAP_FACTOR x the median of the last WINDOW intervals)), and
    :attr:`status_gap_threshold_s` the gaps the status warns of, with a margin learned from the
    stream's own jitter: max(STATUS_GAP_FLOOR_S, GAP_FACTOR x the median, min(JITTER_FACTOR x the
    JITTER_QUANTILE of the last JITTER_WINDOW intervals, STATUS_GAP_CEILING_S)).

    :meth:`observe` does a few float operations, two bisects and in-place insertions into lists
    of :data:`WINDOW` and :data:`JITTER_WINDOW` floats: nothing grows.
    """

    def __init__(self) -> None:
        """No sample seen yet."""
        self._last_s: float | None = None
        self._ring = array("d", bytes(8 * WINDOW))
        self._next = 0
        self._sorted: list[float] = []
        self._jitter_ring = array("d", bytes(8 * JITTER_WINDOW))
        self._jitter_next = 0
        self._jitter_sorted: list[float] = []
        self.gap_threshold_s = math.inf
        self.status_gap_threshold_s = math.inf
        self.gaps_total = 0
        self._start_period()

    def _start_period(self) -> None:
        self._samples = 0
        self._intervals = 0
        self._span_s = 0.0
        self._longest_s = 0.0
        self._gaps = 0
        self._status_gaps = 0

    @property
    def usual_interval_s(self) -> float:
        """The median of the recent intervals (the lower one of an even count); NaN before any."""
        ordered = self._sorted
        return ordered[(len(ordered) - 1) // 2] if ordered else math.nan

    @property
    def jitter_interval_s(self) -> float:
        """The JITTER_QUANTILE of the last JITTER_WINDOW intervals; NaN before any."""
        ordered = self._jitter_sorted
        if not ordered:
            return math.nan
        return ordered[min(len(ordered) - 1, math.ceil(JITTER_QUANTILE * len(ordered)) - 1)]

    def observe(self, stamp_s: float) -> bool:
        """Add a sample's stamp; True if the interval since the previous sample is a gap.

        A stamp not after the previous one, or not finite, starts over from it (the caller drops
        such samples; this only happens when its guard restarts).
        """
        self._samples += 1
        last = self._last_s
        self._last_s = stamp_s if math.isfinite(stamp_s) else None
        if last is None or not stamp_s > last or not math.isfinite(stamp_s):
            return False
        interval = stamp_s - last
        gap = interval > self.gap_threshold_s
        if interval > self.status_gap_threshold_s:
            self._status_gaps += 1
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
        usual_gap = GAP_FACTOR * ordered[(len(ordered) - 1) // 2]
        self.gap_threshold_s = max(usual_gap, GAP_FLOOR_S)
        jitter = self._jitter_sorted
        if len(jitter) == JITTER_WINDOW:
            del jitter[bisect_left(jitter, self._jitter_ring[self._jitter_next])]
        self._jitter_ring[self._jitter_next] = interval
        self._jitter_next = (self._jitter_next + 1) % JITTER_WINDOW
        insort(jitter, interval)
        self.status_gap_threshold_s = max(
            STATUS_GAP_FLOOR_S,
            usual_gap,
            min(JITTER_FACTOR * self.jitter_interval_s, STATUS_GAP_CEILING_S),
        )

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
            status_gap_threshold_s=self.status_gap_threshold_s,
            status_gaps=self._status_gaps,
            jitter_interval_s=self.jitter_interval_s,
        )
        self._start_period()
        return period


# ---- when a shortfall is news


#: A shortfall becomes a WARN once it has lasted this long [s] (3 diagnostics periods of 1 s; a gap
#: counts its whole length) ...
WARN_AFTER_S = 3.0
#: ... and the WARN an OK again once the stream has been clear this long [s].
CLEAR_AFTER_S = 5.0


class PersistentStatus:
    """A status with hysteresis in time: WARN after WARN_AFTER_S short, OK after CLEAR_AFTER_S.

    Fed once per diagnostics period (:meth:`update`) with whether the period fell short; the
    shortfall's duration adds up over consecutive short periods (a period counts whole, a gap
    longer than the period counts its own length, so that one long outage is enough), and one clear
    period starts the count again. Any clear period resets the shortfall's count; any short one the
    clear count. A period length that is not a positive finite number counts as no time.

    >>> status = PersistentStatus()
    >>> [status.update(1.0, problem) for problem in ("gap", None, "gap", "gap", "gap", None)]
    [False, False, False, False, True, True]
    >>> status.update(1.0, None, 0.0), status.update(4.0, None), status.transitions
    (True, False, 2)
    """

    def __init__(self, warn_after_s: float = WARN_AFTER_S, clear_after_s: float = CLEAR_AFTER_S):
        """Start OK, nothing counted.

        Raises:
            ValueError: a duration that is negative or not finite.
        """
        for name, value in (("warn_after_s", warn_after_s), ("clear_after_s", clear_after_s)):
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        self.warn_after_s = warn_after_s
        self.clear_after_s = clear_after_s
        #: True while the status is WARN.
        self.warning = False
        #: How long the stream has been short [s] (0 while clear) ...
        self.short_s = 0.0
        #: ... and how long clear (0 while short).
        self.clear_s = 0.0
        #: Changes of level so far (OK to WARN and back).
        self.transitions = 0
        #: Why the latest short period fell short ("" before any).
        self.last_problem = ""

    def update(self, period_s: float, problem: str | None, lasted_s: float = 0.0) -> bool:
        """One period of ``period_s``: ``problem`` says why it fell short (None: it did not).

        ``lasted_s``: how long the shortfall lasted if longer than the period (a gap's length).
        Returns whether the status is WARN now.
        """
        elapsed = period_s if math.isfinite(period_s) and period_s > 0.0 else 0.0
        if problem is None:
            self.short_s = 0.0
            self.clear_s += elapsed
            if self.warning and self.clear_s >= self.clear_after_s:
                self.warning = False
                self.transitions += 1
            return self.warning
        self.last_problem = problem
        self.clear_s = 0.0
        self.short_s += max(elapsed, lasted_s) if math.isfinite(lasted_s) else elapsed
        if not self.warning and self.short_s >= self.warn_after_s:
            self.warning = True
            self.transitions += 1
        return self.warning


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

    def report(self, now_s: float, expected_rate_hz: float, recovering: bool = False) -> RateReport:
        """Rate and longest gap over the ``window_s`` up to ``now_s`` (not before the start).

        ``recovering`` (the status is WARN): the rate must beat ``min_rate_fraction`` by
        RATE_CLEAR_MARGIN to count as enough.

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
            fraction = min(self.min_rate_fraction + (RATE_CLEAR_MARGIN if recovering else 0.0), 1.0)
            if rate < fraction * expected_rate_hz:
                reasons.append(f"rate below {fraction:.0%} of the promised {expected_rate_hz:g} Hz")
        max_gap = max(self.max_gap_s, GAP_PERIODS * period)
        if self.max_gap_s > 0.0 and longest > max_gap:
            reasons.append(f"a gap longer than {max_gap * 1e3:.0f} ms")
        shortfall = "; ".join(reasons) if reasons else None
        return RateReport(rate, expected_rate_hz, longest, shortfall)

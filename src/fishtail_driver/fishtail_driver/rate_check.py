"""Is a stream of samples as frequent as promised? Measured rate and longest gap over a window.

The driver promises ``publish_rate_hz`` samples per second (with the serial backend at most
``serial_poll_rate_hz``). :class:`RateCheck` records when each sample was read and, on request,
reports the rate over the last ``window_s`` and the longest gap without a sample in it (the gap
still open at the time of the report included), and whether either falls short of the promise:
the rate below ``min_rate_fraction`` of the promised rate, or a gap longer than ``max_gap_s``
(but never less than :data:`GAP_PERIODS` promised periods, which slow promised rates reach by
design).

Times are seconds on one monotonic clock. This module does not import rclpy.
"""

from __future__ import annotations

import collections
import dataclasses

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
        """Rate and longest gap over the ``window_s`` up to ``now_s`` (not before the start)."""
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

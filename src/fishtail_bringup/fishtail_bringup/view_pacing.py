"""What the live view sends, paced to what a screen shows: decimation, late drops, its latency.

The suite publishes tail/state at 200 Hz and markers at 30 Hz; a browser's Rerun viewer takes in
at most about 10 ms of data per drawn frame, so on a slow renderer (a software-rasterised
Chromium) everything sent beyond what it can take waits in the page, and the view falls behind
without bound. The live view therefore sends each stream at a few tens of Hz at most
(:class:`RateLimit`), drops what arrives late instead of sending it (:class:`Lateness`) and says
how old what it sends is (:class:`LatencyWatch`). No rclpy here. docs/visualisation.md
("Keeping up").
"""

from __future__ import annotations

import math


class RateLimit:
    """At most ``rate_hz`` items a second of one stream, judged by their stamps; 0 keeps all.

    Time is cut into periods of ``1 / rate_hz``; the first item whose stamp falls in a period
    is kept, the others of that period are dropped (jittery stamps keep the rate on average). A
    stamp that goes back (a restarted suite) is kept and counted from.

    >>> limit = RateLimit(50.0)
    >>> sum(limit.admit(k / 200.0) for k in range(200))   # 1 s of 200 Hz
    50
    >>> limit.admit(0.0)   # the clock went back: kept, and counted from there
    True
    """

    def __init__(self, rate_hz: float) -> None:
        """Keep ``rate_hz`` a second (0: every item)."""
        self.period_s = 1.0 / rate_hz if rate_hz > 0.0 else 0.0
        self._last = -math.inf
        self._last_period = -math.inf
        self.dropped = 0

    def admit(self, stamp_s: float) -> bool:
        """Whether to keep the item stamped ``stamp_s``."""
        if self.period_s == 0.0:
            return True
        period = math.floor(stamp_s / self.period_s)
        if period != self._last_period or stamp_s < self._last:
            self._last, self._last_period = stamp_s, period
            return True
        self._last = stamp_s
        self.dropped += 1
        return False


class Lateness:
    """Whether a message is late: older, on arrival, than the stream's usual age plus a margin.

    The age is arrival time minus stamp. Its smallest value since the start is taken as the
    usual one, so that a suite on another computer whose clock is off by a constant is not late
    for it; a message ``late_s`` older than that is late (0: nothing is late).
    """

    def __init__(self, late_s: float) -> None:
        """Late beyond ``late_s`` seconds of extra age (0: never)."""
        self.late_s = late_s
        self.usual_age_s = math.inf
        self.dropped = 0

    def late(self, stamp_s: float, now_s: float) -> bool:
        """Whether the message stamped ``stamp_s`` that arrives at ``now_s`` is late (counted)."""
        age = now_s - stamp_s
        self.usual_age_s = min(self.usual_age_s, age)
        if self.late_s > 0.0 and age - self.usual_age_s > self.late_s:
            self.dropped += 1
            return True
        return False


class LatencyWatch:
    """The view's latency (send time minus the newest sent stamp) and when to warn about it.

    :meth:`update` takes each send's latency and returns a sentence when it crosses
    ``warning_s`` (behind) or comes back under it (caught up), at most once per
    ``quiet_s`` for the warnings; None otherwise.

    >>> watch = LatencyWatch(warning_s=1.0, quiet_s=10.0)
    >>> watch.update(0.2, now_s=0.0) is None
    True
    >>> watch.update(1.5, now_s=1.0)
    'behind: what the view sends is 1.5 s old (warning above 1 s)'
    >>> watch.update(1.7, now_s=2.0) is None   # still behind: said once
    True
    >>> watch.update(0.1, now_s=3.0)
    'caught up: 0.1 s (worst 1.7 s while behind)'
    """

    def __init__(self, warning_s: float, quiet_s: float = 10.0) -> None:
        """Warn above ``warning_s`` (0: never), at most once per ``quiet_s``."""
        self.warning_s = warning_s
        self.quiet_s = quiet_s
        self.behind = False
        self.worst_s = 0.0
        self.latest_s = math.nan
        self._said_at = -math.inf

    def update(self, latency_s: float, now_s: float) -> str | None:
        """Take one latency; a sentence to say, or None."""
        self.latest_s = latency_s
        if self.warning_s <= 0.0:
            return None
        if latency_s > self.warning_s:
            self.worst_s = max(self.worst_s, latency_s) if self.behind else latency_s
            if not self.behind and now_s - self._said_at >= self.quiet_s:
                self.behind = True
                self._said_at = now_s
                return (
                    f"behind: what the view sends is {latency_s:.1f} s old "
                    f"(warning above {self.warning_s:g} s)"
                )
            return None
        if self.behind:
            self.behind = False
            return f"caught up: {latency_s:.1f} s (worst {self.worst_s:.1f} s while behind)"
        return None

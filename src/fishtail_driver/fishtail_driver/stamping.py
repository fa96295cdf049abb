"""Message stamps for encoder samples: one monotonic-to-ROS clock mapping, strictly increasing.

The backends date samples on the monotonic clock and messages carry ROS time. :class:`ClockMapping`
keeps one offset between them, observed only where the process was not preempted and slewed, so
that a stamp is never dated wrong by a preemption; :class:`IncreasingStamps` drops, never nudges,
a stamp that is not after the previous one (consumers differentiate by the stamps). All times are
integer nanoseconds; no rclpy. Why and how: docs/serial.md ("Stamps").
"""

from __future__ import annotations

#: Observations whose monotonic bracket is wider than this are not trusted [ns].
MAX_BRACKET_NS = 1_000_000
#: At most this fraction of the elapsed monotonic time is slewed into the offset.
SLEW_FRACTION = 0.05
#: A difference this large between observed and current offset is a clock step [ns].
STEP_NS = 100_000_000


class ClockMapping:
    """Monotonic time -> ROS time through one offset, observed and slewed."""

    def __init__(
        self,
        max_bracket_ns: int = MAX_BRACKET_NS,
        slew_fraction: float = SLEW_FRACTION,
        step_ns: int = STEP_NS,
    ) -> None:
        """No offset until the first :meth:`observe`.

        Raises:
            ValueError: a negative bracket, a slew fraction outside (0, 1) or a step <= 0.
        """
        if max_bracket_ns < 0 or not 0.0 < slew_fraction < 1.0 or step_ns <= 0:
            raise ValueError("need max_bracket_ns >= 0, 0 < slew_fraction < 1, step_ns > 0")
        self.max_bracket_ns = max_bracket_ns
        self.slew_fraction = slew_fraction
        self.step_ns = step_ns
        self.offset_ns: int | None = None
        self._observed_at_ns = 0
        #: Observations not used because the bracket was too wide.
        self.rejected = 0
        #: Steps of the ROS clock followed.
        self.steps = 0

    def observe(self, monotonic_before_ns: int, ros_ns: int, monotonic_after_ns: int) -> None:
        """Account for a ROS clock reading taken between two monotonic readings.

        A small difference is slewed in, one of ``step_ns`` or more (the ROS clock was set) is
        followed at once; an observation whose bracket is wider than ``max_bracket_ns`` is not
        used.

        Raises:
            ValueError: the monotonic readings are out of order.
        """
        if monotonic_after_ns < monotonic_before_ns:
            raise ValueError("the monotonic readings are out of order")
        middle = (monotonic_before_ns + monotonic_after_ns) // 2
        estimate = ros_ns - middle
        if self.offset_ns is None:
            # The best there is so far; later, tighter observations slew it in.
            self.offset_ns = estimate
            self._observed_at_ns = middle
            return
        if monotonic_after_ns - monotonic_before_ns > self.max_bracket_ns:
            self.rejected += 1
            return
        difference = estimate - self.offset_ns
        if abs(difference) >= self.step_ns:
            self.offset_ns = estimate
            self.steps += 1
        else:
            allowed = int(self.slew_fraction * max(0, middle - self._observed_at_ns))
            self.offset_ns += max(-allowed, min(allowed, difference))
        self._observed_at_ns = max(self._observed_at_ns, middle)

    def to_ros_ns(self, monotonic_ns: int) -> int:
        """The ROS time of a monotonic time.

        Raises:
            RuntimeError: before the first observation.
        """
        if self.offset_ns is None:
            raise RuntimeError("no clock observation yet")
        return monotonic_ns + self.offset_ns


class IncreasingStamps:
    """Passes only stamps after the previous passed one (and after 0); counts the others."""

    def __init__(self) -> None:
        """Nothing passed yet."""
        self.last_ns = 0
        #: Stamps dropped because they were not after the previous one.
        self.dropped = 0

    def admit(self, stamp_ns: int) -> int | None:
        """``stamp_ns`` if it is after the last admitted stamp, else None (counted)."""
        if stamp_ns <= self.last_ns:
            self.dropped += 1
            return None
        self.last_ns = stamp_ns
        return stamp_ns

"""The board's encoder readings -> a continuous carrier angle: unwrapping, plausibility, re-bases.

Pure logic (no I/O, no threads), so that every fault can be tested without a port: the serial
backend feeds it each reading with the time the board took it and publishes what it returns.
:class:`CountUnwrapper` follows the 32-bit counter across its wrap; :class:`EncoderTracker`
re-bases the angle after a board reset (it must not jump back), drops corrupt readings that
happen to parse, and estimates the velocity. The rules: docs/serial.md ("What motor/joint_state
and /diagnostics show", "Carrier-phase calibration").

>>> from fishtail_plant.motor.board_units import Scale
>>> tracker = EncoderTracker(Scale(counts_per_revolution=1000), "left", max_speed_rad_s=20.0)
>>> tracker.accept((5000, 0), 0.0, after_connect=True, driven=False).sample.angle_rad
0.0
>>> step = tracker.accept((5010, 0), 0.01, after_connect=False, driven=True)
>>> round(step.sample.angle_rad, 4), step.rebase
(0.0628, None)
>>> tracker.accept((0, 0), 0.02, after_connect=True, driven=True).rebase
'counts read 0 0 (were 5010)'
"""

from __future__ import annotations

import collections
import dataclasses
import math

from fishtail_driver.backends import EncoderSample
from fishtail_driver.protocol import CHANNELS
from fishtail_plant.motor.board_units import Scale, wrap_int32

#: A count this close to zero is standstill jitter, not a reset, when it reads 0.
JITTER_COUNTS = 2
#: Allowance for timing jitter between the board's reading and our receive time [s].
TIMING_SLACK_S = 0.05
#: The motor turns one way: a step against its direction larger than this is a reset [rad].
BACKWARD_TOLERANCE_RAD = 0.2
#: Allowance for this process being descheduled between a reply and its time stamp [s].
STALL_SLACK_S = 0.02


@dataclasses.dataclass(frozen=True)
class UnwrapStep:
    """What :meth:`CountUnwrapper.update` did with one raw count.

    ``event`` is "first" (first sample or first after :meth:`CountUnwrapper.rebase`: the
    continuous count is held), "move" (normal step), "wrap" (a step across the 32-bit wrap) or
    "jump" (a step larger than ``max_step``: treated as a discontinuity, the continuous count is
    held).
    """

    total: int
    delta: int
    event: str


class CountUnwrapper:
    """Continuous count from the board's signed 32-bit counter, held across discontinuities.

    Steps are taken modulo 2**32 (the shortest way round), so crossing the wrap from 2**31 - 1 to
    -2**31 is a step of +1. A step larger than ``max_step`` (when given) is treated as a
    discontinuity: the continuous count stays where it was and counting continues from the new
    raw value. :meth:`rebase` forces the same for the next sample.

    >>> unwrapper = CountUnwrapper()
    >>> raws = (2147483600, 2147483647, -2147483600, 10)
    >>> [unwrapper.update(raw, max_step=1000).event for raw in raws]
    ['first', 'move', 'wrap', 'jump']
    >>> unwrapper.total
    96
    """

    def __init__(self) -> None:
        """Start with no reference: the first sample defines count 0."""
        self.total = 0
        self.last_raw: int | None = None
        self.wraps = 0
        self.jumps = 0

    def rebase(self) -> None:
        """Make the next sample a new reference (the continuous count is held)."""
        self.last_raw = None

    def delta_to(self, raw: int) -> int | None:
        """The (wrapped) step from the last raw reading to ``raw``; None without a reference."""
        return None if self.last_raw is None else wrap_int32(raw - self.last_raw)

    def update(self, raw: int, max_step: int | None = None) -> UnwrapStep:
        """Account for one raw reading; returns the new continuous count and what happened."""
        if self.last_raw is None:
            self.last_raw = raw
            return UnwrapStep(self.total, 0, "first")
        plain = raw - self.last_raw
        delta = wrap_int32(plain)
        self.last_raw = raw
        if max_step is not None and abs(delta) > max_step:
            self.jumps += 1
            return UnwrapStep(self.total, delta, "jump")
        self.total += delta
        if delta != plain:
            self.wraps += 1
            return UnwrapStep(self.total, delta, "wrap")
        return UnwrapStep(self.total, delta, "move")


@dataclasses.dataclass(frozen=True)
class Tracked:
    """What :meth:`EncoderTracker.accept` made of one reading."""

    #: The new sample to publish; None while the reading is held back awaiting confirmation.
    sample: EncoderSample | None
    #: Why the count was re-based at this reading (a board reset), or None.
    rebase: str | None = None
    #: Why an earlier reading was found corrupt and dropped or corrected, or None.
    outlier: str | None = None


class EncoderTracker:
    """One channel's readings -> continuous angle and velocity, re-based after board resets.

    Args:
        scale: the encoder's units.
        channel: "left" or "right": which count of the board's pair is the tail's.
        max_speed_rad_s: the carrier speed limit; twice it bounds a plausible step.
        velocity_window_s: time span of the velocity estimate.
    """

    def __init__(
        self, scale: Scale, channel: str, max_speed_rad_s: float, velocity_window_s: float = 0.1
    ) -> None:
        """Start with no reading.

        Raises:
            ValueError: a channel other than "left" or "right".
        """
        if channel not in CHANNELS:
            raise ValueError(f"channel must be 'left' or 'right', got {channel!r}")
        self.scale = scale
        self.channel_index = CHANNELS.index(channel)
        self.max_speed_rad_s = max_speed_rad_s
        self.velocity_window_s = velocity_window_s
        self.unwrapper = CountUnwrapper()
        #: The newest published sample.
        self.latest: EncoderSample | None = None
        self._last_sample_s: float | None = None
        self._direction = 0  # +1/-1: how the count runs when driven forwards; 0: not known yet
        self._pending: tuple[int, float] | None = None  # a reading awaiting confirmation
        self._history: collections.deque[tuple[float, int]] = collections.deque()

    @property
    def total(self) -> int:
        """The continuous count (counts since the first reading, across wraps and re-bases)."""
        return self.unwrapper.total

    @property
    def wraps(self) -> int:
        """How often the board's counter wrapped."""
        return self.unwrapper.wraps

    def max_step(self, elapsed_s: float) -> int:
        """The largest step in counts the motor can make in ``elapsed_s`` (with slack)."""
        speed = 2.0 * self.max_speed_rad_s
        return math.ceil(self.scale.counts_from_angle(speed * (elapsed_s + TIMING_SLACK_S))) + 16

    def discontinuity(
        self, pair: tuple[int, int], delta: int, elapsed_s: float, previous: int | None = None
    ) -> str | None:
        """Why a step of ``delta`` counts over ``elapsed_s`` cannot be motion, or None.

        ``previous`` is the raw count the step starts from (default: the last accepted one).
        """
        if previous is None:
            previous = self.unwrapper.last_raw
        if previous is not None and pair == (0, 0) and abs(previous) > JITTER_COUNTS:
            return f"counts read 0 0 (were {previous})"
        if abs(delta) > self.max_step(elapsed_s):
            return f"count jumped by {delta} in {elapsed_s:.3f} s"
        backward = self.scale.counts_from_angle(BACKWARD_TOLERANCE_RAD) + JITTER_COUNTS
        if self._direction and delta * self._direction < -backward:
            return f"count went {abs(delta)} against the motor's direction"
        return None

    def trusted(
        self, pair: tuple[int, int], delta: int, elapsed_s: float, previous: int | None = None
    ) -> bool:
        """Whether a possible step matches the speed estimate closely enough to accept at once."""
        if self.discontinuity(pair, delta, elapsed_s, previous) is not None:
            return False
        speed = self.latest.velocity_rad_s if self.latest is not None else 0.0
        predicted = self.scale.counts_from_angle(speed * elapsed_s)
        allowed = JITTER_COUNTS + self.scale.counts_from_angle(
            self.max_speed_rad_s * elapsed_s + abs(speed) * STALL_SLACK_S
        )
        return abs(delta - predicted) <= allowed

    def accept(
        self, pair: tuple[int, int], when_s: float, after_connect: bool, driven: bool
    ) -> Tracked:
        """Account for one reading of the board's pair of counts, taken at ``when_s``.

        ``after_connect``: the first reading after a (re)connect, when there is no speed to
        predict from (only the impossible is ruled out). ``driven``: the board was last
        acknowledged a forward speed (the count's direction is learnt from such steps).
        """
        raw = pair[self.channel_index]
        unwrapper = self.unwrapper
        last_s = self._last_sample_s if self._last_sample_s is not None else when_s
        elapsed = max(when_s - last_s, 0.0)
        delta = unwrapper.delta_to(raw)
        rebase = outlier = None
        if delta is None or unwrapper.last_raw is None:
            self._pending = None
        elif after_connect or (pair == (0, 0) and abs(unwrapper.last_raw) > JITTER_COUNTS):
            self._pending = None
            rebase = self.discontinuity(pair, delta, elapsed)
            if rebase is not None:
                unwrapper.rebase()
        elif self.trusted(pair, delta, elapsed):
            if self._pending is not None:
                outlier = f"reading {self._pending[0]} disagreed with its neighbours; dropped"
                self._pending = None
        elif self._pending is not None and self.trusted(
            pair, wrap_int32(raw - self._pending[0]), max(when_s - self._pending[1], 0.0),
            previous=self._pending[0],
        ):  # fmt: skip
            rebase, outlier = self._confirm_held(pair, last_s, driven)
        else:
            if self._pending is not None:
                outlier = f"reading {self._pending[0]} disagreed with its neighbours; dropped"
            self._pending = (raw, when_s)
            return Tracked(None, None, outlier)
        self._learn_direction(unwrapper.update(raw), driven)
        self._last_sample_s = when_s
        return Tracked(self._sample(when_s, rebase is not None or after_connect), rebase, outlier)

    def _confirm_held(
        self, pair: tuple[int, int], last_s: float, driven: bool
    ) -> tuple[str | None, str | None]:
        """The held reading was confirmed by the next one: take it; (re-base, outlier) reasons."""
        assert self._pending is not None
        held_raw, held_s = self._pending
        self._pending = None
        held_delta = self.unwrapper.delta_to(held_raw)
        assert held_delta is not None
        elapsed = max(held_s - last_s, 0.0)
        rebase = self.discontinuity(pair, held_delta, elapsed)
        outlier = None
        if rebase is not None and abs(held_raw) > self.max_step(elapsed):
            # Confirmed, but too far from 0 for a board that restarted since the last reading:
            # the reading accepted before was a corrupt value that happened to look plausible.
            # Follow the board (a one-off correction) rather than re-basing, which would keep
            # that error in the angle for good.
            outlier = (
                f"reading before {held_raw} was corrupt: angle corrected by {held_delta} counts"
            )
            rebase = None
        if rebase is not None:
            self.unwrapper.rebase()
        self._learn_direction(self.unwrapper.update(held_raw), driven)
        return rebase, outlier

    def _learn_direction(self, step: UnwrapStep, driven: bool) -> None:
        """Learn which way the count runs when the motor is driven forwards (wiring dependent)."""
        if driven and step.event in ("move", "wrap") and abs(step.delta) > JITTER_COUNTS:
            self._direction = 1 if step.delta > 0 else -1

    def _sample(self, when_s: float, restart: bool) -> EncoderSample:
        """The sample of the current count; ``restart`` drops the velocity history."""
        total = self.unwrapper.total
        history = self._history
        if restart:
            history.clear()
        history.append((when_s, total))
        while len(history) > 2 and history[1][0] <= when_s - self.velocity_window_s:
            history.popleft()
        base_s, base_total = history[0]
        if when_s > base_s:
            velocity = self.scale.angle_from_counts(total - base_total) / (when_s - base_s)
        else:
            keep = self.latest is not None and not restart
            velocity = self.latest.velocity_rad_s if keep and self.latest is not None else 0.0
        self.latest = EncoderSample(when_s, self.scale.angle_from_counts(total), velocity)
        return self.latest

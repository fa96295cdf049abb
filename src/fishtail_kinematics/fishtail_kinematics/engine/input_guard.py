"""Plausibility of a carrier-angle stream: which samples the nodes drop, and why (no rclpy).

The kinematics node checks each ``motor/joint_state`` sample and the monitor each ``tail/state``
sample with :class:`CarrierGuard` before using it, so that a corrupt or stray sample never
reaches the engine or the beat statistics; :class:`DropCounts` counts the drops per reason for
``/diagnostics``. A stream that pauses for ``restart_after_ns`` is followed afresh. The rules and
why each bound: docs/kinematics.md ("In the nodes").

>>> guard = CarrierGuard()
>>> [guard.check(t, angle, 0.0, now_ns=10**12) for t, angle in ((1, 0.0), (2, 0.5), (3, 0.2))]
[None, None, 'backwards']
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fishtail_common.interface import CARRIER_JOINT, MOTOR_JOINT_STATE, Level
from fishtail_common.parameters import ParameterSpec, ParameterValue
from fishtail_common.stream_timing import PeriodTiming, PersistentStatus
from fishtail_kinematics.engine.carrier_profile import DEFAULT_TOP_SPEED_RAD_S

#: Largest plausible |carrier angle| [rad] (docs/kinematics.md: why 1e9).
MAX_ABS_CARRIER_ANGLE_RAD = 1e9
#: Default backwards tolerance [rad]: about three counts of the driver's default encoder
#: (2048 counts a turn, gear ratio 1).
DEFAULT_BACKWARDS_TOLERANCE_RAD = 0.01
#: Default lead of a stamp over the node's clock that is still accepted [s]: generous for two
#: hosts whose clocks are synchronised, far below the hour a wrong clock is typically off.
DEFAULT_FUTURE_TOLERANCE_S = 1.0
#: Default time without input after which the nodes say STALE and the guard restarts [s].
DEFAULT_STALE_TIMEOUT_S = 2.0

NON_FINITE = "non_finite"
ANGLE_OUT_OF_RANGE = "angle_out_of_range"
STAMP_IN_FUTURE = "stamp_in_future"
STAMP_NOT_INCREASING = "stamp_not_increasing"
BACKWARDS = "backwards"
#: A forward step beyond what the motor can turn since the last sample (only with a speed limit).
CARRIER_JUMP = "carrier_jump"
#: Margin on the carrier speed limit before a step is a jump: a real motor's speed loop
#: overshoots its limit by tens of per cent at most, a corrupt angle by orders of magnitude.
JUMP_SPEED_MARGIN = 1.5
#: Angle allowed on top of the margin [rad]: three counts of the driver's default encoder, the
#: quantisation at both ends of a short interval (1 kHz: 2 counts in 1 ms are 6 rad/s).
JUMP_SLACK_RAD = 0.01
#: Reasons of :meth:`CarrierGuard.check`, in the order they are checked.
GUARD_REASONS = (NON_FINITE, ANGLE_OUT_OF_RANGE, STAMP_IN_FUTURE, STAMP_NOT_INCREASING, BACKWARDS)
#: The nodes' parameters that configure a guard.
GUARD_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec(
        "backwards_tolerance_rad",
        DEFAULT_BACKWARDS_TOLERANCE_RAD,
        "a carrier angle this far below the highest one so far is dropped (encoder jitter passes)",
        "rad",
        0.0,
        10.0,
    ),
    ParameterSpec(
        "future_tolerance_sec",
        DEFAULT_FUTURE_TOLERANCE_S,
        "a sample stamped further ahead of this node's clock is dropped",
        "s",
        0.001,
        86400.0,
    ),
)
#: Both nodes' stale timeout, which is also when the guard follows a stream afresh.
STALE_TIMEOUT = ParameterSpec(
    "stale_timeout_sec",
    DEFAULT_STALE_TIMEOUT_S,
    "diagnostics say STALE after this long without input; the next sample is then accepted afresh",
    "s",
    0.1,
    600.0,
)
#: The simulator's speed limit of the carrier (read-only): the driver's ``max_speed_rad_s`` default.
MAX_CARRIER_SPEED = ParameterSpec(
    "max_carrier_speed_rad_s",
    DEFAULT_TOP_SPEED_RAD_S,
    f"the motor's top speed: a faster period is warned, a step beyond {JUMP_SPEED_MARGIN:g} times "
    "it over the interval a carrier jump, dropped",
    "rad/s",
    0.1,
    1000.0,
)
#: What each reason means, for a log line.
REASON_TEXT = {
    NON_FINITE: "a NaN or infinite value",
    ANGLE_OUT_OF_RANGE: f"a carrier angle beyond +/-{MAX_ABS_CARRIER_ANGLE_RAD:g} rad",
    STAMP_IN_FUTURE: "a stamp ahead of this node's clock",
    STAMP_NOT_INCREASING: "a stamp not after the previous sample's",
    BACKWARDS: "a carrier angle going backwards (the motor turns one way only)",
    CARRIER_JUMP: "a carrier angle further ahead than the motor can turn since the last sample",
}


def plausible_advance_rad(elapsed_s: float, max_speed_rad_s: float) -> float:
    """The largest carrier advance over ``elapsed_s`` that is not a jump [rad].

    >>> round(plausible_advance_rad(0.005, 20.0), 6)
    0.16
    """
    return JUMP_SPEED_MARGIN * max_speed_rad_s * elapsed_s + JUMP_SLACK_RAD


class CarrierGuard:
    """The plausibility rules for one stream, with its reference sample (docs/kinematics.md).

    :meth:`check` costs a few comparisons and allocates nothing.
    """

    def __init__(
        self,
        backwards_tolerance_rad: float = DEFAULT_BACKWARDS_TOLERANCE_RAD,
        future_tolerance_ns: int = int(DEFAULT_FUTURE_TOLERANCE_S * 1e9),
        restart_after_ns: int = int(DEFAULT_STALE_TIMEOUT_S * 1e9),
        max_speed_rad_s: float = math.inf,
    ) -> None:
        """Create a guard that has accepted nothing yet.

        ``max_speed_rad_s``: the motor's top speed; finite, a forward step beyond
        :func:`plausible_advance_rad` since the reference is a :data:`CARRIER_JUMP`.
        """
        self.backwards_tolerance_rad = backwards_tolerance_rad
        self.future_tolerance_ns = future_tolerance_ns
        self.restart_after_ns = restart_after_ns
        self.max_speed_rad_s = max_speed_rad_s
        self._last_stamp_ns = 0
        self._last_angle = 0.0
        self._highest_angle = -math.inf
        self._accepted_at_ns: int | None = None
        # The last jumped sample (stamp, angle): a step that persists is re-based on it.
        self._candidate: tuple[int, float] | None = None
        #: The last jump: its advance [rad] and interval [s] (0, 0 before any).
        self.jump = (0.0, 0.0)
        #: After an accepted sample: the jumped sample the stream was re-based on, else None.
        self.rebased_from: tuple[int, float] | None = None

    def check(self, stamp_ns: int, angle_rad: float, others: float, now_ns: int) -> str | None:
        """None if the sample is plausible (it becomes the reference), else the reason to drop it.

        ``others`` is the sum of the sample's other values that must be finite (a sum is NaN or
        infinite when one of its terms is); ``now_ns`` is the node's clock, 0 if it has no time
        yet (simulated time before the first /clock), which skips the future check.

        With a finite ``max_speed_rad_s`` a forward jump is held: dropped, the reference kept, so a
        one-sample spike costs one sample. A sample that continues plausibly from the jumped one
        instead of the reference (the step persisted) is accepted and re-bases the stream on it
        (:attr:`rebased_from`): two samples, not a wedge.
        """
        self.rebased_from = None
        if not (math.isfinite(angle_rad) and math.isfinite(others)):
            return NON_FINITE
        if not abs(angle_rad) <= MAX_ABS_CARRIER_ANGLE_RAD:
            return ANGLE_OUT_OF_RANGE
        if now_ns > 0 and stamp_ns - now_ns > self.future_tolerance_ns:
            return STAMP_IN_FUTURE
        accepted_at = self._accepted_at_ns
        if accepted_at is not None and now_ns - accepted_at <= self.restart_after_ns:
            if stamp_ns <= self._last_stamp_ns:
                return STAMP_NOT_INCREASING
            if angle_rad < self._highest_angle - self.backwards_tolerance_rad:
                return BACKWARDS
            if self._is_jump(stamp_ns, angle_rad):
                return CARRIER_JUMP
            if angle_rad > self._highest_angle:
                self._highest_angle = angle_rad
        else:
            self._highest_angle = angle_rad
        self._candidate = None
        self._last_stamp_ns = stamp_ns
        self._last_angle = angle_rad
        self._accepted_at_ns = now_ns
        return None

    def _is_jump(self, stamp_ns: int, angle_rad: float) -> bool:
        """True (and the sample held) if it jumped; a re-base on the held sample is no jump."""
        limit = self.max_speed_rad_s
        advance = angle_rad - self._last_angle
        elapsed_s = (stamp_ns - self._last_stamp_ns) * 1e-9
        if advance <= plausible_advance_rad(elapsed_s, limit):
            return False
        candidate = self._candidate
        if candidate is not None and stamp_ns > candidate[0]:
            from_candidate = angle_rad - candidate[1]
            since_s = (stamp_ns - candidate[0]) * 1e-9
            if (
                -self.backwards_tolerance_rad <= from_candidate
                and from_candidate <= plausible_advance_rad(since_s, limit)
            ):
                self.rebased_from = candidate
                self._highest_angle = candidate[1]
                return False
        self._candidate = (stamp_ns, angle_rad)
        self.jump = (advance, elapsed_s)
        return True

    def reset(self) -> None:
        """Forget the reference: the next plausible sample is accepted whatever its stamp."""
        self._accepted_at_ns = None

    def apply_parameters(self, values: Mapping[str, ParameterValue]) -> None:
        """Take the guard's parameters among ``values``: :data:`GUARD_PARAMETERS`, the timeout."""
        if "backwards_tolerance_rad" in values:
            self.backwards_tolerance_rad = float(values["backwards_tolerance_rad"])
        if "future_tolerance_sec" in values:
            self.future_tolerance_ns = int(float(values["future_tolerance_sec"]) * 1e9)
        if STALE_TIMEOUT.name in values:
            # After the nodes' stale timeout without an accepted sample, follow the stream afresh.
            self.restart_after_ns = int(float(values[STALE_TIMEOUT.name]) * 1e9)
        if MAX_CARRIER_SPEED.name in values:
            self.max_speed_rad_s = float(values[MAX_CARRIER_SPEED.name])


#: Drop reasons of a node that follows the carrier, besides the guard's: the message does not
#: name the carrier joint, or the engine refused the angle.
NO_CARRIER_JOINT = "no_carrier_joint"
ENGINE_REFUSED = "engine_refused"
#: Every reason a carrier follower drops a sample for, in the order the diagnostics list them.
FOLLOWER_REASONS = (*GUARD_REASONS, NO_CARRIER_JOINT, ENGINE_REFUSED)

MOTOR_JOINT_NAME = ParameterSpec(
    "motor_joint_name",
    CARRIER_JOINT,
    f"joint of {MOTOR_JOINT_STATE.name} that is the carrier",
    non_empty=True,
)


class CarrierJoint:
    """Where the carrier joint is in a JointState's names, cached while the names stay the same.

    >>> joint = CarrierJoint("carrier_joint")
    >>> joint.index(["wheel", "carrier_joint"]), joint.index(["wheel"])
    (1, None)
    """

    def __init__(self, name: str) -> None:
        """Look for the joint ``name``."""
        self.name = name
        self._names: tuple[str, ...] = ()
        self._index: int | None = None

    def rename(self, name: str) -> None:
        """Look for another joint from now on."""
        self.name = name
        self._names, self._index = (), None

    def index(self, names: list[str] | tuple[str, ...]) -> int | None:
        """The joint's index in ``names``, or None when they do not name it."""
        key = tuple(names)
        if key != self._names:
            self._names = key
            self._index = key.index(self.name) if self.name in key else None
        return self._index


class DropCounts:
    """Dropped samples per reason: in total, and since the last :meth:`take_period`."""

    def __init__(self, reasons: tuple[str, ...]) -> None:
        """Counters at zero for ``reasons`` (the keys of the diagnostics, in this order)."""
        self.total = dict.fromkeys(reasons, 0)
        self._period = dict.fromkeys(reasons, 0)

    def count(self, reason: str) -> None:
        """One more sample dropped for ``reason``."""
        self.total[reason] += 1
        self._period[reason] += 1

    @property
    def dropped(self) -> int:
        """Samples dropped in total."""
        return sum(self.total.values())

    def take_period(self) -> dict[str, int]:
        """The non-zero counts since the last call, most frequent first; the counts restart."""
        counts = sorted(
            ((reason, n) for reason, n in self._period.items() if n), key=lambda item: -item[1]
        )
        for reason in self._period:
            self._period[reason] = 0
        return dict(counts)

    def values(self) -> dict[str, str]:
        """Diagnostic values: ``dropped`` and ``dropped_<reason>`` for every reason."""
        values = {"dropped": str(self.dropped)}
        values.update((f"dropped_{reason}", str(n)) for reason, n in self.total.items())
        return values


def drops_text(topic: str, counts: Mapping[str, int], period_s: float) -> str:
    """One line naming the reasons, e.g. ``dropped 12 tail/state samples in 1 s: 10 backwards``."""
    total = sum(counts.values())
    reasons = ", ".join(f"{n} {reason}" for reason, n in counts.items())
    return f"dropped {total} {topic} samples in {period_s:g} s: {reasons}"


def input_status(
    topic: str,
    drops: DropCounts,
    timing: PeriodTiming,
    period_s: float,
    persistence: PersistentStatus | None = None,
) -> tuple[Level, str, dict[str, str]]:
    """Level (OK or WARN), message and values of an input stream over one period.

    WARN when samples were dropped (at once: a corrupt sample is a fault, not load), or the
    stream had gaps or a low rate (:mod:`fishtail_common.stream_timing`); with ``persistence``
    (the node's one :class:`PersistentStatus` for this stream) gaps and rate WARN only once they
    persist and stay WARN until they have cleared for a while, the message saying which. The
    message names each problem, the values carry the counts per reason, the measured rate, the
    usual interval and the longest interval of the period.
    """
    counts = drops.take_period()
    problems = []
    if counts:
        problems.append(drops_text(topic, counts, period_s))
    warning = persistence is not None and persistence.warning
    timing_problem = None if timing.healthy_for(warning) else timing.describe(topic)
    values = {**drops.values(), **timing.values()}
    if persistence is None:
        if timing_problem is not None:
            problems.append(timing_problem)
    else:
        # A gap that ended in this period counts its whole length (one long outage is enough).
        lasted = timing.longest_interval_s if timing.status_gaps else 0.0
        warning = persistence.update(period_s, timing_problem, lasted)
        if warning:
            problems.append(
                timing_problem
                or f"{timing.describe(topic)}, recovering from: {persistence.last_problem} "
                f"(OK once clear for {persistence.clear_after_s:g} s)"
            )
        elif timing_problem is not None and not problems:
            return (
                Level.OK,
                (f"{timing_problem} (WARN if it lasts {persistence.warn_after_s:g} s)"),
                values,
            )
    if problems:
        return Level.WARN, "; ".join(problems), values
    return Level.OK, timing.describe(topic), values

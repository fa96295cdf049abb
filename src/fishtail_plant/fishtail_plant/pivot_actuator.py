"""The pivot actuator: a lead screw that shifts the tail's pivot S along the body axis.

The fish's second means of steering, simulated beside the driver's carrier: a slow positioning
axis that runs at a constant speed towards its target within its stroke, exact in closed form
(:meth:`PivotActuator.state` at any time, no stepping). Topics, parameters and the board-side
design: docs/serial.md ("The pivot actuator").

>>> pivot = PivotActuator(PivotLimits(stroke_m=0.03, speed_m_s=0.01))
>>> pivot.command(0.02, now_s=0.0).target_m
0.02
>>> [round(value, 4) for value in pivot.state(1.0)]  # halfway, at 0.01 m/s
[0.01, 0.01]
>>> [round(value, 4) for value in pivot.state(5.0)]  # arrived at 2 s, and stopped
[0.02, 0.0]
>>> outcome = pivot.command(0.05, now_s=5.0)
>>> outcome.target_m, outcome.clipped
(0.03, True)
"""

from __future__ import annotations

import dataclasses
import math

from fishtail_common.parameters import ParameterSpec

#: The actuator's reach each way from the design position of S, as the driver's simulated
#: actuator has it and as the pilot's steering map plans with it.
PIVOT_STROKE = ParameterSpec(
    "pivot_stroke_m", 0.03,
    "pivot: half its travel; it moves within +- this of the design position", "m", 0.001, 0.5,
)  # fmt: skip
#: The lead screw's speed (constant towards the target, stopping at it).
PIVOT_SPEED = ParameterSpec(
    "pivot_speed_m_s", 0.01,
    "pivot: the lead screw's speed (constant towards the target, stopping at it)", "m/s",
    0.0001, 1.0,
)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class PivotLimits:
    """Half the travel [m] about the design position, and the screw's speed [m/s].

    Raises:
        ValueError: a stroke or speed that is not finite and > 0.
    """

    stroke_m: float = float(PIVOT_STROKE.default)
    speed_m_s: float = float(PIVOT_SPEED.default)

    def __post_init__(self) -> None:
        """Refuse a stroke or speed that is not a positive number, with the reason."""
        for name in ("stroke_m", "speed_m_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value!r}")

    @property
    def full_stroke_time_s(self) -> float:
        """How long a move from one end of the stroke to the other takes."""
        return 2.0 * self.stroke_m / self.speed_m_s


@dataclasses.dataclass(frozen=True)
class PivotCommandOutcome:
    """What became of one position command."""

    #: Whether the actuator took it (False: not a finite number; the target is unchanged).
    accepted: bool
    #: The target in force after it [m].
    target_m: float
    #: Whether the target is the stroke's end instead of the position asked for.
    clipped: bool
    #: For the log and diagnostics: why it was refused or clipped ("" when neither).
    reason: str = ""


class PivotActuator:
    """Position, target and the move in progress of one lead screw."""

    def __init__(self, limits: PivotLimits, position_m: float = 0.0, time_s: float = 0.0) -> None:
        """At rest at ``position_m`` (within the stroke) at ``time_s``.

        Raises:
            ValueError: a position that is not finite or outside the stroke.
        """
        if not (math.isfinite(position_m) and abs(position_m) <= limits.stroke_m):
            raise ValueError(
                f"position_m = {position_m!r} is outside the stroke of +-{limits.stroke_m:g} m"
            )
        self.limits = limits
        self.target_m = position_m
        # The move in progress: from start_m at start_s towards target_m at the screw's speed.
        self._start_m = position_m
        self._start_s = time_s

    def _travelled_m(self, now_s: float) -> float:
        """How far the move has gone by ``now_s`` (never past its target, nor before its start)."""
        distance = abs(self.target_m - self._start_m)
        return min(distance, self.limits.speed_m_s * max(now_s - self._start_s, 0.0))

    def state(self, now_s: float) -> tuple[float, float]:
        """Position [m] and velocity [m/s] at ``now_s`` (at or after the last command)."""
        travelled = self._travelled_m(now_s)
        if travelled >= abs(self.target_m - self._start_m):
            return self.target_m, 0.0  # arrived: exactly there, whatever the rounding on the way
        direction = math.copysign(1.0, self.target_m - self._start_m)
        return self._start_m + direction * travelled, direction * self.limits.speed_m_s

    def arrival_s(self) -> float:
        """When the move in progress reaches its target (in the past once it has)."""
        return self._start_s + abs(self.target_m - self._start_m) / self.limits.speed_m_s

    def command(self, position_m: float, now_s: float) -> PivotCommandOutcome:
        """Head for ``position_m`` from wherever the actuator is at ``now_s``.

        Beyond the stroke it heads for the stroke's end (``clipped``); a non-finite position is
        refused (``accepted`` False) and the move in progress goes on. Neither raises.
        """
        stroke = self.limits.stroke_m
        if not math.isfinite(position_m):
            return PivotCommandOutcome(
                False,
                self.target_m,
                False,
                f"pivot command {position_m!r} m refused: not a finite number; the actuator keeps "
                f"heading for {self.target_m:+.4f} m",
            )
        self._start_m, _ = self.state(now_s)
        self._start_s = now_s
        target = min(max(position_m, -stroke), stroke)
        self.target_m = target
        if target == position_m:
            return PivotCommandOutcome(True, target, False)
        return PivotCommandOutcome(
            True,
            target,
            True,
            f"pivot command {position_m:+.4f} m is beyond the stroke of +-{stroke:g} m: "
            f"achievable {target:+.4f} m; the actuator goes to the stroke's end there",
        )

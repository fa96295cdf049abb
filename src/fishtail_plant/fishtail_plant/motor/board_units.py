"""The motor board's numbers: its integer types, its PWM range, its PID frame and its units.

ROSArduinoBridge computes in AVR ``int`` (16-bit) and ``long`` (32-bit) and runs its speed loop
every ``1000 / PID_RATE`` ms; :class:`Scale` converts carrier angles and speeds to encoder counts
and ticks per PID frame. The speed loop of :mod:`fishtail_plant.motor.speed_loop` and the serial
protocol of the driver both count in these units.

>>> scale = Scale(counts_per_revolution=2048)
>>> scale.frame_ms, round(scale.frame_rate_hz, 2)
(33, 30.3)
>>> scale.ticks_per_frame(4.0)
(43, False)
"""

from __future__ import annotations

import dataclasses
import math

#: The firmware's default PID_RATE [Hz] (the frame is ``1000 // PID_RATE`` ms).
DEFAULT_PID_RATE_HZ = 30
#: AVR ``int`` (what ``atoi`` returns on the board).
INT16_MIN, INT16_MAX = -(2**15), 2**15 - 1
#: AVR ``long`` (the encoder counters).
INT32_MIN, INT32_MAX = -(2**31), 2**31 - 1
#: Raw PWM limit of the ``o`` command.
PWM_MAX = 255


def wrap_int32(value: int) -> int:
    """``value`` as a signed 32-bit counter holds it (two's complement wrap).

    >>> wrap_int32(2**31), wrap_int32(-(2**31) - 1)
    (-2147483648, 2147483647)
    """
    return ((value - INT32_MIN) % 2**32) + INT32_MIN


def wrap_int16(value: int) -> int:
    """``value`` as a 16-bit AVR ``int`` holds it (what ``atoi`` makes of 40000)."""
    return ((value - INT16_MIN) % 2**16) + INT16_MIN


def clamp_int16(value: int) -> int:
    """``value`` clamped to [-32768, 32767]."""
    return min(max(value, INT16_MIN), INT16_MAX)


@dataclasses.dataclass(frozen=True)
class Scale:
    """Carrier-side units <-> the board's encoder counts and ticks per PID frame.

    Args:
        counts_per_revolution: encoder counts per motor-shaft revolution (as the board counts
            them, e.g. 4x the lines of a quadrature encoder decoded on both edges).
        gear_ratio: motor-shaft turns per carrier turn.
        pid_rate_hz: the firmware's ``PID_RATE``; the frame is ``1000 // pid_rate_hz`` ms.

    Raises:
        ValueError: counts not an integer >= 1, a gear ratio not finite and > 0, or a PID rate
            not an integer in [1, 1000].
    """

    counts_per_revolution: int
    gear_ratio: float = 1.0
    pid_rate_hz: int = DEFAULT_PID_RATE_HZ

    def __post_init__(self) -> None:
        """Reject meaningless values with the reason."""
        if (
            isinstance(self.counts_per_revolution, bool)
            or not isinstance(self.counts_per_revolution, int)
            or self.counts_per_revolution < 1
        ):
            raise ValueError(
                f"counts_per_revolution must be an integer >= 1, got {self.counts_per_revolution!r}"
            )
        if not (math.isfinite(self.gear_ratio) and self.gear_ratio > 0.0):
            raise ValueError(f"gear_ratio must be finite and > 0, got {self.gear_ratio!r}")
        if (
            isinstance(self.pid_rate_hz, bool)
            or not isinstance(self.pid_rate_hz, int)
            or not 1 <= self.pid_rate_hz <= 1000
        ):
            raise ValueError(
                f"pid_rate_hz must be an integer in [1, 1000] (the firmware's PID_RATE), "
                f"got {self.pid_rate_hz!r}"
            )

    @property
    def frame_ms(self) -> int:
        """PID frame in whole milliseconds, as the firmware computes it (``1000 / PID_RATE``)."""
        return 1000 // self.pid_rate_hz

    @property
    def frame_s(self) -> float:
        """PID frame [s]."""
        return self.frame_ms / 1000.0

    @property
    def frame_rate_hz(self) -> float:
        """Actual PID rate [Hz] (30.30 Hz for PID_RATE 30)."""
        return 1000.0 / self.frame_ms

    @property
    def counts_per_carrier_rev(self) -> float:
        """Encoder counts per carrier revolution."""
        return self.counts_per_revolution * self.gear_ratio

    @property
    def rad_per_count(self) -> float:
        """Carrier angle per encoder count [rad]."""
        return 2.0 * math.pi / self.counts_per_carrier_rev

    def ticks_per_frame_exact(self, speed_rad_s: float) -> float:
        """Carrier speed [rad/s] as (unrounded) encoder ticks per PID frame."""
        return speed_rad_s / self.rad_per_count * self.frame_s

    def ticks_per_frame(self, speed_rad_s: float) -> tuple[int, bool]:
        """Carrier speed [rad/s] -> (ticks per frame rounded to nearest, clamped?).

        The result is clamped to the 16-bit range the board's ``atoi`` can hold.

        Raises:
            ValueError: a non-finite speed.
        """
        if not math.isfinite(speed_rad_s):
            raise ValueError(f"speed must be finite, got {speed_rad_s!r}")
        exact = self.ticks_per_frame_exact(speed_rad_s)
        if exact >= INT16_MAX + 0.5:
            return INT16_MAX, True
        if exact <= INT16_MIN - 0.5:
            return INT16_MIN, True
        rounded = math.floor(abs(exact) + 0.5)
        return (rounded if exact >= 0 else -rounded), False

    def speed_from_ticks(self, ticks_per_frame: float) -> float:
        """Ticks per PID frame -> carrier speed [rad/s]."""
        return ticks_per_frame * self.rad_per_count / self.frame_s

    def angle_from_counts(self, counts: float) -> float:
        """Encoder counts -> carrier angle [rad]."""
        return counts * self.rad_per_count

    def counts_from_angle(self, angle_rad: float) -> float:
        """Carrier angle [rad] -> encoder counts (unrounded)."""
        return angle_rad / self.rad_per_count

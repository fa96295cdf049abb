r"""The motor board's speed loop (ROSArduinoBridge ``diff_controller.h``) in exact integer maths.

The simulated DC motor and the emulated board run the firmware's own PID and its state machine
(``m``, ``r``, ``o``, auto-stop), AVR ``int``/``long`` wrap-around included, so that they see
the PWM a real board would set. :class:`FrameTimer` says when the frames fall; time is not kept
here. The loop, its dead band and the state table: docs/motor-load.md ("The firmware's speed
loop, as emulated").

>>> loop = FirmwareSpeedLoop(counts=(0,))
>>> loop.command((40,), counts=(0,))
>>> loop.frame((0,))     # error 40: (20*40 - 12*0 + 0) / 50 = 16
(16,)
>>> loop.frame((30,))    # input 30, error 10: (200 - 12*30) / 50 = -160/50 -> -3 (toward 0)
(13,)
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Sequence

from fishtail_plant.motor.board_units import INT16_MAX, INT16_MIN, PWM_MAX, wrap_int16, wrap_int32

#: The firmware's defaults (``diff_controller.h``; some forks use Kd 10).
DEFAULT_KP, DEFAULT_KD, DEFAULT_KI, DEFAULT_KO = 20, 12, 0, 50


def c_div(numerator: int, denominator: int) -> int:
    """C integer division: the quotient truncated toward zero (Python's ``//`` floors).

    >>> c_div(-160, 50), -160 // 50, c_div(160, 50)
    (-3, -4, 3)
    """
    quotient = abs(numerator) // abs(denominator)
    return quotient if (numerator < 0) == (denominator < 0) else -quotient


@dataclasses.dataclass(frozen=True)
class PidGains:
    """The firmware's gains (AVR ``int``), as ``u kp:kd:ki:ko`` sets them.

    Raises:
        ValueError: a gain that is not an integer or does not fit 16 bits, or ``ko`` 0.
    """

    kp: int = DEFAULT_KP
    kd: int = DEFAULT_KD
    ki: int = DEFAULT_KI
    ko: int = DEFAULT_KO

    def __post_init__(self) -> None:
        """Refuse what the board cannot hold or would divide by, with the reason."""
        for name in ("kp", "kd", "ki", "ko"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int):
                raise ValueError(f"{name} must be an integer, got {value!r}")
            if not INT16_MIN <= value <= INT16_MAX:
                raise ValueError(f"{name} = {value} does not fit the board's 16-bit int")
        if self.ko == 0:
            raise ValueError("ko must not be 0: the firmware divides by it every frame")


@dataclasses.dataclass
class SetPoint:
    """One channel's ``SetPointInfo``, field for field."""

    target_ticks_per_frame: int = 0
    encoder: int = 0  # long
    prev_enc: int = 0  # long
    prev_input: int = 0  # int
    iterm: int = 0  # int
    output: int = 0  # long, within +-PWM_MAX after a frame


def _check_counts(counts: Sequence[int], channels: int) -> tuple[int, ...]:
    if len(counts) != channels:
        raise ValueError(f"expected {channels} encoder count(s), got {len(counts)}")
    return tuple(wrap_int32(int(count)) for count in counts)


class FirmwareSpeedLoop:
    """The speed loop of every channel of one board, and the PWM it has set.

    Args:
        counts: the encoder counts at power-on, one per channel (the board has two; a model of
            one motor may use one: the other channel's loop only matters through the stopped
            frame's reset test, and an idle channel's PrevInput stays 0).
        gains: Kp, Kd, Ki, Ko.
    """

    def __init__(self, counts: Sequence[int], gains: PidGains | None = None) -> None:
        """Power on: loop reset and stopped, PWM 0.

        Raises:
            ValueError: no channel.
        """
        if not counts:
            raise ValueError("a speed loop needs at least one channel")
        self.channels = len(counts)
        self.gains = gains if gains is not None else PidGains()
        self.set_points = [SetPoint() for _ in range(self.channels)]
        self.moving = False
        #: What setMotorSpeeds() last set, per channel (-255..255).
        self.pwm: tuple[int, ...] = (0,) * self.channels
        self.reset(counts)

    # --- the firmware's functions --------------------------------------------------------------
    def reset(self, counts: Sequence[int]) -> None:
        """``resetPID()``: targets 0, PrevEnc = Encoder = ``counts``, output/PrevInput/ITerm 0."""
        for point, count in zip(self.set_points, _check_counts(counts, self.channels), strict=True):
            point.target_ticks_per_frame = 0
            point.encoder = point.prev_enc = count
            point.output = point.prev_input = point.iterm = 0

    def _set_motor_speeds(self, pwm: Sequence[int]) -> None:
        # setMotorSpeed() on the L298 clamps the magnitude to 255.
        self.pwm = tuple(max(-PWM_MAX, min(PWM_MAX, int(value))) for value in pwm)

    def _do_pid(self, point: SetPoint) -> None:
        """``doPID()``: one channel's frame."""
        gains = self.gains
        current = wrap_int16(point.encoder - point.prev_enc)  # int input = long - long
        error = point.target_ticks_per_frame - current  # long Perror (target is integral)
        derivative = wrap_int16(gains.kd * wrap_int16(current - point.prev_input))  # int maths
        numerator = wrap_int32(wrap_int32(gains.kp * error) - derivative + point.iterm)
        output = wrap_int32(c_div(numerator, gains.ko) + point.output)
        point.prev_enc = point.encoder
        if output >= PWM_MAX:
            output = PWM_MAX
        elif output <= -PWM_MAX:
            output = -PWM_MAX
        else:
            point.iterm = wrap_int16(point.iterm + gains.ki * error)
        point.output = output
        point.prev_input = current

    def frame(self, counts: Sequence[int]) -> tuple[int, ...]:
        """``updatePID()`` with the encoders reading ``counts``; returns the PWM in force after it.

        Running: every channel's doPID, then the motors get the outputs. Stopped: nothing, except
        the reset when a channel's PrevInput is non-zero (docs/motor-load.md, the state table).

        Raises:
            ValueError: not one count per channel.
        """
        checked = _check_counts(counts, self.channels)
        for point, count in zip(self.set_points, checked, strict=True):
            point.encoder = count
        if not self.moving:
            if any(point.prev_input != 0 for point in self.set_points):
                self.reset(checked)
            return self.pwm
        for point in reversed(self.set_points):  # the firmware runs right, then left
            self._do_pid(point)
        self._set_motor_speeds([point.output for point in self.set_points])
        return self.pwm

    # --- the commands that touch the loop ------------------------------------------------------
    def command(self, targets: Sequence[int], counts: Sequence[int]) -> None:
        """``m``: all-zero targets stop (PWM 0, reset, stopped); others set them and run.

        Raises:
            ValueError: not one integer target per channel, a target beyond 16 bits, or (for
                a stop) not one count per channel.
        """
        if len(targets) != self.channels:
            raise ValueError(f"expected {self.channels} target(s), got {len(targets)}")
        for target in targets:
            if isinstance(target, bool) or not isinstance(target, int):
                raise ValueError(f"ticks per frame must be integers, got {target!r}")
            if not INT16_MIN <= target <= INT16_MAX:
                raise ValueError(f"{target} ticks per frame does not fit the board's 16-bit int")
        if all(target == 0 for target in targets):
            self._set_motor_speeds((0,) * self.channels)
            self.reset(counts)
            self.moving = False
        else:
            self.moving = True
        for point, target in zip(self.set_points, targets, strict=True):
            point.target_ticks_per_frame = target

    def reset_encoders(self) -> None:
        """``r`` (after the counters are zeroed): reset the loop at counts 0; running or not."""
        self.reset((0,) * self.channels)

    def raw_pwm(self, pwm: Sequence[int], counts: Sequence[int]) -> None:
        """``o``: reset, stop the loop, set the PWM (clamped to +-255).

        Raises:
            ValueError: not one PWM value and one count per channel.
        """
        if len(pwm) != self.channels:
            raise ValueError(f"expected {self.channels} PWM value(s), got {len(pwm)}")
        self.reset(counts)
        self.moving = False
        self._set_motor_speeds(pwm)

    def auto_stop(self) -> None:
        """No ``m``/``o`` for over 2 s: PWM 0 and the loop stopped, not reset."""
        self._set_motor_speeds((0,) * self.channels)
        self.moving = False

    def set_gains(self, gains: PidGains) -> None:
        """``u``: new gains from the next frame on (the loop's state is kept)."""
        self.gains = gains


class FrameTimer:
    """When the PID frames fall: every ``frame_ms`` whole milliseconds, 1 ms after the grid.

    As the firmware's ``millis() > nextPID`` does (docs/motor-load.md): a late pass does not
    shift the later frames.

    >>> timer = FrameTimer(frame_ms=33, start_s=0.0)
    >>> [round(t, 3) for t in timer.due(0.1)]
    [0.034, 0.067, 0.1]
    """

    def __init__(self, frame_ms: int, start_s: float) -> None:
        """The first frame is one interval and a millisecond after ``start_s``.

        Raises:
            ValueError: ``frame_ms`` not an integer >= 1.
        """
        if isinstance(frame_ms, bool) or not isinstance(frame_ms, int) or frame_ms < 1:
            raise ValueError(f"frame_ms must be an integer >= 1, got {frame_ms!r}")
        self.frame_ms = frame_ms
        self._start_s = start_s
        self._next_index = 1

    @property
    def frame_s(self) -> float:
        """The frame interval [s]."""
        return self.frame_ms / 1000.0

    @property
    def next_s(self) -> float:
        """When the next frame falls."""
        return self._start_s + (self._next_index * self.frame_ms + 1) / 1000.0

    def due(self, now_s: float) -> Iterator[float]:
        """The times of the frames up to ``now_s`` not yet taken, in order (each taken once)."""
        while self.next_s <= now_s:
            when = self.next_s
            self._next_index += 1
            yield when

    def restart(self, start_s: float) -> None:
        """Frames from ``start_s`` on (a board reset restarts ``millis()``)."""
        self._start_s = start_s
        self._next_index = 1

r"""The emulated ROSArduinoBridge firmware: parses commands, answers them, moves the motors.

Pure (no pty, no threads): time is passed in explicitly (seconds, any epoch). The emulation follows
the firmware's source (hbrobotics/ros_arduino_bridge ``ROSArduinoBridge.ino`` and
``diff_controller.h``; ``o`` and the ``b`` reply without a leading space with
``variant="joshnewans"``):

- byte-by-byte command parsing: only CR runs a command; LF is an ordinary byte; the first space
  starts argument 1, the second argument 2, later spaces are skipped; arguments go through a
  16-bit ``atoi`` (``1.9`` -> 1, junk -> 0, 40000 -> -25536); argument buffers hold
  ``arg_buffer_bytes`` - 1 characters (an overflow, undefined behaviour on the board, is cut off
  and reported through ``warn``);
- ``m`` targets are encoder ticks per PID frame, taken over at the next frame (every
  ``1000 // PID_RATE`` ms); ``m 0 0`` stops at once and resets the PID; ``r`` zeroes the encoders
  and the PID target; auto-stop strictly more than 2000 ms after the last ``m``/``o``;
- encoder counts are signed 32-bit and wrap (``encoder_offset`` starts them near the wrap);
- the motors are :class:`fishtail_driver.motor_model.SimulatedMotor` (first-order speed lag: the
  board's PID is taken as ideal up to that lag).

>>> board = Firmware(FirmwareConfig(), now=0.0)
>>> [board.execute(command, 0.0) for command in map(board.feed_byte, b"b\r") if command]
[b' 57600\r\n']
"""

from __future__ import annotations

import collections
import dataclasses
from collections.abc import Callable

from fishtail_driver.motor_model import MotorParameters, SimulatedMotor
from fishtail_driver.protocol import AUTO_STOP_INTERVAL_MS, PWM_MAX, Scale, wrap_int16, wrap_int32

VARIANTS = ("hbrobotics", "joshnewans")
_ATOI_SPACE = b" \t\n\v\f\r"


def atoi16(text: bytes) -> int:
    """avr-libc ``atoi``: optional leading white space and sign, digits; 16-bit wrap-around."""
    index = 0
    while index < len(text) and text[index] in _ATOI_SPACE:
        index += 1
    negative = False
    if index < len(text) and text[index] in b"+-":
        negative = text[index] == ord("-")
        index += 1
    value = 0
    while index < len(text) and 0x30 <= text[index] <= 0x39:
        value = (value * 10 + text[index] - 0x30) & 0xFFFF
        index += 1
    return wrap_int16(-value if negative else value)


@dataclasses.dataclass
class FirmwareConfig:
    """What the emulated board is: its firmware's settings, its encoders and motors."""

    baud: int = 57600
    variant: str = "hbrobotics"
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    pid_rate_hz: int = 30
    time_constant_s: float = 0.05
    max_speed_rad_s: float = 20.0
    encoder_offset: int = 0
    arg_buffer_bytes: int = 32

    def __post_init__(self) -> None:
        """Reject meaningless settings with the reason."""
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}")
        if self.baud < 1:
            raise ValueError(f"baud must be >= 1, got {self.baud}")
        if self.arg_buffer_bytes < 2:
            raise ValueError(f"arg_buffer_bytes must be >= 2, got {self.arg_buffer_bytes}")
        if self.encoder_offset != wrap_int32(self.encoder_offset):
            raise ValueError(f"encoder_offset {self.encoder_offset} is not a 32-bit count")


@dataclasses.dataclass
class ParsedCommand:
    """One CR-terminated command as the firmware's parser leaves it."""

    cmd: int | None
    argv1: bytes
    argv2: bytes
    raw: bytes

    @property
    def text(self) -> str:
        """The raw line (without the CR), printable."""
        return self.raw.decode("ascii", "backslashreplace").replace("\n", "\\n")


class Firmware:
    """The board's state machine, advanced by explicit time stamps (seconds, any epoch)."""

    def __init__(
        self, config: FirmwareConfig, now: float, warn: Callable[[str], None] = print
    ) -> None:
        """Power the board on at ``now`` with the motors at rest."""
        self.config = config
        self.scale = Scale(config.counts_per_revolution, config.gear_ratio, config.pid_rate_hz)
        motor = MotorParameters(
            time_constant_s=config.time_constant_s,
            max_speed_rad_s=config.max_speed_rad_s,
            counts_per_revolution=config.counts_per_revolution,
            gear_ratio=config.gear_ratio,
        )
        self.motors = [SimulatedMotor(motor), SimulatedMotor(motor)]
        self.time = now
        self._warn = warn
        self.argument_overflows = 0
        #: (board time, left, right) of every ``e`` answered: the truth a host's samples are
        #: checked against (bounded: the newest readings only).
        self.encoder_reads: collections.deque[tuple[float, int, int]] = collections.deque(
            maxlen=100_000
        )
        self.autostop_at: float | None = None
        #: When the auto-stop fired (board clock), for tests: it must not while motion is wanted.
        self.auto_stop_times: list[float] = []
        self.next_pid = now + self.scale.frame_s
        self.power_on(now, counts=config.encoder_offset)

    # --- state -----------------------------------------------------------------------------
    def power_on(self, now: float, counts: int = 0) -> None:
        """(Re)start the firmware: encoders read ``counts``, PID idle, parser empty.

        The motors keep their physical state (a reset does not stop a spinning shaft at once).
        """
        self.advance(now)
        for motor in self.motors:
            motor.command(0.0)
        self.offsets = [counts - motor.encoder_counts() for motor in self.motors]
        self.targets = [0, 0]
        self.moving = False
        self.autostop_at = None
        self.next_pid = now + self.scale.frame_s
        self.pid_gains: tuple[int, int, int, int] = (20, 12, 0, 50)
        self._reset_parser()

    def _reset_parser(self) -> None:
        self._cmd: int | None = None
        self._arg = 0
        self._argv = [bytearray(), bytearray()]
        self._raw = bytearray()

    def encoder(self, channel: int) -> int:
        """The board's counter (signed 32-bit) for channel 0 (left) or 1 (right)."""
        return wrap_int32(self.motors[channel].encoder_counts() + self.offsets[channel])

    def advance(self, now: float) -> None:
        """Run PID frames and the auto-stop check up to ``now``."""
        while True:
            event = self.next_pid
            stop_at = self.autostop_at
            is_stop = stop_at is not None and stop_at < event
            if stop_at is not None and is_stop:
                event = stop_at
            if event > now:
                break
            self._move_to(event)
            if is_stop:
                self.auto_stop_times.append(event)
                self.autostop_at = None
                self.moving = False
                self.targets = [0, 0]
                for motor in self.motors:
                    motor.command(0.0)
            else:
                if self.moving:
                    for motor, target in zip(self.motors, self.targets, strict=True):
                        motor.command(self.scale.speed_from_ticks(target))
                self.next_pid += self.scale.frame_s
        self._move_to(now)

    def _move_to(self, when: float) -> None:
        if when > self.time:
            for motor in self.motors:
                motor.advance(when - self.time)
            self.time = when

    # --- parsing -----------------------------------------------------------------------------
    def feed_byte(self, byte: int) -> ParsedCommand | None:
        """One received byte; returns the parsed command when it is a CR."""
        if byte == 13:
            parsed = ParsedCommand(
                self._cmd, bytes(self._argv[0]), bytes(self._argv[1]), bytes(self._raw)
            )
            self._reset_parser()
            return parsed
        self._raw.append(byte)
        if byte == 0x20:
            if self._arg < 2:
                self._arg += 1
            return None
        if self._arg == 0:
            self._cmd = byte
        else:
            buffer = self._argv[self._arg - 1]
            if len(buffer) < self.config.arg_buffer_bytes - 1:
                buffer.append(byte)
            else:
                self.argument_overflows += 1
                self._warn(
                    f"argument {self._arg} longer than {self.config.arg_buffer_bytes - 1} "
                    "characters: buffer overflow (undefined behaviour on the board), cut off"
                )
        return None

    # --- commands ----------------------------------------------------------------------------
    def execute(self, command: ParsedCommand, now: float) -> bytes:
        """Run a parsed command at ``now``; returns the reply bytes (CR LF terminated)."""
        self.advance(now)
        arg1, arg2 = atoi16(command.argv1), atoi16(command.argv2)
        cmd = chr(command.cmd) if command.cmd is not None else ""
        auto_stop_s = AUTO_STOP_INTERVAL_MS / 1000.0 + 0.001  # strictly more than 2000 ms
        if cmd == "b":
            prefix = " " if self.config.variant == "hbrobotics" else ""
            return f"{prefix}{self.config.baud}\r\n".encode("ascii")
        if cmd == "e":
            left, right = self.encoder(0), self.encoder(1)
            self.encoder_reads.append((now, left, right))
            return f"{left} {right}\r\n".encode("ascii")
        if cmd == "r":
            self.offsets = [-motor.encoder_counts() for motor in self.motors]
            self.targets = [0, 0]
            return b"OK\r\n"
        if cmd == "m":
            self.autostop_at = now + auto_stop_s
            if arg1 == 0 and arg2 == 0:
                for motor in self.motors:
                    motor.command(0.0)
                self.moving = False
            else:
                self.moving = True
            self.targets = [arg1, arg2]
            return b"OK\r\n"
        if cmd == "o" and self.config.variant == "joshnewans":
            self.autostop_at = now + auto_stop_s
            self.moving = False
            self.targets = [0, 0]
            for motor, pwm in zip(self.motors, (arg1, arg2), strict=True):
                pwm = min(max(pwm, -PWM_MAX), PWM_MAX)
                motor.command(pwm / PWM_MAX * self.config.max_speed_rad_s)
            return b"OK\r\n"
        if cmd == "u":
            tokens = [token for token in command.argv1.split(b":") if token]
            if len(tokens) > 4:
                self._warn("u with more than 4 gains: pid_args overflow on the board")
            gains = list(self.pid_gains)
            for index, token in enumerate(tokens[:4]):
                gains[index] = atoi16(token)
            self.pid_gains = (gains[0], gains[1], gains[2], gains[3])
            return b"OK\r\n"
        return b"Invalid Command\r\n"

r"""The emulated ROSArduinoBridge firmware: parses commands, answers them, moves the motors.

Our reading of the firmware's source (hbrobotics ``ROSArduinoBridge.ino`` and
``diff_controller.h``; the joshnewans variant's ``o`` and ``b`` reply; with ``firmware="fishtail"``
the project's patch: ``v``, ``f`` and ``k`` with :mod:`fishtail_boards.board_profile_law`,
``i``), quirks included: byte-wise parsing that only CR runs, a 16-bit ``atoi``, short argument
buffers, the speed loop of :class:`fishtail_plant.motor.speed_loop.FirmwareSpeedLoop` on its
frame grid (with ``k``, the profile's own controller), the auto-stop and
wrapping 32-bit counts; every PWM it writes drives a motor of :mod:`fishtail_boards.board_motors`.
Pure (no pty, no threads; time is passed in), so that tests can drive it exactly. What it
emulates and where it was corrected: docs/serial.md ("The emulated board").

>>> board = Firmware(FirmwareConfig(), now=0.0)
>>> [board.execute(command, 0.0) for command in map(board.feed_byte, b"b\r") if command]
[b' 57600\r\n']
"""

from __future__ import annotations

import collections
import dataclasses
from collections.abc import Callable

from fishtail_boards.board_motors import MOTOR_KINDS, make_motor
from fishtail_boards.board_profile_law import CarrierProfileLaw
from fishtail_driver.protocol import AUTO_STOP_INTERVAL_MS
from fishtail_plant.motor.board_units import Scale, wrap_int16, wrap_int32
from fishtail_plant.motor.dc_motor import LoadInertia, LoadTorque, zero_load, zero_load_inertia
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, FrameTimer, PidGains

VARIANTS = ("hbrobotics", "joshnewans")
#: stock: ROSArduinoBridge as it is; fishtail: with the project's patch (firmware/CHANGES.md).
FIRMWARES = ("stock", "fishtail")
#: The project firmware's version, as ``v`` answers it.
FISHTAIL_VERSION = 1
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
    """What the emulated board is: its firmware's settings, its encoders and motors.

    Raises:
        ValueError: an unknown variant or motor, a load on a motor other than dc, a baud rate or
            argument buffer too small, or an encoder offset beyond 32 bits.
    """

    baud: int = 57600
    variant: str = "hbrobotics"
    firmware: str = "stock"
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    pid_rate_hz: int = 30
    time_constant_s: float = 0.05
    max_speed_rad_s: float = 20.0
    encoder_offset: int = 0
    arg_buffer_bytes: int = 32
    motor: str = "ideal"
    #: What the motor of each channel turns (the DC motor model's load callables):
    #: the tail, on both channels, so that the one a host drives turns it. ``motor`` dc only.
    load: LoadTorque = zero_load
    load_inertia: LoadInertia = zero_load_inertia

    def __post_init__(self) -> None:
        """Reject meaningless settings with the reason."""
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}")
        if self.firmware not in FIRMWARES:
            raise ValueError(f"firmware must be one of {FIRMWARES}, got {self.firmware!r}")
        if self.motor not in MOTOR_KINDS:
            raise ValueError(f"motor must be one of {MOTOR_KINDS}, got {self.motor!r}")
        loaded = self.load is not zero_load or self.load_inertia is not zero_load_inertia
        if loaded and self.motor != "dc":
            raise ValueError(f"a load needs motor dc, got motor {self.motor!r} (it feels none)")
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
        self.motors = [
            make_motor(
                config.motor,
                self.scale,
                config.time_constant_s,
                config.max_speed_rad_s,
                config.load,
                config.load_inertia,
            )
            for _ in range(2)
        ]
        self.time = now
        self._warn = warn
        self.argument_overflows = 0
        #: ``u`` commands refused (see :meth:`_update_gains`).
        self.rejected_gains = 0
        #: (board time, left, right) of every ``e`` answered: the truth a host's samples are
        #: checked against (bounded: the newest readings only).
        self.encoder_reads: collections.deque[tuple[float, int, int]] = collections.deque(
            maxlen=100_000
        )
        #: (board time, (left, right) counts read, (left, right) PWM after it) of every PID
        #: frame (bounded): what the loop saw and did.
        self.frames: collections.deque[tuple[float, tuple[int, int], tuple[int, ...]]] = (
            collections.deque(maxlen=100_000)
        )
        self.autostop_at: float | None = None
        #: When the auto-stop fired (board clock), for tests: it must not while motion is wanted.
        self.auto_stop_times: list[float] = []
        self.timer = FrameTimer(self.scale.frame_ms, start_s=now)
        self.offsets = [config.encoder_offset, config.encoder_offset]
        self.loop = FirmwareSpeedLoop(self._counts())
        self.profile = CarrierProfileLaw()
        self.power_on(now, counts=config.encoder_offset)

    # --- state -----------------------------------------------------------------------------
    def power_on(self, now: float, counts: int = 0) -> None:
        """(Re)start the firmware: encoders read ``counts``, loop reset and stopped, PWM 0.

        The motors keep their physical state (a reset does not stop a spinning shaft at once).
        """
        self.advance(now)
        self.offsets = [counts - motor.encoder_counts() for motor in self.motors]
        self.loop = FirmwareSpeedLoop(self._counts())
        self.profile = CarrierProfileLaw()
        self._set_pid_rate(self.config.pid_rate_hz, now)  # the build's PID_RATE again
        self._drive_motors()
        self.autostop_at = None
        self._reset_parser()

    def _reset_parser(self) -> None:
        self._cmd: int | None = None
        self._arg = 0
        self._argv = [bytearray(), bytearray()]
        self._raw = bytearray()

    @property
    def targets(self) -> list[int]:
        """The loop's targets (ticks per frame), left and right."""
        return [point.target_ticks_per_frame for point in self.loop.set_points]

    @property
    def moving(self) -> bool:
        """Whether the speed loop runs (the firmware's ``moving``)."""
        return self.loop.moving

    @property
    def gains(self) -> PidGains:
        """The loop's gains in force."""
        return self.loop.gains

    def encoder(self, channel: int) -> int:
        """The board's counter (signed 32-bit) for channel 0 (left) or 1 (right)."""
        return wrap_int32(self.motors[channel].encoder_counts() + self.offsets[channel])

    def _counts(self) -> tuple[int, int]:
        return self.encoder(0), self.encoder(1)

    def _drive_motors(self) -> None:
        """Hand the motors what ``setMotorSpeeds()`` last wrote (called wherever it writes)."""
        for motor, pwm, target in zip(self.motors, self.loop.pwm, self.targets, strict=True):
            motor.drive(pwm, target, self.loop.moving)

    def advance(self, now: float) -> None:
        """Run PID frames and the auto-stop check up to ``now``.

        At the same millisecond the frame comes first: the firmware's main loop runs
        ``updatePID()`` before the auto-stop test.
        """
        while True:
            frame_at = self.timer.next_s
            stop_at = self.autostop_at
            if stop_at is not None and stop_at < frame_at and stop_at <= now:
                self._move_to(stop_at)
                self.auto_stop_times.append(stop_at)
                self.autostop_at = None
                self.loop.auto_stop()
                self.profile.on = False  # the auto-stop ends a profile
                self._drive_motors()
                continue
            if frame_at > now:
                break
            for when in self.timer.due(frame_at):
                self._move_to(when)
                counts = self._counts()
                profiled = self.profile.on and self.loop.moving
                if profiled:  # the targets from the counts just read
                    for channel, point in enumerate(self.loop.set_points):
                        ticks = wrap_int16(counts[channel] - point.prev_enc)  # the last frame's
                        point.target_ticks_per_frame = self.profile.target(
                            channel, counts[channel], ticks
                        )
                if profiled and self.profile.tuned:  # k: the profile's own controller
                    self.frames.append((when, counts, self.profile.control(self.loop, counts)))
                else:
                    self.frames.append((when, counts, self.loop.frame(counts)))
                self._drive_motors()
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
            left, right = self._counts()
            self.encoder_reads.append((now, left, right))
            return f"{left} {right}\r\n".encode("ascii")
        if cmd == "r":
            self.offsets = [-motor.encoder_counts() for motor in self.motors]
            self.loop.reset_encoders()
            self.profile.on = False
            return b"OK\r\n"
        if cmd == "m":
            self.autostop_at = now + auto_stop_s
            self.profile.on = False
            self.loop.command((arg1, arg2), self._counts())
            if not self.loop.moving:  # m 0 0 wrote PWM 0; other targets wait for the frame
                self._drive_motors()
            return b"OK\r\n"
        if cmd == "o" and self.config.variant == "joshnewans":
            self.autostop_at = now + auto_stop_s
            self.profile.on = False
            self.loop.raw_pwm((arg1, arg2), self._counts())
            self._drive_motors()
            return b"OK\r\n"
        if cmd == "u":
            return self._update_gains(command.argv1)
        if self.config.firmware == "fishtail" and cmd in ("v", "f", "i", "k"):
            return self._fishtail_command(cmd, command.argv1, arg1, now, auto_stop_s)
        return b"Invalid Command\r\n"

    def _fishtail_command(
        self, cmd: str, argv1: bytes, arg1: int, now: float, auto_stop_s: float
    ) -> bytes:
        """The project's commands (firmware/CHANGES.md): ``v``, ``f``, ``i``, ``k``."""
        if cmd == "v":
            rate, frame_ms = self.scale.pid_rate_hz, self.timer.frame_ms
            return (
                f"fishtail {FISHTAIL_VERSION} pid_hz={rate} pid_ms={frame_ms} profile=1\r\n"
            ).encode("ascii")
        if cmd == "f":
            if not self.profile.set_profile(argv1):
                return b"ERR\r\n"
            self.autostop_at = now + auto_stop_s
            if self.profile.scale == 0:  # MEAN 0 stops as m 0 0 does
                self.profile.on = False
                self.loop.command((0, 0), self._counts())
                self._drive_motors()
            else:
                self.loop.moving = True  # the targets come at the next frame
            return b"OK\r\n"
        if cmd == "k":  # from the next frame on, in units that do not depend on the rate
            accepted = self.profile.set_tuning(argv1, self.timer.frame_ms)
            return b"OK\r\n" if accepted else b"ERR\r\n"
        if not 1 <= arg1 <= 500:
            return b"ERR\r\n"
        self.loop.command((0, 0), self._counts())  # stops and resets as m 0 0 does
        self.profile.on = False
        self._drive_motors()
        self._set_pid_rate(arg1, now)
        self.profile.retune(self.timer.frame_ms)  # k's per-frame factors at the new rate
        return b"OK\r\n"

    def _set_pid_rate(self, rate_hz: int, now: float) -> None:
        """Frames every ``1000 // rate_hz`` ms from ``now`` on (the motors' units follow)."""
        self.scale = Scale(self.scale.counts_per_revolution, self.scale.gear_ratio, rate_hz)
        for motor in self.motors:
            if hasattr(motor, "scale"):
                motor.scale = self.scale
        self.timer = FrameTimer(self.scale.frame_ms, start_s=now)

    def _update_gains(self, argument: bytes) -> bytes:
        """``u Kp:Kd:Ki:Ko``: exactly four gains, Ko not 0; anything else is refused.

        The board answers ``OK`` and drives a garbage PWM; the emulation keeps the gains, warns
        and answers ``Invalid Command``, so that a host sending such gains fails its tests
        (docs/serial.md). Fields are split at colons as ``strtok_r`` does: empty ones vanish.
        """
        tokens = [token for token in argument.split(b":") if token]
        reason = None
        if len(tokens) != 4:
            reason = f"{len(tokens)} gains instead of Kp:Kd:Ki:Ko (pid_args[4] on the board)"
        else:
            kp, kd, ki, ko = (atoi16(token) for token in tokens)
            if ko == 0:
                reason = "Ko 0 (the board would divide by zero at every PID frame)"
            else:
                self.loop.set_gains(PidGains(kp, kd, ki, ko))
                return b"OK\r\n"
        self.rejected_gains += 1
        self._warn(f"u {argument.decode('ascii', 'backslashreplace')} refused: {reason}")
        return b"Invalid Command\r\n"

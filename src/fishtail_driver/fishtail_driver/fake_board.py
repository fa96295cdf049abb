"""An emulated ROSArduinoBridge motor board on a pseudo-terminal: ``fishtail-fake-board``.

It prints the pty's device path on stdout (one line, again after every emulated replug) and, with
``--link PATH``, keeps a symlink at PATH pointing at the current pty (replaced atomically; removed
on exit and while "unplugged"), so a host can be configured with a stable port name, as with
``/dev/serial/by-id`` on real hardware.

The emulation follows the firmware's source (hbrobotics/ros_arduino_bridge ``ROSArduinoBridge.ino``
and ``diff_controller.h``; ``o`` and the ``b`` reply without a leading space with
``--variant joshnewans``):

- byte-by-byte command parsing: only CR runs a command; LF is an ordinary byte; the first space
  starts argument 1, the second argument 2, later spaces are skipped; arguments go through a
  16-bit ``atoi`` (``1.9`` -> 1, junk -> 0, 40000 -> -25536); argument buffers hold
  ``--arg-buffer`` - 1 characters (an overflow, undefined behaviour on the board, is cut off and
  reported on stderr);
- ``m`` targets are encoder ticks per PID frame, taken over at the next frame (every
  ``1000 // PID_RATE`` ms); ``m 0 0`` stops at once and resets the PID; ``r`` zeroes the encoders
  and the PID target; auto-stop strictly more than 2000 ms after the last ``m``/``o``;
- encoder counts are signed 32-bit and wrap (``--encoder-offset`` starts them near the wrap);
- the motors are :class:`fishtail_driver.motor_model.SimulatedMotor` (first-order speed lag: the
  board's PID is taken as ideal up to that lag).

Fault injection (seeded by ``--seed``): ``--delay-ms`` delays every reply (a slow board; from
``--delay-after-s`` on only, and SIGUSR2 switches the delay off and on again, so that a host can
connect to a board that turns slow later), ``--drop-rate`` loses a command or its reply,
``--garble-rate`` corrupts a reply (a flipped byte, a truncated line, a binary line, an oversized
line) or the command letter (the board answers ``Invalid Command``),
``--reset-after-s`` resets the board once (counts back to 0, silent for ``--boot-ms``), and so
does every SIGUSR1 (a reset when the caller chooses, e.g. once the motor turns),
``--disconnect-after-s`` unplugs the pty once for ``--disconnect-for-s`` and then plugs in a new
one (a replug power-cycles the board). ``--pace-baud`` delays every byte by its line time at
``--baud`` (10 bits per byte) in both directions, because a pty otherwise transfers at memory speed
whatever the baud rate. ``--log FILE`` appends every command the board runs (one line each, time
in seconds since start) and the injected events.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import errno
import os
import queue
import random
import select
import signal
import sys
import threading
import time
import tty
from collections.abc import Callable

from fishtail_driver.motor_model import MotorParameters, SimulatedMotor
from fishtail_driver.protocol import (
    AUTO_STOP_INTERVAL_MS,
    PWM_MAX,
    Scale,
    wrap_int16,
    wrap_int32,
)

VARIANTS = ("hbrobotics", "joshnewans")
GARBLE_KINDS = ("flip", "truncate", "binary", "oversized", "invalid")
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
class BoardConfig:
    """What the emulated board is and which faults it injects."""

    baud: int = 57600
    pace_baud: bool = False
    variant: str = "hbrobotics"
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    pid_rate_hz: int = 30
    time_constant_s: float = 0.05
    max_speed_rad_s: float = 20.0
    encoder_offset: int = 0
    arg_buffer_bytes: int = 32
    boot_ms: float = 0.0
    delay_ms: float = 0.0
    delay_after_s: float | None = None
    drop_rate: float = 0.0
    garble_rate: float = 0.0
    reset_after_s: float | None = None
    disconnect_after_s: float | None = None
    disconnect_for_s: float = 1.0
    seed: int = 0

    def __post_init__(self) -> None:
        """Reject meaningless settings with the reason."""
        if self.variant not in VARIANTS:
            raise ValueError(f"variant must be one of {VARIANTS}, got {self.variant!r}")
        if self.baud < 1:
            raise ValueError(f"baud must be >= 1, got {self.baud}")
        for name in ("drop_rate", "garble_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.arg_buffer_bytes < 2:
            raise ValueError(f"arg_buffer_bytes must be >= 2, got {self.arg_buffer_bytes}")
        for name in ("boot_ms", "delay_ms", "disconnect_for_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.delay_after_s is not None and not self.delay_after_s >= 0:
            raise ValueError(f"delay_after_s must be >= 0, got {self.delay_after_s}")


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

    def __init__(self, config: BoardConfig, now: float, warn: Callable[[str], None] = print):
        """Power the board on at ``now`` with the motors at rest."""
        self.config = config
        self.scale = Scale(config.counts_per_revolution, config.gear_ratio, config.pid_rate_hz)
        motor = MotorParameters(
            time_constant_s=config.time_constant_s,
            max_speed_rad_s=config.max_speed_rad_s,
            counts_per_revolution=config.counts_per_revolution,
            gear_ratio=config.gear_ratio,
            seed=config.seed,
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
        self.pid_gains = (20, 12, 0, 50)
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
            is_stop = self.autostop_at is not None and self.autostop_at < event
            if is_stop:
                event = self.autostop_at
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
            self.pid_gains = tuple(gains)
            return b"OK\r\n"
        return b"Invalid Command\r\n"


class FakeBoard:
    """The firmware behind a pty, with fault injection; run :meth:`run` in a thread or as main."""

    def __init__(
        self,
        config: BoardConfig,
        link: str | None = None,
        log_path: str | None = None,
        announce: Callable[[str], None] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Set up (nothing is opened until :meth:`open` or :meth:`run`)."""
        self.config = config
        self.link = link
        self._clock = clock
        self._announce = announce or (lambda path: print(path, flush=True))
        self._log = None
        if log_path:
            self._log = open(log_path, "a", buffering=1, encoding="utf-8")  # line-buffered
        self.start_time = clock()
        self.rng = random.Random(config.seed)
        self.firmware = Firmware(config, self.start_time, warn=self._warn)
        self.master: int | None = None
        self._slave: int | None = None
        self.path: str | None = None
        self.byte_s = 10.0 / config.baud if config.pace_baud else 0.0
        self._rx: collections.deque[tuple[float, int]] = collections.deque()
        self._tx: collections.deque[tuple[float, bytes]] = collections.deque()
        self._rx_clock = self._tx_clock = 0.0
        self.boot_until = self.start_time + config.boot_ms / 1000.0
        self._requests: queue.SimpleQueue = queue.SimpleQueue()
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._stop = threading.Event()
        self._loop_thread: threading.Thread | None = None
        self._reset_at = (
            None if config.reset_after_s is None else self.start_time + config.reset_after_s
        )
        self._unplug_at = (
            None if config.disconnect_after_s is None
            else self.start_time + config.disconnect_after_s
        )  # fmt: skip
        self._replug_at: float | None = None
        self._reset_requested = threading.Event()
        #: Whether replies are delayed by ``delay_ms`` now (see :meth:`set_slow`).
        self.slow = config.delay_after_s is None
        self._slow_at = (
            None if config.delay_after_s is None else self.start_time + config.delay_after_s
        )
        self._toggle_slow_requested = threading.Event()
        self.commands: list[tuple[float, str]] = []
        self.counts = collections.Counter()

    # --- helpers -----------------------------------------------------------------------------
    def _warn(self, text: str) -> None:
        print(f"fishtail-fake-board: {text}", file=sys.stderr, flush=True)

    def _record(self, now: float, text: str) -> None:
        if self._log is not None:
            self._log.write(f"{now - self.start_time:10.3f} {text}\n")

    def _wake(self) -> None:
        try:
            os.write(self._wake_w, b"x")
        except OSError:
            pass

    def _call(self, function: Callable[[], None], timeout_s: float = 5.0) -> None:
        """Run ``function`` on the board's loop (now, if the loop is not running elsewhere)."""
        thread = self._loop_thread
        if thread is None or thread is threading.current_thread() or not thread.is_alive():
            function()
            return
        done = threading.Event()
        self._requests.put((function, done))
        self._wake()
        if not done.wait(timeout_s):
            raise TimeoutError("the fake board's loop did not run the request")

    # --- pty ---------------------------------------------------------------------------------
    def open(self) -> str:
        """Create a pty (raw mode), point the link at it and announce its path."""
        master, slave = os.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self.master, self._slave = master, slave
        self.path = os.ttyname(slave)
        if self.link:
            temporary = f"{self.link}.{os.getpid()}.tmp"
            try:
                os.unlink(temporary)
            except FileNotFoundError:
                pass
            os.symlink(self.path, temporary)
            os.replace(temporary, self.link)
        self._announce(self.path)
        return self.path

    def _close_pty(self) -> None:
        if self.link and self.path:
            try:
                if os.readlink(self.link) == self.path:
                    os.unlink(self.link)
            except OSError:
                pass
        for fd in (self.master, self._slave):
            if fd is not None:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self.master = self._slave = None
        self._rx.clear()
        self._tx.clear()

    def _power_on(self, now: float) -> None:
        self.firmware.power_on(now)
        self.boot_until = now + self.config.boot_ms / 1000.0
        self._rx.clear()
        self._tx.clear()

    # --- control (thread-safe) ---------------------------------------------------------------
    def unplug(self) -> None:
        """Emulate pulling the USB cable: the pty closes and the link vanishes."""

        def action() -> None:
            now = self._clock()
            self.counts["unplugs"] += 1
            self._record(now, "# unplug")
            self._close_pty()

        self._call(action)

    def replug(self) -> None:
        """Plug back in: a new pty (and link); the board power-cycles (counts restart at 0)."""

        def action() -> None:
            now = self._clock()
            self.counts["replugs"] += 1
            self._record(now, "# replug")
            if self.master is not None:
                self._close_pty()
            self._power_on(now)
            self.open()

        self._call(action)

    def reset(self) -> None:
        """Emulate a board reset (brown-out, watchdog): counts restart at 0, then boot silence."""

        def action() -> None:
            now = self._clock()
            self.counts["resets"] += 1
            self._record(now, "# reset")
            self._power_on(now)

        self._call(action)

    def request_reset(self) -> None:
        """Reset the board at the loop's next turn (safe from signal handlers and other threads).

        Same effect as :meth:`reset`, without waiting for the loop; logged as ``# reset
        (requested)``.
        """
        self._reset_requested.set()
        self._wake()

    def set_slow(self, slow: bool) -> None:
        """Delay the replies to commands received from now on by ``delay_ms`` (or not).

        Replies already queued keep their time, and replies never overtake each other (one serial
        line), so a reply to a later command may still wait behind a delayed one.
        """

        def action() -> None:
            now = self._clock()
            self._slow_at = None
            if self.slow != slow:
                self.slow = slow
                self.counts["slow_on" if slow else "slow_off"] += 1
                self._record(now, f"# slow {'on' if slow else 'off'}")

        self._call(action)

    def request_slow_toggle(self) -> None:
        """Switch the reply delay off or on at the loop's next turn (safe from signal handlers)."""
        self._toggle_slow_requested.set()
        self._wake()

    def stop(self) -> None:
        """Ask :meth:`run` to return (safe from signal handlers and other threads)."""
        self._stop.set()
        self._wake()

    # --- the loop ----------------------------------------------------------------------------
    def _inject_and_queue(self, command: ParsedCommand, now: float) -> None:
        config, rng = self.config, self.rng
        if config.drop_rate and rng.random() < config.drop_rate:
            if rng.random() < 0.5:
                self.counts["dropped_commands"] += 1
                self._record(now, f"# dropped command {command.text}")
                return
            self.counts["dropped_replies"] += 1
            self._record(now, f"# dropping the reply to {command.text}")
            reply = None
        else:
            reply = b""
        garble = None
        if config.garble_rate and rng.random() < config.garble_rate:
            garble = rng.choice(GARBLE_KINDS)
            self.counts[f"garble_{garble}"] += 1
            self._record(now, f"# garble {garble}")
            if garble == "invalid":
                command = dataclasses.replace(command, cmd=ord("E"))
        self.commands.append((now - self.start_time, command.text))
        self._record(now, command.text)
        out = self.firmware.execute(command, now)
        if reply is None:
            return
        if garble == "flip":
            index = rng.randrange(len(out) - 2)
            out = out[:index] + bytes([out[index] ^ (1 << rng.randrange(8))]) + out[index + 1 :]
        elif garble == "truncate":
            out = out[: rng.randrange(1, len(out) - 1)]
        elif garble == "binary":
            out = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 12))) + b"\r\n"
        elif garble == "oversized":
            out = bytes(rng.randrange(0x30, 0x3A) for _ in range(300)) + b"\r\n"
        delay_s = config.delay_ms / 1000.0 if self.slow else 0.0
        start = max(self._tx_clock, now + delay_s)
        self._tx_clock = start + len(out) * self.byte_s
        self._tx.append((self._tx_clock, out))

    def _receive(self, now: float) -> None:
        while self._rx and self._rx[0][0] <= now:
            arrival, byte = self._rx.popleft()
            if arrival < self.boot_until:
                continue  # the board is booting: input is lost
            self.firmware.advance(arrival)
            command = self.firmware.feed_byte(byte)
            if command is not None:
                self._inject_and_queue(command, arrival)

    def _transmit(self, now: float) -> None:
        while self._tx and self._tx[0][0] <= now:
            _, data = self._tx.popleft()
            if self.master is None:
                continue
            try:
                os.write(self.master, data)
            except BlockingIOError:
                self.counts["tx_overflows"] += 1
            except OSError as error:
                if error.errno != errno.EIO:
                    raise

    def _scheduled(self, now: float) -> None:
        if self._slow_at is not None and now >= self._slow_at:
            self._slow_at = None
            self.slow = True
            self.counts["slow_on"] += 1
            self._record(now, "# slow on (scheduled)")
        if self._toggle_slow_requested.is_set():
            self._toggle_slow_requested.clear()
            self._slow_at = None
            self.slow = not self.slow
            self.counts["slow_on" if self.slow else "slow_off"] += 1
            self._record(now, f"# slow {'on' if self.slow else 'off'} (requested)")
            self._warn(f"reply delay {'on' if self.slow else 'off'} (requested)")
        if self._reset_requested.is_set():
            self._reset_requested.clear()
            self.counts["resets"] += 1
            self._record(now, "# reset (requested)")
            self._warn("board reset (requested)")
            self._power_on(now)
        if self._reset_at is not None and now >= self._reset_at:
            self._reset_at = None
            self.counts["resets"] += 1
            self._record(now, "# reset (scheduled)")
            self._warn("board reset (scheduled)")
            self._power_on(now)
        if self._unplug_at is not None and now >= self._unplug_at:
            self._unplug_at = None
            self.counts["unplugs"] += 1
            self._record(now, "# unplug (scheduled)")
            self._warn(f"unplugged for {self.config.disconnect_for_s:g} s (scheduled)")
            self._close_pty()
            self._replug_at = now + self.config.disconnect_for_s
        if self._replug_at is not None and now >= self._replug_at:
            self._replug_at = None
            self.counts["replugs"] += 1
            self._record(now, "# replug (scheduled)")
            self._power_on(now)
            self.open()

    def _next_wakeup(self, now: float) -> float:
        candidates = [now + 0.1]
        if self._rx:
            candidates.append(self._rx[0][0])
        if self._tx:
            candidates.append(self._tx[0][0])
        for moment in (self._reset_at, self._unplug_at, self._replug_at, self._slow_at):
            if moment is not None:
                candidates.append(moment)
        return min(candidates)

    def run(self) -> None:
        """Serve until :meth:`stop`; opens the pty first if needed; closes it on return."""
        self._loop_thread = threading.current_thread()
        if self.master is None and self._replug_at is None:
            self.open()
        master_quiet_until = 0.0
        try:
            while not self._stop.is_set():
                while True:
                    try:
                        function, done = self._requests.get_nowait()
                    except queue.Empty:
                        break
                    try:
                        function()
                    finally:
                        done.set()
                now = self._clock()
                self._scheduled(now)
                self._receive(now)
                self.firmware.advance(now)
                self._transmit(now)
                timeout = max(0.0, self._next_wakeup(now) - self._clock())
                fds = [self._wake_r]
                if self.master is not None and now >= master_quiet_until:
                    fds.append(self.master)
                readable, _, _ = select.select(fds, [], [], timeout)
                if self._wake_r in readable:
                    os.read(self._wake_r, 4096)
                if self.master is not None and self.master in readable:
                    try:
                        data = os.read(self.master, 4096)
                    except BlockingIOError:
                        data = b""
                    except OSError as error:
                        if error.errno != errno.EIO:
                            raise
                        master_quiet_until = self._clock() + 0.05  # no host: do not spin
                        data = b""
                    received = self._clock()
                    for byte in data:
                        self._rx_clock = max(self._rx_clock, received) + self.byte_s
                        self._rx.append((self._rx_clock, byte))
        finally:
            self._close_pty()
            if self._log is not None:
                self._log.close()
                self._log = None

    def close(self) -> None:
        """Release the wake pipe (after :meth:`run` returned)."""
        for fd in (self._wake_r, self._wake_w):
            try:
                os.close(fd)
            except OSError:
                pass


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fishtail-fake-board",
        description="Emulated ROSArduinoBridge motor board on a pty (prints the device path).",
        epilog="Signals: SIGUSR1 resets the board (counts back to 0, deaf for --boot-ms); "
        "SIGUSR2 switches the reply delay of --delay-ms off and on again; "
        "SIGINT, SIGTERM and SIGHUP end it.",
    )
    add = parser.add_argument
    add("--link", help="keep a symlink to the current pty at this path (removed on exit)")
    add("--log", help="append every command the board runs to this file")
    add("--baud", type=int, default=57600, help="what 'b' answers; line rate for --pace-baud")
    add("--pace-baud", action="store_true", help="delay each byte by 10 bits at --baud")
    add(
        "--variant",
        choices=VARIANTS,
        default="hbrobotics",
        help="hbrobotics: 'b' -> ' 57600', no 'o'; joshnewans: 'b' -> '57600', 'o' raw PWM",
    )
    add("--counts-per-rev", type=int, default=2048, help="encoder counts per motor turn")
    add("--gear-ratio", type=float, default=1.0, help="motor turns per carrier turn")
    add("--pid-rate", type=int, default=30, help="the firmware's PID_RATE [Hz]")
    add("--time-constant", type=float, default=0.05, help="motor speed time constant [s]")
    add("--max-speed", type=float, default=20.0, help="carrier speed limit [rad/s]")
    add("--encoder-offset", type=int, default=0, help="initial encoder count (test the wrap)")
    add("--arg-buffer", type=int, default=32, help="firmware argument buffer size [bytes]")
    add("--boot-ms", type=float, default=0.0, help="input ignored this long after power-up")
    add("--delay-ms", type=float, default=0.0, help="delay every reply (a slow board)")
    add("--delay-after-s", type=float, default=None,
        help="answer at once until this long after start, then delay replies by --delay-ms")
    add("--drop-rate", type=float, default=0.0, help="probability of losing a command/reply")
    add("--garble-rate", type=float, default=0.0, help="probability of corrupting an exchange")
    add("--reset-after-s", type=float, default=None, help="reset the board once, after this")
    add("--disconnect-after-s", type=float, default=None, help="unplug once, after this")
    add("--disconnect-for-s", type=float, default=1.0, help="how long an unplug lasts")
    add("--seed", type=int, default=0, help="seed of the fault injection")
    return parser  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-fake-board``."""
    args = _parser().parse_args(argv)
    try:
        config = BoardConfig(
            baud=args.baud,
            pace_baud=args.pace_baud,
            variant=args.variant,
            counts_per_revolution=args.counts_per_rev,
            gear_ratio=args.gear_ratio,
            pid_rate_hz=args.pid_rate,
            time_constant_s=args.time_constant,
            max_speed_rad_s=args.max_speed,
            encoder_offset=args.encoder_offset,
            arg_buffer_bytes=args.arg_buffer,
            boot_ms=args.boot_ms,
            delay_ms=args.delay_ms,
            delay_after_s=args.delay_after_s,
            drop_rate=args.drop_rate,
            garble_rate=args.garble_rate,
            reset_after_s=args.reset_after_s,
            disconnect_after_s=args.disconnect_after_s,
            disconnect_for_s=args.disconnect_for_s,
            seed=args.seed,
        )
        if config.encoder_offset != wrap_int32(config.encoder_offset):
            raise ValueError(f"--encoder-offset {config.encoder_offset} is not a 32-bit count")
        board = FakeBoard(config, link=args.link, log_path=args.log)
    except (ValueError, OSError) as error:
        print(f"fishtail-fake-board: error: {error}", file=sys.stderr)
        return 2
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, lambda *_: board.stop())
    signal.signal(signal.SIGUSR1, lambda *_: board.request_reset())
    signal.signal(signal.SIGUSR2, lambda *_: board.request_slow_toggle())
    try:
        board.run()
    except BrokenPipeError:
        pass
    finally:
        board.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The ``serial`` motor backend: a ROSArduinoBridge motor board over a serial port (pyserial).

All serial I/O runs in one background thread owned by the backend; the methods the node calls
(:meth:`SerialBackend.set_speed`, :meth:`~SerialBackend.read`, :meth:`~SerialBackend.stop`,
:meth:`~SerialBackend.status`) only exchange state under a lock and never wait for the device.
:meth:`~SerialBackend.close` waits (bounded) for the thread to send ``m 0 0`` and finish.

The thread:

- opens the port (a path such as ``/dev/serial/by-id/...``, or any pyserial URL), then waits for
  the board to answer ``b`` before trusting it (boards that reset when the port opens ignore
  input for a second or two while booting), with bounded exponential backoff between attempts;
- polls ``e`` at ``poll_rate_hz`` and turns the channel's count into the unwrapped carrier angle
  (:class:`fishtail_driver.protocol.CountUnwrapper`); the velocity is the count difference over a
  sliding window of ``velocity_window_s``;
- sends ``m`` when the commanded speed changes and re-sends it every ``resend_period_s`` while it
  is not zero, so the board's 2 s auto-stop never fires while motion is commanded (and fires
  within 2 s if this process dies). With ``command_hold_s`` (the driver node sets it to its
  watchdog timeout plus a margin), a non-zero speed is re-sent only while the last
  :meth:`SerialBackend.set_speed` call is at most that old: if the node stops calling (its
  executor hangs, its watchdog with it), the re-sends stop and the board's own auto-stop stops
  the motor within 2 s of the last ``m``;
- detects, counts and reports every fault: the port missing or failing to open, the path
  vanishing or pointing to another device (unplug/replug), read/write errors, a read timeout, a
  partial, garbled, binary or oversized reply, ``Invalid Command``, replies out of step, and board
  resets (counts back to 0, or a step larger than the motor can make). A transient fault costs one
  poll and a resynchronisation (:meth:`SerialBackend._fence`: a ``b`` request whose reply marks
  the line as back in step, every line before it discarded and counted); the link is declared lost
  (ERROR, port closed, reconnect with backoff) on an I/O error, a vanished path, or when no valid
  reply arrived for ``stale_timeout_s``;
- keeps the published angle continuous: after a board reset (seen mid-run or right after a
  reconnect) the count is re-based (the angle holds its last value and moves on from there); a
  reply of ``0 0`` right after a reconnect is a board reset, not motion, and so is a step larger
  than the motor can make or against its direction. Motion the board did not count (while it
  was resetting or off) is unknown, so a re-base may shift the carrier phase by a constant: it is
  counted (``phase_rebases``) and status() is WARN for ``phase_warn_s`` afterwards, saying so. A
  reconnect to a board that kept counting continues from its count and keeps the phase. A
  reading that disagrees with the speed estimate is held back for one poll: if the next reading
  continues from it, the step was real (motion or reset); if the next one continues from the
  previous reading, the held one was a corrupt value that happened to parse (a flipped digit)
  and is dropped as an outlier;
- dates each reading at the moment its request reached the board (see :meth:`SerialBackend._poll`).

:meth:`SerialBackend.read` returns each new encoder sample once and None when no new sample
arrived since the previous call (and while disconnected): the driver then skips that publish
tick, so ``motor/joint_state`` carries only real readings, at most at the poll rate, and pauses
while the board is unreachable (the outage shows on ``/diagnostics`` as ERROR).

The device missing at start is not fatal (unlike the MotorBackend protocol's default): start()
returns, status() reports ERROR, and the thread keeps trying, so the driver can be started
before the board is plugged in.
"""

from __future__ import annotations

import collections
import dataclasses
import math
import os
import threading
import time
from collections.abc import Callable

import serial

from fishtail_driver.backends import EncoderSample, StopOutcome
from fishtail_driver.protocol import (
    CHANNELS,
    MAX_REPLY_BYTES,
    CountUnwrapper,
    LineFramer,
    OversizedLine,
    ReplyError,
    Scale,
    channel_ticks,
    encode_get_baud,
    encode_motor_speeds,
    encode_read_encoders,
    encode_update_pid,
    parse_baud,
    parse_encoders,
    parse_ok,
    wrap_int32,
)

#: Fault kinds counted in status() (besides the ReplyError kinds).
LINK_FAULTS = ("open_failures", "disconnects", "handshake_failures", "timeouts", "partial_replies")
#: A count this close to zero is standstill jitter, not a reset, when it reads 0.
_JITTER_COUNTS = 2
#: Allowance for timing jitter between the board's reading and our receive time [s].
_TIMING_SLACK_S = 0.05
#: The motor turns one way: a step against its direction larger than this is a reset [rad].
_BACKWARD_TOLERANCE_RAD = 0.2
#: Allowance for this process being descheduled between a reply and its time stamp [s].
_STALL_SLACK_S = 0.02


@dataclasses.dataclass(frozen=True)
class SerialConfig:
    """Serial backend settings; times in seconds.

    Args:
        port: device path (``/dev/ttyACM0``, ``/dev/serial/by-id/...``) or a pyserial URL.
        baud: line rate; must match the firmware's BAUDRATE.
        read_timeout_s: longest wait for one reply.
        channel: motor channel of the tail, "left" or "right" (the other one gets 0).
        counts_per_revolution: encoder counts per motor-shaft turn, as the board counts them.
        gear_ratio: motor-shaft turns per carrier turn.
        pid_rate_hz: the firmware's PID_RATE (the frame is ``1000 // pid_rate_hz`` ms).
        poll_rate_hz: encoder polls per second.
        resend_period_s: re-send the current non-zero ``m`` this often (< 2 s auto-stop).
        max_speed_rad_s: carrier speed limit; twice it bounds a plausible encoder step.
        handshake_timeout_s: how long the board may take to answer after the port opens.
        stale_timeout_s: no valid reply for this long while connected: the link is lost.
        reconnect_min_s: first reconnect backoff (doubles per failure ...).
        reconnect_max_s: ... up to this.
        max_line_bytes: longer reply lines are discarded as oversized.
        velocity_window_s: time span of the velocity estimate.
        fault_hold_s: status() is WARN for this long after a transient fault.
        pid_gains: optional (kp, kd, ki, ko) sent with ``u`` after every connect.
        command_hold_s: re-send a non-zero speed only while the last set_speed() call is at most
            this old (None: keep re-sending it until it changes); see
            :meth:`SerialBackend.set_command_hold`.
        phase_warn_s: status() is WARN for this long after the angle was re-based.
    """

    port: str
    baud: int = 57600
    read_timeout_s: float = 0.1
    channel: str = "left"
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    pid_rate_hz: int = 30
    poll_rate_hz: float = 100.0
    resend_period_s: float = 0.5
    max_speed_rad_s: float = 20.0
    handshake_timeout_s: float = 5.0
    stale_timeout_s: float = 1.0
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = 2.0
    max_line_bytes: int = MAX_REPLY_BYTES
    velocity_window_s: float = 0.1
    fault_hold_s: float = 2.0
    pid_gains: tuple[int, int, int, int] | None = None
    command_hold_s: float | None = None
    phase_warn_s: float = 10.0

    def __post_init__(self) -> None:
        """Reject settings that cannot work, with the reason."""
        checks = (
            (isinstance(self.port, str) and self.port != "", "port must be a non-empty string"),
            (self.baud > 0, f"baud must be > 0, got {self.baud}"),
            (self.channel in CHANNELS, f"channel must be 'left' or 'right', got {self.channel!r}"),
            (0.0 < self.read_timeout_s <= 10.0,
             f"read_timeout_s must be in (0, 10], got {self.read_timeout_s}"),
            (0.0 < self.poll_rate_hz <= 10000.0,
             f"poll_rate_hz must be in (0, 10000], got {self.poll_rate_hz}"),
            (0.0 < self.resend_period_s <= 1.5,
             f"resend_period_s must be in (0, 1.5] to beat the board's 2 s auto-stop, "
             f"got {self.resend_period_s}"),
            (self.max_speed_rad_s > 0.0,
             f"max_speed_rad_s must be > 0, got {self.max_speed_rad_s}"),
            (self.handshake_timeout_s > 0.0,
             f"handshake_timeout_s must be > 0, got {self.handshake_timeout_s}"),
            (self.stale_timeout_s >= 2.0 * self.read_timeout_s,
             f"stale_timeout_s ({self.stale_timeout_s}) must be >= 2 x read_timeout_s "
             f"({self.read_timeout_s})"),
            (0.0 < self.reconnect_min_s <= self.reconnect_max_s,
             "need 0 < reconnect_min_s <= reconnect_max_s"),
            (self.max_line_bytes >= 32, f"max_line_bytes must be >= 32, got {self.max_line_bytes}"),
            (self.velocity_window_s > 0.0, "velocity_window_s must be > 0"),
            (self.command_hold_s is None or self.command_hold_s > 0.0,
             f"command_hold_s must be > 0 or None, got {self.command_hold_s}"),
            (self.phase_warn_s >= 0.0, f"phase_warn_s must be >= 0, got {self.phase_warn_s}"),
        )  # fmt: skip
        for ok, reason in checks:
            if not ok:
                raise ValueError(reason)
        # Validates counts_per_revolution, gear_ratio and pid_rate_hz.
        Scale(self.counts_per_revolution, self.gear_ratio, self.pid_rate_hz)
        if self.pid_gains is not None:
            encode_update_pid(*self.pid_gains)


#: What :meth:`SerialBackend._transact` returns when the exchange failed (None is a valid reply).
_FAILED = object()


class _LinkLostError(Exception):
    """The port is unusable; the worker closes it and reconnects."""


class _ReadTimeoutError(Exception):
    def __init__(self, partial: bytes) -> None:
        super().__init__(partial)
        self.partial = partial


def _is_url(port: str) -> bool:
    return "://" in port


class SerialBackend:
    """MotorBackend for a ROSArduinoBridge board; see the module docstring."""

    name = "serial"

    def __init__(
        self,
        config: SerialConfig,
        clock: Callable[[], float] = time.monotonic,
        opener: Callable[..., serial.SerialBase] | None = None,
    ) -> None:
        """Prepare (nothing is opened until :meth:`start`); ``opener`` is injectable for tests."""
        self.config = config
        self.hardware_id = config.port
        self.scale = Scale(config.counts_per_revolution, config.gear_ratio, config.pid_rate_hz)
        self._clock = clock
        self._opener = opener or serial.serial_for_url
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None
        self._port: serial.SerialBase | None = None
        self._rdev: int | None = None
        self._framer = LineFramer(config.max_line_bytes)
        self._lines: collections.deque[bytes | OversizedLine] = collections.deque()
        self._unwrapper = CountUnwrapper()
        self._byte_s = 10.0 / config.baud
        # Command state (shared).
        self._target_speed = 0.0
        self._target_ticks = 0
        self._acked_ticks: int | None = None
        self._acked_at = -math.inf
        self._motor_retry_at = -math.inf  # after a failed m, not before this
        self._set_at = -math.inf  # time of the last set_speed() call
        self._command_hold_s = config.command_hold_s
        self._resends_paused = False
        # Sample state (shared).
        self._latest: EncoderSample | None = None
        self._latest_seq = 0
        self._read_seq = 0
        self._history: collections.deque[tuple[float, int]] = collections.deque()
        self._last_pair: tuple[int, int] | None = None
        self._last_sample_s: float | None = None
        self._direction = 0  # +1/-1: how the count runs when driven forwards; 0: not known yet
        self._pending: tuple[int, float] | None = None  # a reading awaiting confirmation
        self._last_good_s = -math.inf
        self._poll_times: collections.deque[float] = collections.deque()
        # Status (shared).
        self._connected = False
        self._state = "not started"
        self._board_baud: int | None = None
        self._last_fault: tuple[str, str, float] | None = None
        self._final_stop = "not sent"
        self._last_rebase: tuple[str, float] | None = None  # (why, when)
        self.counters: collections.Counter[str] = collections.Counter()
        self.counters["phase_rebases"] = 0

    # ------------------------------------------------------------------------------------------
    # MotorBackend interface (called from the node's threads; never blocks on I/O)

    def start(self) -> None:
        """Start the I/O thread; returns at once (a missing device is retried, not fatal)."""
        if self._thread is not None:
            return
        self._state = f"opening {self.config.port}"
        self._thread = threading.Thread(target=self._run, name="fishtail-serial", daemon=True)
        self._thread.start()

    def set_speed(self, speed_rad_s: float) -> None:
        """Command a carrier speed; the I/O thread sends it at once and keeps it alive."""
        ticks, clamped = self.scale.ticks_per_frame(speed_rad_s)
        now = self._clock()
        with self._lock:
            if clamped:
                self.counters["clamped_commands"] += 1
            self._target_speed = speed_rad_s
            self._target_ticks = ticks
            self._set_at = now
        self._wake.set()

    @property
    def command_hold_s(self) -> float | None:
        """The current hold time of a non-zero speed (see :meth:`set_command_hold`)."""
        with self._lock:
            return self._command_hold_s

    def set_command_hold(self, hold_s: float | None) -> None:
        """Re-send a non-zero speed only while the last set_speed() is at most ``hold_s`` old.

        None: re-send it for as long as it is commanded. The driver node sets its watchdog
        timeout plus a margin, so that the board's auto-stop takes over if the node hangs.
        """
        if hold_s is not None and not hold_s > 0.0:
            raise ValueError(f"hold_s must be > 0 or None, got {hold_s!r}")
        with self._lock:
            self._command_hold_s = hold_s
        self._wake.set()

    def stop(self) -> None:
        """Command zero speed (``m 0 0``); does not wait for the board. Never raises."""
        try:
            self.set_speed(0.0)
        except Exception:  # stop() must not raise
            pass

    def read(self) -> EncoderSample | None:
        """The newest encoder sample if it was not returned before, else None."""
        with self._lock:
            if self._latest is None or self._latest_seq == self._read_seq:
                return None
            self._read_seq = self._latest_seq
            return self._latest

    def close(self) -> StopOutcome:
        """Send ``m 0 0`` (if connected), stop the thread and close the port; never raises.

        Returns whether the board acknowledged the stop, or why it could not be sent.
        """
        thread = self._thread
        with self._lock:
            self._target_speed = 0.0
            self._target_ticks = 0
            state = self._state
        self._closing.set()
        self._wake.set()
        if thread is None:
            return StopOutcome(False, False, "m 0 0 not sent: the backend was never started")
        thread.join(timeout=3.0 * self.config.read_timeout_s + 1.0)
        alive = thread.is_alive()
        if alive:
            with self._lock:
                self.counters["close_timeouts"] += 1
            port = self._port
            if port is not None:
                try:
                    port.cancel_read()
                except Exception:  # best effort
                    pass
        with self._lock:
            final_stop = self._final_stop
        if final_stop == "acknowledged":
            return StopOutcome(True, True, "stop acknowledged by the board")
        if final_stop == "sent, not acknowledged":
            return StopOutcome(False, True, f"m 0 0 sent to {self.config.port}, not acknowledged")
        why = "the serial thread did not finish in time" if alive else state
        return StopOutcome(False, False, f"m 0 0 not sent: {why}")

    def status(self) -> tuple[int, str, dict[str, str]]:
        """(level, message, values): ERROR while not connected, WARN after recent faults."""
        now = self._clock()
        config = self.config
        with self._lock:
            connected = self._connected
            state = self._state
            fault = self._last_fault
            acked = "" if self._acked_ticks is None else str(self._acked_ticks)
            rebase = self._last_rebase
            pair = "" if self._last_pair is None else " ".join(map(str, self._last_pair))
            values = {
                "port": config.port,
                "baud": str(config.baud),
                "channel": config.channel,
                "state": self._state,
                "connected": str(connected).lower(),
                "board_baud": "" if self._board_baud is None else str(self._board_baud),
                "target_speed_rad_s": f"{self._target_speed:.4f}",
                "target_ticks_per_frame": str(self._target_ticks),
                "acked_ticks_per_frame": acked,
                "pid_frame_ms": str(self.scale.frame_ms),
                "poll_rate_hz": f"{self._achieved_poll_rate():.1f}",
                "encoder_counts": pair,
                "continuous_counts": str(self._unwrapper.total),
                "last_fault": "" if fault is None else f"{fault[0]}: {fault[1]}",
                "final_stop": self._final_stop,
                "resends_paused": str(self._resends_paused).lower(),
                "last_phase_rebase": "" if rebase is None else rebase[0],
            }
            for key in sorted(self.counters):
                values[key] = str(self.counters[key])
        if not connected:
            return 2, f"serial: {state}", values
        notes = []
        if fault is not None and now - fault[2] < config.fault_hold_s:
            notes.append(f"recent fault: {fault[0]}")
        if rebase is not None and now - rebase[1] < config.phase_warn_s:
            notes.append(
                "encoder angle re-based after a board reset or power cycle: the carrier phase "
                "reference may have shifted, phase_rad may need re-calibration"
            )
        if notes:
            return 1, f"serial: connected to {config.port}; {'; '.join(notes)}", values
        return 0, f"serial: connected to {config.port} at {config.baud} baud", values

    # ------------------------------------------------------------------------------------------
    # Shared-state helpers (worker side)

    def _achieved_poll_rate(self) -> float:
        times = self._poll_times
        if len(times) < 2 or self._clock() - times[-1] > 1.0:
            return 0.0
        return (len(times) - 1) / (times[-1] - times[0]) if times[-1] > times[0] else 0.0

    def _fault(self, kind: str, reason: str) -> None:
        with self._lock:
            self.counters[kind] += 1
            self._last_fault = (kind, reason, self._clock())

    def _set_state(self, state: str, connected: bool) -> None:
        with self._lock:
            self._state = state
            self._connected = connected

    # ------------------------------------------------------------------------------------------
    # The I/O thread

    def _run(self) -> None:
        backoff = self.config.reconnect_min_s
        while not self._closing.is_set():
            try:
                self._connect()
            except _LinkLostError as error:
                self._close_port()
                if self._closing.is_set():
                    break
                self._set_state(f"{error}; retrying in {backoff:.1f} s", False)
                self._closing.wait(backoff)
                backoff = min(2.0 * backoff, self.config.reconnect_max_s)
                continue
            except Exception as error:  # the thread must survive anything
                self._close_port()
                self._internal_error(error)
                self._closing.wait(backoff)
                backoff = min(2.0 * backoff, self.config.reconnect_max_s)
                continue
            backoff = self.config.reconnect_min_s
            try:
                self._serve()
            except _LinkLostError as error:
                with self._lock:
                    self.counters["disconnects"] += 1
                    self._last_fault = ("disconnect", str(error), self._clock())
                self._set_state(f"link lost: {error}; reconnecting", False)
            except Exception as error:
                self._internal_error(error)
            finally:
                self._close_port()
            if not self._closing.is_set():
                self._closing.wait(backoff)
        self._set_state("closed", False)

    def _internal_error(self, error: Exception) -> None:
        reason = f"internal error {type(error).__name__}: {error}"
        with self._lock:
            self.counters["internal_errors"] += 1
            self._last_fault = ("internal_error", reason, self._clock())
        self._set_state(f"{reason}; reconnecting", False)

    def _close_port(self) -> None:
        port, self._port = self._port, None
        self._rdev = None
        self._framer.clear()
        self._lines.clear()
        if port is not None:
            try:
                port.close()
            except Exception:  # closing a dead port may fail; nothing to do
                pass

    def _open(self) -> None:
        config = self.config
        if not _is_url(config.port) and not os.path.exists(config.port):
            with self._lock:
                self.counters["port_missing"] += 1
            raise _LinkLostError(f"port {config.port} does not exist (board unplugged?)")
        kwargs = {
            "baudrate": config.baud,
            "timeout": min(config.read_timeout_s, 0.02),
            "write_timeout": config.read_timeout_s,
        }
        if not _is_url(config.port):
            kwargs["exclusive"] = True
        try:
            self._port = self._opener(config.port, **kwargs)
        except (serial.SerialException, OSError, ValueError) as error:
            with self._lock:
                self.counters["open_failures"] += 1
            raise _LinkLostError(f"cannot open {config.port}: {error}") from None
        try:
            self._rdev = os.fstat(self._port.fileno()).st_rdev
        except Exception:  # URLs and test doubles have no device number
            self._rdev = None

    def _connect(self) -> None:
        config = self.config
        self._set_state(f"opening {config.port}", False)
        self._open()
        self._set_state(f"waiting for the board on {config.port} to answer", False)
        start = self._clock()
        deadline = start + config.handshake_timeout_s
        probe_s = max(0.25, config.read_timeout_s)
        baud = None
        while baud is None:
            if self._closing.is_set():
                raise _LinkLostError("closing")
            self._resync(quiet=False)
            self._write(encode_get_baud())
            try:
                line = self._read_line(self._clock() + probe_s)
                if isinstance(line, OversizedLine):
                    raise ReplyError("oversized", "oversized line while waiting for the board")
                baud = parse_baud(line)
            except _ReadTimeoutError:
                pass
            except ReplyError as error:
                if error.kind == "invalid_command":
                    baud = 0  # alive, but a firmware without 'b'
                else:
                    with self._lock:
                        self.counters["handshake_noise"] += 1
            if baud is None and self._clock() >= deadline:
                with self._lock:
                    self.counters["handshake_failures"] += 1
                raise _LinkLostError(
                    f"the board on {config.port} did not answer 'b' within "
                    f"{config.handshake_timeout_s:g} s (wrong port or baud, or not "
                    "ROSArduinoBridge firmware?)"
                )
        with self._lock:
            self._board_baud = baud or None
            if baud and baud != config.baud:
                self.counters["baud_mismatch"] += 1
        pair, when = self._verify_in_step(deadline + config.stale_timeout_s)
        if config.pid_gains is not None:
            if self._transact(encode_update_pid(*config.pid_gains), parse_ok) is _FAILED:
                with self._lock:
                    self.counters["pid_gains_not_acknowledged"] += 1
        # The first reading decides whether the board was reset while we were away.
        self._accept(pair, when, after_connect=True)
        with self._lock:
            self.counters["connects"] += 1
            if self.counters["connects"] > 1:
                self.counters["reconnects"] += 1
            self._acked_ticks = None  # (re)send the current command at once
            self._last_good_s = self._clock()
        self._set_state(f"connected to {config.port}", True)

    def _verify_in_step(self, deadline: float) -> tuple[tuple[int, int], float]:
        """Two ``e`` exchanges, each on a quiet line and answered within the read timeout.

        The protocol has no sequence numbers: a board that answers later than the timeout would
        otherwise look healthy, its late replies taken for answers to later requests. With the
        line quiet before each request, only a timely reply can pass; returns the last reading.
        """
        config = self.config
        # Between the two exchanges the line must stay quiet longer than a reply could be late
        # and still be mistaken for the next one (read timeout + quiet time).
        quiet_s = max(0.05, config.read_timeout_s)
        verified = 0
        last_error = "no reply"
        while True:
            if self._closing.is_set():
                raise _LinkLostError("closing")
            if self._clock() >= deadline:
                with self._lock:
                    self.counters["handshake_failures"] += 1
                raise _LinkLostError(
                    f"the board on {config.port} answers 'b' but not 'e' in step within "
                    f"{config.read_timeout_s:g} s ({last_error})"
                )
            wait_s = quiet_s + (config.read_timeout_s if verified else 0.0)
            limit_s = max(deadline - self._clock(), 0.0)
            if self._resync(quiet=True, quiet_s=wait_s, limit_s=limit_s) and verified:
                verified, last_error = 0, "bytes arrived after a reply (late replies?)"
                with self._lock:
                    self.counters["handshake_noise"] += 1
            sent = self._clock()
            self._write(encode_read_encoders())
            try:
                line = self._read_line(sent + config.read_timeout_s)
                if isinstance(line, OversizedLine):
                    raise ReplyError("oversized", f"a {line.length}-byte line")
                pair = parse_encoders(line)
            except _ReadTimeoutError:
                verified, last_error = 0, f"no reply to 'e' within {config.read_timeout_s:g} s"
                with self._lock:
                    self.counters["handshake_noise"] += 1
                continue
            except ReplyError as error:
                verified, last_error = 0, f"{error.kind}: {error.reason}"
                with self._lock:
                    self.counters["handshake_noise"] += 1
                    if error.kind == "invalid_command":
                        self.counters["invalid_command"] += 1
                continue
            verified += 1
            if verified >= 2:
                return pair, sent + self._request_s(encode_read_encoders())

    def _serve(self) -> None:
        config = self.config
        period = 1.0 / config.poll_rate_hz
        now = self._clock()
        next_poll = now
        next_path_check = now + 0.25
        while True:
            self._wake.clear()
            if self._closing.is_set():
                self._send_final_stop()
                return
            now = self._clock()
            if now >= next_path_check:
                self._check_path()
                next_path_check = now + 0.25
            with self._lock:
                ticks, acked, acked_at = self._target_ticks, self._acked_ticks, self._acked_at
                sendable = self._sendable_locked(ticks, now)
            resend_due = acked_at + config.resend_period_s
            due = sendable and (ticks != acked or (ticks != 0 and now >= resend_due))
            if due and now >= self._motor_retry_at:
                self._send_motor(ticks, resend=ticks == acked)
            now = self._clock()
            if now >= next_poll:
                self._poll()
                next_poll += period
                now = self._clock()
                if next_poll < now - 5 * period:
                    next_poll = now  # far behind: do not burst to catch up
            with self._lock:
                silent_s = now - self._last_good_s
                ticks, acked, acked_at = self._target_ticks, self._acked_ticks, self._acked_at
                sendable = self._sendable_locked(ticks, now)
            if silent_s > config.stale_timeout_s:
                fault = self._last_fault
                detail = f" (last fault: {fault[0]}: {fault[1]})" if fault else ""
                raise _LinkLostError(f"no valid reply for {silent_s:.1f} s{detail}")
            deadline = min(next_poll, next_path_check)
            if not sendable:
                pass  # a stale non-zero speed: nothing to send until set_speed() is called
            elif ticks != acked:
                deadline = min(deadline, max(now, self._motor_retry_at))
            elif ticks != 0:
                deadline = min(deadline, max(acked_at + config.resend_period_s,
                                             self._motor_retry_at))  # fmt: skip
            timeout = deadline - self._clock()
            if timeout > 0:
                self._wake.wait(timeout)

    def _sendable_locked(self, ticks: int, now: float) -> bool:
        """Whether ``ticks`` may be sent now: zero always, non-zero while set_speed() is fresh.

        Call with the lock held; notes (and counts once) when re-sending pauses.
        """
        hold = self._command_hold_s
        if ticks == 0 or hold is None or now - self._set_at <= hold:
            self._resends_paused = False
            return True
        if not self._resends_paused:
            self._resends_paused = True
            self.counters["resend_pauses"] += 1
        return False

    def _check_path(self) -> None:
        port = self.config.port
        if _is_url(port):
            return
        try:
            rdev = os.stat(port).st_rdev
        except OSError:
            raise _LinkLostError(f"{port} vanished (unplugged?)") from None
        if self._rdev is not None and rdev != self._rdev:
            raise _LinkLostError(f"{port} now points to another device (replugged?)")

    def _send_final_stop(self) -> None:
        for _ in range(2):
            if self._transact(encode_motor_speeds(0, 0), parse_ok) is not _FAILED:
                with self._lock:
                    self._final_stop = "acknowledged"
                    self._acked_ticks = 0
                return
            # Written (a failed write raises instead), so the board may well have run it.
            with self._lock:
                self._final_stop = "sent, not acknowledged"

    def _send_motor(self, ticks: int, resend: bool) -> None:
        left, right = channel_ticks(self.config.channel, ticks)
        if self._transact(encode_motor_speeds(left, right), parse_ok) is _FAILED:
            # Retry soon, but never in a tight loop against a board that rejects m at once.
            self._motor_retry_at = self._clock() + min(0.02, self.config.resend_period_s)
            return
        with self._lock:
            self._acked_ticks = ticks
            self._acked_at = self._clock()
            self.counters["motor_resends" if resend else "motor_commands"] += 1

    def _request_s(self, payload: bytes) -> float:
        """Line time of a request: from its write until its CR reaches the board [s]."""
        return len(payload) * self._byte_s

    def _poll(self) -> bool:
        """One ``e`` exchange; the reading is dated when the request reached the board.

        The firmware reads the encoders as soon as the request's CR arrives and writes the reply
        at once; what delays a reply is mostly on the way back (a USB adapter's latency timer
        holds received bytes up to 16 ms, the reply's own line time, this process being
        scheduled), so the middle of the exchange would date a reading from a slow board up to
        half the round trip late. The reading is within [request arrival, reply arrival].
        """
        payload = encode_read_encoders()
        sent = self._clock()
        pair = self._transact(payload, parse_encoders)
        if pair is _FAILED:
            return False
        self._accept(pair, sent + self._request_s(payload), after_connect=False)
        return True

    # --- encoder samples -------------------------------------------------------------------------

    def _max_step(self, elapsed_s: float) -> int:
        speed = 2.0 * self.config.max_speed_rad_s
        return math.ceil(self.scale.counts_from_angle(speed * (elapsed_s + _TIMING_SLACK_S))) + 16

    def _step(self, step) -> None:
        """Learn which way the count runs when the motor is driven forwards (wiring dependent)."""
        if step.event in ("move", "wrap") and abs(step.delta) > _JITTER_COUNTS:
            with self._lock:
                driven = self._acked_ticks is not None and self._acked_ticks > 0
            if driven:
                self._direction = 1 if step.delta > 0 else -1

    def _discontinuity(
        self, pair: tuple[int, int], delta: int, elapsed: float, previous: int | None = None
    ) -> str | None:
        """Why a step of ``delta`` counts over ``elapsed`` s cannot be motion, or None."""
        if previous is None:
            previous = self._unwrapper.last_raw
        if previous is not None and pair == (0, 0) and abs(previous) > _JITTER_COUNTS:
            return f"counts read 0 0 (were {previous})"
        if abs(delta) > self._max_step(elapsed):
            return f"count jumped by {delta} in {elapsed:.3f} s"
        backward = self.scale.counts_from_angle(_BACKWARD_TOLERANCE_RAD) + _JITTER_COUNTS
        if self._direction and delta * self._direction < -backward:
            return f"count went {abs(delta)} against the motor's direction"
        return None

    def _trusted(
        self, pair: tuple[int, int], delta: int, elapsed: float, previous: int | None = None
    ) -> bool:
        """A possible step that matches the speed estimate closely enough to accept at once."""
        if self._discontinuity(pair, delta, elapsed, previous) is not None:
            return False
        speed = self._latest.velocity_rad_s if self._latest is not None else 0.0
        predicted = self.scale.counts_from_angle(speed * elapsed)
        allowed = _JITTER_COUNTS + self.scale.counts_from_angle(
            self.config.max_speed_rad_s * elapsed + abs(speed) * _STALL_SLACK_S
        )
        return abs(delta - predicted) <= allowed

    def _accept(self, pair: tuple[int, int], when: float, after_connect: bool) -> None:
        """Account for one reading; publishes a sample unless the reading awaits confirmation.

        A reading that does not match the speed estimate is held back (``_pending``) until the
        next one: if that one continues from it, the step was real (motion, or a board reset
        when the step is impossible); if it continues from the last accepted reading instead,
        the held one was a corrupt value that happened to parse (an outlier) and is dropped.
        """
        raw = pair[0] if self.config.channel == "left" else pair[1]
        unwrapper = self._unwrapper
        last_s = self._last_sample_s if self._last_sample_s is not None else when
        elapsed = max(when - last_s, 0.0)
        delta = unwrapper.delta_to(raw)
        reset = None
        outlier = None
        if delta is None:
            self._pending = None
        elif after_connect or (pair == (0, 0) and abs(unwrapper.last_raw) > _JITTER_COUNTS):
            # After a gap there is no speed to predict from: only rule out the impossible.
            self._pending = None
            reset = self._discontinuity(pair, delta, elapsed)
            if reset is not None:
                unwrapper.rebase()
        elif self._trusted(pair, delta, elapsed):
            if self._pending is not None:
                outlier = f"reading {self._pending[0]} disagreed with its neighbours; dropped"
                self._pending = None
        elif self._pending is not None and self._trusted(
            pair, wrap_int32(raw - self._pending[0]), max(when - self._pending[1], 0.0),
            previous=self._pending[0],
        ):  # fmt: skip
            held_raw, held_s = self._pending
            self._pending = None
            held_delta = unwrapper.delta_to(held_raw)
            reset = self._discontinuity(pair, held_delta, max(held_s - last_s, 0.0))
            if reset is not None and abs(held_raw) > self._max_step(max(held_s - last_s, 0.0)):
                # Confirmed, but too far from 0 for a board that restarted since the last
                # reading: the reading accepted before was a corrupt value that happened to look
                # plausible. Follow the board (a one-off correction) rather than re-basing, which
                # would keep that error in the angle for good.
                outlier = (
                    f"reading before {held_raw} was corrupt: angle corrected by "
                    f"{held_delta} counts"
                )
                reset = None
            if reset is not None:
                unwrapper.rebase()
            self._step(unwrapper.update(held_raw))
        else:
            if self._pending is not None:
                outlier = f"reading {self._pending[0]} disagreed with its neighbours; dropped"
            self._pending = (raw, when)
            with self._lock:
                self.counters["held_readings"] += 1
                if outlier is not None:
                    self.counters["outliers"] += 1
                    self._last_fault = ("outliers", outlier, self._clock())
            return
        self._step(unwrapper.update(raw))
        with self._lock:
            if outlier is not None:
                self.counters["outliers"] += 1
                self._last_fault = ("outliers", outlier, self._clock())
            if reset is not None:
                self.counters["board_resets"] += 1
                self.counters["phase_rebases"] += 1
                self._last_rebase = (reset, self._clock())
                if not after_connect:
                    # Unexpected: the board lost its target too, so re-send it now.
                    self._last_fault = ("board_reset", reset, self._clock())
                    self._acked_ticks = None
            self.counters["encoder_wraps"] = unwrapper.wraps
            self.counters["polls"] += 1
            self._last_pair = pair
            self._last_sample_s = when
            total = unwrapper.total
            history = self._history
            if reset is not None or after_connect:
                history.clear()
            history.append((when, total))
            window = self.config.velocity_window_s
            while len(history) > 2 and history[1][0] <= when - window:
                history.popleft()
            base_s, base_total = history[0]
            if when > base_s:
                velocity = self.scale.angle_from_counts(total - base_total) / (when - base_s)
            else:
                keep = self._latest is not None and reset is None and not after_connect
                velocity = self._latest.velocity_rad_s if keep else 0.0
            self._latest = EncoderSample(when, self.scale.angle_from_counts(total), velocity)
            self._latest_seq += 1
            times = self._poll_times
            times.append(when)
            while times and times[0] < when - 1.0:
                times.popleft()

    # --- line I/O --------------------------------------------------------------------------------

    def _write(self, payload: bytes) -> None:
        port = self._port
        if port is None:
            raise _LinkLostError("port closed")
        try:
            port.write(payload)
        except serial.SerialTimeoutException:
            with self._lock:
                self.counters["write_timeouts"] += 1
            raise _LinkLostError(f"write to {self.config.port} timed out") from None
        except (serial.SerialException, OSError) as error:
            raise _LinkLostError(f"write to {self.config.port} failed: {error}") from None

    def _read_line(self, deadline: float) -> bytes | OversizedLine:
        port = self._port
        if port is None:
            raise _LinkLostError("port closed")
        while True:
            if self._lines:
                return self._lines.popleft()
            if self._clock() >= deadline:
                raise _ReadTimeoutError(self._framer.pending)
            try:
                waiting = port.in_waiting
                data = port.read(max(1, min(waiting, 4096)))
            except (serial.SerialException, OSError) as error:
                raise _LinkLostError(f"read from {self.config.port} failed: {error}") from None
            if data:
                self._lines.extend(self._framer.feed(data))

    def _resync(
        self, quiet: bool, quiet_s: float | None = None, limit_s: float | None = None
    ) -> bool:
        """Drop buffered input; with ``quiet``, also wait until the line stays silent a moment.

        The silence lasts ``quiet_s`` (default: 30 byte times, at least 5 ms); the wait is bounded
        by ``limit_s`` (default: the read timeout). Returns whether any bytes arrived meanwhile.
        """
        port = self._port
        if port is None:
            raise _LinkLostError("port closed")
        noise = bool(self._framer.pending) or bool(self._lines)
        self._framer.clear()
        self._lines.clear()
        try:
            noise = bool(port.in_waiting) or noise
            port.reset_input_buffer()
            if not quiet:
                return noise
            if quiet_s is None:
                quiet_s = max(0.005, 30 * self._byte_s)
            end = self._clock() + (self.config.read_timeout_s if limit_s is None else limit_s)
            last = self._clock()
            while self._clock() < end and self._clock() - last < quiet_s:
                if port.in_waiting:
                    port.reset_input_buffer()
                    last = self._clock()
                    noise = True
                else:
                    time.sleep(0.001)
        except (serial.SerialException, OSError) as error:
            raise _LinkLostError(f"{self.config.port} failed: {error}") from None
        return noise

    def _drop_input(self) -> int:
        """Discard all buffered input; returns how many reply lines (whole or begun) it held."""
        port = self._port
        if port is None:
            raise _LinkLostError("port closed")
        try:
            waiting = port.in_waiting
            data = port.read(waiting) if waiting else b""
        except (serial.SerialException, OSError) as error:
            raise _LinkLostError(f"{self.config.port} failed: {error}") from None
        lines = len(self._lines) + len(self._framer.feed(data)) + bool(self._framer.pending)
        self._framer.clear()
        self._lines.clear()
        return lines

    def _is_fence_reply(self, line: bytes | OversizedLine) -> bool:
        if isinstance(line, OversizedLine):
            return False
        try:
            parse_baud(line)
            return True
        except ReplyError as error:
            # A firmware without 'b' (handshake answered Invalid Command) answers the fence so.
            return error.kind == "invalid_command" and self._board_baud is None

    def _fence(self) -> None:
        """Get back in step after a failed exchange: no late reply may pass for a later one's.

        The protocol has no request tags, and a board may answer after the read timeout: sent at
        once, the next request would take that late reply for its own (an old reading with a
        current stamp). So: drop the input, send ``b`` and discard every line until a reply to
        ``b`` arrives. The board answers in order, so by then every earlier request has been
        answered or lost, and the next reply answers the next request. A ``b`` reply never
        passes for an encoder reading or an ``OK``, so a fence answered late (and taken for a
        later fence) does no harm either. Discarded lines are counted (``discarded_replies``).
        Fence replies do not count as valid replies: a board that answers only late is declared
        lost after ``stale_timeout_s``. When closing, one attempt only.
        """
        config = self.config
        with self._lock:
            self.counters["resyncs"] += 1
        while True:
            discarded = self._drop_input()
            self._write(encode_get_baud())
            deadline = self._clock() + config.read_timeout_s
            in_step = False
            while not in_step:
                try:
                    line = self._read_line(deadline)
                except _ReadTimeoutError:
                    break
                in_step = self._is_fence_reply(line)
                discarded += not in_step
            with self._lock:
                self.counters["discarded_replies"] += discarded
                silent_s = self._clock() - self._last_good_s
            if in_step or self._closing.is_set():
                return
            if silent_s > config.stale_timeout_s:
                raise _LinkLostError(
                    f"no valid reply for {silent_s:.1f} s (replies late or out of step: "
                    f"{self.counters['discarded_replies']} discarded)"
                )

    def _transact(self, payload: bytes, parse: Callable[[bytes], object]) -> object:
        """Send one command and parse its reply; a transient fault is counted: ``_FAILED``."""
        self._write(payload)
        try:
            line = self._read_line(self._clock() + self.config.read_timeout_s)
        except _ReadTimeoutError as timeout:
            command = payload.rstrip(b"\r").decode("ascii")
            if timeout.partial:
                self._fault(
                    "partial_replies",
                    f"only {timeout.partial[:40]!r} (no line end) within "
                    f"{self.config.read_timeout_s:g} s after {command!r}",
                )
            else:
                self._fault(
                    "timeouts", f"no reply to {command!r} within {self.config.read_timeout_s:g} s"
                )
            self._fence()
            return _FAILED
        if isinstance(line, OversizedLine):
            self._fault(
                "oversized", f"a {line.length}-byte line (starting {line.head!r}) was discarded"
            )
            self._fence()
            return _FAILED
        try:
            value = parse(line)
        except ReplyError as error:
            self._fault(error.kind, error.reason)
            self._fence()
            return _FAILED
        with self._lock:
            self._last_good_s = self._clock()
        return value

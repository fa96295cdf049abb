"""One serial port to a ROSArduinoBridge board: open, write, read lines, exchange, keep in step.

Used by the serial backend's I/O thread only (nothing here is thread-safe but the
:class:`~fishtail_driver.status_counters.StatusCounters` it counts in). A failure that makes the
port unusable raises :class:`LinkLostError` (the backend closes it and reconnects); a failed
exchange (no reply, a partial, oversized or malformed one) is counted, the line is
resynchronised (:meth:`SerialLink.fence`) and the exchange returns :class:`Failed`.
"""

from __future__ import annotations

import collections
import dataclasses
import os
import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

import serial

from fishtail_driver.protocol import (
    LineFramer,
    OversizedLine,
    ReplyError,
    encode_get_baud,
    encode_read_encoders,
    parse_baud,
    parse_encoders,
)
from fishtail_driver.serial_config import SerialConfig
from fishtail_driver.status_counters import StatusCounters

T = TypeVar("T")

#: Opens a port: pyserial's ``serial_for_url`` (tests inject doubles).
PortOpener = Callable[..., serial.Serial]


class LinkLostError(Exception):
    """The port is unusable; the backend closes it and reconnects."""


class ReadTimeoutError(Exception):
    """No whole line arrived before the deadline; ``partial`` holds what did."""

    def __init__(self, partial: bytes) -> None:
        """Keep the bytes of the incomplete line."""
        super().__init__(partial)
        self.partial = partial


@dataclasses.dataclass(frozen=True)
class Answered(Generic[T]):
    """An exchange that got its reply."""

    value: T
    #: When the request's last byte reached the board (monotonic s): when it acted on it.
    request_arrived_s: float
    #: When the reply's line was whole here (monotonic s): the reading is no later than this.
    reply_arrived_s: float

    @property
    def round_trip_s(self) -> float:
        """How long the board may have held the reading: from the request to its reply [s]."""
        return self.reply_arrived_s - self.request_arrived_s


@dataclasses.dataclass(frozen=True)
class Failed:
    """An exchange that failed transiently (counted under ``kind``; the line is back in step)."""

    kind: str
    reason: str


@dataclasses.dataclass(frozen=True)
class Handshake:
    """What a board that answers in step said when the port opened."""

    #: Its ``b`` reply; None for a firmware without ``b`` (it answered Invalid Command).
    board_baud: int | None
    #: The last of the verifying ``e`` readings, when the board took it and when it came back.
    pair: tuple[int, int]
    read_s: float
    reply_s: float


class SerialLink:
    """The port, its line framing and the request/reply discipline of one board."""

    def __init__(
        self,
        config: SerialConfig,
        counters: StatusCounters,
        closing: threading.Event,
        clock: Callable[[], float] = time.monotonic,
        opener: PortOpener | None = None,
    ) -> None:
        """Nothing is opened until :meth:`open`; ``closing`` makes waits give up early."""
        self.config = config
        self.counters = counters
        self._closing = closing
        self._clock = clock
        self._opener: PortOpener = opener or serial.serial_for_url
        self._port: serial.Serial | None = None
        self._rdev: int | None = None
        self._framer = LineFramer(config.max_line_bytes)
        self._lines: collections.deque[bytes | OversizedLine] = collections.deque()
        #: The board's ``b`` reply at the last handshake (None: not known, or no ``b``).
        self.board_baud: int | None = None
        #: When the last valid reply arrived (monotonic s).
        self.last_good_s = -float("inf")
        #: When the probes (``b``) whose replies have not been seen were written: an upper bound,
        #: since a lost reply is never seen (an answered exchange shows that none is still on its
        #: way). Kept across a reopen: a slow board (or its USB stack) still answers them then.
        self._probes: collections.deque[float] = collections.deque()

    # --- the port --------------------------------------------------------------------------

    def open(self) -> None:
        """Open the port (exclusively, for a device path).

        Raises:
            LinkLostError: the device is missing or cannot be opened (naming the cause).
        """
        config = self.config
        if not config.is_url and not os.path.exists(config.port):
            self.counters.count("port_missing")
            raise LinkLostError(f"port {config.port} does not exist (board unplugged?)")
        try:
            self._port = self._opener(
                config.port,
                baudrate=config.baud,
                timeout=min(config.read_timeout_s, 0.02),
                write_timeout=config.read_timeout_s,
                exclusive=None if config.is_url else True,
            )
        except (serial.SerialException, OSError, ValueError) as error:
            self.counters.count("open_failures")
            raise LinkLostError(f"cannot open {config.port}: {error}") from None
        try:
            self._rdev = os.fstat(self._port.fileno()).st_rdev
        except Exception:  # URLs and test doubles have no device number
            self._rdev = None
        # Whatever waits in the input buffer answers requests of an earlier connection.
        self.resync(quiet=False)

    def close(self) -> None:
        """Close the port (if open) and forget buffered input; never raises.

        The count of probes in flight is kept: their replies may still come after a reopen.
        """
        port, self._port = self._port, None
        self._rdev = None
        self._framer.clear()
        self._lines.clear()
        if port is not None:
            try:
                port.close()
            except Exception:  # closing a dead port may fail; nothing to do
                pass

    def cancel_read(self) -> None:
        """Wake a read blocked in the port (from another thread, when closing); best effort."""
        port = self._port
        if port is not None:
            try:
                port.cancel_read()
            except Exception:  # best effort
                pass

    def check_path(self) -> None:
        """Check that the device path still leads to the device that was opened.

        Raises:
            LinkLostError: the path vanished or now points to another device.
        """
        config = self.config
        if config.is_url:
            return
        try:
            rdev = os.stat(config.port).st_rdev
        except OSError:
            raise LinkLostError(f"{config.port} vanished (unplugged?)") from None
        if self._rdev is not None and rdev != self._rdev:
            raise LinkLostError(f"{config.port} now points to another device (replugged?)")

    def _open_port(self) -> serial.Serial:
        if self._port is None:
            raise LinkLostError("port closed")
        return self._port

    # --- line I/O --------------------------------------------------------------------------

    def request_s(self, payload: bytes) -> float:
        """Line time of a request: from its write until its CR reaches the board [s]."""
        return len(payload) * self.config.byte_s

    def write(self, payload: bytes) -> None:
        """Send bytes.

        Raises:
            LinkLostError: the port failed or the write timed out.
        """
        port = self._open_port()
        try:
            port.write(payload)
        except serial.SerialTimeoutException:
            self.counters.count("write_timeouts")
            raise LinkLostError(f"write to {self.config.port} timed out") from None
        except (serial.SerialException, OSError) as error:
            raise LinkLostError(f"write to {self.config.port} failed: {error}") from None

    def read_line(self, deadline: float) -> bytes | OversizedLine:
        """The next reply line (or the marker of an oversized one).

        Raises:
            ReadTimeoutError: no whole line by ``deadline`` (with what did arrive).
            LinkLostError: the port failed.
        """
        port = self._open_port()
        while True:
            if self._lines:
                return self._lines.popleft()
            if self._clock() >= deadline:
                raise ReadTimeoutError(self._framer.pending)
            try:
                waiting = port.in_waiting
                data = port.read(max(1, min(waiting, 4096)))
            except (serial.SerialException, OSError) as error:
                raise LinkLostError(f"read from {self.config.port} failed: {error}") from None
            if data:
                self._lines.extend(self._framer.feed(data))

    def resync(
        self, quiet: bool, quiet_s: float | None = None, limit_s: float | None = None
    ) -> bool:
        """Drop buffered input; with ``quiet``, also wait until the line stays silent a moment.

        The silence lasts ``quiet_s`` (default: 30 byte times, at least 5 ms); the wait is bounded
        by ``limit_s`` (default: the read timeout). Returns whether any bytes arrived meanwhile.

        Raises:
            LinkLostError: the port failed.
        """
        port = self._open_port()
        noise = bool(self._framer.pending) or bool(self._lines)
        self._framer.clear()
        self._lines.clear()
        try:
            noise = bool(port.in_waiting) or noise
            port.reset_input_buffer()
            if not quiet:
                return noise
            if quiet_s is None:
                quiet_s = max(0.005, 30 * self.config.byte_s)
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
            raise LinkLostError(f"{self.config.port} failed: {error}") from None
        return noise

    def drain_input(self) -> tuple[list[bytes | OversizedLine], int]:
        """Take all buffered input: (the whole lines, 1 if a line was begun (dropped) else 0).

        Raises:
            LinkLostError: the port failed.
        """
        port = self._open_port()
        try:
            waiting = port.in_waiting
            data = port.read(waiting) if waiting else b""
        except (serial.SerialException, OSError) as error:
            raise LinkLostError(f"{self.config.port} failed: {error}") from None
        lines = [*self._lines, *self._framer.feed(data)]
        begun = int(bool(self._framer.pending))
        self._framer.clear()
        self._lines.clear()
        return lines, begun

    # --- exchanges -------------------------------------------------------------------------

    def exchange(self, payload: bytes, parse: Callable[[bytes], T]) -> Answered[T] | Failed:
        """Send one request and parse its reply; a transient fault is counted and fenced off.

        Raises:
            LinkLostError: the port failed, or the fence found no valid reply for too long.
        """
        sent = self._clock()
        self.write(payload)
        timeout_s = self.config.read_timeout_s
        try:
            line = self.read_line(self._clock() + timeout_s)
        except ReadTimeoutError as timeout:
            command = payload.rstrip(b"\r").decode("ascii")
            if timeout.partial:
                failed = Failed(
                    "partial_replies",
                    f"only {timeout.partial[:40]!r} (no line end) within {timeout_s:g} s "
                    f"after {command!r}",
                )
            else:
                failed = Failed("timeouts", f"no reply to {command!r} within {timeout_s:g} s")
            return self._failed(failed)
        if isinstance(line, OversizedLine):
            reason = f"a {line.length}-byte line (starting {line.head!r}) was discarded"
            return self._failed(Failed("oversized", reason))
        try:
            value = parse(line)
        except ReplyError as error:
            if self._is_fence_reply(line):
                self._probe_answered()
            return self._failed(Failed(error.kind, error.reason))
        self.last_good_s = self._clock()
        # The board answers in order: a probe written before this request will never answer now.
        self._probes.clear()
        return Answered(value, sent + self.request_s(payload), self.last_good_s)

    def _failed(self, failed: Failed) -> Failed:
        self.counters.fault(failed.kind, failed.reason)
        self.fence()
        return failed

    def _is_fence_reply(self, line: bytes | OversizedLine) -> bool:
        if isinstance(line, OversizedLine):
            return False
        try:
            baud = parse_baud(line)
        except ReplyError as error:
            # A firmware without 'b' (handshake answered Invalid Command) answers the fence so.
            return error.kind == "invalid_command" and self.board_baud is None
        # The board's own answer only: a corrupted reading can look like a bare number.
        return self.board_baud is None or baud == self.board_baud

    def _probe_written(self) -> None:
        self._probes.append(self._clock())

    def _probe_answered(self) -> None:
        if self._probes:
            self._probes.popleft()

    def _probes_in_flight(self) -> int:
        """Probes whose replies may still come: unanswered, written in ``handshake_timeout_s``.

        An older one is taken as lost, so that probes lost while a board boots or stays deaf do
        not make every later fence wait for them.
        """
        horizon = self._clock() - self.config.handshake_timeout_s
        while self._probes and self._probes[0] < horizon:
            self._probes.popleft()
        return len(self._probes)

    def fence(self, give_up_at: float | None = None) -> None:
        """Get back in step after a failed exchange or a (re)connect: no late reply may pass.

        The protocol has no request tags, so a probe (``b``) is written and every line discarded
        (``discarded_replies``) until a probe reply that can only answer a probe written after
        every earlier request: one more than the probes still unanswered from earlier fences and
        handshakes (also of an earlier connection: a slow board answers them after a reopen).
        Why this is enough: docs/serial.md ("Replies that come late"). When closing, one attempt
        only. ``give_up_at`` (the handshake's deadline) replaces the stale timeout.

        Raises:
            LinkLostError: the port failed, or no valid reply came for ``stale_timeout_s`` (or
                not in step by ``give_up_at``).
        """
        config = self.config
        self.counters.count("resyncs")
        owed = self._probes_in_flight() + 1
        while True:
            lines, discarded = self.drain_input()
            for line in lines:
                if self._is_fence_reply(line):
                    self._probe_answered()
                    owed -= 1
                else:
                    discarded += 1
            # The probe written now is after everything else: its reply is always enough.
            owed = max(owed, 1)
            self.write(encode_get_baud())
            self._probe_written()
            deadline = self._clock() + config.read_timeout_s
            while owed > 0:
                try:
                    line = self.read_line(deadline)
                except ReadTimeoutError:
                    break
                if self._is_fence_reply(line):
                    self._probe_answered()
                    owed -= 1
                else:
                    discarded += 1
            self.counters.count("discarded_replies", amount=discarded)
            silent_s = self._clock() - self.last_good_s
            if owed <= 0 or self._closing.is_set():
                return
            if give_up_at is not None:
                if self._clock() >= give_up_at:
                    raise LinkLostError(
                        f"not in step ({self.counters['discarded_replies']} replies discarded)"
                    )
            elif silent_s > config.stale_timeout_s:
                raise LinkLostError(
                    f"no valid reply for {silent_s:.1f} s (replies late or out of step: "
                    f"{self.counters['discarded_replies']} discarded)"
                )

    # --- the handshake ---------------------------------------------------------------------

    def handshake(self) -> Handshake:
        """Wait for the board to answer ``b``, then for two ``e`` replies in step.

        Boards that reset when the port opens ignore input for a second or two while booting,
        hence the wait of up to ``handshake_timeout_s``.

        Raises:
            LinkLostError: the board did not answer (in step) in time, or the link is closing.
        """
        config = self.config
        deadline = self._clock() + config.handshake_timeout_s
        probe_s = max(0.25, config.read_timeout_s)
        baud = None
        while baud is None:
            if self._closing.is_set():
                raise LinkLostError("closing")
            self.resync(quiet=False)
            self.write(encode_get_baud())
            self._probe_written()  # a probe like the fence's: it may be answered later
            try:
                line = self.read_line(self._clock() + probe_s)
                if isinstance(line, OversizedLine):
                    raise ReplyError("oversized", "oversized line while waiting for the board")
                baud = parse_baud(line)
            except ReadTimeoutError:
                pass
            except ReplyError as error:
                if error.kind == "invalid_command":
                    baud = 0  # alive, but a firmware without 'b'
                else:
                    self.counters.count("handshake_noise")
            if baud is not None:
                self._probe_answered()
                self.last_good_s = self._clock()
            if baud is None and self._clock() >= deadline:
                self.counters.count("handshake_failures")
                raise LinkLostError(
                    f"the board on {config.port} did not answer 'b' within "
                    f"{config.handshake_timeout_s:g} s (wrong port or baud, or not "
                    "ROSArduinoBridge firmware?)"
                )
        self.board_baud = baud or None
        if baud and baud != config.baud:
            self.counters.count("baud_mismatch")
        pair, read_s, reply_s = self._verify_in_step(deadline + config.stale_timeout_s)
        return Handshake(self.board_baud, pair, read_s, reply_s)

    def _verify_in_step(self, deadline: float) -> tuple[tuple[int, int], float, float]:
        """Two ``e`` exchanges in a row, fenced and answered within the read timeout.

        The protocol has no sequence numbers: a board that answers later than the timeout would
        otherwise look healthy, its late replies taken for answers to later requests. A quiet
        line is no proof (a reply may come any time later, also after a reopen), so the line is
        fenced (:meth:`fence`) first and again after any failed or late exchange: only a timely
        reply to the request just written can pass. Returns the last reading, when the board
        took it and when its reply came.
        """
        config = self.config
        verified = 0
        last_error = "no reply"
        fenced = False
        while True:
            if self._closing.is_set():
                raise LinkLostError("closing")
            if self._clock() >= deadline:
                self.counters.count("handshake_failures")
                raise LinkLostError(
                    f"the board on {config.port} answers 'b' but not 'e' in step within "
                    f"{config.read_timeout_s:g} s ({last_error})"
                )
            if not fenced:
                verified = 0
                try:
                    self.fence(give_up_at=deadline)
                except LinkLostError as error:
                    if self._clock() < deadline or self._closing.is_set():
                        raise  # the port failed
                    self.counters.count("handshake_failures")
                    raise LinkLostError(
                        f"the board on {config.port} answers 'b' but not 'e' in step within "
                        f"{config.read_timeout_s:g} s ({error})"
                    ) from None
                fenced = True
            if self.resync(quiet=False) and verified:
                verified, last_error = 0, "bytes arrived after a reply (late replies?)"
                self.counters.count("handshake_noise")
                fenced = False
                continue
            sent = self._clock()
            self.write(encode_read_encoders())
            try:
                line = self.read_line(sent + config.read_timeout_s)
                if isinstance(line, OversizedLine):
                    raise ReplyError("oversized", f"a {line.length}-byte line")
                pair = parse_encoders(line)
            except ReadTimeoutError:
                verified, last_error = 0, f"no reply to 'e' within {config.read_timeout_s:g} s"
                self.counters.count("handshake_noise")
                fenced = False
                continue
            except ReplyError as error:
                verified, last_error = 0, f"{error.kind}: {error.reason}"
                self.counters.count("handshake_noise")
                if error.kind == "invalid_command":
                    self.counters.count("invalid_command")
                fenced = False
                continue
            replied = self._clock()
            self.last_good_s = replied
            verified += 1
            if verified >= 2:
                self._probes.clear()  # answered in order: the probes before are done
                return pair, sent + self.request_s(encode_read_encoders()), replied

"""The emulated board on a pseudo-terminal, with fault injection: what ``fishtail-fake-board`` runs.

:class:`FakeBoard` serves :class:`fishtail_boards.board_firmware.Firmware` on a pty that can be
paced to the line rate (a pty otherwise moves bytes at memory speed), unplugged and replugged,
reset, slowed down, and whose exchanges can be dropped or corrupted (seeded): the faults the
serial backend must survive. The switches: docs/serial.md ("The emulated board").
"""

from __future__ import annotations

import collections
import dataclasses
import errno
import os
import queue
import random
import select
import sys
import threading
import time
import tty
from collections.abc import Callable, Iterable

from fishtail_boards.board_firmware import Firmware, FirmwareConfig, ParsedCommand

GARBLE_KINDS = ("flip", "truncate", "binary", "oversized", "invalid")


@dataclasses.dataclass
class BoardConfig(FirmwareConfig):
    """The emulated board (its firmware) and the faults the harness injects.

    Raises:
        ValueError: a rate outside [0, 1], a negative time, or what
            :class:`~fishtail_boards.board_firmware.FirmwareConfig` refuses.
    """

    pace_baud: bool = False
    boot_ms: float = 0.0
    delay_ms: float = 0.0
    delay_after_s: float | None = None
    delay_for_s: float | None = None
    drop_rate: float = 0.0
    garble_rate: float = 0.0
    reset_after_s: float | None = None
    disconnect_after_s: float | None = None
    disconnect_for_s: float = 1.0
    seed: int = 0

    def __post_init__(self) -> None:
        """Reject meaningless settings with the reason."""
        super().__post_init__()
        for name in ("drop_rate", "garble_rate"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        for name in ("boot_ms", "delay_ms", "disconnect_for_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.delay_after_s is not None and not self.delay_after_s >= 0:
            raise ValueError(f"delay_after_s must be >= 0, got {self.delay_after_s}")
        if self.delay_for_s is not None and not self.delay_for_s > 0:
            raise ValueError(f"delay_for_s must be > 0, got {self.delay_for_s}")


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
        #: When a slow spell of ``delay_for_s`` ends (replies already queued keep their time).
        self._fast_at = (
            None if config.delay_for_s is None
            else self.start_time + (config.delay_after_s or 0.0) + config.delay_for_s
        )  # fmt: skip
        self._toggle_slow_requested = threading.Event()
        self._scripted_delays: collections.deque[float] = collections.deque()
        self.commands: list[tuple[float, str]] = []
        self.counts: collections.Counter[str] = collections.Counter()

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
            self._slow_at = self._fast_at = None
            if self.slow != slow:
                self.slow = slow
                self.counts["slow_on" if slow else "slow_off"] += 1
                self._record(now, f"# slow {'on' if slow else 'off'}")

        self._call(action)

    def script_delays(self, delays_s: Iterable[float]) -> None:
        """Delay the next replies by these times [s], one each in order, then as before.

        For tests that need one exact order of replies and timeouts, whatever the host's
        scheduling: the delays set when each reply leaves relative to its command (replies still
        never overtake each other).

        Raises:
            ValueError: a negative or NaN delay.
        """
        delays = [float(delay) for delay in delays_s]
        if any(not delay >= 0.0 for delay in delays):
            raise ValueError(f"delays must be >= 0, got {delays}")

        def action() -> None:
            self._scripted_delays.extend(delays)
            self._record(self._clock(), f"# scripted delays {delays}")

        self._call(action)

    @property
    def scripted_delays_left(self) -> int:
        """How many scripted delays are still to be used."""
        return len(self._scripted_delays)

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
        if self._scripted_delays:
            delay_s = self._scripted_delays.popleft()
        else:
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
        if self._fast_at is not None and now >= self._fast_at:
            self._fast_at = None
            self.slow = False
            self.counts["slow_off"] += 1
            self._record(now, "# slow off (scheduled)")
        if self._toggle_slow_requested.is_set():
            self._toggle_slow_requested.clear()
            self._slow_at = self._fast_at = None
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
        moments = (self._reset_at, self._unplug_at, self._replug_at, self._slow_at, self._fast_at)
        for moment in moments:
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

"""The ``serial`` motor backend: a ROSArduinoBridge motor board over a serial port (pyserial).

All serial I/O runs in one background thread owned by the backend, so that the node's callbacks
never wait for the device: they only exchange state with it under a lock. The thread connects
and reconnects with backoff, polls the encoder, sends and re-sends the speed (only while the node
keeps commanding, so the board's own auto-stop takes over if the node hangs) and counts every
fault. :meth:`SerialBackend.read` returns each new sample once, so ``motor/joint_state`` carries
only real readings. At every connect it asks the board ``v``: the project's firmware follows a
speed profile itself, sent as one ``f`` after ``profile_tuning``'s ``k`` if set
(:mod:`fishtail_driver.board_profile`); on the stock firmware the node follows it on the host
with ``m``. Behaviour, faults and status: docs/serial.md.
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable

from fishtail_common.interface import Level
from fishtail_driver.backends import EncoderSample, StopOutcome
from fishtail_driver.board_command import STOPPED, BoardCommand, CommandState, Pending
from fishtail_driver.board_profile import BoardMode, ProfileFields, board_mode, tune_board
from fishtail_driver.encoder_tracking import EncoderTracker
from fishtail_driver.protocol import (
    channel_ticks,
    encode_motor_speeds,
    encode_query_firmware,
    encode_read_encoders,
    encode_update_pid,
    parse_capabilities,
    parse_encoders,
    parse_ok,
)
from fishtail_driver.serial_config import SerialConfig
from fishtail_driver.serial_link import (
    Answered,
    LinkLostError,
    PortOpener,
    SerialLink,
)
from fishtail_driver.status_counters import StatusCounters
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile


class SerialBackend:
    """MotorBackend for a ROSArduinoBridge board, its I/O on a thread of its own."""

    name = "serial"

    def __init__(
        self,
        config: SerialConfig,
        clock: Callable[[], float] = time.monotonic,
        opener: PortOpener | None = None,
    ) -> None:
        """Prepare (nothing is opened until :meth:`start`); ``opener`` is injectable for tests."""
        self.config = config
        self.hardware_id = config.port
        self.scale = config.scale
        self._clock = clock
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._closing = threading.Event()
        self._thread: threading.Thread | None = None
        self.counters = StatusCounters(clock)
        self.counters.set("phase_rebases", 0)
        self.counters.set("stale_readings", 0)
        self._link = SerialLink(config, self.counters, self._closing, clock, opener)
        self._tracker = EncoderTracker(
            self.scale, config.channel, config.max_speed_rad_s, config.velocity_window_s
        )
        # Command state (shared, locked by itself).
        self._commands = CommandState(self.scale, self.counters, config.command_hold_s)
        self._motor_retry_at = -math.inf  # after a failed m, not before this (I/O thread only)
        # Sample state (shared).
        self._latest: EncoderSample | None = None
        self._latest_seq = 0
        self._read_seq = 0
        self._last_pair: tuple[int, int] | None = None
        self._continuous_counts = 0
        self._poll_times: collections.deque[float] = collections.deque()
        # Status (shared).
        self._connected = False
        self._state = "not started"
        self._final_stop = "not sent"
        self._last_rebase: tuple[str, float] | None = None  # (why, when)
        self._first_after_connect = False  # the next reading is the first since connecting
        self._retune = False  # k again: the board was reset (I/O thread only)

    # ------------------------------------------------------------------------------------------
    # MotorBackend interface (called from the node's threads; never blocks on I/O)

    @property
    def max_sample_rate_hz(self) -> float:
        """New samples come at most at the poll rate."""
        return self.config.poll_rate_hz

    def watchdog_refusal(self, cmd_timeout_sec: float) -> str | None:
        """The node's watchdog is what stops the real motor when commands stop: it must be on."""
        if cmd_timeout_sec > 0.0:
            return None
        return (
            "cmd_timeout_sec must be > 0 with backend serial: the watchdog is what stops the real "
            f"motor when commands stop (got {cmd_timeout_sec:g})"
        )

    def start(self) -> None:
        """Start the I/O thread; returns at once (a missing device is retried, not fatal)."""
        if self._thread is not None:
            return
        self._state = f"opening {self.config.port}"
        self._thread = threading.Thread(target=self._run, name="fishtail-serial", daemon=True)
        self._thread.start()

    def set_speed(self, speed_rad_s: float) -> None:
        """Command a steady carrier speed; the I/O thread sends it at once and keeps it alive."""
        flat = STOPPED if not speed_rad_s > 0.0 else CarrierSpeedProfile(speed_rad_s)
        self.set_profile(flat, speed_rad_s)

    def set_profile(self, profile: CarrierSpeedProfile, speed_rad_s: float) -> None:
        """Command ``profile``, whose speed at the carrier's last angle is ``speed_rad_s``.

        On the project's firmware (:attr:`profile_on_board`) the board follows the profile: it
        is sent as one ``f`` on every change. Otherwise the node follows it, calling this at
        every sample with the speed at the angle measured, and the speed is sent with ``m``.
        """
        if self._commands.set_profile(profile, speed_rad_s, self._clock()):
            self._wake.set()  # only when there is something new to send

    @property
    def profile_on_board(self) -> bool:
        """Whether the board follows the profile in force (then the node need not follow it)."""
        return self._commands.on_board

    @property
    def command_hold_s(self) -> float | None:
        """The current hold time of a non-zero speed (see :meth:`set_command_hold`)."""
        return self._commands.hold_s

    def set_command_hold(self, hold_s: float | None) -> None:
        """Re-send a non-zero speed only while the last set_speed() is at most ``hold_s`` old.

        None: re-send it for as long as it is commanded. The driver node sets its watchdog
        timeout plus a margin, so that the board's auto-stop takes over if the node hangs.

        Raises:
            ValueError: a hold that is neither None nor > 0.
        """
        if hold_s is not None and not hold_s > 0.0:
            raise ValueError(f"hold_s must be > 0 or None, got {hold_s!r}")
        self._commands.hold_s = hold_s
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
        self._commands.stop()
        with self._lock:
            state = self._state
        self._closing.set()
        self._wake.set()
        if thread is None:
            return StopOutcome(False, False, "m 0 0 not sent: the backend was never started")
        thread.join(timeout=3.0 * self.config.read_timeout_s + 1.0)
        alive = thread.is_alive()
        if alive:
            self.counters.count("close_timeouts")
            self._link.cancel_read()
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
        counts, fault = self.counters.snapshot()
        board_baud = self._link.board_baud
        with self._lock:
            connected = self._connected
            state = self._state
            rebase = self._last_rebase
            pair = "" if self._last_pair is None else " ".join(map(str, self._last_pair))
            values = {
                "port": config.port,
                "baud": str(config.baud),
                "channel": config.channel,
                "state": self._state,
                "connected": str(connected).lower(),
                "board_baud": "" if board_baud is None else str(board_baud),
                "pid_frame_ms": str(self.scale.frame_ms),
                "poll_rate_hz": f"{self._achieved_poll_rate(now):.1f}",
                "encoder_counts": pair,
                "continuous_counts": str(self._continuous_counts),
                "last_fault": "" if fault is None else f"{fault[0]}: {fault[1]}",
                "final_stop": self._final_stop,
                "last_phase_rebase": "" if rebase is None else rebase[0],
            }
        values.update(self._commands.status_values())
        for key in sorted(counts):
            values[key] = str(counts[key])
        if not connected:
            return Level.ERROR, f"serial: {state}", values
        notes = []
        if fault is not None and now - fault[2] < config.fault_hold_s:
            notes.append(f"recent fault: {fault[0]}")
        if rebase is not None and now - rebase[1] < config.phase_warn_s:
            notes.append(
                "encoder angle re-based after a board reset or power cycle: the carrier phase "
                "reference may have shifted, phase_rad may need re-calibration"
            )
        if notes:
            return Level.WARN, f"serial: connected to {config.port}; {'; '.join(notes)}", values
        return Level.OK, f"serial: connected to {config.port} at {config.baud} baud", values

    def _achieved_poll_rate(self, now: float) -> float:
        """Polls per second over the last second (call with the lock held)."""
        times = self._poll_times
        if len(times) < 2 or now - times[-1] > 1.0:
            return 0.0
        return (len(times) - 1) / (times[-1] - times[0]) if times[-1] > times[0] else 0.0

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
            except LinkLostError as error:
                self._link.close()
                if self._closing.is_set():
                    break
                self._set_state(f"{error}; retrying in {backoff:.1f} s", False)
                self._closing.wait(backoff)
                backoff = min(2.0 * backoff, self.config.reconnect_max_s)
                continue
            except Exception as error:  # the thread must survive anything
                self._link.close()
                self._internal_error(error)
                self._closing.wait(backoff)
                backoff = min(2.0 * backoff, self.config.reconnect_max_s)
                continue
            backoff = self.config.reconnect_min_s
            try:
                self._serve()
            except LinkLostError as error:
                self.counters.count("disconnects")
                self.counters.note("disconnect", str(error))
                self._set_state(f"link lost: {error}; reconnecting", False)
            except Exception as error:
                self._internal_error(error)
            finally:
                self._link.close()
            if not self._closing.is_set():
                self._closing.wait(backoff)
        self._set_state("closed", False)

    def _internal_error(self, error: Exception) -> None:
        reason = f"internal error {type(error).__name__}: {error}"
        self.counters.count("internal_errors")
        self.counters.note("internal_error", reason)
        self._set_state(f"{reason}; reconnecting", False)

    def _connect(self) -> None:
        config = self.config
        self._set_state(f"opening {config.port}", False)
        self._link.open()
        self._set_state(f"waiting for the board on {config.port} to answer", False)
        handshake = self._link.handshake()
        if config.pid_gains is not None:
            update = self._link.exchange(encode_update_pid(*config.pid_gains), parse_ok)
            if not isinstance(update, Answered):
                self.counters.count("pid_gains_not_acknowledged")
        # Which firmware: the project's follows a profile itself (asked again at every connect).
        query = self._link.exchange(encode_query_firmware(), parse_capabilities)
        answer = query.value if isinstance(query, Answered) else f"{query.kind}: {query.reason}"
        self._tune(board_mode(answer, config.profile_on_board, self.scale))
        # The first reading decides whether the board was reset while we were away.
        # (Not published if stale: then the first poll's reading decides.)
        self._first_after_connect = True
        if self._fresh(handshake.reply_s - handshake.read_s):
            self._accept(handshake.pair, handshake.read_s, after_connect=True)
            self._first_after_connect = False
        self.counters.count("connects")
        if self.counters["connects"] > 1:
            self.counters.count("reconnects")
        self._commands.forget_ack()  # (re)send the current command at once
        self._link.last_good_s = self._clock()
        self._set_state(f"connected to {config.port}", True)

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
            if self._retune:
                self._tune(self._commands.mode)
            now = self._clock()
            if now >= next_path_check:
                self._link.check_path()
                next_path_check = now + 0.25
            pending = self._pending(now)
            command, acked = pending.command, pending.acked
            resend_due = pending.acked_at + config.resend_period_s
            change_due = self._commands.change_due(pending)
            due = pending.sendable and ((command != acked and now >= change_due)
                                        or (command != 0 and now >= resend_due))  # fmt: skip
            if due and now >= self._motor_retry_at:
                self._send_motor(command, resend=command == acked)
            now = self._clock()
            if now >= next_poll:
                self._poll()
                next_poll += period
                now = self._clock()
                if next_poll < now - 5 * period:
                    next_poll = now  # far behind: do not burst to catch up
            silent_s = now - self._link.last_good_s
            pending = self._pending(now)
            command, acked = pending.command, pending.acked
            if silent_s > config.stale_timeout_s:
                fault = self.counters.last_fault
                detail = f" (last fault: {fault[0]}: {fault[1]})" if fault else ""
                raise LinkLostError(f"no valid reply for {silent_s:.1f} s{detail}")
            deadline = min(next_poll, next_path_check)
            if not pending.sendable:
                pass  # a stale non-zero speed: nothing to send until set_speed() is called
            elif command != acked:
                change_due = self._commands.change_due(pending)
                deadline = min(deadline, max(now, self._motor_retry_at, change_due))
            elif command != 0:
                deadline = min(deadline, max(pending.acked_at + config.resend_period_s,
                                             self._motor_retry_at))  # fmt: skip
            timeout = deadline - self._clock()
            if timeout > 0:
                self._wake.wait(timeout)

    def _tune(self, mode: BoardMode) -> None:
        """``k`` where the board follows the profile: after ``v``, and after a board reset."""
        self._retune = False
        self._commands.set_mode(tune_board(mode, self.config.profile_tuning, self._link.exchange))

    def _pending(self, now: float) -> Pending:
        """The command now; ``f``'s phase from the tail channel's count at carrier angle 0."""
        unwrapper = self._tracker.unwrapper  # the I/O thread's own
        zero = None if unwrapper.last_raw is None else unwrapper.last_raw - unwrapper.total
        return self._commands.pending(now, zero)

    def _send_final_stop(self) -> None:
        for _ in range(2):
            if isinstance(self._link.exchange(encode_motor_speeds(0, 0), parse_ok), Answered):
                self._commands.acknowledge(0, self._clock())
                with self._lock:
                    self._final_stop = "acknowledged"
                return
            # Written (a failed write raises instead), so the board may well have run it.
            with self._lock:
                self._final_stop = "sent, not acknowledged"

    def _send_motor(self, command: BoardCommand, resend: bool) -> None:
        if isinstance(command, ProfileFields):
            payload, kind = command.encode(), "profile"
        else:
            left, right = channel_ticks(self.config.channel, command)
            payload, kind = encode_motor_speeds(left, right), "motor"
        reply = self._link.exchange(payload, parse_ok)
        if not isinstance(reply, Answered):
            # Retry soon, but never in a tight loop against a board that rejects m at once.
            self._motor_retry_at = self._clock() + min(0.02, self.config.resend_period_s)
            return
        self._commands.acknowledge(command, self._clock())
        self.counters.count(f"{kind}_resends" if resend else f"{kind}_commands")

    def _poll(self) -> None:
        """One ``e`` exchange; the reading is dated when the request reached the board.

        The firmware reads the encoders as soon as the request's CR arrives and writes the reply
        at once; what delays a reply is mostly on the way back (a USB adapter's latency timer
        holds received bytes up to 16 ms, the reply's own line time, this process being
        scheduled), so the middle of the exchange would date a reading from a slow board up to
        half the round trip late. The reading is within [request arrival, reply arrival].
        """
        reply = self._link.exchange(encode_read_encoders(), parse_encoders)
        if isinstance(reply, Answered) and self._fresh(reply.round_trip_s):
            self._accept(reply.value, reply.request_arrived_s, self._first_after_connect)
            self._first_after_connect = False

    def _fresh(self, round_trip_s: float) -> bool:
        """Whether a reading is dated as well as its stamp promises; counts it if not.

        A reading is stamped when its request reached the board, but it may be as old as its
        round trip: one that took longer than ``read_timeout_s`` (what the stamp promises,
        docs/serial.md) is not published, only counted (``stale_readings``).
        """
        if round_trip_s <= self.config.read_timeout_s:
            return True
        self.counters.fault(
            "stale_readings",
            f"a reading answered {round_trip_s * 1e3:.0f} ms after its request was not "
            f"published (its stamp promises {self.config.read_timeout_s * 1e3:.0f} ms)",
        )
        return False

    def _accept(self, pair: tuple[int, int], when: float, after_connect: bool) -> None:
        """Hand one reading to the tracker; publish its sample, count what it decided."""
        driven = self._commands.driven
        tracked = self._tracker.accept(pair, when, after_connect, driven)
        if tracked.outlier is not None:
            self.counters.fault("outliers", tracked.outlier)
        if tracked.sample is None:
            self.counters.count("held_readings")
            return
        if tracked.rebase is not None:
            self.counters.count("board_resets", "phase_rebases")
            if not after_connect:
                # Unexpected: the board lost its target too, so re-send it now.
                self.counters.note("board_reset", tracked.rebase)
        self.counters.set("encoder_wraps", self._tracker.wraps)
        self.counters.count("polls")
        with self._lock:
            if tracked.rebase is not None:
                self._last_rebase = (tracked.rebase, self._clock())
                if not after_connect:
                    self._commands.forget_ack()
                    self._retune = True
            self._last_pair = pair
            self._continuous_counts = self._tracker.total
            self._latest = tracked.sample
            self._latest_seq += 1
            times = self._poll_times
            times.append(when)
            while times and times[0] < when - 1.0:
                times.popleft()

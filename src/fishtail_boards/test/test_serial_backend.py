"""The serial backend against the emulated board over real ptys: normal use and every fault.

Each fault is checked end to end: it is detected, counted and reported by status(), the backend
recovers by itself and the angle never jumps; the node-facing calls never wait for the I/O thread.

No assertion here depends on how fast this machine runs: waits are for events or counters (with
generous time limits that only bound a failing test), and timing properties are checked on the
fake board's own log and counters (auto-stop fired or not, commands in flight one at a time).
"""

from __future__ import annotations

import math
import signal
import threading
import time

import pytest
import serial

from fishtail_driver.protocol import (
    encode_motor_speeds,
    encode_read_encoders,
    parse_encoders,
    parse_ok,
)
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig
from fishtail_driver.serial_link import Answered, Failed, SerialLink
from fishtail_driver.status_counters import StatusCounters
from fishtail_plant.motor.board_units import INT32_MAX

FAST_RECONNECT = {"reconnect_min_s": 0.05, "reconnect_max_s": 0.2}
SLOW_READ_TIMEOUT_S = 0.3
#: Only bounds how long a failing check waits (a call stuck behind the I/O thread never returns).
STUCK_S = 5.0


class Sampler:
    """Calls backend.read() every 2 ms in a thread, like the node's timer, and keeps the samples."""

    def __init__(self, backend) -> None:
        """Start sampling."""
        self.backend = backend
        self.samples = []
        self.levels = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        count = 0
        while not self._stop.is_set():
            sample = self.backend.read()
            if count % 10 == 0:
                self.levels.append(self.backend.status()[0])
            if sample is not None:
                self.samples.append(sample)
            count += 1
            time.sleep(0.002)

    def angle(self) -> float:
        """The latest published angle (0 before the first sample)."""
        return self.samples[-1].angle_rad if self.samples else 0.0

    def stop(self) -> None:
        """Stop sampling."""
        self._stop.set()
        self._thread.join(2.0)


@pytest.fixture
def sampler():
    """``sampler(backend)``: a running Sampler, stopped at teardown."""
    made = []

    def make(backend) -> Sampler:
        made.append(Sampler(backend))
        return made[-1]

    yield make
    for item in made:
        item.stop()


def assert_no_jump(samples, max_speed_rad_s: float = 20.0, counts: int = 2048) -> None:
    """The one-way motor's angle never moves faster than it can, nor back beyond jitter.

    A corrupt reading within the standstill jitter allowance (2 counts) may pass as motion and
    be taken back at the next reading; anything larger must not.
    """
    assert samples, "no samples"
    jitter_rad = 2 * 2 * math.pi / counts + 1e-9
    for before, after in zip(samples, samples[1:], strict=False):
        step = after.angle_rad - before.angle_rad
        elapsed = after.monotonic_s - before.monotonic_s
        assert after.monotonic_s > before.monotonic_s, "samples out of order or repeated"
        assert step >= -jitter_rad, f"angle went back by {-step:.4f} rad"
        assert step <= 2 * max_speed_rad_s * (elapsed + 0.05), f"angle jumped by {step:.3f} rad"


def level(backend) -> int:
    """status() level."""
    return backend.status()[0]


def counter(backend, name: str) -> int:
    """One of status()'s counters (0 when absent)."""
    return int(backend.status()[2].get(name, "0") or 0)


# --- normal operation ---------------------------------------------------------------------------


def test_polls_commands_reports_and_stops_on_close(fake_board, serial_backend, sampler, wait_until):
    """Connects (OK), moves at the commanded speed, returns each sample once, m 0 0 on close."""
    board = fake_board(counts_per_revolution=2048)
    backend = serial_backend(board.link, poll_rate_hz=100.0, counts_per_revolution=2048)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    samples = sampler(backend)
    backend.set_speed(4.0)
    wait_until(lambda: samples.angle() > 1.5, 3.0, "the angle to advance")
    assert "m 43 0" in board.commands("m")  # round(4 rad/s * 2048 / 2pi * 0.033 s)
    expected_speed = 43 * 2 * math.pi / 2048 / 0.033
    assert samples.samples[-1].velocity_rad_s == pytest.approx(expected_speed, rel=0.05)
    _, message, values = backend.status()
    assert "connected" in message and values["target_ticks_per_frame"] == "43"
    assert 0.0 < float(values["poll_rate_hz"]) <= 130.0  # the rate itself: bench_serial.py
    assert_no_jump(samples.samples)
    # read() hands out each sample once.
    seen = {id(s) for s in samples.samples}
    assert len(seen) == len(samples.samples)
    samples.stop()
    backend.close()
    assert board.commands("m")[-1] == "m 0 0"
    assert backend.status()[2]["final_stop"] == "acknowledged"
    assert backend.status()[0] == 2 and "closed" in backend.status()[1]


def test_right_channel_and_pid_rate(fake_board, serial_backend, wait_until):
    """The speed goes to the configured channel in ticks of the configured PID frame."""
    board = fake_board(pid_rate_hz=50, counts_per_revolution=1000, gear_ratio=2.0)
    backend = serial_backend(
        board.link, channel="right", pid_rate_hz=50, counts_per_revolution=1000, gear_ratio=2.0
    )
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    backend.set_speed(2 * math.pi)  # one carrier turn per second = 2000 counts/s = 40 per 20 ms
    wait_until(lambda: "m 0 40" in board.commands("m"), 2.0, "m 0 40")
    wait_until(lambda: board.board.firmware.encoder(1) > 200, 2.0, "the right motor to turn")
    assert board.board.firmware.encoder(0) == 0


@pytest.mark.slow
def test_resend_beats_the_auto_stop_and_stop_is_not_resent(fake_board, serial_backend, wait_until):
    """Motion lasts beyond the board's 2 s auto-stop; after stop() only one m 0 0 is sent."""
    board = fake_board()
    backend = serial_backend(board.link, resend_period_s=0.3)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    backend.set_speed(4.0)
    # Re-sends are at least resend_period_s apart, so 8 of them span at least 2.4 s: longer than
    # the board's auto-stop interval, which must not have fired meanwhile.
    wait_until(lambda: counter(backend, "motor_resends") >= 8, 10.0, "8 re-sends")
    firmware = board.board.firmware
    times = [t for t, text in list(board.board.commands) if text == "m 43 0"]
    assert len(times) >= 9 and times[-1] - times[0] > 2.0
    assert firmware.auto_stop_times == [], "the board auto-stopped while motion was commanded"
    assert firmware.moving and firmware.motors[0].target_rad_s > 3.9
    backend.stop()
    wait_until(lambda: board.commands("m")[-1] == "m 0 0", 3.0, "m 0 0")
    count = len(board.commands("m"))
    # 60 polls at 100 Hz span at least 54 poll periods (the schedule catches up with at most a
    # few polls in a row): 0.54 s, more than the 0.3 s after which a zero would be re-sent.
    polls = counter(backend, "polls")
    wait_until(lambda: counter(backend, "polls") >= polls + 60, 10.0, "60 more polls")
    assert len(board.commands("m")) == count, "a zero speed was re-sent"
    assert firmware.motors[0].target_rad_s == 0.0


@pytest.mark.slow
def test_resends_stop_when_set_speed_goes_stale(fake_board, serial_backend, wait_until):
    """command_hold_s: re-sent while set_speed() keeps coming; once it stops, the board stops.

    This is the backstop for a hung node: its executor (and watchdog) stalls, set_speed() is no
    longer called, the I/O thread stops re-sending and the board's own auto-stop fires.
    """
    board = fake_board()
    backend = serial_backend(board.link, resend_period_s=0.05, command_hold_s=0.5)
    assert backend.command_hold_s == 0.5
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    firmware = board.board.firmware

    def fed(condition):
        def check():
            backend.set_speed(4.0)  # the node's commands, every few ms
            return condition()

        return check

    # Fed: re-sends go on past the hold time (16 re-sends >= 0.05 s apart span >= 0.8 s).
    wait_until(fed(lambda: counter(backend, "motor_resends") >= 16), 10.0, "16 re-sends")
    assert counter(backend, "resend_pauses") == 0
    assert backend.status()[2]["resends_paused"] == "false"
    # Not fed: the re-sends stop after the hold time and the board auto-stops 2 s later.
    wait_until(lambda: firmware.auto_stop_times, 10.0, "the board's auto-stop")
    assert not firmware.moving
    values = backend.status()[2]
    assert values["resends_paused"] == "true" and values["resend_pauses"] == "1"
    assert values["target_ticks_per_frame"] == "43"  # still commanded, deliberately not sent
    count = len(board.commands("m"))
    polls = counter(backend, "polls")
    wait_until(lambda: counter(backend, "polls") >= polls + 30, 10.0, "30 more polls")
    assert len(board.commands("m")) == count, "a stale speed was sent after the auto-stop"
    # Fed again: the speed goes out at once and the motor turns again.
    backend.set_speed(4.0)
    wait_until(lambda: firmware.moving, 3.0, "the motor moving again")
    assert backend.status()[2]["resends_paused"] == "false"
    assert len(firmware.auto_stop_times) == 1


class GatedPort:
    """A pyserial port whose read() blocks while ``gate`` is clear: the I/O thread stuck in I/O."""

    def __init__(self, port, gate: threading.Event, stuck: threading.Event) -> None:
        """Wrap ``port``."""
        self._port = port
        self._gate = gate
        self._stuck = stuck
        self.inside = 0

    def read(self, size: int = 1) -> bytes:
        """Block while the gate is clear (``stuck`` tells the test), then read."""
        if not self._gate.is_set():
            self.inside += 1
            self._stuck.set()
            self._gate.wait()
            self.inside -= 1
        return self._port.read(size)

    def __getattr__(self, name: str):
        """Everything else: the real port."""
        return getattr(self._port, name)


def test_node_facing_calls_never_wait_for_the_io_thread(fake_board, serial_backend, wait_until):
    """read(), status(), set_speed() and stop() return while the I/O thread is blocked in a read.

    The I/O thread is held inside the port's read() on an event the test controls; a lock held
    across I/O would keep the calls from returning until the test lets it go.
    """
    gate, stuck = threading.Event(), threading.Event()
    gate.set()
    ports: list[GatedPort] = []

    def opener(url, **kwargs):
        ports.append(GatedPort(serial.serial_for_url(url, **kwargs), gate, stuck))
        return ports[-1]

    board = fake_board()
    backend = serial_backend(board.link, opener=opener)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    backend.set_speed(4.0)
    wait_until(lambda: "m 43 0" in board.commands("m"), 3.0, "m 43 0")
    results = {}
    done = threading.Event()

    def node_side() -> None:
        results["read"] = backend.read()
        results["status"] = backend.status()
        backend.set_speed(6.0)
        backend.stop()
        backend.set_speed(6.0)
        results["read_again"] = backend.read()
        done.set()

    gate.clear()
    try:
        assert stuck.wait(STUCK_S), "the I/O thread never reached a read"
        caller = threading.Thread(target=node_side, daemon=True)
        caller.start()
        returned = done.wait(STUCK_S)
        still_stuck = ports[-1].inside == 1 and not gate.is_set()
    finally:
        gate.set()
    assert returned, "a node-facing call waited for the I/O thread"
    assert still_stuck
    assert results["status"][0] == 0 and results["read_again"] is None
    # Released, the I/O thread sends the newest command.
    ticks = backend.status()[2]["target_ticks_per_frame"]
    assert ticks != "43"
    wait_until(lambda: board.commands("m")[-1] == f"m {ticks} 0", 3.0, f"m {ticks} 0")


# --- faults ----------------------------------------------------------------------------------


def test_device_missing_at_start_is_retried_with_bounded_backoff(
    fake_board, serial_backend, tmp_path, wait_until
):
    """No device: ERROR naming the cause, retries at most reconnect_max_s apart, then OK."""
    link = tmp_path / "later"
    backend = serial_backend(link, **FAST_RECONNECT)
    wait_until(lambda: counter(backend, "port_missing") >= 4, 3.0, "4 open attempts")
    level_now, message, _ = backend.status()
    assert level_now == 2 and "does not exist" in message
    assert backend.read() is None
    # Bounded backoff: 5 more attempts take about 5 x 0.2 s; doubling without a bound would
    # take 0.8 + 1.6 + 3.2 + ... s.
    before = counter(backend, "port_missing")
    wait_until(lambda: counter(backend, "port_missing") >= before + 5, 2.5, "5 more attempts")
    fake_board(link=link)
    wait_until(lambda: level(backend) == 0, 2.0, "status OK once the board appears")
    wait_until(lambda: backend.read() is not None, 1.0, "a sample")


def test_unplug_and_replug(fake_board, serial_backend, sampler, wait_until):
    """The path vanishes: ERROR, no samples; it comes back (a reset board): OK, no angle jump."""
    board = fake_board()
    backend = serial_backend(board.link, **FAST_RECONNECT)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    samples = sampler(backend)
    backend.set_speed(6.0)
    wait_until(lambda: samples.angle() > 2.0, 3.0, "motion")
    board.board.unplug()
    wait_until(lambda: level(backend) == 2, 1.0, "ERROR after the unplug")
    held = samples.angle()
    count = len(samples.samples)
    assert "link lost" in backend.status()[1] or "does not exist" in backend.status()[1]
    board.board.replug()
    # Connected again; WARN, not OK: the replugged board restarted its count (phase re-based).
    wait_until(lambda: level(backend) == 1, 2.0, "WARN after the replug")
    assert "phase_rad may need re-calibration" in backend.status()[1]
    wait_until(lambda: samples.angle() > held + 2.0, 3.0, "motion after the replug")
    after = samples.samples[count]
    assert abs(after.angle_rad - held) < 0.05, "the angle jumped across the replug"
    assert_no_jump(samples.samples)
    values = backend.status()[2]
    assert int(values["disconnects"]) >= 1 and int(values["reconnects"]) >= 1
    assert int(values["board_resets"]) >= 1  # the replugged board started from 0
    assert values["phase_rebases"] == values["board_resets"]


def test_board_process_killed_and_restarted_at_the_same_link(
    board_process, serial_backend, sampler, tmp_path, wait_until
):
    """fishtail-fake-board killed (an abrupt unplug), a new one at the same link: recovers."""
    link = tmp_path / "tty"
    first = board_process(link)
    first.next_path()
    backend = serial_backend(link, **FAST_RECONNECT)
    wait_until(lambda: level(backend) == 0, 5.0, "status OK")
    samples = sampler(backend)
    backend.set_speed(5.0)
    wait_until(lambda: samples.angle() > 1.0, 3.0, "motion")
    first.kill(signal.SIGKILL)
    wait_until(lambda: level(backend) == 2, 2.0, "ERROR after the kill")
    held = samples.angle()
    second = board_process(link)
    second.next_path()
    wait_until(lambda: level(backend) == 1, 5.0, "connected (WARN: re-based) to the new board")
    wait_until(lambda: samples.angle() > held + 1.0, 3.0, "motion with the new board")
    assert_no_jump(samples.samples)


def test_dropped_replies_are_timeouts_and_the_link_survives(
    fake_board, serial_backend, sampler, wait_until
):
    """Lost commands/replies: counted timeouts, WARN, still connected, still moving."""
    board = fake_board(drop_rate=0.15, seed=1)
    backend = serial_backend(board.link, read_timeout_s=SLOW_READ_TIMEOUT_S, stale_timeout_s=2.0)
    wait_until(lambda: level(backend) < 2, 5.0, "connected")
    samples = sampler(backend)
    backend.set_speed(4.0)
    wait_until(lambda: counter(backend, "timeouts") >= 3 and samples.angle() > 1.0, 8.0,
               "3 timeouts and motion")  # fmt: skip
    assert 1 in samples.levels and 2 not in samples.levels
    assert "no reply to" in backend.status()[2]["last_fault"]
    assert_no_jump(samples.samples)


def test_slow_board_within_the_read_timeout_is_fine(fake_board, serial_backend, wait_until):
    """A 20 ms reply delay under a 100 ms timeout: no faults, each poll waits for its reply.

    The lower poll rate follows from one request in flight at a time, checked on the board's
    clock: each ``e`` arrives at least the reply delay after the previous one.
    """
    board = fake_board(delay_ms=20.0)
    backend = serial_backend(board.link, read_timeout_s=0.1)
    wait_until(lambda: counter(backend, "polls") >= 20, 5.0, "20 polls")
    values = backend.status()[2]
    assert level(backend) == 0 and values["last_fault"] == ""
    assert counter(backend, "timeouts") == 0
    times = [t for t, text in list(board.board.commands) if text == "e"]
    assert len(times) >= 20
    assert min(b - a for a, b in zip(times, times[1:], strict=False)) >= 0.020 - 1e-6


def test_unresponsive_board_is_an_error_until_it_answers(fake_board, serial_backend, wait_until):
    """Replies later than the timeout: the handshake fails, ERROR says so, retries go on."""
    board = fake_board(delay_ms=300.0)
    backend = serial_backend(
        board.link, read_timeout_s=0.05, handshake_timeout_s=0.4, stale_timeout_s=0.3,
        **FAST_RECONNECT,
    )  # fmt: skip
    wait_until(lambda: counter(backend, "handshake_failures") >= 2, 4.0, "2 failed handshakes")
    level_now, message, _ = backend.status()
    assert level_now == 2 and ("did not answer" in message or "not 'e' in step" in message)
    assert counter(backend, "connects") == 0, "late replies were taken for a healthy board"
    assert backend.read() is None


def test_garbled_partial_oversized_binary_and_invalid_replies(
    fake_board, serial_backend, sampler, wait_until
):
    """Every kind of corrupt exchange is detected and counted; the angle never jumps."""
    board = fake_board(garble_rate=0.25, seed=3)
    backend = serial_backend(board.link, read_timeout_s=0.05, poll_rate_hz=200.0)
    wait_until(lambda: level(backend) < 2, 3.0, "connected")
    samples = sampler(backend)
    backend.set_speed(5.0)
    kinds = ("garbled", "binary", "oversized", "partial_replies", "invalid_command")
    wait_until(lambda: all(counter(backend, kind) >= 1 for kind in kinds), 8.0,
               f"each of {kinds}")  # fmt: skip
    wait_until(lambda: samples.angle() > 2.0, 3.0, "motion")
    assert 2 not in samples.levels, "a garbled reply dropped the link"
    assert_no_jump(samples.samples)
    garbled = sum(board.board.counts[f"garble_{k}"] for k in ("flip", "truncate", "binary"))
    assert garbled > 0


def test_invalid_command_for_every_request_is_reported(fake_board, serial_backend, wait_until):
    """A board that answers Invalid Command to e (no USE_BASE): not trusted, ERROR with reason."""
    board = fake_board(garble_rate=1.0, seed=5)
    board.board.rng.choice = lambda kinds: "invalid"  # every exchange: Invalid Command
    backend = serial_backend(
        board.link, handshake_timeout_s=0.3, stale_timeout_s=0.3, **FAST_RECONNECT
    )
    wait_until(lambda: counter(backend, "invalid_command") >= 3, 3.0, "Invalid Command counted")
    wait_until(lambda: counter(backend, "handshake_failures") >= 1, 3.0, "handshake failure")
    assert level(backend) == 2 and "answers 'b' but not 'e'" in backend.status()[1]


def test_board_reset_while_running(fake_board, serial_backend, sampler, wait_until):
    """Counts fall back to 0 mid-run: counted as a reset, WARN, no jump, the speed is re-sent."""
    board = fake_board(boot_ms=150.0)
    backend = serial_backend(board.link, resend_period_s=1.5)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    samples = sampler(backend)
    backend.set_speed(6.0)
    wait_until(lambda: samples.angle() > 2.0, 3.0, "motion")
    board.board.reset()
    wait_until(lambda: counter(backend, "board_resets") >= 1, 2.0, "the reset detected")
    assert level(backend) == 1 and "board_reset" in backend.status()[2]["last_fault"]
    assert counter(backend, "phase_rebases") == 1
    assert "phase_rad may need re-calibration" in backend.status()[1]
    held = samples.angle()
    # The board lost its target in the reset; it is moving again well before the 1.5 s resend.
    wait_until(lambda: board.board.firmware.moving, 1.0, "the speed re-sent")
    wait_until(lambda: samples.angle() > held + 1.0, 3.0, "motion after the reset")
    assert_no_jump(samples.samples)


def test_phase_rebase_warns_for_phase_warn_s(fake_board, serial_backend, wait_until):
    """A re-base keeps status() WARN (naming the phase) after the fault's own WARN ended."""
    board = fake_board()
    backend = serial_backend(board.link, fault_hold_s=0.1, phase_warn_s=60.0)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    assert backend.status()[2]["phase_rebases"] == "0"
    backend.set_speed(6.0)
    wait_until(lambda: board.board.firmware.encoder(0) > 500, 3.0, "motion")
    board.board.reset()
    wait_until(lambda: counter(backend, "phase_rebases") == 1, 3.0, "the re-base")
    wait_until(lambda: "recent fault" not in backend.status()[1], 5.0, "the fault's WARN to end")
    level_now, message, values = backend.status()
    assert level_now == 1 and "carrier phase reference may have shifted" in message
    assert values["last_phase_rebase"].startswith("count")  # the reason, e.g. "count jumped by"


def test_phase_rebase_warning_ends(fake_board, serial_backend, wait_until):
    """After phase_warn_s the status is OK again; the counter stays."""
    board = fake_board()
    backend = serial_backend(board.link, fault_hold_s=0.1, phase_warn_s=0.3)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    backend.set_speed(6.0)
    wait_until(lambda: board.board.firmware.encoder(0) > 500, 3.0, "motion")
    board.board.reset()
    wait_until(lambda: counter(backend, "phase_rebases") == 1, 3.0, "the re-base")
    wait_until(lambda: level(backend) == 0, 5.0, "OK again")
    assert counter(backend, "phase_rebases") == 1


def test_counter_wrap_is_continuous(fake_board, serial_backend, sampler, wait_until):
    """Counts crossing INT32_MAX -> INT32_MIN keep the angle continuous and correct."""
    board = fake_board(encoder_offset=INT32_MAX - 3000, counts_per_revolution=2048)
    backend = serial_backend(board.link)
    wait_until(lambda: level(backend) == 0, 3.0, "status OK")
    samples = sampler(backend)
    backend.set_speed(15.0)
    wait_until(lambda: counter(backend, "encoder_wraps") >= 1, 3.0, "the wrap")
    wait_until(lambda: samples.angle() > 15.0, 3.0, "motion past the wrap")
    assert_no_jump(samples.samples)
    board_counts = board.board.firmware.motors[0].encoder_counts()
    assert samples.angle() == pytest.approx(board_counts * 2 * math.pi / 2048, abs=1.0)


def test_cli_fault_switches_disconnect_and_reset(
    board_process, serial_backend, sampler, tmp_path, wait_until
):
    """--disconnect-after-s and --reset-after-s of fishtail-fake-board, end to end."""
    link = tmp_path / "tty"
    log = tmp_path / "board.log"
    process = board_process(
        link, "--disconnect-after-s", "1.0", "--disconnect-for-s", "0.4",
        "--reset-after-s", "2.2", "--boot-ms", "100", log=log,
    )  # fmt: skip
    first = process.next_path()
    backend = serial_backend(link, **FAST_RECONNECT)
    samples = sampler(backend)
    backend.set_speed(5.0)
    second = process.next_path(5.0)  # announced again after the scheduled replug
    assert first.startswith("/dev/pts/") and second.startswith("/dev/pts/")
    wait_until(lambda: counter(backend, "reconnects") >= 1, 3.0, "the reconnect")
    wait_until(lambda: counter(backend, "board_resets") >= 2, 3.0, "replug and scheduled reset")
    wait_until(lambda: level(backend) < 2 and samples.angle() > 3.0, 3.0, "motion after")
    assert 2 in samples.levels
    assert_no_jump(samples.samples)
    text = log.read_text()
    assert "# unplug (scheduled)" in text and "# reset (scheduled)" in text


# --- late replies, reading times, the final stop ------------------------------------------------


def test_late_replies_are_discarded_never_taken_for_later_ones(
    fake_board, serial_backend, sampler, wait_until
):
    """A board that turns slow (300 ms under a 100 ms timeout): no sample from a late reply.

    Every sample must carry the count the board read at the sample's time (checked on the
    board's own record of its readings); late replies are counted as discarded; the link is
    declared lost (no timely reply) and comes back when the board is fast again.
    """
    board = fake_board(delay_ms=300.0)
    board.board.set_slow(False)
    backend = serial_backend(board.link, read_timeout_s=0.1, stale_timeout_s=1.0,
                             **FAST_RECONNECT)  # fmt: skip
    samples = sampler(backend)
    wait_until(lambda: level(backend) == 0, 5.0, "connected")
    backend.set_speed(4.0)
    wait_until(lambda: samples.angle() > 1.0, 5.0, "motion")
    board.board.set_slow(True)
    wait_until(lambda: counter(backend, "discarded_replies") >= 2, 5.0, "late replies discarded")
    wait_until(lambda: counter(backend, "disconnects") >= 1, 5.0, "the link declared lost")
    board.board.set_slow(False)
    held = samples.angle()
    wait_until(lambda: samples.angle() > held + 1.0, 10.0, "motion once the board is fast again")
    backend.set_speed(4.0)  # keep the command fresh for the check below
    samples.stop()
    read_at = {}
    for when, left, _ in list(board.board.firmware.encoder_reads):
        read_at.setdefault(left, []).append(when)
    count_rad = 2 * math.pi / 2048
    for sample in samples.samples:
        times = read_at[round(sample.angle_rad / count_rad)]
        error = min(abs(when - sample.monotonic_s) for when in times)
        # A late reply taken for a later request's would be dated >= 0.1 s after its reading.
        assert error < 0.05, f"a sample dated {error:.3f} s away from the board's reading"
    assert_no_jump(samples.samples)


def test_a_fence_never_ends_on_the_probe_reply_of_an_earlier_fence(fake_board):
    """Probes re-sent by one fence and answered during the next: no reply taken out of turn.

    Every fence probe (``b``) gets the same reply. The board's reply delays are scripted
    (read timeout 0.2 s; every step below at least 0.1 s from the next, so the host's
    scheduling cannot change the order):

    ====  =================================================================================
    0.0   e0 (reply 0.3 s late); timeout at 0.2: fence 1 probes, b1 (reply at 0.5)
    0.4   fence 1 times out, probes again: b2 (0.6 s late: reply at 1.0)
    0.5   b1 answers: fence 1 in step (b2 still on its way); e1 (0.6 s late: reply at 1.1)
    0.7   e1 times out: fence 2 probes, b3 (reply at 1.3)
    1.0   b2's reply: fence 2 must not take it for b3's (b2 was written before e1) ...
    1.1   ... or the next ``e`` would take e1's late reply for its own, dated 0.5 s late
    ====  =================================================================================

    Checked on the board's own record: the n-th ``e`` the host writes is the n-th reading the
    board takes, so every accepted reading must be exactly that one.
    """
    board = fake_board()
    counters = StatusCounters(time.monotonic)
    link = SerialLink(
        SerialConfig(port=str(board.link), read_timeout_s=0.2, stale_timeout_s=10.0),
        counters, threading.Event(),
    )  # fmt: skip
    link.open()
    try:
        link.handshake()
        assert isinstance(link.exchange(encode_motor_speeds(43, 0), parse_ok), Answered)
        reads = board.board.firmware.encoder_reads
        first = len(reads)  # the handshake's requests were all answered in step
        board.board.script_delays([0.3, 0.3, 0.6, 0.6, 0.6])  # e0, b1, b2, e1, b3
        results = []
        while board.board.scripted_delays_left or len(results) < 5:
            assert len(results) < 40, "the scenario did not play out"
            results.append(link.exchange(encode_read_encoders(), parse_encoders))
    finally:
        link.close()
    assert isinstance(results[0], Failed) and isinstance(results[1], Failed)
    assert counters["resyncs"] >= 2 and counters["discarded_replies"] >= 2
    records = list(reads)[first:]
    for index, result in enumerate(results):
        if isinstance(result, Answered):
            _, left, right = records[index]
            assert result.value == (left, right), (
                f"request {index} accepted {result.value}, the board's reading for it was "
                f"{(left, right)}: a late reply taken for a later request's"
            )


def test_reading_is_dated_when_the_request_reached_the_board(
    fake_board, serial_backend, wait_until
):
    """Replies 60 ms late: accepted, each dated at its request, not mid-way to the reply."""
    board = fake_board(delay_ms=60.0)
    backend = serial_backend(board.link, read_timeout_s=0.1)
    wait_until(lambda: counter(backend, "polls") >= 10, 10.0, "10 polls")
    sample = backend.read()
    reads = [when for when, _, _ in list(board.board.firmware.encoder_reads)]
    error = min(abs(when - sample.monotonic_s) for when in reads)
    assert error < 0.02, f"the reading is dated {error * 1e3:.0f} ms away from the board's read"
    assert counter(backend, "timeouts") == 0 and counter(backend, "discarded_replies") == 0


def test_close_reports_whether_the_stop_got_through(
    fake_board, serial_backend, tmp_path, wait_until
):
    """Acknowledged by a board; not sent when there is no board, or when never started."""
    board = fake_board()
    backend = serial_backend(board.link)
    wait_until(lambda: level(backend) == 0, 5.0, "connected")
    outcome = backend.close()
    assert outcome.confirmed and outcome.sent and "acknowledged" in outcome.detail
    assert backend.close() == outcome  # twice: the same answer
    missing = serial_backend(tmp_path / "no-board")
    wait_until(lambda: "does not exist" in missing.status()[1], 5.0, "the port missing")
    outcome = missing.close()
    assert not outcome.confirmed and not outcome.sent
    assert "not sent" in outcome.detail and "does not exist" in outcome.detail
    never = SerialBackend(SerialConfig(port=str(tmp_path / "no-board")))
    assert not never.close().sent


def assert_dated_at_the_boards_reading(board, samples, tolerance_s: float = 0.05) -> None:
    """Each sample carries the count the board read at (about) the sample's time.

    A late reply taken for a later request's would be dated at least the read timeout late.
    """
    read_at: dict[int, list[float]] = {}
    for when, left, _ in list(board.board.firmware.encoder_reads):
        read_at.setdefault(left, []).append(when)
    count_rad = 2 * math.pi / 2048
    errors = []
    for sample in samples:
        times = read_at[round(sample.angle_rad / count_rad)]
        errors.append(min(abs(when - sample.monotonic_s) for when in times))
    stale = [error for error in errors if error >= tolerance_s]
    assert not stale, (
        f"{len(stale)} of {len(errors)} samples dated {max(stale) * 1e3:.0f} ms (worst) away "
        "from the board's reading"
    )


@pytest.mark.slow
def test_queued_late_replies_are_never_taken_after_a_reopen(
    fake_board, serial_backend, sampler, wait_until
):
    """A board slow for seconds (replies 300 ms late, queued): no stale sample after a reopen.

    The link is declared lost and the port reopened several times while the board is slow; its
    replies to requests written before each reopen still come afterwards. None may be taken for
    the answer to a request written after it (the handshake's in-step check used to take one:
    a sample 300 ms old with a current stamp, 1.2 rad off at 4 rad/s, at every reopen). They
    are discarded and counted; once the board is prompt again the link comes back.
    """
    board = fake_board(delay_ms=300.0)
    board.board.set_slow(False)
    backend = serial_backend(board.link, read_timeout_s=0.1, stale_timeout_s=1.0,
                             **FAST_RECONNECT)  # fmt: skip
    samples = sampler(backend)
    wait_until(lambda: level(backend) == 0, 5.0, "connected")
    backend.set_speed(4.0)
    wait_until(lambda: samples.angle() > 1.0, 5.0, "motion")
    board.board.set_slow(True)

    def reopens() -> int:
        return counter(backend, "reconnects") + counter(backend, "handshake_failures")

    wait_until(lambda: counter(backend, "disconnects") >= 1, 5.0, "the link declared lost")
    deadline = time.monotonic() + 20.0
    while reopens() < 3:  # several reopens while the board is slow
        assert time.monotonic() < deadline, "no reopens while the board is slow"
        backend.set_speed(4.0)  # keep the command fresh
        time.sleep(0.05)
    board.board.set_slow(False)
    held = samples.angle()
    deadline = time.monotonic() + 10.0
    while samples.angle() <= held + 1.0:
        assert time.monotonic() < deadline, "no motion once the board is fast again"
        backend.set_speed(4.0)
        time.sleep(0.05)
    samples.stop()
    assert_dated_at_the_boards_reading(board, samples.samples)
    assert_no_jump(samples.samples)
    assert counter(backend, "discarded_replies") >= 3
    assert "stale_readings" in backend.status()[2]


def test_a_reading_answered_later_than_its_stamp_promises_is_counted_not_published(
    fake_board, serial_backend, sampler, wait_until
):
    """The I/O thread held up 150 ms with a reply in hand (read timeout 100 ms): not published.

    The reading may be as old as its round trip; a stamp at the request promises no more than
    the read timeout, so it is counted (``stale_readings``, WARN naming it) instead.
    """
    board = fake_board()
    backend = serial_backend(board.link, read_timeout_s=0.1)
    wait_until(lambda: counter(backend, "polls") >= 5, 5.0, "connected and polling")
    link = backend._link
    read_line, exchange = link.read_line, link.exchange
    stalled: list[bool] = []
    late: list[Answered] = []

    def stalled_read_line(deadline: float):
        line = read_line(deadline)
        if not stalled and line[:1].isdigit():
            stalled.append(True)
            time.sleep(0.15)  # the host preempted after the reply came
        return line

    def watched_exchange(payload, parse):
        result = exchange(payload, parse)
        if isinstance(result, Answered) and result.round_trip_s > 0.1:
            late.append(result)
        return result

    samples = sampler(backend)
    link.exchange = watched_exchange
    link.read_line = stalled_read_line
    wait_until(lambda: counter(backend, "stale_readings") == 1, 5.0, "the stale reading counted")
    polls = counter(backend, "polls")
    wait_until(lambda: counter(backend, "polls") >= polls + 5, 5.0, "polls go on")
    samples.stop()
    status = backend.status()
    assert status[0] == 1 and "stale_readings" in status[1], status[1]
    assert "not published" in status[2]["last_fault"]
    assert counter(backend, "stale_readings") == 1
    assert len(late) == 1
    stamps = [sample.monotonic_s for sample in samples.samples]
    assert late[0].request_arrived_s not in stamps, "the reading held up 150 ms was published"

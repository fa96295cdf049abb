"""The serial path against both boards: the project's fake board and the real firmware in simavr.

Each test runs twice through the ``either_board`` fixture: on the fake board (the project's
reading of ROSArduinoBridge, a DC motor) and on the joshnewans fork's firmware built for a Nano
and run instruction by instruction in simavr, driving the same DC motor model (Pololu 37D 30:1,
64-count encoder). The firmware side skips with one line where the AVR toolchain is missing.

Durations and speeds are measured on the board's own clock (``BoardUnderTest.clock_at``: the
host's for the fake board, the simulated one for the firmware), so a simulator that falls behind
wall time on a busy host makes a test slower, never wrong. Time limits only bound a failing wait.

Behaviours only the fake board can show (corrupted and lost replies, slow replies, scheduled
faults) stay in test_serial_backend.py and test_driver_serial.py, fake only: the firmware in the
simulator has no fault injection.
"""

from __future__ import annotations

import math
import time

import pytest

from fishtail_plant.motor.board_units import INT32_MAX

POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}
COUNTS_PER_CARRIER_TURN = 64 * 30
#: 40 ticks per 33 ms frame: 3.97 rad/s of the carrier.
SPEED_RAD_S = 40 * 2 * math.pi / COUNTS_PER_CARRIER_TURN / 0.033
#: The firmware's loop leaves a steady error of up to 2 ticks per frame (its dead band, where
#: |Kp error - Kd change| < Ko changes nothing; firmware_pid): 5 % of 40.
SPEED_TOLERANCE = 0.05
#: Only bounds a failing wait: a simulator starved of CPU runs slower than wall time.
PATIENCE_S = 30.0


def level(backend) -> int:
    """status() level."""
    return backend.status()[0]


def counter(backend, name: str) -> int:
    """One of status()'s counters (0 when absent)."""
    return int(backend.status()[2].get(name, "0") or 0)


def wait_board_time(board, seconds: float, wait_until) -> float:
    """Wait until ``seconds`` of the board's clock have passed; the board's time then."""
    until = board.clock() + seconds
    wait_until(
        lambda: board.clock() >= until, PATIENCE_S + 2 * seconds, f"{seconds} s of board time"
    )
    return board.clock()


def collect_readings(backend, board, seconds: float, wait_until) -> list:
    """The backend's new readings over ``seconds`` of board time (polled like the node does).

    At least two: on a host too busy for the simulator to keep up with wall time, the backend may
    time out and reconnect within the span, and the wait goes on until readings come again.
    """
    readings: list = []
    until = board.clock() + seconds

    def poll() -> bool:
        reading = backend.read()
        if reading is not None and (not readings or reading.monotonic_s > readings[-1].monotonic_s):
            readings.append(reading)
        return board.clock() >= until and len(readings) >= 2

    wait_until(poll, PATIENCE_S + 2 * seconds, f"{seconds} s of readings")
    return readings


@pytest.mark.slow
def test_the_speed_is_held(either_board, serial_backend, wait_until):
    """The serial backend at 40 ticks per frame: the carrier turns at that speed, board time."""
    board = either_board()
    backend = serial_backend(board.link, poll_rate_hz=100.0, **POLOLU)
    wait_until(lambda: level(backend) == 0, PATIENCE_S, "status OK")
    backend.set_speed(SPEED_RAD_S)
    wait_board_time(board, 1.5, wait_until)  # the loop settles
    readings = collect_readings(backend, board, 3.0, wait_until)
    first, last = readings[0], readings[-1]
    elapsed = board.clock_at(last.monotonic_s) - board.clock_at(first.monotonic_s)
    mean = (last.angle_rad - first.angle_rad) / elapsed
    assert abs(mean / SPEED_RAD_S - 1.0) < SPEED_TOLERANCE, (
        f"{board.kind}: mean {mean:.3f} rad/s over {elapsed:.2f} s, not {SPEED_RAD_S:.3f}"
    )


def test_the_angle_is_continuous_across_the_32_bit_wrap(either_board, serial_backend, wait_until):
    """Counts started 1500 below INT32_MAX cross to INT32_MIN: the angle goes on without a step."""
    board = either_board(encoder_offset=INT32_MAX - 1500)
    backend = serial_backend(board.link, poll_rate_hz=100.0, **POLOLU)
    wait_until(lambda: level(backend) == 0, PATIENCE_S, "status OK")
    backend.set_speed(SPEED_RAD_S)
    readings = collect_readings(backend, board, 2.5, wait_until)  # 1500 counts take about 1.3 s
    assert counter(backend, "encoder_wraps") >= 1, f"{board.kind}: no wrap counted"
    assert counter(backend, "board_resets") == 0, f"{board.kind}: the wrap taken for a reset"
    count_rad = 2 * math.pi / COUNTS_PER_CARRIER_TURN
    for before, after in zip(readings, readings[1:], strict=False):
        step = after.angle_rad - before.angle_rad
        elapsed = board.clock_at(after.monotonic_s) - board.clock_at(before.monotonic_s)
        assert step >= -2 * count_rad, f"{board.kind}: the angle went back by {-step:.4f} rad"
        # Twice the commanded speed over the interval, plus two PID frames of slack.
        assert step <= 2 * SPEED_RAD_S * (elapsed + 0.066), (
            f"{board.kind}: the angle jumped by {step:.3f} rad in {elapsed:.3f} s"
        )
    assert readings[-1].angle_rad > 1.5 * 1500 * count_rad  # well past the wrap


@pytest.mark.slow
def test_the_board_stops_itself_2_s_after_the_last_m(either_board, raw_port):
    """``m 40 40`` once: turning until 2 s after it (board time), stopped after."""
    board = either_board()
    port = raw_port(board.link)
    assert port.ask("m 40 40") == "OK"
    commanded = board.clock()  # the m ran at or before this
    samples: list[tuple[float, int]] = []
    while not samples or samples[-1][0] < commanded + 3.2:
        counts = port.counts()
        samples.append((board.clock_at(time.monotonic()), counts[0]))
        assert len(samples) < 100000, "the board's clock stands still"

    def window(start: float, end: float) -> list[tuple[float, int]]:
        found = [(when, count) for when, count in samples if start <= when - commanded <= end]
        assert len(found) >= 2, f"{board.kind}: no two readings {start}-{end} s after the m"
        return found

    def moved(start: float, end: float) -> int:
        found = window(start, end)
        return found[-1][1] - found[0][1]

    # Still driven 1.5-1.95 s after the m (at least 80 % of 40 ticks per 33 ms frame) ...
    driven = window(1.5, 1.95)
    rate = (driven[-1][1] - driven[0][1]) / (driven[-1][0] - driven[0][0])
    assert rate >= 0.8 * 40 / 0.033, f"{board.kind}: {rate:.0f} counts/s: stopped before 2 s"
    # ... and standing 2.7 s after it (the PWM cut at 2 s, the motor coasted down).
    assert moved(2.7, 3.2) == 0, f"{board.kind}: still turning 2.7 s after the last m"


def test_a_reset_mid_run_is_detected_and_the_angle_goes_on(
    either_board, serial_backend, wait_until
):
    """A reset (DTR) while turning: the counts fall to 0, the backend counts a reset, re-sends."""
    board = either_board()
    backend = serial_backend(board.link, poll_rate_hz=100.0, resend_period_s=1.5, **POLOLU)
    wait_until(lambda: level(backend) == 0, PATIENCE_S, "status OK")
    backend.set_speed(SPEED_RAD_S)
    readings = collect_readings(backend, board, 1.0, wait_until)
    board.reset()
    try:
        wait_until(lambda: counter(backend, "board_resets") >= 1, PATIENCE_S, "the reset")
    except pytest.fail.Exception:
        pytest.fail(f"{board.kind}: no reset detected; the backend says {backend.status()!r}")
    held = backend.read() or readings[-1]
    readings += collect_readings(backend, board, 1.0, wait_until)
    assert readings[-1].angle_rad > held.angle_rad + 1.0, f"{board.kind}: no motion after reset"
    assert min(r.angle_rad for r in readings if r.monotonic_s >= held.monotonic_s) >= (
        held.angle_rad - 0.2
    ), f"{board.kind}: the angle fell back after the reset"


def test_the_stop_gets_through_on_close(either_board, serial_backend, raw_port, wait_until):
    """Closing the backend (the driver's SIGINT path) sends ``m 0 0``: the motor stops at once."""
    board = either_board()
    backend = serial_backend(board.link, poll_rate_hz=100.0, **POLOLU)
    wait_until(lambda: level(backend) == 0, PATIENCE_S, "status OK")
    backend.set_speed(SPEED_RAD_S)
    collect_readings(backend, board, 0.5, wait_until)
    assert backend.close().confirmed, f"{board.kind}: the stop did not get through"
    closed = board.clock()
    port = raw_port(board.link)
    wait_board_time(board, 0.3, wait_until)  # coasting down
    standing = port.counts()
    wait_board_time(board, 0.5, wait_until)
    assert port.counts() == standing, f"{board.kind}: still turning after the stop"
    assert board.clock() < closed + 2.0, "measured after the auto-stop would have stopped it"


def test_unplug_and_replug(either_board, serial_backend, wait_until):
    """The USB cable pulled: ERROR; plugged back (board power-cycled): WARN, the angle goes on."""
    board = either_board()
    backend = serial_backend(
        board.link, poll_rate_hz=100.0, reconnect_min_s=0.05, reconnect_max_s=0.2, **POLOLU
    )
    wait_until(lambda: level(backend) == 0, PATIENCE_S, "status OK")
    backend.set_speed(SPEED_RAD_S)
    readings = collect_readings(backend, board, 1.0, wait_until)
    board.unplug()
    wait_until(lambda: level(backend) == 2, PATIENCE_S, "ERROR after the unplug")
    assert "link lost" in backend.status()[1] or "does not exist" in backend.status()[1]
    held = readings[-1].angle_rad
    board.replug()
    wait_until(lambda: level(backend) == 1, PATIENCE_S, "WARN after the replug (phase re-based)")
    after = collect_readings(backend, board, 1.0, wait_until)
    assert abs(after[0].angle_rad - held) < 0.3, f"{board.kind}: the angle jumped at the replug"
    assert after[-1].angle_rad > after[0].angle_rad + 1.0, f"{board.kind}: no motion after it"
    values = backend.status()[2]
    assert int(values["disconnects"]) >= 1 and int(values["reconnects"]) >= 1
    assert int(values["board_resets"]) >= 1, f"{board.kind}: the replugged board kept its count"


def test_the_driver_stops_the_motor_on_sigint(either_board, driver_run, raw_port, wait_until):
    """The driver node on the board: turning it; SIGINT: exits 0 and the motor stands at once."""
    board = either_board()
    run = driver_run(
        board.link, encoder_counts_per_revolution=64, gear_ratio=30.0, max_speed_rad_s=10.0
    )
    run.start_motion(SPEED_RAD_S)
    run.wait(lambda: run.angle() > 1.0, PATIENCE_S, "the joint_state angle to advance")
    run.stop()
    stopped = board.clock()
    port = raw_port(board.link)
    wait_board_time(board, 0.3, wait_until)  # coasting down
    standing = port.counts()
    wait_board_time(board, 0.5, wait_until)
    assert port.counts() == standing, f"{board.kind}: still turning after the driver's SIGINT"
    assert board.clock() < stopped + 2.0, "measured after the auto-stop would have stopped it"

"""End to end: what the driver node publishes from a slow board, and what it says when it stops.

The emulated board runs in this process (``fake_board``), so the test knows when the board read
each encoder count it reported (``Firmware.encoder_reads``); the driver is a separate process
(``driver_run``), observed through ROS only. A published sample carries a count the board
reported; it must be stamped with (about) the time the board read that count:

* a board that answers later than ``serial_read_timeout_sec``: its late replies must never be
  taken for the answers to later requests (they would be stamped hundreds of ms after the board
  read them); they are discarded and counted (``discarded_replies``);
* a board that answers within the timeout but slowly: every reply is accepted, stamped when the
  request reached the board (not when the reply came back), and the poll rate that falls as a
  consequence is a WARN with the measured rate and the longest gap;
* a healthy board: OK, with the measured rate in the values.

And: the driver tells the truth about the final stop; an empty joint name is refused at start.
"""

from __future__ import annotations

import collections
import math
import statistics
import time

import pytest

SPEED = 4.0
COUNT_RAD = 2 * math.pi / 2048
READ_TIMEOUT_S = 0.1
#: How far a stamp may be from the time the board read the count. Honest stamps are off only by
#: the time between the driver's clock reading before it sends ``e`` and the emulated board
#: running the command (its loop waking up, two processes scheduled on a busy machine); a late
#: reply taken for the answer to a later request is off by more than the read timeout, since only
#: replies later than that are late. So the bound is the read timeout itself: what the defect
#: violates, with all of the timeout as margin for scheduling.
STAMP_TOLERANCE_S = READ_TIMEOUT_S


def stamp_s(message) -> float:
    """A header stamp in seconds."""
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def wall_minus_monotonic() -> float:
    """ROS (system) time minus monotonic time, from the tightest of a few bracketed readings."""
    best = (math.inf, 0.0)
    for _ in range(50):
        before = time.monotonic()
        wall = time.time()
        after = time.monotonic()
        best = min(best, (after - before, wall - 0.5 * (before + after)))
    return best[1]


def read_time_errors(joints: list, board) -> list[float]:
    """Per sample: when the board read the count it carries minus its stamp (monotonic, s).

    The driver's angle 0 is its first reading, and the board starts at rest at count 0, so a
    sample's angle is its board count times the count's angle.
    """
    offset = wall_minus_monotonic()
    read_at = collections.defaultdict(list)
    for when, left, _ in list(board.board.firmware.encoder_reads):
        read_at[left].append(when)
    errors = []
    for index, message in enumerate(joints):
        count = round(message.position[0] / COUNT_RAD)
        times = read_at.get(count)
        assert times, (
            f"sample {index}: angle {message.position[0]:.4f} rad (count {count}) is no count "
            "the board reported"
        )
        stamp = stamp_s(message) - offset
        errors.append(min((when - stamp for when in times), key=abs))
    return errors


def assert_stamped_when_read(joints: list, board) -> list[float]:
    """Every sample stamped within STAMP_TOLERANCE_S of the board's reading; returns the errors."""
    assert joints, "no samples"
    errors = read_time_errors(joints, board)
    worst = max(range(len(errors)), key=lambda i: abs(errors[i]))
    assert abs(errors[worst]) <= STAMP_TOLERANCE_S, (
        f"sample {worst} of {len(joints)} is stamped {-errors[worst]:+.3f} s after the board read "
        f"it: its angle is {abs(errors[worst]) * SPEED:.2f} rad off at {SPEED:g} rad/s "
        f"({sum(abs(e) > STAMP_TOLERANCE_S for e in errors)} samples off)"
    )
    return errors


def assert_strictly_increasing(joints: list) -> None:
    """Each stamp later than the one before."""
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in joints]
    back = [i for i in range(1, len(stamps)) if stamps[i] <= stamps[i - 1]]
    assert not back, f"{len(back)} stamps not after the previous one, first at sample {back[0]}"


@pytest.mark.parametrize("delay_ms", [150.0, 300.0])
def test_late_replies_are_discarded_not_published(fake_board, driver_run, delay_ms):
    """Replies later than the read timeout: counted as discarded, never published as samples.

    The board answers at once until the motor turns, then every reply is ``delay_ms`` late (150
    and 300 ms, delays at which boards have been seen to answer), then it is fast again: the
    driver must come back, and no sample of the whole run may carry an angle the board read at
    another time than its stamp.
    """
    board = fake_board(delay_ms=delay_ms)
    board.board.set_slow(False)
    run = driver_run(board.link, serial_read_timeout_sec=READ_TIMEOUT_S)
    run.start_motion(SPEED)
    run.wait(lambda: run.angle() > 1.0, 10.0, "the joint_state angle to advance")
    mark = len(run.diagnostics)
    board.board.set_slow(True)
    run.wait(lambda: run.counter("discarded_replies") > 0, 10.0,
             "late replies counted as discarded on /diagnostics")  # fmt: skip
    run.wait(lambda: any(level >= 1 for level, _, _ in run.statuses(mark)), 5.0,
             "WARN or ERROR while the board is slow")  # fmt: skip
    board.board.set_slow(False)
    held = run.angle()
    run.wait(lambda: run.angle() > held + 1.0, 15.0, "motion once the board is fast again")
    run.stop()
    assert_stamped_when_read(run.joints, board)
    assert_strictly_increasing(run.joints)
    assert run.counter("phase_rebases") == 0


@pytest.mark.slow
def test_queued_late_replies_are_not_published_after_a_reopen(fake_board, driver_run):
    """Replies 300 ms late and queued for seconds: none published after a reopen, all counted.

    The driver declares the link lost and reopens the port while the board is slow; the board
    still answers requests written before each reopen afterwards. No such reply may be published
    as a later request's (it was: samples 300 ms old with current stamps); they are discarded
    and counted on /diagnostics (``stale_readings`` beside them), and the driver comes back once
    the board is prompt.
    """
    board = fake_board(delay_ms=300.0)
    board.board.set_slow(False)
    run = driver_run(board.link, serial_read_timeout_sec=READ_TIMEOUT_S)
    run.start_motion(SPEED)
    run.wait(lambda: run.angle() > 1.0, 10.0, "the joint_state angle to advance")
    board.board.set_slow(True)
    run.wait(lambda: run.counter("disconnects") >= 1, 10.0, "the link declared lost")
    run.wait(lambda: run.counter("reconnects") + run.counter("handshake_failures") >= 3, 20.0,
             "three reopens while the board is slow")  # fmt: skip
    board.board.set_slow(False)
    held = run.angle()
    run.wait(lambda: run.angle() > held + 1.0, 15.0, "motion once the board is fast again")
    run.stop()
    assert_stamped_when_read(run.joints, board)
    assert_strictly_increasing(run.joints)
    assert run.counter("discarded_replies") >= 3
    assert "stale_readings" in run.statuses()[-1][2]


def test_slow_board_within_the_timeout_is_stamped_at_the_request_and_warns(fake_board, driver_run):
    """Replies 80 ms late under a 100 ms timeout: accepted, stamped honestly, the rate a WARN.

    Each poll waits for its reply, so the poll rate falls to about 12 Hz of the promised 100 Hz.
    The fake board reads the encoder when the request arrives and delays the reply, as the
    firmware does behind a slow return path: the stamp must be the request's time, not the
    middle of the exchange (40 ms later).
    """
    board = fake_board(delay_ms=80.0)
    run = driver_run(board.link, serial_read_timeout_sec=READ_TIMEOUT_S)
    run.start_motion(SPEED)
    run.wait(lambda: run.angle() > 1.0, 15.0, "the joint_state angle to advance")
    mark = len(run.diagnostics)

    def rate_warning() -> bool:
        return any(level == 1 and "rate" in message and
                   float(values.get("joint_state_rate_hz") or "inf") < 80.0
                   for level, message, values in run.statuses(mark))  # fmt: skip

    run.wait(rate_warning, 10.0, "WARN for the poll rate below the promised 100 Hz")
    level, message, values = next(s for s in run.statuses(mark) if s[0] == 1 and "rate" in s[1])
    assert float(values["joint_state_expected_rate_hz"]) == pytest.approx(100.0)
    assert float(values["joint_state_longest_gap_ms"]) >= 60.0, values
    samples = len(run.joints)
    run.wait(lambda: len(run.joints) >= samples + 20, 10.0, "20 more samples")
    run.stop()
    errors = assert_stamped_when_read(run.joints, board)
    median = statistics.median(abs(e) for e in errors)
    # Dated at the request, the typical stamp is within scheduling noise of the reading; dated at
    # the reply (as before) it would be 40 ms late, half the 80 ms delay.
    assert median < 0.03, f"stamps are {median * 1e3:.1f} ms (median) off the board's readings"
    assert_strictly_increasing(run.joints)
    # A reply is discarded only after one came late: a poll's timeout, or, while connecting, an
    # 'e' the in-step check did not see in time (handshake_noise: a loaded machine adds to the
    # board's 80 ms), whose late reply the fence then throws away.
    late = run.counter("timeouts") + run.counter("handshake_noise")
    assert run.counter("discarded_replies") == 0 or late > 0, run.statuses()[-1][2]


def test_healthy_board_is_ok_with_the_measured_rate(fake_board, driver_run):
    """A prompt board at 100 Hz: OK, the measured rate in the values, samples stamped right."""
    board = fake_board()
    run = driver_run(board.link)
    run.start_motion(SPEED)
    run.wait(lambda: run.angle() > 1.0, 10.0, "the joint_state angle to advance")
    mark = len(run.diagnostics)
    run.wait(lambda: any(level == 0 and float(values.get("joint_state_rate_hz") or 0) >= 80.0
                         for level, _, values in run.statuses(mark)),
             10.0, "OK with the measured rate on /diagnostics")  # fmt: skip
    output = run.stop()
    assert "stop acknowledged" in output, output
    assert_stamped_when_read(run.joints, board)
    assert_strictly_increasing(run.joints)


def test_exit_does_not_claim_a_stop_it_could_not_send(fake_board, driver_run):
    """The board is unplugged when the driver exits: it says the stop was not sent."""
    board = fake_board()
    run = driver_run(board.link)
    run.start_motion(SPEED)
    run.wait(lambda: run.angle() > 0.5, 10.0, "the joint_state angle to advance")
    board.board.unplug()
    run.wait(lambda: run.statuses() and run.statuses()[-1][0] == 2, 5.0, "ERROR after the unplug")
    output = run.stop()
    assert "motor commanded to stop" not in output, output
    assert "stop command could not be sent" in output, output


def test_empty_joint_name_is_refused_at_start(driver_process):
    """Exit status 2 and one line naming the reason, no traceback."""
    driver = driver_process(params={"joint_name": "''"})
    assert driver.wait(30.0) == 2, driver.output()
    errors = [line for line in driver.output().splitlines() if line.startswith("driver: error:")]
    assert len(errors) == 1 and "joint_name" in errors[0], driver.output()
    assert "Traceback" not in driver.output()

"""The emulated board reproduces the firmware's parsing quirks, PID-frame timing and auto-stop."""

from __future__ import annotations

import doctest
import os
import signal

import pytest
import serial

from fishtail_boards import board_firmware
from fishtail_boards.board_firmware import Firmware, FirmwareConfig
from fishtail_boards.board_pty import BoardConfig, FakeBoard
from fishtail_boards.fake_board import main
from fishtail_plant.motor.board_units import INT32_MAX, INT32_MIN


def firmware(**config) -> Firmware:
    """A board powered on at t = 0 (warnings collected in .warnings)."""
    warnings: list[str] = []
    board = Firmware(FirmwareConfig(**config), 0.0, warn=warnings.append)
    board.warnings = warnings
    return board


def send(board: Firmware, data: bytes, now: float = 0.0) -> list[bytes]:
    """Feed bytes at ``now``; the replies of the commands they complete."""
    replies = []
    for byte in data:
        command = board.feed_byte(byte)
        if command is not None:
            replies.append(board.execute(command, now))
    return replies


def test_doctests():
    """The examples in the firmware's documentation hold."""
    result = doctest.testmod(board_firmware)
    assert result.failed == 0 and result.attempted >= 2


def test_only_cr_runs_a_command_and_lf_is_an_ordinary_byte():
    """LF-only lines get no reply; a stray LF before the letter is harmless; after it, not."""
    board = firmware()
    assert send(board, b"e\n") == []
    assert send(board, b"\r") == [b"Invalid Command\r\n"]  # the LF became the command letter
    assert send(board, b"\ne\r") == [b"0 0\r\n"]  # the last letter before a space wins
    assert send(board, b"\r") == [b"Invalid Command\r\n"]  # a bare CR


def test_argument_parsing_quirks():
    """Later spaces are skipped, a double space empties argument 1, atoi is 16-bit."""
    board = firmware()
    send(board, b"m 1 2 3\r")
    assert board.targets == [1, 23]
    send(board, b"m  5\r")
    assert board.targets == [0, 5]
    send(board, b"m 40000 1.9\r")
    assert board.targets == [-25536, 1]
    send(board, b"m junk 7\r")
    assert board.targets == [0, 7]


def test_argument_overflow_is_cut_off_and_reported():
    """More characters than the buffer holds: undefined on the board, reported here."""
    board = firmware(arg_buffer_bytes=16)
    send(board, b"m " + b"1" * 20 + b" 2\r")
    assert board.argument_overflows == 5 and board.warnings


@pytest.mark.parametrize(
    ("variant", "reply"), [("hbrobotics", b" 57600\r\n"), ("joshnewans", b"57600\r\n")]
)
def test_baud_reply_per_variant(variant, reply):
    """The hbrobotics firmware prints a leading space, the joshnewans fork does not."""
    assert send(firmware(variant=variant), b"b\r") == [reply]


def test_raw_pwm_only_in_the_joshnewans_fork():
    """``o`` is Invalid Command on hbrobotics; on joshnewans it drives the motor at once."""
    assert send(firmware(), b"o 100 0\r") == [b"Invalid Command\r\n"]
    board = firmware(variant="joshnewans", max_speed_rad_s=20.0)
    assert send(board, b"o 300 -5\r") == [b"OK\r\n"]
    assert board.motors[0].target_rad_s == pytest.approx(20.0)  # clamped to 255
    assert board.motors[1].target_rad_s == 0.0  # one-way model: negative -> 0


def test_speed_takes_effect_at_the_next_pid_frame():
    """``m`` sets ticks per frame; the motor follows from the next 33 ms frame on."""
    board = firmware(counts_per_revolution=2048)
    send(board, b"m 43 0\r", now=0.001)
    board.advance(0.032)
    assert board.motors[0].target_rad_s == 0.0
    board.advance(0.034)
    assert board.motors[0].target_rad_s == pytest.approx(43 * 2 * 3.14159265 / 2048 / 0.033)


def test_stop_is_immediate_and_auto_stop_strictly_after_2000_ms():
    """``m 0 0`` stops at once; without a new m the board stops itself after > 2 s."""
    board = firmware()
    send(board, b"m 40 0\r", now=0.0)
    send(board, b"e\r", now=1.9)  # e does not refresh the auto-stop timer
    board.advance(2.0)
    assert board.moving and board.motors[0].target_rad_s > 0.0
    assert board.auto_stop_times == []
    board.advance(2.0015)
    assert not board.moving and board.motors[0].target_rad_s == 0.0
    assert board.auto_stop_times == [pytest.approx(2.001)]  # reported, for the backend's tests
    send(board, b"m 40 0\r", now=3.0)
    board.advance(3.05)
    assert board.motors[0].target_rad_s > 0.0
    send(board, b"m 0 0\r", now=3.06)
    assert board.motors[0].target_rad_s == 0.0 and not board.moving


def test_encoders_wrap_and_reset():
    """Counts are signed 32-bit and wrap; ``r`` zeroes them."""
    board = firmware(encoder_offset=INT32_MAX - 10)
    send(board, b"m 100 100\r", now=0.0)
    board.advance(1.0)
    left, right = (int(v) for v in send(board, b"e\r", now=1.0)[0].split())
    assert INT32_MIN <= left < 0 and left == right  # wrapped
    assert send(board, b"r\r", now=1.0) == [b"OK\r\n"]
    assert send(board, b"e\r", now=1.0) == [b"0 0\r\n"]


def test_cli_rejects_bad_options(capsys):
    """Bad settings exit with status 2 and the reason, without a traceback."""
    assert main(["--drop-rate", "2"]) == 2
    assert "drop_rate" in capsys.readouterr().err


def test_sigusr1_resets_the_board(board_process, tmp_path, wait_until):
    """``kill -USR1`` resets the running board: counts back near 0, logged, the process goes on."""
    link, log = tmp_path / "tty", tmp_path / "board.log"
    process = board_process(link, log=log)
    process.next_path()
    with serial.Serial(str(link), 57600, timeout=1.0) as port:

        def ask(command: bytes) -> bytes:
            port.write(command + b"\r")
            return port.read_until(b"\r\n")

        def left_count() -> int:
            return int(ask(b"e").split()[0])

        assert ask(b"m 40 0") == b"OK\r\n"
        wait_until(lambda: left_count() > 2000, 5.0, "the encoder to count")
        before = left_count()
        os.kill(process.popen.pid, signal.SIGUSR1)
        wait_until(lambda: "# reset (requested)" in log.read_text(), 5.0, "the reset logged")
        after = left_count()  # the shaft coasts a little after the reset, from 0
        assert 0 <= after < before // 2, (before, after)
        assert ask(b"m 40 0") == b"OK\r\n"  # the board still answers
    assert process.popen.poll() is None


def test_slow_switch_delays_replies_from_delay_after_s_and_sigusr2(board_process, tmp_path):
    """``--delay-ms`` from ``--delay-after-s`` on; SIGUSR2 switches it off and on; order kept.

    Checked on the board's log (no timing of this process): the scheduled and requested
    switches are logged, and every ``e`` is still answered, in order, with its own reading.
    """
    link, log = tmp_path / "tty", tmp_path / "board.log"
    process = board_process(link, "--delay-ms", "300", "--delay-after-s", "0.5", log=log)
    process.next_path()
    with serial.Serial(str(link), 57600, timeout=5.0) as port:

        def ask(command: bytes) -> bytes:
            port.write(command + b"\r")
            return port.read_until(b"\r\n")

        assert ask(b"b") == b" 57600\r\n"  # prompt before --delay-after-s
        while "# slow on (scheduled)" not in log.read_text():
            assert ask(b"e") == b"0 0\r\n"
        os.kill(process.popen.pid, signal.SIGUSR2)
        while "# slow off (requested)" not in log.read_text():
            assert ask(b"e") == b"0 0\r\n"
        os.kill(process.popen.pid, signal.SIGUSR2)
        while "# slow on (requested)" not in log.read_text():
            assert ask(b"e") == b"0 0\r\n"
    assert process.popen.poll() is None


def test_reply_delay_is_added_after_the_reading():
    """The board reads the encoders when the request arrives; the delay is on the way back."""
    now = [0.0]
    board = FakeBoard(BoardConfig(delay_ms=80.0, delay_after_s=1.0), announce=lambda _: None,
                      clock=lambda: now[0])  # fmt: skip
    try:
        assert not board.slow
        board._scheduled(1.0)
        assert board.slow
        now[0] = 2.0
        board._rx.extend((2.0, byte) for byte in b"e\r")
        board._receive(2.0)
        assert board.firmware.encoder_reads[-1][0] == 2.0
        assert board._tx[-1][0] == pytest.approx(2.08)
        board.set_slow(False)
        board._rx.extend((2.01, byte) for byte in b"e\r")
        board._receive(2.01)
        # Not before the delayed reply: replies never overtake each other on one line.
        assert board._tx[-1][0] == pytest.approx(2.08)
    finally:
        board.close()


def test_slow_spell_of_delay_for_s_queues_replies_and_ends():
    """``delay_for_s``: replies late from ``delay_after_s`` for that long; queued ones keep theirs.

    A reply to a command after the spell still waits behind the delayed one before it (one line).
    """
    now = [0.0]
    config = BoardConfig(delay_ms=300.0, delay_after_s=1.0, delay_for_s=8.0)
    board = FakeBoard(config, announce=lambda _: None, clock=lambda: now[0])
    try:
        board._scheduled(1.0)
        assert board.slow
        for moment in (8.9, 8.95):  # two requests queue: each 300 ms late, in order
            board._rx.extend((moment, byte) for byte in b"e\r")
            board._receive(moment)
        assert [when for when, _ in board._tx] == pytest.approx([9.2, 9.25])
        assert board._next_wakeup(8.95) == pytest.approx(9.0)
        board._scheduled(9.0)
        assert not board.slow and board.counts["slow_off"] == 1
        board._rx.extend((9.01, byte) for byte in b"e\r")
        board._receive(9.01)
        assert board._tx[-1][0] == pytest.approx(9.25)  # behind the queued replies
    finally:
        board.close()
    with pytest.raises(ValueError, match="delay_for_s"):
        BoardConfig(delay_for_s=0.0)

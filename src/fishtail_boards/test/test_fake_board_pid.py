"""The emulated board runs the firmware's speed loop, and its PWM drives the chosen motor."""

from __future__ import annotations

import math

import pytest
import serial

from fishtail_boards.board_firmware import Firmware, FirmwareConfig
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
from fishtail_plant.motor.pid_dc_motor import PidDrivenDcMotor
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, PidGains

#: The Pololu 37D 30:1 with its 64-count encoder: 40 ticks per 33 ms frame = 3.97 rad/s.
POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}
SPEED_40_TICKS = 40 * 2 * math.pi / (64 * 30.0) / 0.033


def firmware(**config) -> Firmware:
    """A board powered on at t = 0 (warnings collected in .warnings)."""
    warnings: list[str] = []
    board = Firmware(FirmwareConfig(**config), 0.0, warn=warnings.append)
    board.warnings = warnings
    return board


def send(board: Firmware, text: str, now: float) -> bytes:
    """One command at ``now``; its reply."""
    replies = [
        board.execute(command, now)
        for command in map(board.feed_byte, text.encode("ascii") + b"\r")
        if command is not None
    ]
    assert len(replies) == 1
    return replies[0]


def counts(board: Firmware) -> tuple[int, int]:
    """The board's counters now."""
    return board.encoder(0), board.encoder(1)


def test_the_pwm_of_a_scripted_run_is_the_speed_loop_driven_by_the_same_counts():
    """Replaying the board's frames and commands through a FirmwareSpeedLoop gives its PWM."""
    board = firmware(motor="dc", variant="joshnewans", **POLOLU)
    script = [(0.0, "m 40 40"), (1.0101, "m 0 0"), (1.5, "m 40 20"), (4.2, "o 100 0"),
              (4.5, "m 30 30"), (4.8, "r"), (5.0, "m 25 0")]  # fmt: skip
    commands = []  # (time, text, counts just before it)
    for when, text in script:
        board.advance(when)
        commands.append((when, text, counts(board)))
        assert send(board, text, when) == b"OK\r\n"
        if text == "m 0 0":
            assert board.loop.pwm == (0, 0) and board.motors[0].target_rad_s == 0.0  # at once
    board.advance(6.0)
    assert board.auto_stop_times == [pytest.approx(3.501)]  # 1.5 s + 2001 ms, no m/o between

    frames = list(board.frames)
    # On the 33 ms grid, a millisecond after it (the firmware's millis() > nextPID).
    grid = [round((when - 0.001) / 0.033, 6) for when, _, _ in frames]
    assert grid == list(range(1, len(frames) + 1))
    replay = FirmwareSpeedLoop((0, 0))
    events = sorted(
        [(when, 0, ("frame", frame_counts, pwm)) for when, frame_counts, pwm in frames]
        + [(when, 1, ("command", text, before)) for when, text, before in commands]
        + [(when, 1, ("auto-stop", None, None)) for when in board.auto_stop_times],
        key=lambda event: (event[0], event[1]),  # a frame at the same instant runs first
    )
    for _, _, (kind, detail, extra) in events:
        if kind == "frame":
            assert replay.frame(detail) == extra
        elif kind == "auto-stop":
            replay.auto_stop()
        elif detail == "r":
            replay.reset_encoders()
        elif detail.startswith("o"):
            replay.raw_pwm(tuple(int(v) for v in detail.split()[1:]), extra)
        else:
            replay.command(tuple(int(v) for v in detail.split()[1:]), extra)
    assert replay.pwm == board.loop.pwm
    # The auto-stop caught the motors turning: the next frame reset the loop (output 0), and
    # the PWM stayed 0 until the o.
    after_stop = [pwm for when, _, pwm in frames if 3.501 < when < 4.2]
    assert after_stop and all(pwm == (0, 0) for pwm in after_stop)
    assert any(pwm[0] > 0 for when, _, pwm in frames if when < 1.0101)


def test_the_dc_motor_on_the_board_has_the_simulated_backends_ripple():
    """Same motor, scale and frame grid: the board's speed is the PidDrivenDcMotor's."""
    board = firmware(motor="dc", **POLOLU)
    drive = PidDrivenDcMotor(DcMotor(DcMotorParameters()), Scale(**POLOLU))
    drive.command(4.0)
    assert send(board, "m 40 0", 0.0) == b"OK\r\n"
    speeds = []
    for step in range(1, 151):
        board.advance(step * 0.01)
        drive.advance(0.01)
        assert board.motors[0].speed_rad_s == pytest.approx(drive.speed_rad_s, rel=1e-9, abs=1e-9)
        speeds.append(board.motors[0].speed_rad_s)
    settled = speeds[100:]
    assert sum(settled) / len(settled) == pytest.approx(SPEED_40_TICKS, rel=0.05)
    # Unloaded, the integer loop stops in its dead band (|20 error| < 50): a steady PWM and a
    # speed error of up to 2 ticks per frame, which the ideal motor does not have.
    assert len({pwm for _, _, pwm in list(board.frames)[-10:]}) == 1
    assert 0.0 < abs(settled[-1] - SPEED_40_TICKS) <= 2 / 40 * SPEED_40_TICKS
    assert board.motors[1].speed_rad_s == 0.0


def test_first_order_motor_driven_by_the_pwm_settles_at_the_target():
    """The first-order lag under the loop holds the commanded ticks per frame on average."""
    board = firmware(motor="first-order")
    send(board, "m 43 43", 0.0)
    board.advance(1.5)
    start = counts(board)
    for step in range(1, 11):  # keep it alive past the auto-stop
        board.advance(1.5 + 0.1 * step)
        send(board, "m 43 43", 1.5 + 0.1 * step)
    delta = counts(board)[0] - start[0]
    assert delta / 1.0 * 0.033 == pytest.approx(43, rel=0.06)
    assert board.loop.pwm[0] == pytest.approx(43 / 0.843, rel=0.1)  # 0.843 ticks/frame per PWM


@pytest.mark.parametrize(
    ("argument", "reason"),
    [("20:12:0:0", "Ko 0"), ("20:12:0", "3 gains"), ("1:2:3:4:5", "5 gains"), ("", "0 gains")],
)
def test_gains_the_board_would_misbehave_on_are_refused(argument, reason):
    """Ko 0 (division by zero), missing or extra gains: Invalid Command, gains kept, reported."""
    board = firmware()
    assert send(board, f"u {argument}", 0.0) == b"Invalid Command\r\n"
    assert board.gains == PidGains() and board.rejected_gains == 1
    assert reason in board.warnings[-1]


def test_gains_take_effect_at_the_next_frame():
    """Empty fields vanish (strtok); the new Kp doubles the first frame's PWM; Ko may be < 0."""
    board = firmware()
    assert send(board, "u 40::12:0:50", 0.0) == b"OK\r\n"
    assert board.gains == PidGains(40, 12, 0, 50)
    send(board, "m 40 0", 0.0)
    board.advance(0.034)
    assert board.loop.pwm == (32, 0)  # 40 * 40 / 50; the default Kp 20 gives 16
    assert send(board, "u 20:12:0:-50", 0.1) == b"OK\r\n"
    assert board.gains.ko == -50


@pytest.mark.slow
def test_dc_board_holds_the_speed_over_the_pty(fake_board, serial_backend, wait_until):
    """``--motor dc``: m 40 40 answered over the pty; the driver's serial path sees ~4 rad/s."""
    board = fake_board(motor="dc", **POLOLU)
    with serial.Serial(str(board.link), 57600, timeout=2.0) as port:
        port.write(b"m 40 40\r")
        assert port.read_until(b"\r\n") == b"OK\r\n"
    firmware_ = board.board.firmware
    wait_until(lambda: firmware_.encoder(1) > 3 * 64 * 30 // 10, 5.0, "the right motor to turn")
    assert firmware_.motors[1].speed_rad_s == pytest.approx(SPEED_40_TICKS, rel=0.15)

    backend = serial_backend(board.link, poll_rate_hz=100.0, **POLOLU)
    wait_until(lambda: backend.status()[0] == 0, 3.0, "status OK")
    backend.set_speed(4.0)
    wait_until(lambda: "m 40 0" in board.commands("m"), 3.0, "m 40 0")
    samples = []

    def collected_for(seconds: float) -> bool:
        sample = backend.read()
        if sample is not None:
            samples.append(sample)
        return bool(samples) and samples[-1].monotonic_s - samples[0].monotonic_s >= seconds

    wait_until(lambda: collected_for(2.5), 10.0, "2.5 s of samples")
    settled = [s for s in samples if s.monotonic_s >= samples[0].monotonic_s + 1.0]
    first, last = settled[0], settled[-1]
    mean_speed = (last.angle_rad - first.angle_rad) / (last.monotonic_s - first.monotonic_s)
    assert mean_speed == pytest.approx(SPEED_40_TICKS, rel=0.05)
    assert firmware_.auto_stop_times == []  # the backend's re-sends kept it alive
    assert firmware_.frames[-1][2][0] > 0  # the loop drives the left motor

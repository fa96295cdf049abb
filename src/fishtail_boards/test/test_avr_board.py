"""The real ROSArduinoBridge firmware in simavr (``make firmware``), alone and with its motors.

These tests run the firmware and the simulator that ``make test`` builds before pytest
(tools/test-firmware.sh; the ``firmware_build`` fixture) where the AVR toolchain and simavr are
installed (tools/test-system-packages.sh installs them as root), and skip, saying why,
otherwise. Nothing here is timed on the host's clock: the firmware's behaviour is read per
simulated millisecond. The serial path's behaviours against the firmware (speed held, wrap,
auto-stop, reset, stop) are in test_two_boards.py, beside the fake board's.
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
import threading
import time
import tty
from pathlib import Path

import pytest

from fishtail_boards.avr_board import (
    SET_POINT_ENCODER,
    SET_POINT_PREV_ENC,
    MotorSide,
    SimulatedBoard,
    built_artifacts,
    firmware_variables,
)
from fishtail_boards.board_motors import DcChannelMotor
from fishtail_plant.motor.board_units import INT32_MAX, Scale
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop

#: The Pololu 37D 30:1 with its 64-count encoder.
SCALE = Scale(64, 30.0)
DC_PARAMETERS = dataclasses.replace(DcMotorParameters(), gear_ratio=SCALE.gear_ratio)


@pytest.fixture
def artifacts(firmware_build: Path) -> tuple[Path, Path]:
    """The firmware ELF and the simulator (make firmware); skip without the toolchain."""
    found = built_artifacts(firmware_build)
    assert found is not None
    return found


def start(argv: list[str], stderr: Path) -> subprocess.Popen:
    """Start a board process (its stdout, the pty path, discarded; stderr to a file)."""
    with open(stderr, "wb") as err:
        return subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err,
            env=dict(os.environ), start_new_session=True,
        )  # fmt: skip


def stop(process: subprocess.Popen) -> None:
    """SIGTERM and wait."""
    if process.poll() is None:
        process.send_signal(signal.SIGTERM)
        process.wait(5.0)


def wait_for(path: Path, timeout_s: float = 10.0) -> Path:
    """``path`` once a board process has made it."""
    deadline = time.monotonic() + timeout_s
    while not path.exists():
        assert time.monotonic() < deadline, f"no {path} within {timeout_s} s"
        time.sleep(0.05)
    return path


@pytest.fixture
def avr_board(firmware_build, tmp_path):
    """``avr_board(*args)``: ``fishtail-avr-board`` at ``tmp_path/board``: link, process, stderr."""
    processes: list[subprocess.Popen] = []

    def launch(*args: str) -> tuple[Path, subprocess.Popen, Path]:
        link = tmp_path / "board"
        argv = [sys.executable, "-m", "fishtail_boards.avr_board", "--link", str(link),
                "--build-dir", str(firmware_build), *args]  # fmt: skip
        stderr = tmp_path / "avr_board.stderr"
        processes.append(start(argv, stderr))
        return wait_for(link), processes[-1], stderr

    yield launch
    for process in processes:
        stop(process)


def test_the_built_firmware_answers_over_its_pty(artifacts, raw_port, tmp_path):
    """The simulator alone (no motors): ``b``, ``e``, ``m 20 20`` as the joshnewans fork answers."""
    elf, simulator = artifacts
    link = tmp_path / "board"
    process = start([str(simulator), str(elf), "--link", str(link)], tmp_path / "sim.stderr")
    try:
        port = raw_port(wait_for(link))
        assert port.ask("b") == "57600"
        assert port.ask("e") == "0 0"
        assert port.ask("m 20 20") == "OK"
        assert port.ask("e") == "0 0"  # no motors attached: the encoders stand still
    finally:
        stop(process)
    assert not link.exists()


def test_motor_side_answers_pwms_with_encoder_counts():
    """One exchange: the DC motors move on by the time between lines at the PWM read before."""
    from fishtail_boards.avr_board import _motors, _parser

    side = MotorSide(_motors(_parser().parse_args([])))
    assert side.exchange("D 1000 0 0") == "0 0\n"
    for step in range(2, 502):
        answer = side.exchange(f"D {step * 1000} 255 -255")
    left, right = map(int, answer.split())
    assert left > 100 and right < -100 and side.pwm == (255, -255)
    with pytest.raises(ValueError, match="unexpected line"):
        side.exchange("X 1 2 3")


def test_the_motors_can_come_from_a_motor_file():
    """``--motor FILE``: its motor at ``--gear-ratio`` or the file's default, else refused."""
    from fishtail_boards.avr_board import _motors, _parser

    motors = Path(__file__).resolve().parents[3] / "config" / "motors"
    chosen = _motors(_parser().parse_args(["--motor", str(motors / "pololu-37d-12v.yaml"),
                                           "--gear-ratio", "18.75"]))  # fmt: skip
    assert chosen[0].motor.parameters.gear_ratio == 18.75 and chosen[0].scale.gear_ratio == 18.75
    default = _motors(_parser().parse_args(["--motor", str(motors / "pololu-25d-hp-12v.yaml")]))
    assert default[0].scale.gear_ratio == 46.85
    with pytest.raises(ValueError, match="not offered"):
        _motors(_parser().parse_args(["--motor", str(motors / "pololu-37d-12v.yaml"),
                                      "--gear-ratio", "40"]))  # fmt: skip
    assert _motors(_parser().parse_args([]))[0].motor.parameters == DC_PARAMETERS


def test_the_cli_starts_the_counts_high_and_resets_on_sigusr1(avr_board, raw_port):
    """``--encoder-offset``: ``e`` answers it; SIGUSR1 (DTR) boots the firmware again at 0."""
    link, process, _ = avr_board("--encoder-offset", str(INT32_MAX - 5))
    port = raw_port(link)
    assert port.counts() == (INT32_MAX - 5, INT32_MAX - 5)
    process.send_signal(signal.SIGUSR1)
    deadline = time.monotonic() + 10.0
    while True:  # the reset takes effect within a millisecond of the signal
        assert time.monotonic() < deadline, "the board did not reset"
        try:
            if port.counts(timeout_s=1.0) == (0, 0):
                break
        except (AssertionError, ValueError):
            # No reply (RawPort's NoReplyError) to a request the reboot swallowed, or a reply it
            # cut short: ask again.
            port.drain()
    assert port.ask("b") == "57600"


def test_a_reset_while_the_simulator_waits_for_its_motors_does_not_end_it(
    firmware_build, raw_port, tmp_path
):
    """SIGUSR1 sent while the simulator waits for the motor side's answer: it boots, runs on.

    The motor side sends the reset from inside its answer, so the signal always lands while the
    simulator is blocked reading that answer (on a loaded host, where it spends most of its time).
    """
    reset_sent = threading.Event()
    board_holder: list[SimulatedBoard] = []

    def observe(now_us: int, pwm: tuple[int, int], watched: tuple[int, ...]) -> None:
        if now_us >= 50_000 and board_holder and not reset_sent.is_set():
            board_holder[0].reset()
            time.sleep(0.05)  # the signal is delivered before the answer goes out
            reset_sent.set()

    motors = [DcChannelMotor(DC_PARAMETERS, SCALE) for _ in range(2)]
    with open(tmp_path / "sim.stderr", "wb") as stderr:
        board = SimulatedBoard(motors, tmp_path / "board", firmware_build,
                               observer=observe, stderr=stderr)  # fmt: skip
    board_holder.append(board)
    try:
        assert board.ready.wait(10.0), "the simulator did not start"
        assert reset_sent.wait(30.0), "the reset was never sent"
        deadline = time.monotonic() + 30.0
        while board.process.poll() is None and board.simulated_s() < 0.2:
            assert time.monotonic() < deadline, "the simulator stands still after the reset"
            time.sleep(0.01)
        assert board.process.poll() is None, "the reset ended the simulator"
        port = raw_port(tmp_path / "board")
        assert port.ask("b") == "57600", "the board did not answer after the reset"
    finally:
        board.stop()


#: A scripted run: (simulated seconds, left and right ticks per frame). Opposite signs, a stop
#: mid-run (m 0 0, the loop reset), a restart beyond the motor's speed (the PWM saturates at 255,
#: the integral clamp), and at the end no command for over 2 s: the firmware's auto-stop, without
#: a reset, while the motors still turn, and the stopped frame's reset after it.
SCRIPT = [(0.1, (40, 40)), (0.8, (20, -30)), (1.4, (0, 0)), (1.7, (400, 25)), (2.3, (-15, 50))]
RUN_S = 4.8
#: The firmware variables watched per millisecond (build/firmware/symbols.txt names, offsets).
WATCHED = [("nextPID", 0, 4), ("lastMotorCommand", 0, 4), ("moving", 0, 1),
           ("leftPID", SET_POINT_ENCODER, 4), ("rightPID", SET_POINT_ENCODER, 4),
           ("leftPID", SET_POINT_PREV_ENC, 4), ("rightPID", SET_POINT_PREV_ENC, 4)]  # fmt: skip


def signed32(value: int) -> int:
    """An unsigned 32-bit word as the firmware's ``long``."""
    return value - (1 << 32) if value >= 1 << 31 else value


def test_firmware_speed_loop_gives_the_firmware_pwm_frame_by_frame(firmware_build, tmp_path):
    """FirmwareSpeedLoop on the encoder counts the firmware read: the same PWM at every frame.

    The firmware runs a scripted series of ``m`` commands in simavr with its DC motors. Per
    simulated millisecond the simulator reports the PWM on the L298 pins and the firmware's own
    variables: when ``nextPID`` moves a PID frame ran (its encoder readings are in
    ``leftPID.Encoder``/``rightPID.Encoder``), when ``lastMotorCommand`` moves an ``m`` ran (a
    stop's reset reads the encoders into PrevEnc), when ``moving`` falls without a command the
    auto-stop cut the motors. The emulation replays those events in order and must give the
    firmware's PWM after every one of them, exactly.

    Each command is written just after a frame (from the motor side, while the simulator waits
    for its answer), so that it runs well before the next one: two events in one millisecond
    would leave their order unknown, and the test says so if it happens.
    """
    variables = firmware_variables(firmware_build)
    extra = [arg for name, offset, size in WATCHED
             for arg in ("--watch", f"{variables[name][0] + offset:#x}:{size}")]  # fmt: skip
    records: list[tuple[int, tuple[int, int], tuple[int, ...]]] = []
    pending = list(SCRIPT)
    port_fd: list[int] = []
    finished = threading.Event()

    def observe(now_us: int, pwm: tuple[int, int], watched: tuple[int, ...]) -> None:
        frame_ran = bool(records) and records[-1][2][0] != watched[0]
        records.append((now_us, pwm, watched))
        if port_fd and pending and frame_ran and now_us >= pending[0][0] * 1e6:
            left, right = pending.pop(0)[1]
            os.write(port_fd[0], f"m {left} {right}\r".encode("ascii"))
        if now_us >= RUN_S * 1e6:
            finished.set()

    motors = [DcChannelMotor(DC_PARAMETERS, SCALE) for _ in range(2)]
    with open(tmp_path / "sim.stderr", "wb") as stderr:
        board = SimulatedBoard(motors, tmp_path / "board", firmware_build, extra,
                               observer=observe, stderr=stderr)  # fmt: skip
    try:
        assert board.ready.wait(10.0), "the simulator did not start"
        port_fd.append(os.open(tmp_path / "board", os.O_RDWR | os.O_NOCTTY))
        tty.setraw(port_fd[0])
        assert finished.wait(120.0), "the scripted run did not finish"
    finally:
        board.stop()
        if port_fd:
            os.close(port_fd[0])
    assert not pending, f"commands never sent: {pending}"

    # The events of each millisecond, from the change of the watched variables.
    previous = (33, 2000, 0, 0, 0, 0, 0)  # the firmware's initial values
    events: list[str | None] = []
    for _, _, watched in records:
        frame_ran = watched[0] != previous[0]
        command_ran = watched[1] != previous[1]
        auto_stopped = bool(previous[2]) and not watched[2] and not command_ran
        assert frame_ran + command_ran + auto_stopped <= 1, (
            f"two events in one millisecond ({len(events)} ms): their order is unknown"
        )
        events.append("frame" if frame_ran else "command" if command_ran
                      else "auto-stop" if auto_stopped else None)  # fmt: skip
        previous = watched

    loop = FirmwareSpeedLoop(counts=(0, 0))
    commands = iter(targets for _, targets in SCRIPT)
    frames = compared = 0
    for index, (now_us, pwm, watched) in enumerate(records[:-1]):
        event, following = events[index], records[index + 1][2]
        if event == "command":
            # resetPID's encoder reading (m 0 0) may land in the next millisecond.
            prev_enc = (signed32(following[5]), signed32(following[6]))
            loop.command(next(commands), counts=prev_enc)
        elif event == "auto-stop":
            loop.auto_stop()
        elif event == "frame":
            loop.frame((signed32(watched[3]), signed32(watched[4])))
            frames += 1
        # A millisecond can end inside setMotorSpeeds(): the PWM is whole only once the variable
        # written after it (nextPID, moving) has changed, or a millisecond after an m's stamp.
        if event == "command" or events[index + 1] in ("frame", "auto-stop"):
            continue
        assert loop.pwm == pwm, (
            f"at {now_us / 1e3:.0f} ms (frame {frames}): emulation {loop.pwm}, firmware {pwm}"
        )
        compared += 1
    assert frames >= RUN_S / 0.033 - 3 and compared > 0.9 * len(records)
    assert next(commands, None) is None, "not every scripted command was seen to run"
    assert max(abs(p) for _, (p, _), _ in records) == 255, "the script never saturated the PWM"

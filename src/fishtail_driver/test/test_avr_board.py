"""The real ROSArduinoBridge firmware in simavr (``make firmware``), alone and with its motors.

These tests build the firmware and the simulator (firmware/build.sh) when the AVR toolchain and
simavr are installed (tools/test-system-packages.sh installs them as root) and skip otherwise.
Simulated time is paced to wall time, so speeds are measured on the host's clock, as the serial
backend measures them.
"""

from __future__ import annotations

import math
import os
import re
import select
import signal
import subprocess
import sys
import time
import tty
from pathlib import Path

import pytest

from fishtail_driver.avr_board import MotorSide, built_artifacts

ROOT = Path(__file__).resolve().parents[3]
BUILD_DIR = ROOT / "build" / "firmware"
#: The Pololu 37D 30:1 with its 64-count encoder: 40 ticks per 33 ms frame = 3.97 rad/s.
POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}
FRAME_S = 0.033


@pytest.fixture(scope="module")
def artifacts() -> tuple[Path, Path]:
    """The firmware ELF and the simulator, built now (make firmware); skip without the toolchain."""
    build = subprocess.run(
        [str(ROOT / "firmware" / "build.sh")], capture_output=True, text=True, check=False
    )
    if build.returncode in (2, 3):  # no toolchain / no sketch: the reason is the first line
        reason = (build.stderr.strip().splitlines() or ["no output"])[0]
        pytest.skip(f"firmware in simavr: {reason}")
    assert build.returncode == 0, f"make firmware failed:\n{build.stdout}{build.stderr}"
    found = built_artifacts(BUILD_DIR)
    assert found is not None, "make firmware left no ELF or simulator"
    return found


class Pty:
    """The board's serial port in raw mode, one command and its reply line at a time."""

    def __init__(self, path: Path, timeout_s: float = 10.0) -> None:
        """Open ``path`` once the simulator has made it."""
        deadline = time.monotonic() + timeout_s
        while not path.exists():
            assert time.monotonic() < deadline, f"no {path} within {timeout_s} s"
            time.sleep(0.05)
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self.fd)

    def ask(self, command: str, timeout_s: float = 2.0) -> str:
        """Send ``command`` with its CR; the reply line without CR LF."""
        os.write(self.fd, command.encode("ascii") + b"\r")
        reply, deadline = b"", time.monotonic() + timeout_s
        while not reply.endswith(b"\r\n"):
            left = deadline - time.monotonic()
            assert left > 0, f"no reply to {command!r} (got {reply!r})"
            if select.select([self.fd], [], [], left)[0]:
                reply += os.read(self.fd, 256)
        return reply.decode("ascii").strip()

    def counts(self) -> tuple[int, int]:
        """The encoder counts (``e``)."""
        left, right = self.ask("e").split()
        return int(left), int(right)

    def close(self) -> None:
        """Close the port."""
        os.close(self.fd)


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


def most_behind_ms(stderr: Path) -> float:
    """How far an ended simulator fell behind wall time at most, from its last line on stderr."""
    text = stderr.read_text(errors="replace")
    found = re.findall(r"at most ([0-9.]+) ms behind", text)
    assert found, f"the simulator did not report its clock: {text}"
    return float(found[-1])


def check_in_real_time(process: subprocess.Popen, stderr: Path, failure: str | None) -> None:
    """Stop the board; skip if the host could not run it at wall-clock pace, else fail on failure.

    Speeds are measured on the host's clock: a simulator starved of CPU (a busy machine) falls
    behind and so does its motor; that says nothing of the firmware. 30 ms behind is 2 % of the
    tests' 1.5 s windows.
    """
    stop(process)
    behind_ms = most_behind_ms(stderr)
    if behind_ms > 30.0:
        pytest.skip(f"firmware in simavr: fell {behind_ms:.0f} ms behind wall time, host too busy")
    if failure is not None:
        pytest.fail(failure)


@pytest.fixture
def avr_board(artifacts, tmp_path):
    """``fishtail-avr-board`` (the firmware with its DC motors) on ``tmp_path/board``."""
    link = tmp_path / "board"
    argv = [sys.executable, "-m", "fishtail_driver.avr_board", "--link", str(link),
            "--build-dir", str(artifacts[0].parent)]  # fmt: skip
    stderr = tmp_path / "avr_board.stderr"
    process = start(argv, stderr)
    port = Pty(link)
    yield port, link, process, stderr
    port.close()
    stop(process)


def test_the_built_firmware_answers_over_its_pty(artifacts, tmp_path):
    """The simulator alone (no motors): ``b``, ``e``, ``m 20 20`` as the joshnewans fork answers."""
    elf, simulator = artifacts
    link = tmp_path / "board"
    process = start([str(simulator), str(elf), "--link", str(link)], tmp_path / "sim.stderr")
    try:
        port = Pty(link)
        assert port.ask("b") == "57600"
        assert port.ask("e") == "0 0"
        assert port.ask("m 20 20") == "OK"
        assert port.ask("e") == "0 0"  # no motors attached: the encoders stand still
        port.close()
    finally:
        stop(process)
    assert not link.exists()


def test_motor_side_answers_pwms_with_encoder_counts():
    """One exchange: the DC motors move on by the time between lines at the PWM read before."""
    from fishtail_driver.avr_board import _motors, _parser

    side = MotorSide(_motors(_parser().parse_args([])))
    assert side.exchange("D 1000 0 0") == "0 0\n"
    for step in range(2, 502):
        answer = side.exchange(f"D {step * 1000} 255 -255")
    left, right = map(int, answer.split())
    assert left > 100 and right < -100 and side.pwm == (255, -255)
    with pytest.raises(ValueError, match="unexpected line"):
        side.exchange("X 1 2 3")


def test_the_firmware_pid_holds_40_ticks_per_frame_and_stops_itself(avr_board):
    """``m 40 40``: the counts grow at ~40 per 33 ms frame; 2 s after the last ``m`` they stop."""
    port, _, process, stderr = avr_board
    assert port.ask("b") == "57600"
    assert port.ask("m 40 40") == "OK"
    time.sleep(1.0)  # the loop settles
    assert port.ask("m 40 40") == "OK"
    start_counts, start_s = port.counts(), time.monotonic()
    time.sleep(1.5)
    end_counts, end_s = port.counts(), time.monotonic()
    frames = (end_s - start_s) / FRAME_S
    rates = [(end_counts[c] - start_counts[c]) / frames for c in (0, 1)]
    time.sleep(1.5)  # 3 s after the last m: the auto-stop has cut the PWM, the motor coasted down
    stopped = port.counts()
    time.sleep(0.5)
    moved = port.counts() != stopped
    off = [rate for rate in rates if abs(rate / 40.0 - 1.0) > 0.06]
    failure = f"ticks per frame {rates}, not 40" if off else None
    failure = failure or ("still turning 3 s after the last m" if moved else None)
    check_in_real_time(process, stderr, failure)


def test_the_serial_backend_holds_the_carrier_speed_on_the_real_firmware(
    avr_board, serial_backend, wait_until
):
    """The driver's serial backend at 3.97 rad/s (40 ticks per frame) holds it within a few %."""
    _, link, process, stderr = avr_board
    speed = 40 * 2 * math.pi / (64 * 30.0) / FRAME_S
    backend = serial_backend(link, poll_rate_hz=100.0, **POLOLU)
    wait_until(lambda: backend.status()[0] == 0, 10.0, "status OK")
    backend.set_speed(speed)
    time.sleep(1.5)  # settle
    first = backend.read()
    time.sleep(3.0)
    last = backend.read()
    assert first is not None and last is not None
    mean = (last.angle_rad - first.angle_rad) / (last.monotonic_s - first.monotonic_s)
    off = abs(mean / speed - 1.0) > 0.04
    check_in_real_time(process, stderr, f"mean {mean:.3f} rad/s, not {speed:.3f}" if off else None)

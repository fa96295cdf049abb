"""The real firmware in simavr: the simulator's CPU, the command round trip beside the fake board.

Prints figures only. ``fishtail-avr-board`` (ROSArduinoBridge built for a Nano by ``make
firmware``, in simavr at 16 MHz paced to wall time, its motors the DC gear motor) is measured

* while the serial backend polls it at the driver's default rate (100 Hz) with the motor turning,
  and while nobody talks to it: the CPU of the simulator (C, libsimavr) and of its motor side
  (Python), and how far simulated time fell behind wall time;
* for the command round trip of ``m`` and ``e`` at 57600 baud, the method of bench_serial.py,
  beside ``fishtail-fake-board`` unpaced (a pty at memory speed) and ``--pace-baud`` (the line
  time added). The firmware's UART runs at 57600 baud in simulated time, so its figures include
  the line time, the firmware's own parsing and a millisecond of lockstep at most.

Skipped (one line, exit 0) where the AVR toolchain is missing. Run with ``make bench`` (or
``python bench/bench_firmware.py``).
"""

from __future__ import annotations

import math
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_serial import percentile, round_trips, start_board
from fishtail_boards.avr_board import built_artifacts
from fishtail_driver.protocol import encode_motor_speeds, encode_read_encoders
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig
from measure import ROOT, cpu_seconds

BAUD = 57600
POLL_RATE_HZ = 100.0  # the driver's serial_poll_rate_hz default
MEASURE_S = 6.0
#: 40 ticks per 33 ms frame of the Pololu 37D 30:1 with its 64-count encoder [rad/s].
SPEED_RAD_S = 40 * 2 * math.pi / (64 * 30) / 0.033


def build() -> str | None:
    """Build the firmware and the simulator; why not, or None."""
    done = subprocess.run([str(ROOT / "firmware" / "build.sh")], capture_output=True, text=True)
    if done.returncode != 0:
        return (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[0]
    return None if built_artifacts(ROOT / "build" / "firmware") else "nothing built"


def start_firmware(link: Path, stderr_path: Path) -> subprocess.Popen:
    """``fishtail-avr-board`` at ``link``, once its pty is there."""
    with open(stderr_path, "wb") as stderr:
        board = subprocess.Popen(
            [sys.executable, "-m", "fishtail_boards.avr_board", "--link", str(link),
             "--build-dir", str(ROOT / "build" / "firmware")],
            stdout=subprocess.PIPE, stderr=stderr, text=True, start_new_session=True,
        )  # fmt: skip
    assert board.stdout is not None
    board.stdout.readline()  # the pty path: the board is ready
    return board


def simulator_pid(board: subprocess.Popen) -> int:
    """The simulator's process: the motor side's child."""
    children = Path(f"/proc/{board.pid}/task/{board.pid}/children").read_text().split()
    return int(children[0])


def stop_firmware(board: subprocess.Popen, stderr_path: Path) -> str:
    """SIGTERM; the simulator's last line (simulated and wall time, how far behind)."""
    board.send_signal(signal.SIGTERM)
    board.wait(10)
    lines = re.findall(r"avr_board: .*behind", stderr_path.read_text(errors="replace"))
    return lines[-1] if lines else "(no report)"


def cpu_while(board: subprocess.Popen, link: Path | None) -> tuple[float, float, float]:
    """CPU fractions of the simulator and the motor side over MEASURE_S, and the poll rate.

    With ``link`` the serial backend polls the board at POLL_RATE_HZ and turns the motor.
    """
    backend = None
    if link is not None:
        config = SerialConfig(port=str(link), baud=BAUD, poll_rate_hz=POLL_RATE_HZ,
                              counts_per_revolution=64, gear_ratio=30.0)  # fmt: skip
        backend = SerialBackend(config)
        backend.start()
        deadline = time.monotonic() + 10.0
        while backend.status()[0] != 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"backend did not connect: {backend.status()[1]}")
            time.sleep(0.01)
        backend.set_speed(SPEED_RAD_S)
        time.sleep(1.0)
    try:
        simulator = simulator_pid(board)
        polls = int(backend.status()[2].get("polls", "0")) if backend else 0
        start, sim0, side0 = time.monotonic(), cpu_seconds(simulator), cpu_seconds(board.pid)
        time.sleep(MEASURE_S)
        elapsed = time.monotonic() - start
        sim_cpu = (cpu_seconds(simulator) - sim0) / elapsed
        side_cpu = (cpu_seconds(board.pid) - side0) / elapsed
        rate = (int(backend.status()[2].get("polls", "0")) - polls) / elapsed if backend else 0.0
    finally:
        if backend is not None:
            backend.close()
    return sim_cpu, side_cpu, rate


def rtt_row(name: str, link: Path) -> str:
    """``m`` and ``e`` round trips (median, p99) against the board at ``link``."""
    m_times, _ = round_trips(link, BAUD, encode_motor_speeds(43, 0))
    e_times, _ = round_trips(link, BAUD, encode_read_encoders())
    m_ms = statistics.median(m_times) * 1e3, percentile(m_times, 0.99) * 1e3
    e_ms = statistics.median(e_times) * 1e3, percentile(e_times, 0.99) * 1e3
    return (f"{name:>26} | {m_ms[0]:>9.3f} {m_ms[1]:>7.3f} | {e_ms[0]:>9.3f} {e_ms[1]:>7.3f} "
            f"| {1 / statistics.median(e_times):>8.0f}")  # fmt: skip


def main() -> int:
    """Measure and print."""
    print(__doc__.split("\n\n")[0])
    reason = build()
    if reason is not None:
        print(f"skipped: firmware in simavr: {reason}")
        return 0
    print(f"{os.cpu_count()} CPUs, other work may be running; CPU in % of one core\n")
    with tempfile.TemporaryDirectory(prefix="fishtail-bench-") as directory:
        folder = Path(directory)
        for label, polled in (("idle (no host)", False), (f"polled {POLL_RATE_HZ:g} Hz", True)):
            link, stderr = folder / f"tty{int(polled)}", folder / f"board{int(polled)}.stderr"
            board = start_firmware(link, stderr)
            try:
                sim_cpu, side_cpu, rate = cpu_while(board, link if polled else None)
            finally:
                report = stop_firmware(board, stderr)
            achieved = f", {rate:.1f} polls/s achieved" if polled else ""
            print(f"{label:>16}: simulator {sim_cpu * 100:5.1f} %, motor side "
                  f"{side_cpu * 100:5.1f} %{achieved}; {report}")  # fmt: skip

        header = (f"{'board at 57600 baud':>26} | {'m rtt med':>9} {'p99':>7} | "
                  f"{'e rtt med':>9} {'p99':>7} | {'e/s max':>8}")  # fmt: skip
        print(f"\n{header}\n{'-' * len(header)}")
        for name, paced in (("fake board, pty", False), ("fake board, --pace-baud", True)):
            link = folder / f"fake{int(paced)}"
            fake = start_board(link, BAUD, paced)
            try:
                print(rtt_row(name, link))
            finally:
                fake.terminate()
                fake.wait(5)
        link, stderr = folder / "ttyrtt", folder / "rtt.stderr"
        board = start_firmware(link, stderr)
        try:
            print(rtt_row("firmware in simavr", link))
        finally:
            report = stop_firmware(board, stderr)
        print(f"{'':>26}   ({report})")
    print("\nround trips in ms; e/s max: 1 / median e round trip.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

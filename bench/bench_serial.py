"""Serial backend throughput over a pty: command round trip and achieved encoder poll rate.

Prints figures only. Targets: >= 100 Hz encoder polling at 57600 baud, >= 500 Hz at 1 000 000.

A pty moves bytes at memory speed whatever baud rate is configured, so every figure is measured
twice against the emulated board (``fishtail-fake-board``, run as its own process):

* ``pty``: unpaced, an upper bound that shows the host-side cost (Python, pyserial, the pty);
* ``paced``: the board delays every byte by its line time at the baud rate (10 bits per byte,
  ``--pace-baud``), which is what a real UART adds at best.

The theoretical bound printed next to them is the line time of the bytes one exchange moves.
Neither includes what real hardware adds on top: the USB-serial adapter's latency (an FTDI chip
flushes every 16 ms by default: set its latency_timer to 1 ms), the board's own processing and its
64-byte transmit buffer. Real figures are lower; measure on the target with this script's method.
Run with ``make bench`` (or ``python bench/bench_serial.py``).
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import serial

from fishtail_driver.protocol import LineFramer, encode_motor_speeds, encode_read_encoders
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig

BAUDS = ((57600, 100.0), (1_000_000, 500.0))
ROUND_TRIP_S = 1.5
POLL_S = 2.0
BITS_PER_BYTE = 10  # start bit, 8 data bits, stop bit


def start_board(link: Path, baud: int, paced: bool) -> subprocess.Popen:
    """A fishtail-fake-board process serving a pty at ``link``."""
    argv = [sys.executable, "-m", "fishtail_boards.fake_board", "--link", str(link),
            "--baud", str(baud)]  # fmt: skip
    if paced:
        argv.append("--pace-baud")
    board = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
    board.stdout.readline()  # the pty path: the board is ready
    return board


def round_trips(link: Path, baud: int, payload: bytes) -> tuple[list[float], int]:
    """Round-trip times [s] of ``payload`` for ROUND_TRIP_S seconds, and the reply length."""
    times = []
    reply_length = 0
    with serial.Serial(str(link), baud, timeout=0.5) as port:
        framer = LineFramer()
        port.reset_input_buffer()
        end = time.perf_counter() + ROUND_TRIP_S
        while time.perf_counter() < end:
            start = time.perf_counter()
            port.write(payload)
            lines = []
            while not lines:
                data = port.read(max(1, port.in_waiting))
                if not data:
                    raise RuntimeError(f"no reply to {payload!r}")
                lines = framer.feed(data)
            times.append(time.perf_counter() - start)
            reply_length = len(lines[0]) + 2  # CR LF
    return times, reply_length


def achieved_poll_rate(link: Path, baud: int, rate_hz: float) -> float:
    """Encoder samples per second that SerialBackend achieves at ``rate_hz`` (while moving)."""
    backend = SerialBackend(SerialConfig(port=str(link), baud=baud, poll_rate_hz=rate_hz))
    backend.start()
    try:
        deadline = time.monotonic() + 5.0
        while backend.status()[0] != 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"backend did not connect: {backend.status()[1]}")
            time.sleep(0.01)
        backend.set_speed(4.0)
        time.sleep(0.2)

        def polls() -> int:
            return int(backend.status()[2].get("polls", "0"))

        # Every successful e exchange yields a sample (read() hands out the newest one).
        before, start = polls(), time.monotonic()
        time.sleep(POLL_S)
        return (polls() - before) / (time.monotonic() - start)
    finally:
        backend.close()


def percentile(values: list[float], fraction: float) -> float:
    """Nearest-rank percentile."""
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(fraction * len(ordered)))]


def main() -> int:
    """Measure and print."""
    print(__doc__.split("\n\n")[0])
    print(f"pyserial {serial.__version__}, {os.cpu_count()} CPUs; figures in ms and Hz\n")
    header = (f"{'baud':>8} {'mode':>6} | {'m rtt med':>9} {'p99':>6} | {'e rtt med':>9} "
              f"{'p99':>6} | {'line e':>6} {'line m':>6} | {'poll max':>8} "
              f"{'poll@target':>14}")  # fmt: skip
    print(header)
    print("-" * len(header))
    with tempfile.TemporaryDirectory(prefix="fishtail-bench-") as directory:
        for baud, target in BAUDS:
            for paced in (False, True):
                link = Path(directory) / f"tty{baud}{'p' if paced else ''}"
                board = start_board(link, baud, paced)
                try:
                    m_payload = encode_motor_speeds(43, 0)
                    m_times, m_reply = round_trips(link, baud, m_payload)
                    e_payload = encode_read_encoders()
                    e_times, e_reply = round_trips(link, baud, e_payload)
                    maximum = achieved_poll_rate(link, baud, 10000.0)
                    at_target = achieved_poll_rate(link, baud, target)
                finally:
                    board.terminate()
                    board.wait(5)
                line_e = (len(e_payload) + e_reply) * BITS_PER_BYTE / baud
                line_m = (len(m_payload) + m_reply) * BITS_PER_BYTE / baud
                m_ms = statistics.median(m_times) * 1e3, percentile(m_times, 0.99) * 1e3
                e_ms = statistics.median(e_times) * 1e3, percentile(e_times, 0.99) * 1e3
                print(
                    f"{baud:>8} {'paced' if paced else 'pty':>6} | "
                    f"{m_ms[0]:>9.3f} {m_ms[1]:>6.3f} | {e_ms[0]:>9.3f} {e_ms[1]:>6.3f} | "
                    f"{line_e * 1e3:>6.3f} {line_m * 1e3:>6.3f} | {maximum:>8.0f} "
                    f"{at_target:>8.1f}/{target:<5.0f}"
                )  # fmt: skip
            worst_e = (len(encode_read_encoders()) + 25) * BITS_PER_BYTE / baud
            print(
                f"{'':>8} bound: e with the longest reply (25 bytes) takes {worst_e * 1e3:.3f} ms "
                f"on the line: at most {1 / worst_e:.0f} polls/s; the typical reply above allows "
                f"{1 / line_e:.0f}/s"
            )
    print(
        "\nline e / line m: theoretical line time of one exchange (command + reply bytes x 10 "
        "bits / baud).\npty rows are upper bounds (a pty ignores the baud rate); paced rows add "
        "the line time;\nreal hardware adds USB latency and board processing on top of both."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""fishtail-run end to end: the suite starts, the tail beats, a verdict shows, everything stops."""

from __future__ import annotations

import doctest
import os
import signal
import subprocess
import sys
import time

import fishtail_bringup.console

RUN_TIMEOUT_S = 60.0


def test_console_doctests():
    result = doctest.testmod(fishtail_bringup.console)
    assert result.attempted > 0 and result.failed == 0


def test_bounded_run_shows_beats_and_a_symmetric_verdict(ros_domain):
    # 12 rad/s gives a beat every 0.52 s, so 6 s is several beats even with slow discovery.
    completed = subprocess.run(
        [sys.executable, "-m", "fishtail_bringup.run", "--speed", "12", "--duration", "6"],
        env=os.environ.copy(),
        capture_output=True,
        text=True,
        timeout=RUN_TIMEOUT_S,
    )
    output = completed.stdout + completed.stderr
    assert completed.returncode == 0, output
    assert "driver up" in output and "kinematics up" in output and "monitor up" in output
    last = next(line for line in output.splitlines() if line.startswith("fishtail-run: last state"))
    assert " OK: symmetric" in last, output
    assert "motor commanded to stop" in output


def test_sigint_stops_every_node(ros_domain):
    process = subprocess.Popen(
        [sys.executable, "-m", "fishtail_bringup.run", "--mechanism", "undulatory"],
        env=os.environ.copy(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    deadline = time.monotonic() + RUN_TIMEOUT_S
    # Wait until the console shows a computed tail state, i.e. all nodes run and talk.
    for line in process.stdout:
        lines.append(line)
        if "carrier" in line and "--" not in line.split("carrier")[1][:12]:
            break
        assert time.monotonic() < deadline, "".join(lines)
    process.send_signal(signal.SIGINT)
    rest, _ = process.communicate(timeout=RUN_TIMEOUT_S)
    output = "".join(lines) + rest
    assert process.returncode == 0, output
    assert "motor commanded to stop; driver exiting" in output
    assert "non-zero status" not in output and "killed" not in output

"""fishtail-run on a loaded computer: two CPU hogs beside the suite, no flapping, no watchdog stop.

The suite as ``make run`` starts it (driver, kinematics, monitor, each a process, commanded by
fishtail-run at 4 rad/s) with two processes that each keep a core busy. Over 30 diagnostics
periods of the driver (counted as they arrive, not timed) no status may go back to a level it
left after the suite settled (the first judged beat): the gaps and rates of a loaded computer
must not flip WARN and OK (docs/kinematics.md, "Gaps and rate"), and the driver's watchdog must
never stop the motor (docs/serial.md, "The command watchdog and its margin").
"""

from __future__ import annotations

import itertools
import re
import signal
import sys

import pytest

pytestmark = [pytest.mark.integration, pytest.mark.slow]

HOG = [sys.executable, "-c", "while True: pass"]
RUN = [sys.executable, "-m", "fishtail_bringup.run", "--speed", "4"]
#: Driver diagnostics (one a second) to watch once the suite has settled.
PERIODS = 30
#: Generous: a loaded computer starts the nodes slowly; the wait ends at the event.
TIMEOUT_S = 240.0


def flips(levels: list[int]) -> list[int]:
    """The level sequence with repeats removed, if it returns to a level it left; else []."""
    changes = [level for level, _ in itertools.groupby(levels)]
    return changes if len(changes) != len(set(changes)) else []


def test_two_cpu_hogs_flip_no_status_and_never_stop_the_motor(start_process, ros):
    for index in range(2):
        start_process(f"hog{index}", HOG)
    diagnostics = ros.record_diagnostics()
    run = start_process("fishtail-run", RUN)

    def settled_at() -> int | None:
        """Index of the first array that carries a judged verdict of the monitor."""
        for index, array in enumerate(diagnostics.messages):
            for status in array.status:
                if status.name.endswith("tail swing symmetry") and "symmetric" in status.message:
                    return index
        return None

    ros.spin_until(lambda: settled_at() is not None, TIMEOUT_S, "the monitor's first verdict")
    start = settled_at()
    assert start is not None

    def driver_periods() -> int:
        return sum(
            1
            for array in diagnostics.messages[start:]
            for status in array.status
            if status.name.startswith("/driver:")
        )

    ros.spin_until(lambda: driver_periods() >= PERIODS, TIMEOUT_S, f"{PERIODS} driver reports")
    run.send_signal(signal.SIGINT)
    assert run.wait(60.0) == 0, run.output()
    output = run.stdout()

    levels: dict[str, list[int]] = {}
    messages: dict[str, list[str]] = {}
    watchdog_stops = set()
    for array in diagnostics.messages[start:]:
        for status in array.status:
            level = status.level[0] if isinstance(status.level, bytes) else status.level
            levels.setdefault(status.name, []).append(int(level))
            messages.setdefault(status.name, []).append(status.message)
            values = {pair.key: pair.value for pair in status.values}
            if "watchdog_stops" in values:
                watchdog_stops.add(values["watchdog_stops"])
    flipped = {name: flips(sequence) for name, sequence in levels.items() if flips(sequence)}
    assert not flipped, (flipped, {name: messages[name] for name in flipped})
    assert watchdog_stops == {"0"}, watchdog_stops
    assert "no speed command" not in output, output
    margin = re.search(r"speed commands every .*", output)
    assert margin is not None, output
    print(f"under two CPU hogs: {margin.group(0)}")

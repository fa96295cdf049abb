"""A command run until its output shows what a test waits for, then stopped with Ctrl-C.

For the tests of ``fishtail-run`` and the like, which run until Ctrl-C: instead of a fixed
``--duration`` (too short on a loaded machine, wasted time on an idle one), the output is read as
it comes and SIGINT goes to the process as soon as ``seen(output)`` holds.
"""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import threading
import time
from collections.abc import Callable, Sequence

#: How often the output is looked at while waiting [s].
POLL_S = 0.05


@dataclasses.dataclass(frozen=True)
class StoppedRun:
    """What a run printed (stdout and stderr interleaved) and how it ended."""

    returncode: int
    output: str
    #: True when ``seen`` held and SIGINT stopped it; False when it ended by itself or timed out.
    seen: bool
    #: Seconds from the start until ``seen`` held (or the run ended without it).
    waited_s: float


def run_until(
    argv: Sequence[str],
    seen: Callable[[str], bool],
    timeout_s: float,
    exit_timeout_s: float = 60.0,
) -> StoppedRun:
    """Run ``argv`` until ``seen(output so far)`` holds, then SIGINT it and wait for its end.

    If ``seen`` does not hold within ``timeout_s`` the process gets SIGINT all the same, so that
    the test's own assertions show the output. A process that does not end within
    ``exit_timeout_s`` of the SIGINT is killed and the run fails with AssertionError.
    """
    # Unbuffered, so that what a Python program prints arrives as it prints it.
    environment = {**os.environ, "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen(
        list(argv), env=environment, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT, text=True, errors="replace",
    )  # fmt: skip
    chunks: list[str] = []
    assert process.stdout is not None

    def read() -> None:
        assert process.stdout is not None
        for line in process.stdout:
            chunks.append(line)

    reader = threading.Thread(target=read, name="run-until-reader", daemon=True)
    reader.start()
    started = time.monotonic()
    found = False
    while process.poll() is None and time.monotonic() - started < timeout_s:
        if seen("".join(chunks)):
            found = True
            break
        time.sleep(POLL_S)
    waited = time.monotonic() - started
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        process.wait(exit_timeout_s)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
        reader.join(5.0)
        raise AssertionError(
            f"{' '.join(argv)} did not end within {exit_timeout_s:g} s of SIGINT:\n"
            + "".join(chunks)
        ) from None
    reader.join(exit_timeout_s)
    return StoppedRun(process.returncode, "".join(chunks), found, waited)

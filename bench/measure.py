"""What every benchmark shares: the workspace paths, best-of timing, one core, CPU time, verdicts.

Imported by the bench/bench_*.py scripts (run from the repository root, so bench/ is on their
path); not a benchmark itself (`make bench` runs bench/bench_*.py only).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from pathlib import Path

TICKS_PER_S = os.sysconf("SC_CLK_TCK")

#: The workspace, where the benchmarks write (bench/out/) and what they run (config/).
ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "out"
GEOMETRY = ROOT / "config" / "oscillatory.yaml"
FISH = ROOT / "config" / "fish.yaml"


def pin_to_one_core() -> str:
    """Pin this process to its first allowed core; says whether it could ("pinned to one core")."""
    try:
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    except (AttributeError, OSError):
        return "not pinned"
    return "pinned to one core"


def best_of(function: Callable[[], object], repeats: int) -> float:
    """Shortest wall time of ``repeats`` calls, in seconds (the least disturbed run)."""
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def verdict(met: bool) -> str:
    """The word printed after a figure and its target."""
    return "met" if met else "MISSED"


def cpu_seconds(pid: int | str = "self") -> float:
    """CPU time (utime + stime) of a process from /proc/<pid>/stat, seconds."""
    with open(f"/proc/{pid}/stat", encoding="ascii") as stream:
        fields = stream.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICKS_PER_S  # fields 14, 15 of stat

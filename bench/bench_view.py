"""Live view beside the suite at the default rates: its cost to the suite and its own CPU.

The suite as ``fishtail-run --swim`` starts it (driver at its default 200 Hz on the simulated motor,
kinematics and monitor with config/oscillatory.yaml, the swimming simulator with config/fish.yaml),
each a process; a probe in this process commands 4 rad/s. Over WINDOW_S windows, one after the
other on the same suite:

1. the suite alone;
2. with ``fishtail-view`` running and no viewer connected;
3. with one viewer connected: Rerun's own program as a client that saves the stream to a file
   (the native viewer without its window; a browser tab costs the view the same stream);
4. after that viewer left.

CPU is utime + stime of each process from /proc/<pid>/stat over the window, in % of one core; the
client's own CPU is printed beside, not counted in the view's. Figures only, no targets; also
written to bench/out/bench_view.json. Run with `make bench` (about a minute).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fishtail_bringup.view_rerun import free_port
from fishtail_common.interface import SUITE_NODES, SWIM_NODE, TAIL_MARKERS, TAIL_STATE
from fishtail_common.testing import (
    WIDENING_VARIABLES,
    NodeProcess,
    Probe,
    claim_domain,
    isolated_ros_environment,
)
from measure import FISH, GEOMETRY, OUT, ROOT, cpu_seconds

SPEED_RAD_S = 4.0
WARMUP_S = 3.0
WINDOW_S = 10.0
START_TIMEOUT_S = 30.0


def node_argv(module: str, *params_files: Path) -> list[str]:
    """A node's command line, as fishtail-run builds it."""
    argv = [sys.executable, "-m", module, "--ros-args"]
    for path in params_files:
        argv += ["--params-file", str(path)]
    return argv


def window(probe: Probe, processes: dict[str, NodeProcess]) -> dict[str, float]:
    """CPU % of one core of each process over WINDOW_S, after WARMUP_S."""
    probe.spin_for(WARMUP_S)
    start = {name: cpu_seconds(p.pid) for name, p in processes.items()}
    began = time.monotonic()
    probe.spin_for(WINDOW_S)
    wall = time.monotonic() - began
    return {
        name: 100.0 * (cpu_seconds(p.pid) - start[name]) / wall for name, p in processes.items()
    }


def run(work: Path, domain: int) -> dict[str, dict[str, float]]:
    """The four windows; CPU per process in each."""
    suite: dict[str, NodeProcess] = {}
    extra: dict[str, NodeProcess] = {}
    probe = Probe(domain)
    results: dict[str, dict[str, float]] = {}
    try:
        for node in (*SUITE_NODES, SWIM_NODE):
            files = (GEOMETRY, FISH) if node == SWIM_NODE else (GEOMETRY,)
            suite[node.name] = NodeProcess(node.name, node_argv(node.module, *files), work, ROOT)
        probe.command_speed(SPEED_RAD_S)
        probe.wait_for_publishers("fish/odom", timeout=START_TIMEOUT_S)
        probe.wait_for_publishers(TAIL_STATE.name, timeout=START_TIMEOUT_S)
        results["suite alone"] = window(probe, suite)

        grpc = free_port()
        view_argv = [sys.executable, "-m", "fishtail_bringup.view", "--port", str(grpc),
                     "--web-port", str(free_port())]  # fmt: skip
        extra["view"] = NodeProcess("view", view_argv, work, ROOT)
        probe.spin_until(lambda: "live view at" in extra["view"].stdout(), START_TIMEOUT_S, "view")
        results["view, no viewer"] = window(probe, {**suite, **extra})

        client_argv = [shutil.which("rerun") or "rerun", f"rerun+http://127.0.0.1:{grpc}/proxy",
                       "--save", str(work / "client.rrd"), "--bind", "127.0.0.1",
                       "--port", str(free_port())]  # fmt: skip
        extra["client"] = NodeProcess("client", client_argv, work, ROOT)
        probe.wait_for_subscribers(TAIL_MARKERS.name, timeout=START_TIMEOUT_S)
        results["view, one viewer"] = window(probe, {**suite, **extra})

        extra.pop("client").stop()
        probe.spin_until(
            lambda: probe.node.count_subscribers(TAIL_MARKERS.name) == 0,
            START_TIMEOUT_S,
            "the view to let go of the suite",
        )
        results["view, viewer left"] = window(probe, {**suite, **extra})
    finally:
        for process in (*extra.values(), *suite.values()):
            process.stop()
        probe.close()
    return results


def report(results: dict[str, dict[str, float]]) -> None:
    """One block per window: each process, the suite's sum, the view's."""
    print(
        f"live view benchmark: driver 200 Hz, {SPEED_RAD_S:g} rad/s, kinematics (markers 30 Hz "
        f"when subscribed), monitor, simulator (markers 10 Hz); {WINDOW_S:g} s windows; "
        f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}"
    )
    names = [node.name for node in (*SUITE_NODES, SWIM_NODE)]
    alone = sum(results["suite alone"][name] for name in names)
    for label, cpu in results.items():
        suite = sum(cpu[name] for name in names)
        parts = ", ".join(f"{name} {cpu[name]:.1f}" for name in names)
        line = f"  {label:<18} suite {suite:5.1f} % ({suite - alone:+5.1f}; {parts})"
        if "view" in cpu:
            line += f" | view {cpu['view']:5.1f} %"
        if "client" in cpu:
            line += f" | client (not counted) {cpu['client']:5.1f} %"
        print(line)


def main() -> int:
    """Run the windows on a domain of their own, print, write bench/out/bench_view.json."""
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="bench_view_") as tmp, claim_domain() as lock:
        work = Path(tmp)
        for name in WIDENING_VARIABLES:
            os.environ.pop(name, None)
        os.environ.update(isolated_ros_environment(lock.domain, work / "ros_log"))
        # Rerun's program keeps its settings here, with usage analytics off.
        for name in ("XDG_CONFIG_HOME", "XDG_DATA_HOME", "XDG_CACHE_HOME"):
            os.environ[name] = str(work / name.lower())
        os.environ["CI"] = "1"
        rerun = shutil.which("rerun") or "rerun"
        subprocess.run([rerun, "analytics", "disable"], check=True, capture_output=True)
        results = run(work, lock.domain)
    report(results)
    (OUT / "bench_view.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

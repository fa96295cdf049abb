"""Simulator node beside the suite at the default rates: its CPU share and its odometry's latency.

The driver (default parameters: 200 Hz, sim backend), kinematics and monitor
(config/oscillatory.yaml) and the swimming simulator (the same geometry and config/fish.yaml, every
other parameter at its default: 5 ms sub-steps, markers at 10 Hz, tf where tf2_msgs is installed)
run as their own processes, as ``fishtail-run --swim`` starts them; a probe in this process
commands the carrier at 4 rad/s and records motor/joint_state, tail/state and fish/odom. Over a
WINDOW_S window after a WARMUP_S warm-up from the first odometry it measures:

* CPU of each node process (utime + stime from /proc/<pid>/stat over the window), % of one core;
* latency of fish/odom: probe receive time - header stamp. The simulator stamps each odometry
  message with the stamp of the motor/joint_state sample it integrated up to (the time the driver
  read the encoder), so this is the whole path sample -> driver publish -> simulator (RK4 to the
  sample) -> probe; tail/state's (sample -> kinematics -> probe) is printed beside it;
* coverage: of the motor samples the probe received in the window, how many have an odometry
  message of the same stamp; and, from the simulator's /diagnostics "received" counter, roughly
  how many samples never reached its callback (its sensor-data input queue holds 5 samples, 25 ms
  at 200 Hz: a simulator busier than that loses the oldest).

Also printed: the simulator's own /diagnostics (dropped samples, sub-steps, whether tf is on) and
the machine's load average (other processes on the two cores change every figure). Prints figures
only (no targets) and writes bench/out/bench_swim_node.json. Run with `make bench` (about 30 s).
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from fishtail_common.interface import (
    FISH_ODOM,
    MOTOR_JOINT_STATE,
    SUITE_NODES,
    SWIM_NODE,
    TAIL_STATE,
)
from fishtail_common.testing import (
    WIDENING_VARIABLES,
    NodeProcess,
    Probe,
    Recorder,
    claim_domain,
    isolated_ros_environment,
)
from fishtail_msgs.msg import TailState
from measure import FISH, GEOMETRY, OUT, ROOT, cpu_seconds

SPEED_RAD_S = 4.0
WARMUP_S = 2.0
WINDOW_S = 20.0
#: Odometry of the window's last samples may still be in flight when it closes.
IN_FLIGHT_S = 0.3
START_TIMEOUT_S = 30.0


def stamps_and_receipts(recorder: Recorder, window: tuple[int, int]) -> tuple[np.ndarray, ...]:
    """Header stamps and receive times (ns) of the messages stamped inside ``window``."""
    stamps = np.array([Probe.stamp_ns(message) for message in recorder.messages], dtype=np.int64)
    received = np.array(recorder.receive_ns, dtype=np.int64)
    inside = (stamps >= window[0]) & (stamps < window[1])
    return stamps[inside], received[inside]


def latency(recorder: Recorder, window: tuple[int, int]) -> dict[str, float | int]:
    """Receive time - header stamp of the messages in ``window``: count, p50, p99, max (ms)."""
    stamps, received = stamps_and_receipts(recorder, window)
    milliseconds = (received - stamps) * 1e-6
    if milliseconds.size == 0:
        return {"messages": 0}
    return {
        "messages": int(milliseconds.size),
        "p50_ms": float(np.percentile(milliseconds, 50)),
        "p99_ms": float(np.percentile(milliseconds, 99)),
        "max_ms": float(milliseconds.max()),
    }


def _swim_arrays(diagnostics: Recorder) -> list:
    """The DiagnosticArrays that hold a simulator status, once per status (as Probe.statuses)."""
    prefix = f"/{SWIM_NODE.name}:"
    return [
        array
        for array in diagnostics.messages
        for status in array.status
        if status.name.startswith(prefix)
    ]


def node_processes(work: Path) -> dict[str, NodeProcess]:
    """The suite and the simulator, each started as ``python -m <module>``."""
    processes = {}
    for node in (*SUITE_NODES, SWIM_NODE):
        argv = [sys.executable, "-m", node.module, "--ros-args"]
        if node.name != "driver":  # the driver runs on its defaults
            argv += ["--params-file", str(GEOMETRY)]
        if node is SWIM_NODE:
            argv += ["--params-file", str(FISH)]
        processes[node.name] = NodeProcess(node.name, argv, work, cwd=ROOT)
    return processes


def run(domain: int, work: Path) -> dict:
    """Start everything, measure one window, stop everything; the figures."""
    processes = node_processes(work)
    probe = Probe(domain, "bench_swim_node")
    try:
        motor = probe.record(JointState, MOTOR_JOINT_STATE.name)
        state = probe.record(TailState, TAIL_STATE.name)
        odom = probe.record(Odometry, FISH_ODOM.name)
        diagnostics = probe.record_diagnostics()
        probe.command_speed(SPEED_RAD_S)
        probe.wait_for_messages(odom, 1, START_TIMEOUT_S, FISH_ODOM.name)
        probe.spin_for(WARMUP_S)
        pids = {name: process.pid for name, process in processes.items()}
        cpu_start = {name: cpu_seconds(pid) for name, pid in pids.items()}
        cpu_start["probe (this process)"] = cpu_seconds()
        wall_start = time.monotonic()
        window = (time.time_ns(), 0)
        probe.spin_for(WINDOW_S)
        window = (window[0], time.time_ns())
        wall = time.monotonic() - wall_start
        cpu = {name: cpu_seconds(pid) for name, pid in pids.items()}
        cpu["probe (this process)"] = cpu_seconds()
        probe.spin_for(IN_FLIGHT_S)
        swim = probe.statuses(diagnostics, SWIM_NODE.name)
        load = os.getloadavg()[0]
    finally:
        probe.close()
        for process in processes.values():
            process.send_signal(2)  # SIGINT: all at once, so they stop in parallel
        for process in processes.values():
            process.stop()
    samples, _ = stamps_and_receipts(motor, window)
    odometry, _ = stamps_and_receipts(odom, window)
    # The simulator's "received" counter at its first and last diagnostics of the window, against
    # the motor samples stamped between them (approximate: the counter is read at publish time).
    counts = [
        (Probe.stamp_ns(array), int(Probe.values(status)["received"]))
        for (_, _, status), array in zip(swim, _swim_arrays(diagnostics), strict=True)
    ]
    counts = [(stamp, n) for stamp, n in counts if window[0] <= stamp < window[1]]
    before_simulator = None
    if len(counts) >= 2:
        (t0, n0), (t1, n1) = counts[0], counts[-1]
        sent = int(np.count_nonzero((samples > t0) & (samples <= t1)))
        before_simulator = {"samples": sent, "not_received": max(0, sent - (n1 - n0))}
    return {
        "window_s": (window[1] - window[0]) * 1e-9,
        "cpu_pct": {name: 100.0 * (cpu[name] - cpu_start[name]) / wall for name in cpu},
        "odom_latency": latency(odom, window),
        "tail_state_latency": latency(state, window),
        "motor_samples": int(samples.size),
        "odom_of_those": int(np.count_nonzero(np.isin(samples, odometry))),
        "lost_before_simulator": before_simulator,
        "load_average_1min": load,
        "swim_diagnostics": probe.values(swim[-1][2]) if swim else {},
        "swim_level": swim[-1][1] if swim else None,
    }


def report(result: dict) -> None:
    """Print the figures."""
    print(
        f"simulator beside the suite, default rates (driver 200 Hz), carrier {SPEED_RAD_S:g} "
        f"rad/s, {result['window_s']:.1f} s window after {WARMUP_S:g} s warm-up; "
        f"{os.cpu_count()} cores, load average {result['load_average_1min']:.2f} at the end"
    )
    for name, percent in result["cpu_pct"].items():
        print(f"  CPU {name:<22} {percent:5.1f} % of a core")
    for label, key in (("fish/odom", "odom_latency"), ("tail/state", "tail_state_latency")):
        figures = result[key]
        if figures["messages"] == 0:
            print(f"  latency {label:<11} no messages in the window")
            continue
        print(
            f"  latency {label:<11} p50 {figures['p50_ms']:.2f} ms, p99 {figures['p99_ms']:.2f} "
            f"ms, max {figures['max_ms']:.2f} ms ({figures['messages']} messages; receive time "
            "- motor sample stamp)"
        )
    print(
        f"  coverage            {result['odom_of_those']} of the {result['motor_samples']} motor "
        "samples the probe received have their fish/odom"
    )
    lost = result["lost_before_simulator"]
    if lost is not None:
        print(
            f"    of which ~{lost['not_received']} of {lost['samples']} never reached the "
            "simulator's callback (from its /diagnostics received counter)"
        )
    values = result["swim_diagnostics"]
    keys = ("dropped", "sub_steps", "beats", "speed_m_s", "tf")
    shown = ", ".join(f"{key} {values[key]}" for key in keys if key in values)
    print(f"  simulator's last diagnostics (level {result['swim_level']}): {shown or '(none)'}")


def main() -> int:
    """Run once, print the figures, write bench/out/bench_swim_node.json."""
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="bench_swim_node_") as tmp, claim_domain() as lock:
        work = Path(tmp)
        os.environ.update(isolated_ros_environment(lock.domain, work))
        for name in WIDENING_VARIABLES:
            os.environ.pop(name, None)
        result = run(lock.domain, work)
    report(result)
    (OUT / "bench_swim_node.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

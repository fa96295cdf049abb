"""Suite benchmark: driver at 1 kHz -> kinematics -> monitor + probe, in one process and in several.

For each configuration the driver publishes motor/joint_state at 1 kHz (carrier at 4 rad/s), the
kinematics node turns every sample into tail/state, the monitor node (subscribed to tail/state
and motor/cmd_speed) segments it into beats and publishes tail/symmetry and /diagnostics, and a
probe subscriber in this process measures, over a 10 s window after a 1 s warm-up:

* lost messages: motor/joint_state samples the driver published in the window (the driver's
  publisher is wrapped to record each header stamp, nothing else changes) without a tail/state of
  the same stamp at the probe - lost between driver and kinematics or kinematics and probe (the
  probe's best-effort subscription has a deep queue so that it is not the one dropping; the
  kinematics node's /diagnostics "received" counter tells roughly how many the driver ->
  kinematics hop lost);
* latency: probe receive time - tail/state header stamp (the driver's publish time): median, p99;
* CPU: utime + stime deltas from /proc/<pid>/stat over the window, in % of one core.

The measurement starts only once the monitor is taking part: in (a) once it has received a
tail/state, in (b) once its /diagnostics is no longer STALE (it says STALE until tail/state
arrives). The monitor's beat count over the window and its last verdict are printed as a check
that it did its work (its own tail/state losses are not counted: the loss figure is the probe's).

Configurations: (a) one process, DriverNode, KinematicsNode and MonitorNode composed with the
probe on one rclpy EventsExecutor; (b) driver, kinematics and monitor as their own processes
(kinematics and monitor with ``python -m``, the driver module's own main() through a few lines
that record its stamps), the probe here; CPU per node process. The one-process CPU figure
includes the probe (deserialising 1 kHz of tail/state); a further 10 s run of (a) without the
probe's subscriptions gives the suite's own CPU. Prints figures next to the targets (no asserts)
and writes bench/out/bench_suite.json.
Run with `make bench`.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from array import array
from pathlib import Path

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64

from fishtail_bringup.console import VERDICT_NAMES
from fishtail_common.testing import claim_domain
from fishtail_msgs.msg import SymmetryReport, TailState
from measure import cpu_seconds

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "bench" / "out"
CONFIG = ROOT / "config" / "oscillatory.yaml"
RATE_HZ = 1000.0
SPEED_RAD_S = 4.0
WARMUP_S = 1.0
WINDOW_S = 10.0
#: Samples published in the last moments of the window may still be in flight when it closes.
IN_FLIGHT_S = 0.2
DISCOVERY_TIMEOUT_S = 20.0
PROBE_QUEUE_DEPTH = 1000
#: DiagnosticStatus level the monitor reports while no tail/state reaches it.
LEVEL_STALE = 3

TARGETS = {
    "one process": {"lost_pct": 0.0, "p99_ms": 1.0, "cpu_pct": 30.0},
    "separate processes": {"lost_pct": 0.5, "p99_ms": 5.0},
}

# Runs the real driver node (python -m fishtail_driver.node) with its motor/joint_state publisher
# wrapped to record the stamps it publishes; they are written to argv[1] at exit.
DRIVER_WRAPPER = r"""
import atexit, sys
from array import array
import fishtail_driver.node as driver_module

stamps = array("q")
original_init = driver_module.DriverNode.__init__

def counting_init(self, *args, **kwargs):
    original_init(self, *args, **kwargs)
    publish = self.state_publisher.publish

    def counting_publish(message):
        publish(message)
        stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)

    self.state_publisher.publish = counting_publish

driver_module.DriverNode.__init__ = counting_init
path = sys.argv[1]

def dump():
    with open(path, "wb") as stream:
        stamps.tofile(stream)

atexit.register(dump)
sys.argv = ["driver", *sys.argv[2:]]
sys.exit(driver_module.main())
"""


# ---- environment


# ---- the probe


class Probe:
    """tail/state subscriber recording (stamp, receive time); commands the motor speed.

    Also follows the monitor: its tail/symmetry reports (stamp, verdict) and its /diagnostics.
    """

    def __init__(self, context: Context | None = None, subscribe: bool = True) -> None:
        """Create the node, its subscriptions (unless not ``subscribe``) and the command timer."""
        self.node = rclpy.create_node("probe", context=context)
        self.stamps = array("q")
        self.received = array("q")
        self.kinematics_received: list[tuple[int, int]] = []  # (diagnostics stamp, count)
        self.beats: list[tuple[int, int]] = []  # (tail/symmetry stamp, verdict)
        self.monitor_level: int | None = None  # of the monitor's latest /diagnostics
        self.monitor_message = ""
        self.command = self.node.create_publisher(Float64, "motor/cmd_speed", 10)
        self.node.create_timer(0.2, lambda: self.command.publish(Float64(data=SPEED_RAD_S)))
        if not subscribe:
            return
        # Sensor-data QoS (best effort) like any consumer of tail/state, but a deep queue: the
        # probe must not be the one that drops samples when this process is descheduled.
        qos = QoSProfile(depth=PROBE_QUEUE_DEPTH)
        qos.reliability = qos_profile_sensor_data.reliability
        qos.durability = qos_profile_sensor_data.durability
        self.node.create_subscription(TailState, "tail/state", self._on_state, qos)
        # The kinematics node's "received" counter, to split losses before and after it.
        self.node.create_subscription(DiagnosticArray, "/diagnostics", self._on_diagnostics, 10)
        # The monitor's per-beat reports (reliable, like its publisher), to see it at work.
        self.node.create_subscription(SymmetryReport, "tail/symmetry", self._on_beat, 10)

    def monitor_active(self) -> bool:
        """True once the monitor's /diagnostics says it is receiving tail/state (not STALE)."""
        return self.monitor_level is not None and self.monitor_level != LEVEL_STALE

    def _on_state(self, message: TailState) -> None:
        now = time.time_ns()
        stamp = message.header.stamp
        self.stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
        self.received.append(now)

    def _on_beat(self, message: SymmetryReport) -> None:
        stamp = message.header.stamp
        self.beats.append((stamp.sec * 1_000_000_000 + stamp.nanosec, int(message.verdict)))

    def _on_diagnostics(self, message: DiagnosticArray) -> None:
        stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
        for status in message.status:
            if status.name.startswith("/monitor:"):
                level = status.level
                self.monitor_level = level[0] if isinstance(level, bytes) else int(level)
                self.monitor_message = status.message
            if status.name.startswith("/kinematics:"):
                values = {pair.key: pair.value for pair in status.values}
                if "received" in values:
                    self.kinematics_received.append((stamp, int(values["received"])))


def spin(executor, seconds: float, until=None) -> bool:
    """Spin for up to ``seconds``; stop early (True) when ``until()`` becomes true."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        executor.spin_once(timeout_sec=0.01)
        if until is not None and until():
            return True
    return until is None


def measure(executor, ready, pids: dict[str, int | str]) -> dict:
    """Wait for ``ready()``, warm up, spin WINDOW_S; the window's bounds (ns) and CPU % per pid."""
    if not spin(executor, DISCOVERY_TIMEOUT_S, ready):
        raise SystemExit(
            "bench_suite: the suite did not connect (no tail/state at the probe or the monitor)"
        )
    spin(executor, WARMUP_S)
    cpu_start = {name: cpu_seconds(pid) for name, pid in pids.items()}
    wall_start = time.monotonic()
    window_start_ns = time.time_ns()
    spin(executor, WINDOW_S)
    window_end_ns = time.time_ns()
    wall = time.monotonic() - wall_start
    cpu = {name: 100.0 * (cpu_seconds(pid) - cpu_start[name]) / wall for name, pid in pids.items()}
    spin(executor, IN_FLIGHT_S)  # let the last samples of the window arrive
    return {"window": (window_start_ns, window_end_ns), "cpu_pct": cpu}


def figures(published: np.ndarray, probe: Probe, window: tuple[int, int]) -> dict:
    """Loss and latency over the samples the driver published inside ``window``."""
    start, end = window
    published = published[(published >= start) & (published < end)]
    stamps = np.frombuffer(probe.stamps, dtype=np.int64)
    received = np.frombuffer(probe.received, dtype=np.int64)
    inside = (stamps >= start) & (stamps < end)
    stamps, received = stamps[inside], received[inside]
    _, first = np.unique(stamps, return_index=True)  # duplicates would hide losses
    stamps, received = stamps[first], received[first]
    lost = int(np.count_nonzero(~np.isin(published, stamps)))
    latency_ms = (received - stamps) * 1e-6
    # Between the first and the last kinematics diagnostics of the window: published samples
    # minus those the kinematics node counted (approximate: the counter is read at publish time).
    lost_before_kinematics = None
    counts = [(t, n) for t, n in probe.kinematics_received if start <= t < end]
    if len(counts) >= 2:
        (t0, n0), (t1, n1) = counts[0], counts[-1]
        sent = int(np.count_nonzero((published > t0) & (published <= t1)))
        lost_before_kinematics = {"published": sent, "lost": max(0, sent - (n1 - n0))}
    # Beats the monitor completed inside the window (a report's stamp is that of the tail/state
    # sample that closed the beat) and the verdicts it gave them.
    verdicts = [verdict for stamp, verdict in probe.beats if start <= stamp < end]
    monitor = {
        "beats": len(verdicts),
        "verdicts": {
            VERDICT_NAMES.get(v, str(v)): verdicts.count(v) for v in sorted(set(verdicts))
        },
        "last_diagnostics": probe.monitor_message,
    }
    return {
        "monitor": monitor,
        "lost_before_kinematics": lost_before_kinematics,
        "published": int(published.size),
        "publish_rate_hz": published.size / ((end - start) * 1e-9),
        "received": int(stamps.size),
        "lost": lost,
        "lost_pct": 100.0 * lost / max(published.size, 1),
        "latency_median_ms": float(np.median(latency_ms)) if latency_ms.size else float("nan"),
        "latency_p99_ms": float(np.percentile(latency_ms, 99)) if latency_ms.size else float("nan"),
        "latency_max_ms": float(latency_ms.max()) if latency_ms.size else float("nan"),
    }


# ---- (a) one process


def run_one_process(domain: int, driver_params: Path, with_probe: bool = True) -> dict:
    """DriverNode + KinematicsNode + MonitorNode + probe on one EventsExecutor in this process.

    Without the probe's subscriptions, only the CPU figure means something: that of the suite.
    """
    from fishtail_driver.node import DriverNode
    from fishtail_kinematics.nodes.kinematics_node import KinematicsNode
    from fishtail_kinematics.nodes.monitor_node import MonitorNode

    args = ["bench", "--ros-args", "--params-file", str(CONFIG)]
    args += ["--params-file", str(driver_params)]
    rclpy.init(args=args, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    driver = kinematics = monitor = probe = executor = None
    try:
        driver = DriverNode()
        published = array("q")
        publish = driver.state_publisher.publish

        def counting_publish(message):
            publish(message)
            stamp = message.header.stamp
            published.append(stamp.sec * 1_000_000_000 + stamp.nanosec)

        driver.state_publisher.publish = counting_publish
        kinematics = KinematicsNode()
        monitor = MonitorNode()
        probe = Probe(subscribe=with_probe)
        executor = EventsExecutor()
        for node in (driver, kinematics, monitor, probe.node):
            executor.add_node(node)
        # The window starts once tail/state reaches the monitor (and the probe, if subscribed).
        monitor_fed = lambda: monitor.last_input_ns is not None  # noqa: E731
        if with_probe:
            ready = lambda: len(probe.stamps) > 0 and monitor_fed()  # noqa: E731
            run = measure(executor, ready, {"process": "self"})
            result = figures(np.frombuffer(published, dtype=np.int64), probe, run["window"])
        else:
            ready = lambda: kinematics.received > 0 and monitor_fed()  # noqa: E731
            run = measure(executor, ready, {"process": "self"})
            result = {}
        result["cpu_pct"] = run["cpu_pct"]
        return result
    finally:
        if executor is not None:
            executor.shutdown()
        if driver is not None:
            driver.shutdown()
        for node in (probe.node if probe else None, monitor, kinematics, driver):
            if node is not None:
                node.destroy_node()
        rclpy.try_shutdown()


# ---- (b) separate processes


def run_separate_processes(domain: int, driver_params: Path, work: Path) -> dict:
    """Driver, kinematics and monitor as processes, the probe in this one."""
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "PYTHONUNBUFFERED": "1"}
    stamps_path = work / "driver_stamps.bin"
    commands = {
        "driver": [sys.executable, "-c", DRIVER_WRAPPER, str(stamps_path),
                   "--ros-args", "--params-file", str(driver_params)],
        "kinematics": [sys.executable, "-m", "fishtail_kinematics.nodes.kinematics_node",
                       "--ros-args", "--params-file", str(CONFIG)],
        "monitor": [sys.executable, "-m", "fishtail_kinematics.nodes.monitor_node",
                    "--ros-args", "--params-file", str(CONFIG)],
    }  # fmt: skip
    processes: dict[str, subprocess.Popen] = {}
    context = Context()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    probe = executor = None
    try:
        for name, argv in commands.items():
            with open(work / f"{name}.log", "wb") as log:
                processes[name] = subprocess.Popen(
                    argv, cwd=ROOT, env=env, stdin=subprocess.DEVNULL, stdout=log,
                    stderr=subprocess.STDOUT, start_new_session=True,
                )  # fmt: skip
        probe = Probe(context)
        executor = EventsExecutor(context=context)
        executor.add_node(probe.node)
        pids = {name: process.pid for name, process in processes.items()}
        # tail/state at the probe, and the monitor no longer STALE (it receives tail/state too).
        ready = lambda: len(probe.stamps) > 0 and probe.monitor_active()  # noqa: E731
        run = measure(executor, ready, {**pids, "probe (this process)": "self"})
    finally:
        for process in processes.values():
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        for name, process in processes.items():
            try:
                process.wait(10.0)
            except subprocess.TimeoutExpired:
                os.killpg(process.pid, signal.SIGKILL)
                process.wait()
                print(f"bench_suite: {name} did not exit on SIGINT; killed", file=sys.stderr)
        if executor is not None:
            executor.shutdown()
        if probe is not None:
            probe.node.destroy_node()
        context.try_shutdown()
    if not stamps_path.exists():
        raise SystemExit(f"bench_suite: the driver wrote no stamps; see {work / 'driver.log'}")
    published = np.fromfile(stamps_path, dtype=np.int64)
    result = figures(published, probe, run["window"])
    result["cpu_pct"] = run["cpu_pct"]
    return result


# ---- report


def _mark(value: float, limit: float) -> str:
    return "met" if value <= limit else "MISSED"


def report(name: str, result: dict) -> None:
    """Print one configuration's figures next to its targets."""
    target = TARGETS[name]
    print(f"\n{name}:")
    print(
        f"  driver published  {result['published']} samples in {WINDOW_S:g} s "
        f"({result['publish_rate_hz']:.1f} Hz; asked {RATE_HZ:g} Hz)"
    )
    print(
        f"  lost              {result['lost']} ({result['lost_pct']:.3f} %)"
        f"      target <= {target['lost_pct']:g} %: {_mark(result['lost_pct'], target['lost_pct'])}"
    )
    split = result["lost_before_kinematics"]
    if split is not None:
        print(
            f"    of which ~{split['lost']} of {split['published']} were never counted by the "
            "kinematics node (lost driver -> kinematics, from its /diagnostics counter)"
        )
    print(
        f"  latency median    {result['latency_median_ms']:.3f} ms, p99 "
        f"{result['latency_p99_ms']:.3f} ms, max {result['latency_max_ms']:.3f} ms"
        f"      target p99 <= {target['p99_ms']:g} ms: "
        f"{_mark(result['latency_p99_ms'], target['p99_ms'])}"
    )
    monitor = result["monitor"]
    verdicts = ", ".join(f"{n} {name}" for name, n in monitor["verdicts"].items()) or "none"
    print(
        f"  monitor           {monitor['beats']} beats completed in the window ({verdicts}); "
        f"last diagnostics: {monitor['last_diagnostics'] or '(none)'}"
    )
    for process, cpu in result["cpu_pct"].items():
        label = {"process": "whole process", "suite without the probe": "w/o probe (own run)"}.get(
            process, process
        )
        line = f"  CPU {label:<22} {cpu:5.1f} % of a core"
        if "cpu_pct" in target:
            limit = target["cpu_pct"]
            line += f"      target suite <= {limit:g} %: {_mark(cpu, limit)}"
        print(line)
    if "cpu_pct" not in target:
        suite = sum(v for k, v in result["cpu_pct"].items() if not k.startswith("probe"))
        print(f"  CPU {'the three nodes':<22} {suite:5.1f} % of a core (no target)")


def run_all(domains: list[int], driver_params: Path, work: Path) -> dict:
    """Both configurations on their own domains, and the one-process suite without the probe."""
    print(
        f"suite benchmark: driver {RATE_HZ:g} Hz at {SPEED_RAD_S:g} rad/s -> kinematics "
        f"({CONFIG.name}) -> monitor + probe; {WINDOW_S:g} s window after {WARMUP_S:g} s "
        "warm-up; "
        f"{os.cpu_count()} cores; ROS domains {domains}"
    )
    results = {
        "one process": run_one_process(domains[0], driver_params),
        "separate processes": run_separate_processes(domains[1], driver_params, work),
    }
    without_probe = run_one_process(domains[2], driver_params, with_probe=False)
    results["one process"]["cpu_pct"]["suite without the probe"] = without_probe["cpu_pct"][
        "process"
    ]
    return results


def main() -> int:
    """Run both configurations, print the figures, write bench/out/bench_suite.json."""
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="bench_suite_") as tmp:
        work = Path(tmp)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        os.environ["ROS_LOG_DIR"] = str(work / "ros_log")
        # Only the publish rate is set for the driver; everything else is its default.
        driver_params = work / "driver.yaml"
        driver_params.write_text(f"driver:\n  ros__parameters:\n    publish_rate_hz: {RATE_HZ!r}\n")
        # Three domains, locked like the tests' (a test run in parallel never shares one).
        with contextlib.ExitStack() as held:
            domains = [held.enter_context(claim_domain()).domain for _ in range(3)]
            results = run_all(domains, driver_params, work)
    for name, result in results.items():
        report(name, result)
    (OUT / "bench_suite.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

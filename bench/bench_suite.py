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
that record its stamps; the relays likewise), the probe here; CPU per node process. The
one-process CPU figure includes the probe (deserialising 1 kHz of tail/state); a further 5 s
run of (a) without the probe's subscriptions gives the suite's own CPU.

The floor: each configuration also runs with bench/relay_nodes.py's driver, kinematics and
monitor, which publish and take the suite's topics with its message types, QoS and rates but
compute nothing. Suite and relay runs alternate (suite, relay, suite, relay: ROUNDS rounds) so
that the machine's noise falls on both alike; the suite's CPU (of the nodes, in % of a core and
per sample the driver published) and latency (median and p99 of the rounds' samples pooled) are
printed as multiples of the relay's, against FLOOR_TARGETS. The suite's own figures against
TARGETS are those of the first round. Prints figures next to the targets (no asserts) and writes
bench/out/bench_suite.json.
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
from collections.abc import Callable
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
from fishtail_common.ros import SuiteNodeBase
from fishtail_common.testing import claim_domain
from fishtail_msgs.msg import SymmetryReport, TailState
from measure import cpu_seconds, verdict
from relay_nodes import DriverRelay, KinematicsRelay, MonitorRelay

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "bench"
OUT = BENCH / "out"
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

#: What runs: the suite's nodes, or bench/relay_nodes.py's stand-ins that compute nothing.
SUITE = "suite"
RELAY = "relay"
#: Suite and relay runs alternate this many times in each layout, so that the machine's noise
#: falls on both alike.
ROUNDS = 2
#: Window of the one-process runs without the probe, which give only a CPU figure.
CPU_WINDOW_S = 5.0

# CPU has no absolute target: a share of a core measures the machine as much as the suite; the
# suite's CPU is judged as a ratio to the relay's (FLOOR_TARGETS).
TARGETS = {
    "one process": {"lost_pct": 0.0, "p99_ms": 1.0},
    "separate processes": {"lost_pct": 0.5, "p99_ms": 5.0},
}
#: The suite's CPU and latency at most this multiple of the relay's (its floor), by layout.
FLOOR_TARGETS = {"one process": 1.15, "separate processes": 1.2}

# Runs a driver (argv[2], a module: the real one or bench/relay_nodes.py) with the
# motor/joint_state publisher of its node class (argv[3]) wrapped to record the stamps it
# publishes; they are written to argv[1] at exit. The arguments before --ros-args go to the
# module's main() (the relay's node name), the whole command line to rclpy.
DRIVER_WRAPPER = r"""
import atexit, importlib, sys
from array import array

path, module_name, class_name, *rest = sys.argv[1:]
module = importlib.import_module(module_name)
node_class = getattr(module, class_name)
stamps = array("q")
original_init = node_class.__init__

def counting_init(self, *args, **kwargs):
    original_init(self, *args, **kwargs)
    publish = self.state_publisher.publish

    def counting_publish(message):
        publish(message)
        stamps.append(message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec)

    self.state_publisher.publish = counting_publish

node_class.__init__ = counting_init

def dump():
    with open(path, "wb") as stream:
        stamps.tofile(stream)

atexit.register(dump)
main_args = rest[: rest.index("--ros-args")] if "--ros-args" in rest else rest
sys.argv = ["driver", *rest]
sys.exit(module.main(*main_args))
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


def measure(executor, ready, pids: dict[str, int | str], window_s: float = WINDOW_S) -> dict:
    """Wait for ``ready()``, warm up, spin ``window_s``; the window's bounds (ns), CPU % per pid."""
    if not spin(executor, DISCOVERY_TIMEOUT_S, ready):
        raise SystemExit(
            "bench_suite: the suite did not connect (no tail/state at the probe or the monitor)"
        )
    spin(executor, WARMUP_S)
    cpu_start = {name: cpu_seconds(pid) for name, pid in pids.items()}
    wall_start = time.monotonic()
    window_start_ns = time.time_ns()
    spin(executor, window_s)
    window_end_ns = time.time_ns()
    wall = time.monotonic() - wall_start
    cpu = {name: 100.0 * (cpu_seconds(pid) - cpu_start[name]) / wall for name, pid in pids.items()}
    spin(executor, IN_FLIGHT_S)  # let the last samples of the window arrive
    return {"window": (window_start_ns, window_end_ns), "cpu_pct": cpu}


#: Key of the per-sample latencies (ms, an array) in a run's figures; pooled over the rounds for
#: the floor comparison, not written to the JSON file.
LATENCIES = "latencies_ms"


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
        LATENCIES: latency_ms,
    }


# ---- (a) one process


def suite_nodes(kind: str) -> tuple[Callable[[], SuiteNodeBase], ...]:
    """Constructors of the driver, kinematics and monitor of ``kind`` ("suite" or "relay")."""
    if kind == RELAY:
        return (DriverRelay, KinematicsRelay, MonitorRelay)
    from fishtail_driver.node import DriverNode
    from fishtail_kinematics.nodes.kinematics_node import KinematicsNode
    from fishtail_kinematics.nodes.monitor_node import MonitorNode

    return (DriverNode, KinematicsNode, MonitorNode)


def run_one_process(
    domain: int,
    driver_params: Path,
    kind: str = SUITE,
    with_probe: bool = True,
    window_s: float = WINDOW_S,
) -> dict:
    """Driver, kinematics and monitor of ``kind`` + probe on one EventsExecutor in this process.

    Without the probe's subscriptions, only the CPU figure means something: that of the nodes.
    """
    make_driver, make_kinematics, make_monitor = suite_nodes(kind)
    args = ["bench", "--ros-args", "--params-file", str(CONFIG)]
    args += ["--params-file", str(driver_params)]
    rclpy.init(args=args, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    driver = kinematics = monitor = probe = executor = None
    try:
        driver = make_driver()
        published = array("q")
        publish = driver.state_publisher.publish

        def counting_publish(message):
            publish(message)
            stamp = message.header.stamp
            published.append(stamp.sec * 1_000_000_000 + stamp.nanosec)

        driver.state_publisher.publish = counting_publish
        kinematics = make_kinematics()
        monitor = make_monitor()
        probe = Probe(subscribe=with_probe)
        executor = EventsExecutor()
        for node in (driver, kinematics, monitor, probe.node):
            executor.add_node(node)
        # The window starts once tail/state reaches the monitor (and the probe, if subscribed).
        monitor_fed = lambda: monitor.last_input_ns is not None  # noqa: E731
        if with_probe:
            ready = lambda: len(probe.stamps) > 0 and monitor_fed()  # noqa: E731
            run = measure(executor, ready, {"process": "self"}, window_s)
            result = figures(np.frombuffer(published, dtype=np.int64), probe, run["window"])
        else:
            ready = lambda: kinematics.received > 0 and monitor_fed()  # noqa: E731
            run = measure(executor, ready, {"process": "self"}, window_s)
            start, end = run["window"]
            stamps = np.frombuffer(published, dtype=np.int64)
            inside = np.count_nonzero((stamps >= start) & (stamps < end))
            result = {"publish_rate_hz": inside / ((end - start) * 1e-9)}
        result["cpu_pct"] = run["cpu_pct"]
        return result
    finally:
        if executor is not None:
            executor.shutdown()
        if driver is not None:
            driver.before_exit()
        for node in (probe.node if probe else None, monitor, kinematics, driver):
            if node is not None:
                node.destroy_node()
        rclpy.try_shutdown()


# ---- (b) separate processes


def node_commands(kind: str, driver_params: Path, stamps_path: Path) -> dict[str, list[str]]:
    """The command lines of the driver, kinematics and monitor processes of ``kind``."""
    config = ["--ros-args", "--params-file", str(CONFIG)]
    if kind == RELAY:
        relay = [sys.executable, str(BENCH / "relay_nodes.py")]
        return {
            "driver": [sys.executable, "-c", DRIVER_WRAPPER, str(stamps_path), "relay_nodes",
                       "DriverRelay", "driver", "--ros-args", "--params-file", str(driver_params)],
            "kinematics": [*relay, "kinematics", *config],
            "monitor": [*relay, "monitor", *config],
        }  # fmt: skip
    return {
        "driver": [sys.executable, "-c", DRIVER_WRAPPER, str(stamps_path), "fishtail_driver.node",
                   "DriverNode", "--ros-args", "--params-file", str(driver_params)],
        "kinematics": [sys.executable, "-m", "fishtail_kinematics.nodes.kinematics_node", *config],
        "monitor": [sys.executable, "-m", "fishtail_kinematics.nodes.monitor_node", *config],
    }  # fmt: skip


def run_separate_processes(domain: int, driver_params: Path, work: Path, kind: str = SUITE) -> dict:
    """Driver, kinematics and monitor of ``kind`` as processes, the probe in this one."""
    # bench/ on the path: the driver wrapper imports relay_nodes.
    path = os.pathsep.join(filter(None, [str(BENCH), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "PYTHONUNBUFFERED": "1", "PYTHONPATH": path}
    stamps_path = work / f"{kind}_driver_stamps.bin"
    stamps_path.unlink(missing_ok=True)
    commands = node_commands(kind, driver_params, stamps_path)
    processes: dict[str, subprocess.Popen] = {}
    context = Context()
    rclpy.init(context=context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO)
    probe = executor = None
    try:
        for name, argv in commands.items():
            with open(work / f"{kind}_{name}.log", "wb") as log:
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
        raise SystemExit(
            f"bench_suite: the driver wrote no stamps; see {work / f'{kind}_driver.log'}"
        )
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
        label = {"process": "whole process", "without the probe": "w/o probe (own run)"}.get(
            process, process
        )
        print(f"  CPU {label:<22} {cpu:5.1f} % of a core")
    if "process" not in result["cpu_pct"]:
        suite = sum(v for k, v in result["cpu_pct"].items() if not k.startswith("probe"))
        print(f"  CPU {'the three nodes':<22} {suite:5.1f} % of a core (no target)")


def run_all(domains: list[int], driver_params: Path, work: Path) -> dict:
    """ROUNDS rounds of suite and relay runs, alternating, in both layouts.

    A round: in one process the suite then the relay with the probe, then both without it (the
    nodes' own CPU); as separate processes the suite then the relay. The suite and the relay
    each have their own domain per layout (``domains``: one process suite, relay; separate
    processes suite, relay), so that nothing of one run reaches the other's probe.
    """
    print(
        f"suite benchmark: driver {RATE_HZ:g} Hz at {SPEED_RAD_S:g} rad/s -> kinematics "
        f"({CONFIG.name}) -> monitor + probe; {WINDOW_S:g} s window after {WARMUP_S:g} s "
        f"warm-up ({CPU_WINDOW_S:g} s without the probe); suite and relay alternate, {ROUNDS} "
        f"rounds; {os.cpu_count()} cores; ROS domains {domains}",
        flush=True,
    )
    one_domain = {SUITE: domains[0], RELAY: domains[1]}
    separate_domain = {SUITE: domains[2], RELAY: domains[3]}
    rounds: dict[str, list[dict[str, dict]]] = {"one process": [], "separate processes": []}
    for index in range(ROUNDS):
        one: dict[str, dict] = {}
        separate: dict[str, dict] = {}
        for kind in (SUITE, RELAY):
            print(f"  round {index + 1}: one process, {kind}", flush=True)
            one[kind] = run_one_process(one_domain[kind], driver_params, kind)
        for kind in (SUITE, RELAY):
            without_probe = run_one_process(
                one_domain[kind], driver_params, kind, with_probe=False, window_s=CPU_WINDOW_S
            )
            one[kind]["cpu_pct"]["without the probe"] = without_probe["cpu_pct"]["process"]
            one[kind]["publish_rate_hz without the probe"] = without_probe["publish_rate_hz"]
        for kind in (SUITE, RELAY):
            print(f"  round {index + 1}: separate processes, {kind}", flush=True)
            separate[kind] = run_separate_processes(
                separate_domain[kind], driver_params, work, kind
            )
        rounds["one process"].append(one)
        rounds["separate processes"].append(separate)
    return rounds


# ---- the floor


def nodes_cpu_pct(layout: str, result: dict) -> float:
    """CPU of the driver, kinematics and monitor, % of a core, without the probe."""
    cpu = result["cpu_pct"]
    if layout == "one process":
        return cpu["without the probe"]
    return cpu["driver"] + cpu["kinematics"] + cpu["monitor"]


def nodes_cpu_us_per_sample(layout: str, result: dict) -> float:
    """:func:`nodes_cpu_pct` per motor/joint_state sample published, microseconds.

    The driver's timer misses ticks when the machine is busy, so runs differ in how many samples
    they carried; per sample, their CPU figures compare.
    """
    key = "publish_rate_hz without the probe" if layout == "one process" else "publish_rate_hz"
    return 1e4 * nodes_cpu_pct(layout, result) / result[key]


def floor_figures(layout: str, rounds: list[dict[str, dict]]) -> dict:
    """Suite and relay figures over the rounds, the suite's as multiples of the relay's.

    CPU (of the nodes, % of a core and per sample published): the mean over the rounds (the
    windows are equal), and each round's ratio; latency: the median and p99 of every round's
    samples pooled.
    """
    rows: dict[str, dict] = {}

    def row(name: str, values: dict[str, list[float]] | dict[str, float], per_round: bool) -> None:
        if per_round:
            suite, relay = values[SUITE], values[RELAY]
            rows[name] = {
                SUITE: float(np.mean(suite)),
                RELAY: float(np.mean(relay)),
                "rounds": [s / r for s, r in zip(suite, relay, strict=True)],
            }
        else:
            rows[name] = {SUITE: values[SUITE], RELAY: values[RELAY]}
        rows[name]["ratio"] = rows[name][SUITE] / rows[name][RELAY]

    row(
        "CPU of the nodes %",
        {kind: [nodes_cpu_pct(layout, r[kind]) for r in rounds] for kind in (SUITE, RELAY)},
        per_round=True,
    )
    row(
        "CPU per sample us",
        {
            kind: [nodes_cpu_us_per_sample(layout, r[kind]) for r in rounds]
            for kind in (SUITE, RELAY)
        },
        per_round=True,
    )
    if layout == "one process":
        row(
            "CPU with the probe %",
            {kind: [r[kind]["cpu_pct"]["process"] for r in rounds] for kind in (SUITE, RELAY)},
            per_round=True,
        )
    pooled = {kind: np.concatenate([r[kind][LATENCIES] for r in rounds]) for kind in (SUITE, RELAY)}
    row("latency median ms", {k: float(np.median(v)) for k, v in pooled.items()}, False)
    row("latency p99 ms", {k: float(np.percentile(v, 99)) for k, v in pooled.items()}, False)
    lost = {kind: [r[kind]["lost"] for r in rounds] for kind in (SUITE, RELAY)}
    return {"rows": rows, "lost": lost}


def report_floor(layout: str, floor: dict) -> None:
    """Print the suite's figures beside the relay's, the ratios and the floor targets."""
    limit = FLOOR_TARGETS[layout]
    print(f"\n{layout}, against the floor ({ROUNDS} rounds, suite and relay alternating):")
    print(f"  {'':<22} {'suite':>9} {'relay':>9} {'suite/relay':>12}")
    for name, row in floor["rows"].items():
        figure, unit = name.rsplit(" ", 1)
        # The probe is the same in both runs and pulls the ratio towards 1: no target on it.
        target = (
            "" if "probe" in name else f"target <= {limit:g}x: {verdict(row['ratio'] <= limit)}"
        )
        rounds = ""
        if "rounds" in row:
            rounds = "(rounds " + ", ".join(f"{r:.2f}x" for r in row["rounds"]) + ")"
        print(
            f"  {figure:<22} {row[SUITE]:7.3f} {unit:<3}{row[RELAY]:7.3f} {unit:<3}"
            f"{row['ratio']:8.3f}x  {target} {rounds}".rstrip()
        )
    lost = floor["lost"]
    print(
        f"  {'lost per round':<22} suite {', '.join(map(str, lost[SUITE]))}; "
        f"relay {', '.join(map(str, lost[RELAY]))} (of {RATE_HZ * WINDOW_S:.0f})"
    )


def main() -> int:
    """Run both layouts against their floor, print the figures, write bench/out/bench_suite.json."""
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="bench_suite_") as tmp:
        work = Path(tmp)
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        os.environ["ROS_LOG_DIR"] = str(work / "ros_log")
        # Only the publish rate is set for the driver; everything else is its default.
        driver_params = work / "driver.yaml"
        driver_params.write_text(f"driver:\n  ros__parameters:\n    publish_rate_hz: {RATE_HZ!r}\n")
        # Four domains, locked like the tests' (a test run in parallel never shares one).
        with contextlib.ExitStack() as held:
            domains = [held.enter_context(claim_domain()).domain for _ in range(4)]
            rounds = run_all(domains, driver_params, work)
    results: dict[str, dict] = {}
    for layout, layout_rounds in rounds.items():
        # The suite's own figures against its absolute targets: those of the first round.
        first = layout_rounds[0][SUITE]
        report(layout, first)
        floor = floor_figures(layout, layout_rounds)
        report_floor(layout, floor)
        results[layout] = {
            **first,
            "floor": floor,
            "rounds": [
                {kind: {k: v for k, v in run.items() if k != LATENCIES} for kind, run in r.items()}
                for r in layout_rounds
            ],
        }
        results[layout].pop(LATENCIES)
    (OUT / "bench_suite.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Soak: the piloted suite flies a waypoint route for minutes while each node is killed once.

Driver, kinematics, monitor, simulator and pilot as separate processes at the default rates
(config/oscillatory.yaml, config/fish.yaml; fishtail-run's command lines, from
:class:`fishtail_bringup.supervisor.Supervisor`), on a ROS domain of their own. A probe in this
process sends the route's current waypoint on goal_pose every GOAL_PERIOD_S (a square of
SQUARE_SIDE_M, repeated; the next waypoint once fish/odom is within the pilot's goal tolerance of
it, as ``fishtail-run --square`` does). Along the way each node in turn is killed (SIGKILL) and
started again, at 15 %, 30 %, ... 75 % of the run. Printed (and written to
bench/out/bench_soak.json):

* messages and non-finite ones (NaN, inf: any float field, but tail/state's fields of the
  undulatory mechanism, NaN by design for the oscillatory one) on every topic the probe hears;
* RSS of each node at the start (after the warm-up), the middle and the end, and its growth;
* goals reached before and after each restart, and the time from the kill to the next goal;
* every change of a status's level on /diagnostics around each kill (AROUND_KILL_S: which node's
  status said what, and when after the kill), the other changes counted by status and level, and
  each status's silences over SILENCE_S (a kill shows as one);
* CPU of each node over the run (all its processes), % of one core.

Figures only, no targets. `make bench` runs a short soak (SHORT_MINUTES, or SOAK_MINUTES from the
environment); the 30-minute soak: ``SOAK_MINUTES=30 make bench`` (every benchmark), or alone
``source tools/env.sh && PYTHONPATH=test/support:$PYTHONPATH python bench/bench_soak.py``
(``--minutes 30`` is its default when run by hand; ``--minutes 3`` for a quick one). It ends by
itself: about a minute of start-up and warm-up more than the minutes asked.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import psutil
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_bringup.supervisor import Supervisor
from fishtail_common.interface import (
    DIAGNOSTICS,
    FISH_ODOM,
    GOAL_POSE,
    MECHANISM_CODES,
    MOTOR_CMD_PROFILE,
    MOTOR_JOINT_STATE,
    ODOM_FRAME,
    PILOT_NODE,
    PIVOT_CMD_POSITION,
    SUITE_NODES,
    SWIM_NODE,
    TAIL_JOINT_STATES,
    TAIL_STATE,
)
from fishtail_common.ros import publisher_qos
from fishtail_common.testing import (
    PROBE_QUEUE_DEPTH,
    NodeProcess,
    Probe,
    claim_domain,
    isolated_ros_environment,
)
from fishtail_msgs.msg import CarrierSpeedProfile, TailState
from fishtail_pilot.pilot import GOAL_TOLERANCE
from fishtail_pilot.route import GoalRoute, square_route
from measure import FISH, GEOMETRY, OUT, ROOT, cpu_seconds

NODES = (*SUITE_NODES, SWIM_NODE, PILOT_NODE)
#: Minutes under `make bench` (no --minutes, no SOAK_MINUTES); by hand the default is 30.
SHORT_MINUTES = 2.0
LONG_MINUTES = 30.0
SQUARE_SIDE_M = 1.0
GOAL_PERIOD_S = 1.0
#: The kills, as fractions of the run, one node each in NODES order.
KILL_FRACTIONS = tuple(0.15 * (index + 1) for index in range(len(NODES)))
#: RSS and CPU are sampled this often (s).
SAMPLE_PERIOD_S = 5.0
#: A node's /diagnostics silent for longer than this is an outage (they publish at 1 Hz).
SILENCE_S = 1.5
#: The /diagnostics changes printed one by one: this long before and after each kill (s).
AROUND_KILL_S = (5.0, 30.0)
#: Discovery, the pilot's steering map, the first goal on its way.
START_TIMEOUT_S = 90.0
WARMUP_S = 10.0
LISTENED: tuple[tuple[Any, str], ...] = (
    (Odometry, FISH_ODOM.name),
    (JointState, MOTOR_JOINT_STATE.name),
    (TailState, TAIL_STATE.name),
    (JointState, TAIL_JOINT_STATES.name),
    (CarrierSpeedProfile, MOTOR_CMD_PROFILE.name),
    (Float64, PIVOT_CMD_POSITION.name),
)


#: TailState's fields of mechanism 2 only: NaN by design for the oscillatory mechanism.
UNDULATORY_ONLY = frozenset(
    f"_{name}"
    for name in (
        "theta4", "theta4_dot", "pin_u_distance", "pin_u_distance_rate", "slider_a_distance",
        "slider_a_distance_rate", "theta5", "theta5_dot",
    )
)  # fmt: skip


def non_finite(value: Any, skip: frozenset[str] = frozenset()) -> tuple[int, int]:
    """(NaN, inf) counts among the float fields of a message, recursively; ``skip``: slots."""
    if isinstance(value, float):
        return int(math.isnan(value)), int(math.isinf(value))
    if isinstance(value, np.ndarray) or (hasattr(value, "typecode") and value.typecode in "fd"):
        values = np.asarray(value, dtype=np.float64)
        return int(np.isnan(values).sum()), int(np.isinf(values).sum())
    if isinstance(value, (list, tuple)):
        nan = inf = 0
        for item in value:
            a, b = non_finite(item)
            nan, inf = nan + a, inf + b
        return nan, inf
    slots = getattr(value, "__slots__", None)
    if slots is None or isinstance(value, (str, bytes, int, bool)):
        return 0, 0
    nan = inf = 0
    for slot in slots:
        if slot in skip:
            continue
        a, b = non_finite(getattr(value, slot))
        nan, inf = nan + a, inf + b
    return nan, inf


class Counter:
    """Messages on one topic, those holding a NaN or an inf, and the first of them (when)."""

    def __init__(self) -> None:
        """Start at zero."""
        self.messages = 0
        self.with_nan = 0
        self.with_inf = 0
        self.first_bad_ns: int | None = None

    def __call__(self, message: Any) -> None:
        """Subscription callback."""
        self.messages += 1
        oscillatory = getattr(message, "mechanism", None) == MECHANISM_CODES["oscillatory"]
        nan, inf = non_finite(message, UNDULATORY_ONLY if oscillatory else frozenset())
        self.with_nan += nan > 0
        self.with_inf += inf > 0
        if (nan or inf) and self.first_bad_ns is None:
            self.first_bad_ns = time.time_ns()


class SoakProbe:
    """Sends the route's goals, counts the topics, follows the route and /diagnostics."""

    def __init__(self, probe: Probe) -> None:
        """Create the publisher, its timer and the subscriptions."""
        self.probe = probe
        self.route = GoalRoute(square_route(SQUARE_SIDE_M), float(GOAL_TOLERANCE.default))
        self.reached_ns: list[int] = []
        self.goal = PoseStamped()
        self.goal.header.frame_id = ODOM_FRAME
        self.goal_publisher = probe.node.create_publisher(
            PoseStamped, GOAL_POSE.name, publisher_qos(GOAL_POSE)
        )
        probe.node.create_timer(GOAL_PERIOD_S, self.send_goal)
        qos = QoSProfile(depth=PROBE_QUEUE_DEPTH)
        qos.reliability = qos_profile_sensor_data.reliability
        qos.durability = qos_profile_sensor_data.durability
        self.counters: dict[str, Counter] = {}
        for message_type, topic in LISTENED:
            counter = Counter()
            callback: Callable[[Any], None] = counter
            if topic == FISH_ODOM.name:
                callback = self._odom_callback(counter)
            probe.node.create_subscription(message_type, topic, callback, qos)
            self.counters[topic] = counter
        #: (time ns, status name, level, message) at each change of a status's level.
        self.changes: list[tuple[int, str, int, str]] = []
        self.level: dict[str, int] = {}
        #: Status name -> arrival times (ns) of its statuses.
        self.seen: dict[str, list[int]] = {}
        probe.node.create_subscription(DiagnosticArray, DIAGNOSTICS.name, self._on_diagnostics, 50)

    def send_goal(self) -> None:
        """Publish the route's current waypoint; the route starts again once done."""
        if self.route.finished:
            self.route.index = 0
        goal = self.route.current
        assert goal is not None
        self.goal.header.stamp = self.probe.node.get_clock().now().to_msg()
        self.goal.pose.position.x, self.goal.pose.position.y = goal
        self.goal_publisher.publish(self.goal)

    def _odom_callback(self, counter: Counter) -> Callable[[Odometry], None]:
        def on_odom(message: Odometry) -> None:
            counter(message)
            position = message.pose.pose.position
            if self.route.update((position.x, position.y)):
                self.reached_ns.append(time.time_ns())
                self.send_goal()

        return on_odom

    def _on_diagnostics(self, message: DiagnosticArray) -> None:
        now = time.time_ns()
        for status in message.status:
            level = status.level[0] if isinstance(status.level, bytes) else int(status.level)
            self.seen.setdefault(status.name, []).append(now)
            if self.level.get(status.name) != level:
                self.level[status.name] = level
                self.changes.append((now, status.name, level, status.message))


def rss_mb(pid: int) -> float:
    """Resident set size of a process, MB (NaN if it has gone)."""
    try:
        return psutil.Process(pid).memory_info().rss / 1e6
    except psutil.Error:
        return math.nan


def soak(minutes: float, domain: int, log_dir: Path) -> dict[str, Any]:
    """Run the suite for ``minutes`` with the kills; the raw figures."""
    supervisor = Supervisor(GEOMETRY, "", [], NODES, FISH)
    argv = supervisor.commands()
    env = {**os.environ, **isolated_ros_environment(domain, log_dir)}
    processes: dict[str, NodeProcess] = {}
    cpu_done = dict.fromkeys(argv, 0.0)  # CPU seconds of each node's killed processes
    samples: list[tuple[float, dict[str, float]]] = []  # (run time s, RSS MB by node)
    kills: list[dict[str, Any]] = []
    probe = Probe(domain, "bench_soak")
    try:
        soak_probe = SoakProbe(probe)
        for name, command in argv.items():
            processes[name] = NodeProcess(name, command, log_dir, cwd=ROOT, env=env)

        def alive() -> None:
            for process in processes.values():
                if process.returncode is not None:
                    raise RuntimeError(f"{process.name} exited:\n{process.output()}")

        def first_goal() -> bool:
            alive()
            return len(soak_probe.reached_ns) > 0

        start_s = probe.spin_until(first_goal, START_TIMEOUT_S, "the first waypoint reached")
        probe.spin_for(WARMUP_S)
        duration_s = minutes * 60.0
        start = time.monotonic()
        start_ns = time.time_ns()
        kill_at = (fraction * duration_s for fraction in KILL_FRACTIONS)
        schedule = list(zip(kill_at, argv, strict=True))
        next_sample = 0.0
        while (elapsed := time.monotonic() - start) < duration_s:
            if elapsed >= next_sample:
                samples.append((elapsed, {n: rss_mb(p.pid) for n, p in processes.items()}))
                next_sample += SAMPLE_PERIOD_S
            if schedule and elapsed >= schedule[0][0]:
                _, name = schedule.pop(0)
                old = processes[name]
                cpu_done[name] += cpu_seconds(old.pid)
                kill_ns = time.time_ns()
                old.send_signal(signal.SIGKILL)
                old.wait(10.0)
                processes[name] = NodeProcess(f"{name}.2", argv[name], log_dir, cwd=ROOT, env=env)
                kills.append({"node": name, "at_s": elapsed, "kill_ns": kill_ns})
            alive()
            probe.spin_for(min(0.5, max(0.05, next_sample - elapsed)))
        end_ns = time.time_ns()
        wall_s = time.monotonic() - start
        samples.append((wall_s, {n: rss_mb(p.pid) for n, p in processes.items()}))
        cpu = {
            name: 100.0 * (cpu_done[name] + cpu_seconds(processes[name].pid)) / (wall_s + start_s)
            for name in argv
        }
        cpu["probe (this process)"] = 100.0 * cpu_seconds() / (wall_s + start_s)
    finally:
        probe.close()
        for process in processes.values():
            process.send_signal(signal.SIGINT)
        for process in processes.values():
            process.stop()
    return {
        "minutes": minutes,
        "start_s": start_s,
        "start_ns": start_ns,
        "end_ns": end_ns,
        "kills": kills,
        "samples": samples,
        "cpu_pct": cpu,
        "probe": soak_probe,
        "load_average": os.getloadavg(),
    }


def report(raw: dict[str, Any]) -> dict[str, Any]:
    """Print the figures; them, as JSON-ready values."""
    probe: SoakProbe = raw["probe"]
    start_ns = raw["start_ns"]

    def at(ns: int) -> float:
        return (ns - start_ns) * 1e-9

    out: dict[str, Any] = {"minutes": raw["minutes"], "start_s": raw["start_s"]}
    print(f"soak of {raw['minutes']:g} min; the loop took {raw['start_s']:.1f} s to the first goal")
    print("\nnon-finite messages per topic (messages holding a NaN / an inf):")
    out["topics"] = {}
    for topic, counter in probe.counters.items():
        bad = counter.first_bad_ns
        first = "" if bad is None else f", first at {at(bad):.1f} s"
        print(
            f"  {topic:22s} {counter.messages:9d} messages, NaN {counter.with_nan}, "
            f"inf {counter.with_inf}{first}"
        )
        out["topics"][topic] = vars(counter)

    samples = raw["samples"]
    middle = min(samples, key=lambda sample: abs(sample[0] - samples[-1][0] / 2))
    print("\nRSS of each node, MB (start, middle, end; * a restart happened before that sample):")
    out["rss_mb"] = {}
    for name in samples[0][1]:
        kill = next(k["at_s"] for k in raw["kills"] if k["node"] == name)
        figures = []
        for when, rss in (samples[0], middle, samples[-1]):
            figures.append(f"{rss[name]:7.1f}{'*' if when > kill else ' '}")
        after = [rss[name] for when, rss in samples if when > kill + 30.0]
        growth = f"{after[-1] - after[0]:+.1f} MB" if len(after) > 1 else "too short to tell"
        before = [rss[name] for when, rss in samples if when < kill]
        first_growth = f"{before[-1] - before[0]:+.1f} MB" if len(before) > 1 else "n/a"
        print(
            f"  {name:11s} {' '.join(figures)}  growth: first process {first_growth}, "
            f"restarted one from 30 s after its start {growth}"
        )
        out["rss_mb"][name] = [(when, rss[name]) for when, rss in samples]

    reached = [at(ns) for ns in probe.reached_ns]
    print(f"\nroute: {len(reached)} waypoints reached (square of {SQUARE_SIDE_M:g} m, repeated)")
    out["kills"] = []
    for kill in raw["kills"]:
        kill_s = at(kill["kill_ns"])
        goals_before = sum(1 for t in reached if t < kill_s)
        after = [t for t in reached if t >= kill_s]
        following = f"{after[0] - kill_s:.1f} s" if after else "NEVER (the route did not resume)"
        print(
            f"  {kill['node']:11s} killed at {kill_s:7.1f} s: {goals_before} goals before, "
            f"{len(after)} after; next goal reached {following} after the kill"
        )
        out["kills"].append({**kill, "goals_before": goals_before, "goals_after": len(after),
                             "next_goal_s": after[0] - kill_s if after else None})  # fmt: skip

    kill_times = [(at(k["kill_ns"]), k["node"]) for k in raw["kills"]]

    def nearest(t: float) -> str:
        if not kill_times:
            return ""
        kill_s, node = min(kill_times, key=lambda k: abs(k[0] - t))
        return f"(kill of {node} {t - kill_s:+.1f} s)"

    levels = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
    out["diagnostics"] = [(at(ns), name, level, text) for ns, name, level, text in probe.changes]
    print(
        f"\n/diagnostics: every change of a status's level from {AROUND_KILL_S[0]:g} s before "
        f"each kill to {AROUND_KILL_S[1]:g} s after it (or the next kill), time from the kill:"
    )
    # Each change goes to the latest kill it follows (or precedes by at most AROUND_KILL_S[0]).
    around: dict[int, list[int]] = {}
    for index, (t, *_) in enumerate(out["diagnostics"]):
        before = [k for k, (kill_s, _) in enumerate(kill_times) if kill_s - AROUND_KILL_S[0] <= t]
        if before and t - kill_times[before[-1]][0] <= AROUND_KILL_S[1]:
            around.setdefault(before[-1], []).append(index)
    inside = {index for indices in around.values() for index in indices}
    for k, (kill_s, node) in enumerate(kill_times):
        print(f"  kill of {node} at {kill_s:.1f} s:")
        for index in around.get(k, []):
            t, name, level, text = out["diagnostics"][index]
            print(f"    {t - kill_s:+6.1f} s {levels.get(level, level):5s} {name}: {text}")
    print("/diagnostics: the other changes (warm-up included), by status and level: count, first")
    others: dict[tuple[str, int], list[tuple[float, str]]] = {}
    for index, (t, name, level, text) in enumerate(out["diagnostics"]):
        if index not in inside:
            others.setdefault((name, level), []).append((t, text))
    for (name, level), seen in others.items():
        t, text = seen[0]
        print(f"  {levels.get(level, level):5s} {name}: {len(seen)}x, first at {t:.1f} s: {text}")
    print(f"/diagnostics: silences over {SILENCE_S:g} s:")
    for name, times in probe.seen.items():
        arrivals = np.asarray(times, dtype=np.int64)
        gaps = np.flatnonzero(np.diff(arrivals) > SILENCE_S * 1e9)
        for gap in gaps.tolist():
            t = at(int(arrivals[gap]))
            length = (arrivals[gap + 1] - arrivals[gap]) * 1e-9
            print(f"  {name}: silent {length:.1f} s from {t:.1f} s {nearest(t)}")
        last = at(int(arrivals[-1]))
        if raw["end_ns"] - arrivals[-1] > SILENCE_S * 1e9:
            print(f"  {name}: silent from {last:.1f} s to the end")

    print("\nCPU of each node over the run, all its processes (% of one core):")
    for name, pct in raw["cpu_pct"].items():
        print(f"  {name:20s} {pct:6.1f}")
    out["cpu_pct"] = raw["cpu_pct"]
    load = raw["load_average"]
    print(f"load average at the end: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")
    return out


def _interrupt(*_: object) -> None:
    raise KeyboardInterrupt


def main() -> int:
    """Parse the options, run the soak, print and write the figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("SOAK_MINUTES")
    if default is None:
        default = str(SHORT_MINUTES if "MAKELEVEL" in os.environ else LONG_MINUTES)
    parser.add_argument("--minutes", type=float, default=float(default),
                        help="length of the soak after the warm-up (default: SOAK_MINUTES, or "
                        f"{SHORT_MINUTES:g} under make, {LONG_MINUTES:g} by hand)")  # fmt: skip
    arguments = parser.parse_args()
    if not arguments.minutes > 0:
        parser.error("--minutes must be positive")
    signal.signal(signal.SIGTERM, _interrupt)  # so that the nodes are stopped on the way out
    with claim_domain() as lock, tempfile.TemporaryDirectory(prefix="bench_soak_") as work:
        raw = soak(arguments.minutes, lock.domain, Path(work))
        figures = report(raw)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "bench_soak.json").write_text(json.dumps(figures, indent=1, default=str))
    return 0


if __name__ == "__main__":
    sys.exit(main())

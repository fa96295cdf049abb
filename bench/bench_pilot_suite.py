"""The pilot in the live closed loop at the default rates: CPU of each node, odometry to command.

The loop as ``fishtail-run --pilot`` starts it, without the monitor (which the loop does not need):
the driver (simulated first-order motor, every parameter at its default: motor/joint_state at
200 Hz), the kinematics node (config/oscillatory.yaml), the swimming simulator and the pilot (both
with config/oscillatory.yaml and config/fish.yaml, modulation steering, control_rate_hz 20), on a
ROS domain of their own (localhost discovery, logs in a temporary directory). The command lines are
fishtail-run's own (:class:`fishtail_bringup.supervisor.Supervisor`). A probe in this process
publishes cmd_vel (0.3 m/s, 0.1 rad/s) at 10 Hz (the pilot's watchdog is 0.5 s) and records the
arrival (time.time_ns() in its callback) of every fish/odom, with its stamp, and of every
motor/cmd_profile. After the first cmd_profile (the pilot builds its steering map at start-up,
before it subscribes) and a WARMUP_S warm-up (the fish gets up to speed), over a WINDOW_S window:

* CPU of each process (utime + stime from /proc/<pid>/stat), % of one core;
* odometry -> command latency, from the probe: each cmd_profile (it has no header) is paired with
  the latest fish/odom the probe received before it, and

  - ``profile - odom arrival``: the profile's arrival minus that odometry's arrival, both at the
    probe. The odometry reaches the pilot and the probe at about the same time (one publication,
    two subscribers), so this is roughly the pilot's handling (deserialising, Pilot.observe,
    publishing) plus the pilot -> probe hop, plus the difference between the odometry's delivery
    to the pilot and to the probe. The probe's own reception delay (its executor dispatching the
    callback) falls on both ends and mostly cancels; where it does not, it biases the figure
    either way: a probe late for the odometry shortens it, one late for the profile lengthens it.
    Worse, the pairing itself is only right when the profile arrives before the probe has seen
    the next odometry (5 ms later at 200 Hz) and after the probe has seen the one that triggered
    it: a slow pilot (over one odometry period) is paired with a newer message and reads short
    (the figure cannot exceed about one period by much), a probe slower than the pilot to take the
    odometry pairs with the older message and reads about one period long.
  - ``profile - odom stamp``: the profile's arrival minus that odometry's header stamp, which is
    the stamp of the motor sample the simulator integrated up to (the driver's encoder read): the
    whole loop sample -> driver -> simulator -> pilot -> probe. The probe's reception delay falls
    on the profile end only, so it lengthens this figure; the pairing errs as above (a newer
    odometry shortens it by about a period, an older one lengthens it).

* the same with the exact pairing, as a check on the probe's: the pilot runs through a few lines
  (PILOT_WRAPPER, like bench_suite.py's driver wrapper) that record, in the pilot's process, each
  fish/odom callback's entry time and stamp and, for each cmd_profile published, the time it was
  handed to publish() and the stamp of the odometry whose callback published it (in the one-process
  layout the wrapper runs fishtail-one-process and records the same). Each profile at the probe is
  matched to its publication by content (mean speed, depth, phase), which gives: the loop split into
  its legs (motor sample stamp -> pilot's callback; the callback -> publish; publish -> probe), the
  two probe figures above with the right odometry, and how often the probe's pairing picked it. The
  wrapper costs a list append per odometry message; the node is otherwise the pilot's own main();
* the odometry rate the pilot sees (its callbacks, from the wrapper) and the probe sees; the
  profile rate (the pilot sends on the first odometry at least 1/control_rate_hz after its last
  send: 50 to 55 ms apart at 200 Hz odometry, about 19 a second).

The same again with the four nodes hosted in one process (``fishtail-one-process``, as
``fishtail-run --pilot --one-process`` starts them), the probe still in this process.

Also printed: the pilot's and the simulator's last /diagnostics (mode, speeds; the simulator's
dropped samples) as a check that the loop swam as commanded, and the machine's load average
(other processes on the cores change every figure). Figures only, no targets; also written to
bench/out/bench_pilot_suite.json. Run with `make bench` (about a minute).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import tempfile
import time
from array import array
from pathlib import Path
from typing import Any

import numpy as np
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, qos_profile_sensor_data

from fishtail_bringup.supervisor import Supervisor
from fishtail_common.interface import (
    CMD_VEL,
    FISH_ODOM,
    MOTOR_CMD_PROFILE,
    PILOT_NODE,
    SUITE_NODES,
    SWIM_NODE,
)
from fishtail_common.ros import publisher_qos, subscriber_qos
from fishtail_common.testing import (
    PROBE_QUEUE_DEPTH,
    WIDENING_VARIABLES,
    NodeProcess,
    Probe,
    claim_domain,
    isolated_ros_environment,
)
from fishtail_msgs.msg import CarrierSpeedProfile
from measure import FISH, GEOMETRY, OUT, ROOT, cpu_seconds

#: The loop's nodes: the driver and the kinematics node of the suite, the simulator, the pilot.
NODES = (*(node for node in SUITE_NODES if node.name != "monitor"), SWIM_NODE, PILOT_NODE)
SPEED_M_S = 0.3
YAW_RATE_RAD_S = 0.1
CMD_VEL_PERIOD_S = 0.1
WARMUP_S = 3.0
WINDOW_S = 20.0
#: Messages of the window's last moments may still be in flight when it closes.
IN_FLIGHT_S = 0.3
#: Discovery, the pilot's steering map (numba's cache on a first run) and the first profile.
START_TIMEOUT_S = 60.0
#: Reliable, like the pilot's publisher, with a queue deep enough for a descheduled probe.
PROFILE_QUEUE_DEPTH = 100
LAYOUTS = ("separate processes", "one process")

# Runs argv[2] (a module: the pilot node, or fishtail-one-process hosting it) with PilotNode
# wrapped to record each fish/odom callback's entry time and stamp and each cmd_profile published
# (the time, the stamp of the odometry whose callback published it or -1, its three fields); they
# are written to argv[1] (JSON) at exit. The remaining arguments are the module's command line.
PILOT_WRAPPER = r"""
import atexit, importlib, json, sys, time

path, module_name, *rest = sys.argv[1:]
from fishtail_pilot import node as pilot_node

node_class = pilot_node.PilotNode
odom = []  # entry time ns, stamp ns, in turn
sent = []  # publish time ns, trigger stamp ns (-1: not from an odometry callback), in turn
content = []  # mean_speed, modulation_depth, modulation_phase, in turn
current = [-1]
on_odom = node_class._on_odom

def recording_on_odom(self, message):
    entry = time.time_ns()
    stamp = message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec
    odom.extend((entry, stamp))
    current[0] = stamp
    try:
        on_odom(self, message)
    finally:
        current[0] = -1

node_class._on_odom = recording_on_odom
original_init = node_class.__init__

def recording_init(self, *args, **kwargs):
    original_init(self, *args, **kwargs)
    publish = self.profile_publisher.publish

    def recording_publish(message):
        sent.extend((time.time_ns(), current[0]))
        content.extend((message.mean_speed, message.modulation_depth, message.modulation_phase))
        publish(message)

    self.profile_publisher.publish = recording_publish

node_class.__init__ = recording_init

def dump():
    with open(path, "w") as stream:
        json.dump({"odom": odom, "sent": sent, "content": content}, stream)

atexit.register(dump)
module = importlib.import_module(module_name)
sys.argv = [module_name, *rest]
sys.exit(module.main())
"""


def _stop_on_sigterm() -> None:
    """SIGTERM ends this benchmark like Ctrl-C, so that the ``finally`` blocks stop the nodes."""

    def handler(*_: object) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, handler)


def commands(one_process: bool, pilot_record: Path) -> dict[str, list[str]]:
    """fishtail-run's command lines for NODES, the pilot's (or the host's) through the wrapper."""
    supervisor = Supervisor(GEOMETRY, "", [], NODES, FISH, one_process=one_process)
    result = {}
    for label, argv in supervisor.commands().items():
        python, module_flag, module, *rest = argv
        assert module_flag == "-m", argv
        if label == PILOT_NODE.name or one_process:
            argv = [python, "-c", PILOT_WRAPPER, str(pilot_record), module, *rest]
        result["the 4 nodes" if one_process else label] = argv
    return result


class LoopProbe:
    """cmd_vel at 10 Hz out; fish/odom (stamp, arrival) and cmd_profile (content, arrival) in."""

    def __init__(self, probe: Probe) -> None:
        """Create the publisher, its timer and the two subscriptions."""
        self.odom_stamp = array("q")
        self.odom_arrival = array("q")
        self.profile_arrival = array("q")
        self.profile_content: list[tuple[float, float, float]] = []
        self.twist = Twist()
        self.twist.linear.x = SPEED_M_S
        self.twist.angular.z = YAW_RATE_RAD_S
        self.cmd_vel = probe.node.create_publisher(Twist, CMD_VEL.name, publisher_qos(CMD_VEL))
        probe.node.create_timer(CMD_VEL_PERIOD_S, lambda: self.cmd_vel.publish(self.twist))
        # Best effort like the pilot's subscription, with a deep queue: a descheduled probe must
        # not be the one that drops odometry.
        odom_qos = QoSProfile(depth=PROBE_QUEUE_DEPTH)
        odom_qos.reliability = qos_profile_sensor_data.reliability
        odom_qos.durability = qos_profile_sensor_data.durability
        probe.node.create_subscription(Odometry, FISH_ODOM.name, self._on_odom, odom_qos)
        profile_qos = QoSProfile(depth=PROFILE_QUEUE_DEPTH)
        profile_qos.reliability = subscriber_qos(MOTOR_CMD_PROFILE).reliability
        probe.node.create_subscription(
            CarrierSpeedProfile, MOTOR_CMD_PROFILE.name, self._on_profile, profile_qos
        )

    def _on_odom(self, message: Odometry) -> None:
        self.odom_arrival.append(time.time_ns())
        self.odom_stamp.append(Probe.stamp_ns(message))

    def _on_profile(self, message: CarrierSpeedProfile) -> None:
        self.profile_arrival.append(time.time_ns())
        self.profile_content.append(
            (message.mean_speed, message.modulation_depth, message.modulation_phase)
        )


# ---- one run


def run(layout: str, domain: int, work: Path) -> dict[str, Any]:
    """Start the loop in ``layout``, drive it, measure one window, stop it; the raw records."""
    one_process = layout == "one process"
    tag = "one" if one_process else "separate"
    record_path = work / f"{tag}_pilot_record.json"
    log_dir = work / tag
    log_dir.mkdir()
    env = {**os.environ, **isolated_ros_environment(domain, log_dir)}
    processes: dict[str, NodeProcess] = {}
    probe = Probe(domain, "bench_pilot_suite")
    try:
        loop = LoopProbe(probe)
        diagnostics = probe.record_diagnostics()
        for label, argv in commands(one_process, record_path).items():
            processes[label] = NodeProcess(label, argv, log_dir, cwd=ROOT, env=env)

        def started() -> bool:
            for process in processes.values():
                if process.returncode is not None:
                    raise RuntimeError(f"{process.name} exited at start-up:\n{process.output()}")
            return len(loop.profile_arrival) > 0

        start_s = probe.spin_until(started, START_TIMEOUT_S, f"the first {MOTOR_CMD_PROFILE.name}")
        probe.spin_for(WARMUP_S)
        pids: dict[str, int | str] = {name: process.pid for name, process in processes.items()}
        pids["probe (this process)"] = "self"
        load_start = os.getloadavg()
        cpu_start = {name: cpu_seconds(pid) for name, pid in pids.items()}
        wall_start = time.monotonic()
        window_start = time.time_ns()
        probe.spin_for(WINDOW_S)
        window = (window_start, time.time_ns())
        wall = time.monotonic() - wall_start
        cpu = {
            name: 100.0 * (cpu_seconds(pid) - cpu_start[name]) / wall for name, pid in pids.items()
        }
        load_end = os.getloadavg()
        probe.spin_for(IN_FLIGHT_S)
        last_status = {}
        for name in (PILOT_NODE.name, SWIM_NODE.name):
            statuses = Probe.statuses(diagnostics, name)
            if statuses:
                _, level, status = statuses[-1]
                last_status[name] = {
                    "level": level,
                    "message": status.message,
                    "values": Probe.values(status),
                }
    finally:
        probe.close()
        for process in processes.values():
            process.send_signal(signal.SIGINT)  # all at once, so they stop in parallel
        for process in processes.values():
            process.stop()  # waits, then kills the group of one that hangs
    if not record_path.exists():
        raise RuntimeError(f"the pilot wrote no record; its output:\n{processes_output(processes)}")
    return {
        "layout": layout,
        "start_s": start_s,
        "window": window,
        "cpu_pct": cpu,
        "load_average": {"start": load_start, "end": load_end},
        "loop": loop,
        "pilot_record": json.loads(record_path.read_text()),
        "last_status": last_status,
    }


def processes_output(processes: dict[str, NodeProcess]) -> str:
    """Every process's command line, status and output."""
    return "\n".join(process.output() for process in processes.values())


# ---- figures


def spread(nanoseconds: list[int] | np.ndarray) -> dict[str, float | int]:
    """Count, p50, p99 and max of durations given in ns, in ms."""
    values = np.asarray(nanoseconds, dtype=np.float64) * 1e-6
    if values.size == 0:
        return {"count": 0}
    return {
        "count": int(values.size),
        "p50_ms": float(np.percentile(values, 50)),
        "p99_ms": float(np.percentile(values, 99)),
        "max_ms": float(values.max()),
    }


def figures(raw: dict[str, Any]) -> dict[str, Any]:
    """Rates and latencies over the window from the probe's and the pilot's records."""
    start, end = raw["window"]
    span_s = (end - start) * 1e-9
    loop: LoopProbe = raw["loop"]
    odom_arrival = np.frombuffer(loop.odom_arrival, dtype=np.int64)
    odom_stamp = np.frombuffer(loop.odom_stamp, dtype=np.int64)
    profile_arrival = np.frombuffer(loop.profile_arrival, dtype=np.int64)
    record = raw["pilot_record"]
    pilot_odom = np.array(record["odom"], dtype=np.int64).reshape(-1, 2)  # entry, stamp
    sent = np.array(record["sent"], dtype=np.int64).reshape(-1, 2)  # publish, trigger stamp
    sent_content = [tuple(c) for c in np.array(record["content"]).reshape(-1, 3).tolist()]

    inside = (profile_arrival >= start) & (profile_arrival < end)
    profiles = np.flatnonzero(inside)
    pilot_inside = pilot_odom[(pilot_odom[:, 0] >= start) & (pilot_odom[:, 0] < end)]
    probe_odom_count = int(np.count_nonzero((odom_arrival >= start) & (odom_arrival < end)))

    # The probe's pairing: the latest odometry it received before each profile.
    latest = np.searchsorted(odom_arrival, profile_arrival[profiles], side="left") - 1
    paired = latest >= 0
    profile_at = profile_arrival[profiles][paired]
    paired_stamp = odom_stamp[latest[paired]]
    probe_pairing = {
        "profile_minus_odom_arrival": spread(profile_at - odom_arrival[latest[paired]]),
        "profile_minus_odom_stamp": spread(profile_at - paired_stamp),
    }

    # The exact pairing: each profile's publication (by content, the latest published before
    # its arrival) and the odometry whose callback published it.
    published: dict[tuple[float, ...], list[tuple[int, int]]] = {}
    for (publish_ns, trigger), content in zip(sent.tolist(), sent_content, strict=True):
        published.setdefault(content, []).append((publish_ns, trigger))
    probe_arrival_of: dict[int, int] = {}
    for stamp, arrival in zip(odom_stamp.tolist(), odom_arrival.tolist(), strict=True):
        probe_arrival_of.setdefault(stamp, arrival)
    pilot_entry_of: dict[int, int] = {}
    for entry, stamp in pilot_odom.tolist():
        pilot_entry_of.setdefault(stamp, entry)
    legs: dict[str, list[int]] = {
        "stamp_to_pilot_callback": [],
        "callback_to_publish": [],
        "publish_to_probe": [],
        "profile_minus_odom_arrival": [],
        "profile_minus_odom_stamp": [],
    }
    agreement = {"same": 0, "newer": 0, "older": 0, "odometry missed by the probe": 0}
    unmatched = not_from_odometry = 0
    probe_paired_stamp = dict(zip(profiles[paired].tolist(), paired_stamp.tolist(), strict=True))
    for index in profiles.tolist():
        arrival = int(profile_arrival[index])
        candidates = [c for c in published.get(loop.profile_content[index], []) if c[0] <= arrival]
        if not candidates:
            unmatched += 1
            continue
        publish_ns, trigger = max(candidates)
        if trigger < 0:
            not_from_odometry += 1
            continue
        legs["publish_to_probe"].append(arrival - publish_ns)
        legs["profile_minus_odom_stamp"].append(arrival - trigger)
        if trigger in pilot_entry_of:
            entry = pilot_entry_of[trigger]
            legs["stamp_to_pilot_callback"].append(entry - trigger)
            legs["callback_to_publish"].append(publish_ns - entry)
        if trigger not in probe_arrival_of:
            agreement["odometry missed by the probe"] += 1
            continue
        legs["profile_minus_odom_arrival"].append(arrival - probe_arrival_of[trigger])
        chosen = probe_paired_stamp.get(index)
        if chosen == trigger:
            agreement["same"] += 1
        elif chosen is not None and chosen > trigger:
            agreement["newer"] += 1
        else:
            agreement["older"] += 1
    gaps = np.diff(pilot_inside[:, 0]) if len(pilot_inside) > 1 else np.array([], dtype=np.int64)
    return {
        "layout": raw["layout"],
        "window_s": span_s,
        "start_s": raw["start_s"],
        "cpu_pct": raw["cpu_pct"],
        "load_average": raw["load_average"],
        "odometry_at_pilot": len(pilot_inside),
        "odometry_at_pilot_hz": len(pilot_inside) / span_s,
        "odometry_at_pilot_longest_gap_ms": float(gaps.max()) * 1e-6 if gaps.size else None,
        "odometry_at_probe": probe_odom_count,
        "odometry_at_probe_hz": probe_odom_count / span_s,
        "profiles_at_probe": int(profiles.size),
        "profiles_at_probe_hz": profiles.size / span_s,
        "probe_pairing": probe_pairing,
        "exact_pairing": {name: spread(values) for name, values in legs.items()},
        "probe_pairing_versus_exact": agreement,
        "profiles_unmatched": unmatched,
        "profiles_not_from_odometry": not_from_odometry,
        "last_status": raw["last_status"],
    }


# ---- report


def _latency_cell(figure: dict[str, float | int]) -> str:
    if not figure.get("count"):
        return "none"
    return f"{figure['p50_ms']:.2f} / {figure['p99_ms']:.2f} / {figure['max_ms']:.1f}"


def report(results: dict[str, dict[str, Any]]) -> None:
    """Print the figures as a table, one column per layout."""
    layouts = list(results)
    first = results[layouts[0]]
    load = ", ".join(
        f"{name} {r['load_average']['start'][0]:.2f} -> {r['load_average']['end'][0]:.2f}"
        for name, r in results.items()
    )
    print(
        f"pilot closed loop at the default rates: driver 200 Hz (sim motor) -> kinematics, "
        f"simulator -> pilot (20 Hz); cmd_vel {SPEED_M_S:g} m/s, {YAW_RATE_RAD_S:g} rad/s at "
        f"{1 / CMD_VEL_PERIOD_S:g} Hz; {first['window_s']:.1f} s window after {WARMUP_S:g} s "
        f"warm-up; {os.cpu_count()} cores; load average (1 min, window start -> end): {load}"
    )
    width = 26
    header = "".join(f"{name:>{width}}" for name in layouts)
    print(f"\n{'':<44}{header}")

    def row(label: str, cells: list[str]) -> None:
        print(f"{label:<44}" + "".join(f"{cell:>{width}}" for cell in cells))

    names: list[str] = []
    for result in results.values():
        names += [name for name in result["cpu_pct"] if name not in names]
    for name in names:
        cells = [
            f"{r['cpu_pct'][name]:.1f} %" if name in r["cpu_pct"] else "-" for r in results.values()
        ]
        row(f"CPU {name}", cells)
    row(
        "CPU the nodes, total",
        [
            f"{sum(v for k, v in r['cpu_pct'].items() if not k.startswith('probe')):.1f} %"
            for r in results.values()
        ],
    )
    row("start-up to the first cmd_profile", [f"{r['start_s']:.1f} s" for r in results.values()])
    row(
        "fish/odom at the pilot",
        [
            f"{r['odometry_at_pilot']} ({r['odometry_at_pilot_hz']:.1f} Hz)"
            for r in results.values()
        ],
    )
    row(
        "  its longest gap",
        [f"{r['odometry_at_pilot_longest_gap_ms'] or 0:.1f} ms" for r in results.values()],
    )
    row(
        "fish/odom at the probe",
        [
            f"{r['odometry_at_probe']} ({r['odometry_at_probe_hz']:.1f} Hz)"
            for r in results.values()
        ],
    )
    row(
        "cmd_profile at the probe",
        [
            f"{r['profiles_at_probe']} ({r['profiles_at_probe_hz']:.1f} Hz)"
            for r in results.values()
        ],
    )
    print("\nlatency, ms: p50 / p99 / max")
    print("the probe's pairing (the latest fish/odom it received before each cmd_profile):")
    for key, label in (
        ("profile_minus_odom_arrival", "  profile arrival - odom arrival"),
        ("profile_minus_odom_stamp", "  profile arrival - odom stamp"),
    ):
        row(label, [_latency_cell(r["probe_pairing"][key]) for r in results.values()])
    print("the exact pairing (the odometry whose callback published it, from the pilot's record):")
    for key, label in (
        ("profile_minus_odom_arrival", "  profile arrival - odom arrival"),
        ("profile_minus_odom_stamp", "  profile arrival - odom stamp"),
        ("stamp_to_pilot_callback", "    = odom stamp -> pilot's callback"),
        ("callback_to_publish", "    + pilot's callback -> publish"),
        ("publish_to_probe", "    + publish -> probe's callback"),
    ):
        row(label, [_latency_cell(r["exact_pairing"][key]) for r in results.values()])
    row(
        "  probe's pairing: same / newer / older",
        [
            "{same} / {newer} / {older}".format(**r["probe_pairing_versus_exact"])
            for r in results.values()
        ],
    )
    row(
        "  unmatched / not from odometry / odom lost",
        [
            f"{r['profiles_unmatched']} / {r['profiles_not_from_odometry']} / "
            f"{r['probe_pairing_versus_exact']['odometry missed by the probe']}"
            for r in results.values()
        ],
    )
    print()
    for name, result in results.items():
        for node, status in result["last_status"].items():
            values = status["values"]
            keys = {
                PILOT_NODE.name: ("mode", "speed_command_m_s", "mean_speed_m_s",
                                  "yaw_rate_command_rad_s", "carrier_mean_speed_rad_s",
                                  "modulation_depth"),
                SWIM_NODE.name: ("speed_m_s", "dropped", "sub_steps", "received"),
            }[node]  # fmt: skip
            shown = ", ".join(f"{key} {values[key]}" for key in keys if key in values)
            print(
                f"{name}: {node}'s last diagnostics (level {status['level']}): "
                f"{status['message']}; {shown}"
            )


def main() -> int:
    """Run both layouts, print the figures, write bench/out/bench_pilot_suite.json."""
    _stop_on_sigterm()
    OUT.mkdir(parents=True, exist_ok=True)
    for name in WIDENING_VARIABLES:
        os.environ.pop(name, None)
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="bench_pilot_suite_") as tmp:
        work = Path(tmp)
        # This process's probe: localhost discovery, logs in the temporary directory (the domain
        # is given to each run's context).
        os.environ.update(isolated_ros_environment(0, work))
        del os.environ["ROS_DOMAIN_ID"]
        with contextlib.ExitStack() as held:
            domains = [held.enter_context(claim_domain()).domain for _ in LAYOUTS]
            for layout, domain in zip(LAYOUTS, domains, strict=True):
                print(f"  {layout} (ROS domain {domain})", flush=True)
                results[layout] = figures(run(layout, domain, work))
    report(results)
    (OUT / "bench_pilot_suite.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
